"""Flare rays (pipeline/flare_rays.py): spikes and streaks out of a light, nothing else."""

from __future__ import annotations

import numpy as np

from pipeline.colour import linear_to_srgb, srgb_to_linear
from pipeline.flare_rays import RayConfig, find_lights, ray_mask

S = 256
C = (100.0, 120.0)  # the light, off-centre


def _scene(seed: int = 0) -> np.ndarray:
    """A dusk scene in linear light: smooth gradient plus fine texture, no light."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:S, 0:S].astype(np.float32)
    base = 0.02 + 0.03 * yy / S
    tex = 0.01 * rng.random((S, S)).astype(np.float32)
    return np.repeat((base + tex)[..., None], 3, -1)


def _polar():
    yy, xx = np.mgrid[0:S, 0:S].astype(np.float32)
    dx, dy = xx - C[0], yy - C[1]
    return np.hypot(dx, dy), np.arctan2(dy, dx)


def _core(lin: np.ndarray, radius: float = 3.0) -> np.ndarray:
    r, _ = _polar()
    lin[r <= radius] = 4.0
    return lin


def _spikes(n: int = 8, length: float = 150.0, width: float = 1.2, amp: float = 0.4):
    """[S, S] linear light of ``n`` thin spikes from the light, fading along them, and the
    pixels where they add more than 0.05 (clearly visible)."""
    r, th = _polar()
    light = np.zeros((S, S), np.float32)
    for k in range(n):
        a = 2 * np.pi * k / n + 0.1
        along = r * np.cos(th - a)
        across = r * np.sin(th - a)
        fall = np.clip(1 - along / length, 0, 1) ** 2 * (along > 0)
        light += amp * fall * np.exp(-0.5 * (across / width) ** 2)
    return light, (light > 0.05) & (r > 5)


def _srgb(lin: np.ndarray) -> np.ndarray:
    return np.clip(linear_to_srgb(np.clip(lin, 0, None)), 0, 1).astype(np.float32)


def test_spikes_out_of_a_light_are_marked_and_little_else():
    light, visible = _spikes()
    img = _srgb(_core(_scene() + light[..., None]))
    marked = ray_mask(img)
    recall = (marked & visible).sum() / visible.sum()
    near = np.zeros_like(visible)
    near[:, :] = light > 0.003  # within the spikes' faint tails
    precision = (marked & near).sum() / max(marked.sum(), 1)
    assert recall > 0.6, recall
    assert precision > 0.9, precision


def test_a_bare_lamp_and_its_round_glow_are_not_rays():
    r, _ = _polar()
    glow = 0.5 * (1 + (r / 12.0) ** 2) ** -2  # a glow as bright at every angle
    img = _srgb(_core(_scene() + glow[..., None]))
    assert len(find_lights(img, RayConfig())) == 1
    assert ray_mask(img).mean() < 1e-3


def test_no_saturated_light_no_rays():
    light, _ = _spikes()
    img = _srgb(_scene() + 0.3 * light[..., None])  # spikes, but no light to leave
    assert find_lights(img, RayConfig()) == []
    assert not ray_mask(img).any()


def test_a_bright_edge_along_a_ray_is_a_step_not_a_ridge():
    """A sunlit wall whose edge runs straight away from the light: one side of the edge is
    as bright as the ray, so it is no spike."""
    _, th = _polar()
    lin = _scene()
    wedge = (th > 0.3) & (th < 1.9)
    lin[wedge] += 0.25
    img = _srgb(_core(lin))
    assert ray_mask(img).mean() < 2e-3


def test_large_saturated_areas_are_not_lights():
    lin = _scene()
    lin[:60] = 3.0  # a blown-out sky: 23 % of the image
    img = _srgb(lin)
    assert find_lights(img, RayConfig()) == []
    assert find_lights(img, RayConfig(max_light=0.5)) != []  # it is saturated


def test_bad_polar_input_never_leaks_garbage():
    """A light in the corner: most of the polar image lies outside the photo."""
    lin = _scene()
    lin[:4, :4] = 4.0
    marked = ray_mask(_srgb(lin))
    assert marked.shape == (S, S) and marked.mean() < 1e-3


def test_fade_test_drops_rays_that_do_not_fade():
    """A bright band whose light grows away from the light (a cloud lying along the ray)
    passes the ridge rule; the fade test removes most of it (rows beside the band see only
    its part near the light, which does fade, and may stay)."""
    r, th = _polar()
    band = 0.3 * np.exp(-0.5 * ((r * np.sin(th - 0.1)) / 5.0) ** 2) * (np.cos(th - 0.1) > 0)
    band *= 0.2 + 0.8 * np.clip(r / 150.0, 0, 1)
    img = _srgb(_core(_scene() + band[..., None]))
    # one band, one spike: min_rays 1, so that only the fade test decides
    without = ray_mask(img, RayConfig(fade=0.0, min_rays=1)).sum()
    with_fade = ray_mask(img, RayConfig(fade=1.5, min_rays=1)).sum()
    assert without > 500 and with_fade < 0.25 * without, (without, with_fade)
    # a spike that fades keeps its marks under the same test
    light, visible = _spikes(n=1)
    spike = _srgb(_core(_scene() + light[..., None]))
    assert ((ray_mask(spike, RayConfig(fade=1.5, min_rays=1)) & visible).sum()
            > 0.6 * visible.sum())


def test_linear_round_trip_used_by_the_fixtures():
    x = np.linspace(0, 1, 11, dtype=np.float32)
    assert np.allclose(srgb_to_linear(linear_to_srgb(x)), x, atol=1e-4)


def test_mask_stage_adds_rays_to_the_fmg_mask_at_working_size():
    import cv2

    from pipeline.mask import flare_marks, ray_marks

    light, visible = _spikes()
    img = _srgb(_core(_scene() + light[..., None]))
    bgr = (img[..., ::-1] * 255 + 0.5).astype(np.uint8)
    big = cv2.resize(bgr, (2 * S, 2 * S), interpolation=cv2.INTER_NEAREST)  # exact 2x
    probs = np.zeros((2 * S, 2 * S), np.float32)
    probs[:20, :20] = 0.9  # what the FMG marked
    rays = ray_marks(big, work_size=S)  # found at 256, brought back to 512
    assert rays.shape == (2 * S, 2 * S)
    up = cv2.resize(visible.astype(np.uint8), (2 * S, 2 * S),
                    interpolation=cv2.INTER_NEAREST) > 0
    assert (rays & up).sum() / up.sum() > 0.5
    plain = flare_marks(None, big, 0.5, S, rays=False, probs=probs)
    both = flare_marks(None, big, 0.5, S, rays=True, probs=probs)
    assert plain.sum() == 400 and np.array_equal(both, plain | rays)


def test_ray_directions_count_groups_split_by_the_gap():
    from pipeline.flare_rays import ray_directions

    def count_rays(rows, gap):
        return len(ray_directions(rows, gap))

    rows = np.zeros(360, bool)
    assert count_rays(rows, 10.0) == 0
    rows[5:8] = True
    assert count_rays(rows, 10.0) == 1
    rows[100:103] = True
    assert count_rays(rows, 10.0) == 2
    rows[358:360] = True  # wraps onto the first group: still two
    assert count_rays(rows, 10.0) == 2
    rows[12] = True  # 4 degrees from the first group: the same ray
    assert count_rays(rows, 10.0) == 2


def test_ray_directions_are_the_middles_of_the_groups():
    from pipeline.flare_rays import ray_directions

    rows = np.zeros(720, bool)  # half a degree per row
    rows[20:40] = True  # 10..20 degrees
    rows[700:720] = True  # 350..360: apart from the first by 10 degrees of gap
    rows[380:400] = True  # 190..200
    got = ray_directions(rows, 5.0)
    assert np.allclose(sorted(got), [15.0, 195.0, 355.0], atol=0.5)
    assert ray_directions(rows, 15.0) != got and len(ray_directions(rows, 15.0)) == 2


def test_opposite_rays_are_enough_others_are_not():
    """min_rays 3 with ``opposite``: a streak through the light (two rays 180 degrees
    apart) is kept; two rays at a right angle (a corner of scene lines) are not."""
    from pipeline.flare_rays import enough_rays

    cfg = RayConfig(min_rays=3, opposite=8.0)
    assert enough_rays([10.0, 192.0], cfg) and not enough_rays([10.0, 100.0], cfg)
    assert not enough_rays([10.0, 192.0], RayConfig(min_rays=3, opposite=0.0))
    assert enough_rays([10.0, 100.0, 250.0], cfg) and not enough_rays([10.0], cfg)
    two, _ = _spikes(n=2)  # two spikes, opposite
    img = _srgb(_core(_scene() + two[..., None]))
    assert not ray_mask(img, RayConfig(min_rays=3)).any()
    assert ray_mask(img, RayConfig(min_rays=3, opposite=8.0)).sum() > 50


def test_min_rays_drops_a_light_with_one_ray_and_keeps_a_starburst():
    """One spike from a light (a scene line starting at a bright object looks like this) is
    kept with min_rays 1 and dropped with 2; an 8-spike starburst survives min_rays 3."""
    one, _ = _spikes(n=1)
    img = _srgb(_core(_scene() + one[..., None]))
    assert ray_mask(img, RayConfig(min_rays=1)).sum() > 50
    assert not ray_mask(img, RayConfig(min_rays=2)).any()
    star, visible = _spikes(n=8)
    img = _srgb(_core(_scene() + star[..., None]))
    kept = ray_mask(img, RayConfig(min_rays=3))
    assert (kept == ray_mask(img, RayConfig(min_rays=1))).all()
    assert (kept & visible).sum() > 0.6 * visible.sum()


def _lamp_with_a_saturated_streak(amp: float = 3.0):
    """A lamp (saturated disc of radius 6) with a broad streak through it both ways, its
    middle saturated for about 50 px each side (the saturated region: the disc and two thin arms,
    too ragged to be a light by itself), fading to the frame's edge."""
    r, th = _polar()
    a = 0.35
    along, across = r * np.cos(th - a), r * np.sin(th - a)
    streak = amp * np.exp(-np.abs(along) / 45.0) * np.exp(-0.5 * (across / 1.2) ** 2)
    lin = _scene() + streak[..., None]
    lin[r <= 6] = 4.0
    return lin, streak


def test_light_core_keeps_the_lamp_and_drops_the_arms():
    from pipeline.flare_rays import light_core

    r, th = _polar()
    region = (r <= 6) | ((np.abs(r * np.sin(th - 0.35)) <= 1.0) & (r <= 40))
    core = light_core(region)
    assert core[int(C[1]), int(C[0])] and not (core & ~region).any()
    assert core.sum() <= (r <= 6.5).sum() and core.sum() >= 0.8 * (r <= 6).sum()
    assert not core[r > 8].any()  # the arms are gone


def test_a_lamp_with_a_saturated_streak_is_found_by_its_core():
    lin, _ = _lamp_with_a_saturated_streak()
    img = _srgb(lin)
    assert find_lights(img, RayConfig()) == []  # the region is too ragged to be a light
    lights = find_lights(img, RayConfig(cores=True))
    assert len(lights) == 1
    x, y, rad = lights[0]
    assert abs(x - C[0]) < 1.5 and abs(y - C[1]) < 1.5 and 5 < rad < 8


def test_the_streak_through_a_lamp_found_by_its_core_is_marked():
    from pipeline.flare_rays import found_by_core

    lin, streak = _lamp_with_a_saturated_streak()
    img = _srgb(lin)
    r, _ = _polar()
    visible = (streak > 0.05) & (streak < 0.9) & (r > 10)  # unsaturated, clearly visible
    cfg = RayConfig(cores=True)
    assert found_by_core(img, find_lights(img, cfg), cfg) == [True]
    marked = ray_mask(img, cfg)
    assert (marked & visible).sum() > 0.5 * visible.sum()
    assert (marked & (streak < 0.003)).sum() < 0.05 * marked.sum()
    assert not ray_mask(img, RayConfig(cores=True, core_opposite=0)).any()  # two rays only
    assert not ray_mask(img).any()  # without cores the lamp is not found


def test_cores_never_make_a_blown_sky_or_a_compact_light_different():
    lin = _scene()
    lin[:60] = 3.0  # a blown-out sky: its core is as large
    img = _srgb(lin)
    assert find_lights(img, RayConfig(cores=True)) == []
    light, _ = _spikes()
    img = _srgb(_core(_scene() + light[..., None]))
    assert find_lights(img, RayConfig(cores=True)) == find_lights(img, RayConfig())
    assert (ray_mask(img, RayConfig(cores=True)) == ray_mask(img)).all()
