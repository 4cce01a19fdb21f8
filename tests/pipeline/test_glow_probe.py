"""benchmarks/glow_probe.py: both ways of finding a light's outer glow mark a drawn glow
beyond the mask, and nothing without a marked light."""

from __future__ import annotations

import numpy as np

from pipeline.colour import LUMA, linear_to_srgb, srgb_to_linear
from tests.conftest import load_benchmark

H, W = 120, 160
X, Y = 80.0, 60.0


def _scene(seed: int = 0) -> np.ndarray:
    """[H, W, 3] linear light: a dark textured scene (vertical bars and noise)."""
    rng = np.random.default_rng(seed)
    bars = 0.02 + 0.03 * (np.arange(W) // 8 % 2)
    base = np.broadcast_to(bars[None, :, None], (H, W, 3)).copy()
    return base + rng.uniform(0, 0.01, (H, W, 3))


def _glow() -> tuple[np.ndarray, np.ndarray]:
    """[H, W] a lens glow ``a (1 + (d / w)^2)^-2`` about (X, Y), and its saturated core."""
    yy, xx = np.mgrid[:H, :W]
    d = np.hypot(xx - X, yy - Y)
    return 0.6 * (1 + (d / 12.0) ** 2) ** -2, d <= 2.5


def _case():
    scene = _scene()
    glow, core = _glow()
    flared = scene + glow[..., None]
    flared[core] = 4.0
    img = np.clip(linear_to_srgb(np.clip(flared, 0, 1)), 0, 1).astype(np.float32)
    lum_scene = scene @ LUMA
    truth = glow > np.maximum(0.012, 0.1 * lum_scene)
    yy, xx = np.mgrid[:H, :W]
    marks = np.hypot(xx - X, yy - Y) <= 10  # the FMG's blob stops short of the glow
    return img, scene, truth, marks


def test_ring_probe_marks_the_glow_beyond_the_mask():
    bench = load_benchmark("glow_probe")
    img, _, truth, marks = _case()
    g = bench.ring_glow(img, marks)
    beyond = truth & ~marks
    assert not (g & marks).any()
    assert g.sum() > 0.5 * beyond.sum()
    assert (g & truth).sum() >= 0.9 * g.sum()


def test_views_probe_marks_the_glow_beyond_the_mask():
    bench = load_benchmark("glow_probe")
    img, scene, truth, marks = _case()
    lum_view = srgb_to_linear(img) @ LUMA.astype(np.float32)
    lum_cons = (scene @ LUMA).astype(np.float32)  # the neighbours see the scene alone
    support = np.full((H, W), 3)
    g = bench.views_glow(img, marks, lum_view, lum_cons, support)
    beyond = truth & ~marks
    assert g.sum() > 0.5 * beyond.sum()
    assert (g & truth).sum() >= 0.9 * g.sum()


def test_no_marked_light_no_glow():
    bench = load_benchmark("glow_probe")
    img, scene, _, marks = _case()
    far = np.zeros_like(marks)
    far[5:15, 5:15] = True  # a mark away from the light: no saturated part in it
    assert not bench.ring_glow(img, far).any()
    lum = srgb_to_linear(img) @ LUMA.astype(np.float32)
    assert not bench.views_glow(img, far, lum, (scene @ LUMA).astype(np.float32),
                                np.full((H, W), 3)).any()
    assert bench.marked_lights(img, marks)  # the light itself is found where marked
