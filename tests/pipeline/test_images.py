"""pipeline.images.put_label and the mask stage's overview sheet that uses it."""

import numpy as np

from pipeline.images import put_label
from pipeline.mask import overview_sheet


def _columns(img: np.ndarray, value: int) -> np.ndarray:
    """Columns holding a pixel of ``value`` in every channel."""
    return np.nonzero((img == value).all(axis=2).any(axis=0))[0]


def test_label_outline_stays_under_its_glyphs():
    """The black outline hugs the white glyphs: it reaches at most a pixel or two past them
    (a thick black pass drawn under a thin white one ran ~19 px past this label's end)."""
    img = np.full((40, 400, 3), 128, np.uint8)
    put_label(img, "02928139_3448003521  0.0%")
    white, black = _columns(img, 255), _columns(img, 0)
    assert white.size and black.size
    assert black.min() >= white.min() - 2 and black.max() <= white.max() + 2


def test_long_label_is_shrunk_then_shortened_keeping_its_end():
    """A label wider than the image is drawn smaller, then cut in the middle: nothing is
    drawn past the image's right margin, and the tail (the flare share) is kept."""
    img = np.full((40, 120, 3), 128, np.uint8)
    put_label(img, "a_very_long_photo_name_from_a_phone_0001  12.5%")
    drawn = np.nonzero((img != 128).any(axis=2).any(axis=0))[0]
    assert drawn.size and drawn.max() <= 120 - 3
    fits = np.full((40, 400, 3), 128, np.uint8)
    put_label(fits, "a_very_long_photo_name_from_a_phone_0001  12.5%")
    assert np.nonzero((fits != 128).any(axis=2).any(axis=0))[0].max() > 120


def test_label_at_the_bottom():
    img = np.full((60, 200, 3), 128, np.uint8)
    put_label(img, "streaks  mask 2.0%", scale=0.38, bottom=True)
    rows = np.nonzero((img == 255).all(axis=2).any(axis=1))[0]
    assert rows.min() > 30 and rows.max() < 60


def test_overview_label_spans_the_cell_of_a_portrait_photo():
    """A portrait photo's thumbnail is narrower than its cell: its label runs past the
    thumbnail into the cell, so the flare share at its end shows."""
    tiles = [("02928139_3448003521", np.full((1000, 600, 3), 100, np.uint8),
              np.zeros((1000, 600), bool))]
    sheet = overview_sheet(tiles, thumb=320)
    thumb_w = round(600 * min(320 / 600, 240 / 1000))
    label_rows = sheet[2:30]
    assert _columns(label_rows, 255).max() > 2 + thumb_w + 10
