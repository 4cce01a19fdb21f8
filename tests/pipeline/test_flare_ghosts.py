"""Ghost lines (pipeline/flare_ghosts.py): weak FMG regions on a light's ghost line kept."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.flare_ghosts import GhostConfig, ghost_line_mask, line_distance

H, W = 240, 320
CENTRE = ((W - 1) / 2, (H - 1) / 2)
LIGHT = (60.0, 50.0, 3.0)  # (x, y, radius), upper left of the centre


def _disc(x: float, y: float, r: float) -> np.ndarray:
    yy, xx = np.mgrid[0:H, 0:W]
    return np.hypot(xx - x, yy - y) <= r


def _on_line(t: float) -> tuple[float, float]:
    """The point c + t (light - c) of the light's ghost line (t = 1: the light)."""
    return (CENTRE[0] + t * (LIGHT[0] - CENTRE[0]), CENTRE[1] + t * (LIGHT[1] - CENTRE[1]))


def test_line_distance():
    assert line_distance(np.array([5.0]), np.array([3.0]), (0, 0), (10, 0))[0] == 3.0
    assert line_distance(np.array([2.0]), np.array([2.0]), (0, 0), (1, 1))[0] == pytest.approx(0)


def test_weak_discs_on_the_line_are_kept_and_others_not():
    """Weak discs (probability 0.4, under any cut) centred on the line through the light and
    the centre, on either side of the centre, are marked whole; the same disc off the line,
    one at the light (its glow), one too weak and a region too large are not."""
    on_a, on_b = _disc(*_on_line(0.3), 8), _disc(*_on_line(-0.6), 12)
    off = _disc(_on_line(-0.3)[0] + 40, _on_line(-0.3)[1] - 30, 8)   # 50 px off the line
    glow = _disc(LIGHT[0], LIGHT[1], 9)
    faint = _disc(*_on_line(-0.1), 8)
    probs = np.zeros((H, W), np.float32)
    for m in (on_a, on_b, off, glow):
        probs[m] = 0.4
    probs[faint] = 0.1                                   # under ``low``
    got = ghost_line_mask(probs, [LIGHT])
    assert (got == (on_a | on_b)).all()
    huge = np.zeros((H, W), np.float32)
    huge[:, :200] = 0.4                                  # over max_area, though on the line
    assert not ghost_line_mask(huge, [LIGHT]).any()


def test_nothing_without_a_light_or_with_a_light_at_the_centre():
    probs = np.zeros((H, W), np.float32)
    probs[_disc(*_on_line(0.3), 8)] = 0.4
    assert not ghost_line_mask(probs, []).any()
    assert not ghost_line_mask(probs, [(CENTRE[0] + 1, CENTRE[1], 3.0)]).any()
    # a looser ``along`` reaches a disc a little off the line; the default does not
    shifted = np.zeros((H, W), np.float32)
    x, y = _on_line(-0.5)
    shifted[_disc(x + 7, y - 5, 8)] = 0.4                # about 8.6 px off, radius 8
    one = GhostConfig(min_chain=1)
    assert not ghost_line_mask(shifted, [LIGHT], cfg=one).any()
    assert ghost_line_mask(shifted, [LIGHT], cfg=GhostConfig(along=1.5, min_chain=1)).any()


def test_a_lone_region_on_the_line_needs_a_chain():
    """By default (``min_chain`` 2) one weak disc on a light's line is not enough; two are
    kept, both; with ``min_chain`` 1 the lone one is kept too."""
    lone = np.zeros((H, W), np.float32)
    lone[_disc(*_on_line(-0.6), 12)] = 0.4
    assert not ghost_line_mask(lone, [LIGHT]).any()
    assert ghost_line_mask(lone, [LIGHT], cfg=GhostConfig(min_chain=1)).any()
    pair = lone.copy()
    pair[_disc(*_on_line(0.3), 8)] = 0.4
    assert (ghost_line_mask(pair, [LIGHT]) == (pair > 0)).all()
    assert not ghost_line_mask(pair, [LIGHT], cfg=GhostConfig(min_chain=3)).any()


def test_ghost_marks_find_the_light_in_the_photo():
    """``pipeline.mask.ghost_marks`` finds the saturated light in the image (at the working
    size; the photo twice as large) and keeps the weak disc on its line."""
    import cv2

    from pipeline.mask import flare_marks, ghost_marks

    img = np.full((H, W, 3), 60, np.uint8)
    cv2.circle(img, (int(LIGHT[0]), int(LIGHT[1])), 3, (255, 255, 255), -1)
    probs = np.zeros((H, W), np.float32)
    ghost = _disc(*_on_line(-0.6), 12) | _disc(*_on_line(0.3), 8)   # a chain of two
    probs[ghost] = 0.4
    assert (ghost_marks(img, probs, 512) == ghost).all()
    big = cv2.resize(img, (2 * W, 2 * H), interpolation=cv2.INTER_NEAREST)
    big_probs = cv2.resize(probs, (2 * W, 2 * H), interpolation=cv2.INTER_NEAREST)
    big_ghost = cv2.resize(ghost.astype(np.uint8), (2 * W, 2 * H),
                           interpolation=cv2.INTER_NEAREST) > 0
    assert (ghost_marks(big, big_probs, W) == big_ghost).all()      # lights found at W
    assert not ghost_marks(np.full((H, W, 3), 60, np.uint8), probs, 512).any()  # no light
    # in the mask: under the cut alone it is not flare; with the rule it is
    assert not flare_marks(None, img, 0.75, 512, probs=probs).any()
    assert (flare_marks(None, img, 0.75, 512, probs=probs, ghosts=GhostConfig()) == ghost).all()
