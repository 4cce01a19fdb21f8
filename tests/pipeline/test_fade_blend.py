"""``pipeline.render.fade_blend``: how a frame's renders with other frames' sources are joined."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.render.fade_blend import blend_renders, checked_flow


def _scene(shift: float, size=(96, 128), seed=0) -> np.ndarray:
    """A smooth textured RGB uint8 image, its content moved ``shift`` pixels to the right
    (the same texture for every shift: a window of a larger canvas, sampled bilinearly)."""
    import cv2

    rng = np.random.default_rng(seed)
    H, W = size
    canvas = cv2.GaussianBlur(rng.random((H + 40, W + 40, 3)).astype(np.float32), (0, 0), 2.5)
    canvas = (canvas - canvas.min()) / (canvas.max() - canvas.min()) * 255
    gx, gy = np.meshgrid(np.arange(W, dtype=np.float32) + 20 - shift,
                         np.arange(H, dtype=np.float32) + 20)
    return np.rint(cv2.remap(canvas, gx, gy, cv2.INTER_LINEAR)).astype(np.uint8)


def _err(a: np.ndarray, b: np.ndarray, m: int = 12) -> float:
    """Mean absolute difference away from the border."""
    return float(np.abs(a[m:-m, m:-m].astype(float) - b[m:-m, m:-m].astype(float)).mean())


def test_checked_flow_finds_a_shift():
    """The flow from an image to itself moved 3 pixels right is about (3, 0) inside."""
    f = checked_flow(_scene(0), _scene(3))
    inner = f[12:-12, 12:-12]
    assert np.median(inner[..., 0]) == pytest.approx(3, abs=0.3)
    assert np.abs(np.median(inner[..., 1])) < 0.3


def test_mix_is_the_weighted_mean_and_identical_renders_pass_through():
    """``mix`` rounds the weighted mean; every mode leaves a frame whose renders agree as it
    is (the flow between equal images is zero)."""
    a, b = np.full((8, 8, 3), 30, np.uint8), np.full((8, 8, 3), 90, np.uint8)
    assert (blend_renders(a, [(b, 1 / 3)], "mix") == 50).all()
    img = _scene(0)
    for mode in ("mix", "align", "morph"):
        out = blend_renders(img, [(img.copy(), 1 / 3), (img.copy(), 1 / 3)], mode)
        assert out.dtype == np.uint8 and np.array_equal(out, img), mode
    with pytest.raises(ValueError, match="fade blend"):
        blend_renders(img, [(img, 0.5)], "blur")


def test_align_and_morph_do_not_double_a_misaligned_render():
    """A frame's own render and one with other sources that puts the scene 3 pixels to the
    right, faded in at a third: ``mix`` is a double image (far from both the scene at 0 and
    at 1 px); ``align`` is the frame's own render (the other warped onto it); ``morph`` is
    the scene a third of the way across, at 1 px."""
    own, other = _scene(0), _scene(3)
    mix = blend_renders(own, [(other, 1 / 3)], "mix")
    align = blend_renders(own, [(other, 1 / 3)], "align")
    morph = blend_renders(own, [(other, 1 / 3)], "morph")
    at1 = _scene(1)
    assert _err(align, own) < 0.5 * _err(mix, own)
    assert _err(morph, at1) < 0.5 * _err(mix, at1)
    assert _err(morph, at1) < _err(morph, own)


def test_blends_keep_sixteen_bit_frames():
    """uint16 renders (TIFF frames) blend in their own range: ``align`` keeps the frame's
    own render, ``morph`` at a half is the scene half way (1 px of 2)."""
    def wide(x):
        return x.astype(np.uint16) * 257

    own, other = wide(_scene(0)), wide(_scene(2))
    mix = blend_renders(own, [(other, 0.5)], "mix")
    for mode, truth in (("align", own), ("morph", wide(_scene(1)))):
        out = blend_renders(own, [(other, 0.5)], mode)
        assert out.dtype == np.uint16 and out.max() > 255
        assert _err(out, truth) < 0.5 * _err(mix, truth), mode
