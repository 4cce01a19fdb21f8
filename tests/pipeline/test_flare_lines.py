"""Streak lines (pipeline/flare_lines.py): a thin streak through a light, both ways."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.colour import linear_to_srgb
from pipeline.flare_lines import LineConfig, line_mask
from pipeline.flare_rays import RayConfig, find_lights, ray_mask

H, W = 288, 384
LIGHT = (150.0, 131.0)


def _background(seed: int = 0) -> np.ndarray:
    """[H, W] linear light: a dusk gradient with fine texture and a few soft blobs."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:H, :W].astype(np.float32)
    lin = 0.03 + 0.04 * yy / H + 0.01 * rng.random((H, W)).astype(np.float32)
    for _ in range(6):
        cx, cy, r = rng.uniform(0, W), rng.uniform(0, H), rng.uniform(10, 40)
        lin += 0.05 * np.exp(-0.5 * ((xx - cx) ** 2 + (yy - cy) ** 2) / r ** 2)
    return lin


def _streak(angle_deg: float, sigma: float = 1.2, amp: float = 0.15, both: bool = True,
            miss: float = 0.0) -> np.ndarray:
    """[H, W] linear light of a thin straight streak through LIGHT (``miss`` pixels off its
    centre), slowly fading; one half only unless ``both``."""
    yy, xx = np.mgrid[:H, :W].astype(np.float32)
    a = np.deg2rad(angle_deg)
    dx, dy = xx - LIGHT[0], yy - LIGHT[1]
    along = dx * np.cos(a) + dy * np.sin(a)
    across = -dx * np.sin(a) + dy * np.cos(a) - miss
    light = amp * np.exp(-np.abs(along) / 600.0) * np.exp(-0.5 * (across / sigma) ** 2)
    return light if both else light * (along > 0)


def _photo(lin: np.ndarray) -> np.ndarray:
    """sRGB [H, W, 3] float with the saturated light drawn at LIGHT."""
    yy, xx = np.mgrid[:H, :W].astype(np.float32)
    lin = lin.copy()
    lin[np.hypot(xx - LIGHT[0], yy - LIGHT[1]) <= 4] = 4.0
    return np.clip(linear_to_srgb(np.clip(lin, 0, 1)), 0, 1)[..., None].repeat(3, -1).astype(
        np.float32)


@pytest.mark.parametrize("angle,miss", [(1.5, 0.0), (37.0, 1.0), (-80.0, 0.0)])
def test_a_thin_streak_through_a_light_is_marked_and_nothing_else(angle, miss):
    streak = _streak(angle, miss=miss)
    img = _photo(_background() + streak)
    lights = find_lights(img, RayConfig())
    assert len(lights) == 1
    marked = line_mask(img, lights)
    core = streak > 0.05  # clearly visible
    yy, xx = np.mgrid[:H, :W]
    core &= np.hypot(xx - LIGHT[0], yy - LIGHT[1]) > 8
    assert (marked & core).sum() / core.sum() > 0.7
    near = streak > 0.003  # the streak's faint flanks
    assert (marked & ~near).sum() <= 0.01 * marked.sum()


def test_a_line_that_leaves_the_light_one_way_only_is_not_a_streak():
    """A bright scene line ending at a light (a lit edge, a railing) is one-sided."""
    img = _photo(_background() + _streak(20.0, both=False))
    assert not line_mask(img, find_lights(img, RayConfig())).any()


def test_no_light_or_a_clean_light_marks_nothing():
    img = _photo(_background())
    assert not line_mask(img, []).any()
    assert not line_mask(img, find_lights(img, RayConfig())).any()


def test_a_faint_streak_under_the_thresholds_is_not_marked_and_symmetry_is_a_rule():
    """Under abs_threshold the streak is no ridge. A streak far brighter one way than the
    other (0.15) loses lines to the symmetry rule (0.3) that it keeps without it (0), and one
    nearly even (0.6) keeps them."""
    img = _photo(_background() + _streak(5.0, amp=0.005))
    assert not line_mask(img, find_lights(img, RayConfig())).any()
    yy, xx = np.mgrid[:H, :W].astype(np.float32)
    marks = {}
    for ratio in (0.15, 0.6):
        img = _photo(_background() + np.where(xx > LIGHT[0], 1.0, ratio) * _streak(5.0))
        lights = find_lights(img, RayConfig())
        marks[ratio] = (line_mask(img, lights).sum(),
                        line_mask(img, lights, LineConfig(symmetry=0)).sum())
    assert marks[0.15][0] < 0.6 * marks[0.15][1]
    assert marks[0.6][0] == marks[0.6][1] > 1000


def test_ray_mask_adds_the_lines_only_when_asked():
    """RayConfig.lines (mask --streak-lines): one streak through a light leaves it in two
    directions, under the rays' three; the lines mark it."""
    img = _photo(_background() + _streak(2.0))
    assert not ray_mask(img, RayConfig()).any()
    assert ray_mask(img, RayConfig(lines=True)).sum() > 200


def test_each_half_line_is_sampled_as_far_as_it_can_be_in_the_frame():
    """_in_frame: from any start, every step at which the ray still samples the image is
    within its length (so sampling only that far changes nothing), and at most two steps
    more."""
    from pipeline.flare_lines import _in_frame

    rng = np.random.default_rng(3)
    h, w, reach = 40, 60, 200
    x, y = rng.uniform(-2, w + 1, 500), rng.uniform(-2, h + 1, 500)
    a = rng.uniform(0, 2 * np.pi, 500)
    a[:8] = np.arange(8) * np.pi / 4  # along the axes and the diagonals
    dx, dy = np.cos(a), np.sin(a)
    length = _in_frame(x, y, dx, dy, w, h, reach)
    t = np.arange(reach)[None]
    px, py = x[:, None] + t * dx[:, None], y[:, None] + t * dy[:, None]
    samples = (px > -1) & (px < w) & (py > -1) & (py < h)
    last = np.where(samples, t, -1).max(1) + 1
    assert (last <= length).all() and (length <= np.minimum(last + 2, reach)).all()


def test_a_broad_beam_is_found_on_the_photo_shrunk_and_the_default_scale_is_the_rule():
    """A beam 12 px across (sigma) through a light is no ridge against samples 4 px across
    at full size; at a quarter of the size it is a thin one, and line_mask_scaled with
    (1, 0.25) marks most of it and little else. Scale 1 alone is line_mask itself, and a
    clean light marks nothing at either scale."""
    from pipeline.flare_lines import line_mask_scaled

    beam = _streak(25.0, sigma=12.0, amp=0.12)
    img = _photo(_background() + beam)
    lights = find_lights(img, RayConfig())
    yy, xx = np.mgrid[:H, :W]
    core = (beam > 0.05) & (np.hypot(xx - LIGHT[0], yy - LIGHT[1]) > 16)
    alone = line_mask(img, lights)
    assert (alone & core).sum() < 0.2 * core.sum()
    both = line_mask_scaled(img, lights, (1.0, 0.25))
    assert (both & core).sum() > 0.6 * core.sum()
    assert (both & ~(beam > 0.005)).sum() <= 0.1 * both.sum()
    assert np.array_equal(line_mask_scaled(img, lights), alone)
    thin = _photo(_background() + _streak(37.0, miss=1.0))
    thin_lights = find_lights(thin, RayConfig())
    assert np.array_equal(line_mask_scaled(thin, thin_lights, (1.0,)),
                          line_mask(thin, thin_lights))
    clean = _photo(_background())
    assert not line_mask_scaled(clean, find_lights(clean, RayConfig()), (1.0, 0.25)).any()
    # through the rays' rule (mask --streak-lines --streak-scales 1,0.25)
    assert (ray_mask(img, RayConfig(lines=True, line_scales=(1.0, 0.25))) & core).sum() > (
        0.6 * core.sum())


def test_the_mask_options_reach_the_line_scales():
    """mask --streak-scales reaches the rays' rule; unset, the rule's one scale; without
    --streak-lines one line before anything runs."""
    from pipeline.errors import UserError
    from pipeline.mask import MaskConfig, ray_config
    from pipeline.options import validate

    assert ray_config(MaskConfig()).line_scales == (1.0,)
    cfg = MaskConfig(streak_lines=True, streak_scales=(1.0, 0.25))
    assert ray_config(cfg).lines and ray_config(cfg).line_scales == (1.0, 0.25)
    with pytest.raises(UserError, match="--streak-scales"):
        validate(MaskConfig(streak_scales=(0.25,)))
