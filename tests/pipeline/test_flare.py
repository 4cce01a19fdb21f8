"""Properties of the physically based flare synthesizer (pipeline/flare/)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pipeline import flare as F
from pipeline.colour import image_to_linear, linear_to_srgb, srgb_to_linear
from pipeline.errors import UserError
from pipeline.flare import lens as flare_lens
from pipeline.flare import scatter as flare_scatter

# a small bank keeps every test fast; the physics is the same as the default's
BANK = dict(psf_size=128, n_psfs=3, n_wavelengths=9, dust_count=(5, 20))
# the tests of the dirty-aperture lens (the ``scatter`` kind) render that kind alone
SMALL = dict(BANK, kinds=("scatter",))


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("DEFLARE_CACHE", str(tmp_path / "cache"))
    flare_scatter._BANKS.clear()
    yield
    flare_scatter._BANKS.clear()


def small_cfg(**kw) -> F.FlareConfig:
    return F.FlareConfig(**{**SMALL, **kw})


def test_srgb_linear_round_trip_and_monotonic():  # the one sRGB pair (pipeline/colour.py)
    x = np.linspace(0, 1, 1001, dtype=np.float32)
    lin = srgb_to_linear(x)
    assert np.all(np.diff(lin) > 0)
    assert abs(lin[500] - 0.2140) < 1e-3  # sRGB 0.5 is about 21% linear
    np.testing.assert_allclose(linear_to_srgb(lin), x, atol=2e-6)


def test_psf_bank_normalised_non_negative_and_cached(tmp_path):
    cfg = small_cfg()
    bank = F.psf_bank(cfg)
    assert bank.shape == (3, 128, 128, 3) and bank.dtype == np.float32
    assert bank.min() >= 0
    np.testing.assert_allclose(bank.sum(axis=(1, 2)), 1.0, atol=1e-3)
    c = 64  # energy concentrates at the centre (Airy core), tails are faint
    assert np.all(bank[:, c, c].min(-1) > 100 * np.median(bank, axis=(1, 2)).max(-1))
    path = tmp_path / "cache" / f"psf_bank_{cfg.bank_key()}.npz"
    assert path.is_file()
    flare_scatter._BANKS.clear()
    np.testing.assert_array_equal(F.psf_bank(cfg), bank)  # read back from disk
    assert small_cfg(bank_seed=5).bank_key() != cfg.bank_key()


def test_red_psf_wider_than_blue():
    """Each wavelength's PSF is magnified by lambda / lambda0: red spreads further."""
    bank = F.psf_bank(small_cfg())
    yy, xx = np.mgrid[0:128, 0:128] - 64
    r2 = (xx ** 2 + yy ** 2)[None, ..., None]
    second_moment = (bank * r2).sum(axis=(1, 2))  # [n, 3]
    assert np.all(second_moment[:, 0] > second_moment[:, 2])


def _photo(h=96, w=128, seed=0):
    rng = np.random.default_rng(seed)
    return (rng.uniform(0.05, 0.6, (h, w, 3)) * 255).astype(np.uint8)


def test_energy_adds_in_linear_light():
    cfg = small_cfg()
    rng = np.random.default_rng(1)
    img = _photo()
    lens = F.sample_lens(cfg, rng)
    layers = F.render_flare(lens, (60.0, 40.0), img.shape[:2], rng, intensity=1.0)
    out = F.apply_flare(img, layers)
    assert out.dtype == np.float32 and out.shape == img.shape
    expect = srgb_to_linear(img / 255.0) + layers.flare + layers.core
    ok = expect < 0.999  # where nothing clipped
    assert ok.mean() > 0.3 and (~ok).any()
    np.testing.assert_allclose(srgb_to_linear(out)[ok], expect[ok], atol=1e-5)
    np.testing.assert_allclose(out[expect >= 1], 1.0, atol=1e-6)  # clipped
    # float input in [0, 1] gives the same result as uint8
    np.testing.assert_allclose(F.apply_flare(img / 255.0, layers), out, atol=1e-6)


def test_mask_excludes_core_and_marks_flare():
    cfg = small_cfg()
    rng = np.random.default_rng(2)
    img = _photo()
    flared, layers = F.synthesize(img, cfg, rng, light_xy=(64.0, 48.0))
    core = layers.core.max(-1) > 0
    assert core.any() and layers.mask.any()
    assert not (layers.mask & core).any()
    lum = layers.flare @ F.LUMA
    assert lum[layers.mask].min() > cfg.mask_abs_threshold
    # with no background the threshold is the absolute one alone
    plain = F.render_flare(F.sample_lens(cfg, rng), (64.0, 48.0), (96, 128))
    plain_core = plain.core.max(-1) > 0
    expect = (plain.flare @ F.LUMA > cfg.mask_abs_threshold) & ~plain_core
    np.testing.assert_array_equal(plain.mask, expect)
    # a brighter background hides more of the same flare (relative threshold)
    lens = F.sample_lens(cfg, np.random.default_rng(3))
    dark = F.render_flare(lens, (64, 48), (96, 128), None, 1.0, np.full((96, 128, 3), 0.01))
    bright = F.render_flare(lens, (64, 48), (96, 128), None, 1.0, np.full((96, 128, 3), 0.9))
    assert bright.mask.sum() < dark.mask.sum()
    assert not (bright.mask & ~dark.mask).any()


def test_same_seed_same_output_different_seed_differs():
    cfg = small_cfg()
    img = _photo()
    a, la = F.synthesize(img, cfg, np.random.default_rng(7))
    b, lb = F.synthesize(img, cfg, np.random.default_rng(7))
    c, _ = F.synthesize(img, cfg, np.random.default_rng(8))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(la.mask, lb.mask)
    assert np.abs(a - c).max() > 0.05


def test_ghost_centroids_lie_on_light_centre_line():
    cfg = small_cfg(ghost_count=(5, 5), ghost_chroma=(0.0, 0.0), ghost_radius=(0.01, 0.02))
    lens = F.sample_lens(cfg, np.random.default_rng(4))
    lens = dataclasses.replace(lens, scatter_flux=0.0, glare_amplitude=0.0)
    H, W = 300, 400
    light, centre = np.array([300.0, 200.0]), np.array([(W - 1) / 2, (H - 1) / 2])
    for t in (-1.2, -0.5, 0.4):
        g = dataclasses.replace(lens.ghosts[0], t=t)
        layers = F.render_flare(dataclasses.replace(lens, ghosts=[g]), tuple(light), (H, W))
        lum = layers.flare @ F.LUMA
        yy, xx = np.mgrid[0:H, 0:W]
        cxy = np.array([(lum * xx).sum(), (lum * yy).sum()]) / lum.sum()
        np.testing.assert_allclose(cxy, centre + t * (light - centre), atol=0.6)
        np.testing.assert_allclose(layers.ghost_xy[0], centre + t * (light - centre))
        d = light - centre
        off_line = abs(d[0] * (cxy - centre)[1] - d[1] * (cxy - centre)[0]) / np.hypot(*d)
        assert off_line < 0.6


def test_ghosts_grow_with_distance_from_centre():
    cfg = small_cfg(ghost_count=(1, 1), ghost_chroma=(0.0, 0.0))
    lens = F.sample_lens(cfg, np.random.default_rng(5))
    lens = dataclasses.replace(lens, scatter_flux=0.0, glare_amplitude=0.0)
    areas = []
    for t in (0.2, -0.8, 1.4):
        g = dataclasses.replace(lens.ghosts[0], t=t, ring=False)
        fl = F.render_flare(dataclasses.replace(lens, ghosts=[g]), (250, 150), (300, 400)).flare
        areas.append((fl.max(-1) > 0.5 * fl.max()).sum())
    assert areas[0] < areas[1] < areas[2]


def test_light_outside_frame_still_flares():
    cfg = small_cfg()
    lens = F.sample_lens(cfg, np.random.default_rng(6))
    layers = F.render_flare(lens, (-30.0, -20.0), (96, 128), intensity=2.0)
    assert np.isfinite(layers.flare).all()
    assert not layers.core.any()  # the light itself is not in the picture
    assert layers.flare.max() > cfg.mask_abs_threshold and layers.mask.any()
    far = F.render_flare(lens, (-5000.0, -5000.0), (96, 128))
    assert far.flare[..., 1].mean() < layers.flare[..., 1].mean()


def test_unseen_config_never_overlaps_default():
    d, u = F.FlareConfig(), F.FlareConfig.unseen()
    assert not set(d.aperture_blades) & set(u.aperture_blades)
    assert d.ghost_count[1] < u.ghost_count[0]
    for lo, hi in u.ghost_hues:
        for dlo, dhi in d.ghost_hues:
            assert hi < dlo or lo > dhi
    assert u.bank_key() != d.bank_key()


def test_lens_summary_is_json():
    import json

    lens = F.sample_lens(small_cfg(), np.random.default_rng(0))
    s = json.loads(json.dumps(lens.summary()))
    assert len(s["ghosts"]) == len(lens.ghosts) and s["bank"] == lens.cfg.bank_key()


# --------------------------------------------------------------------------- kinds of flare
H, W = 96, 128
BLACK = np.zeros((H, W, 3), np.uint8)
GREY = np.full((H, W, 3), 128, np.uint8)
WHITE_LIGHT = dict(light_temperature=(6500.0, 6500.0))  # light_rgb = (1, 1, 1)


def kind_cfg(*kinds: str, **kw) -> F.FlareConfig:
    return F.FlareConfig(**{**BANK, "kinds": kinds, **kw})


def documented_threshold(img: np.ndarray) -> float:
    """The mask rule on a uniform photo: max(MASK_THRESHOLD, MASK_RELATIVE x its luminance)."""
    lum = float(srgb_to_linear(img[0, 0] / 255.0) @ F.LUMA)
    return max(F.MASK_THRESHOLD, F.MASK_RELATIVE * lum)


@pytest.mark.parametrize("kind", F.KINDS)
@pytest.mark.parametrize("img", [BLACK, GREY], ids=["black", "grey"])
def test_each_kind_masks_exactly_where_its_light_exceeds_the_threshold(kind, img):
    cfg = kind_cfg(kind, intensity=(2.0, 2.0))
    assert cfg.mask_abs_threshold == F.MASK_THRESHOLD
    _, layers = F.synthesize(img, cfg, np.random.default_rng(11), light_xy=(44.0, 30.0))
    assert layers.kinds == (kind,)
    thr = documented_threshold(img)
    np.testing.assert_allclose(F.mask_threshold(cfg, (H, W), image_to_linear(img)), thr,
                               rtol=1e-6)
    lum = F.luminance(layers.flare)
    core = layers.core.max(-1) > 0
    np.testing.assert_array_equal(layers.mask, (lum > np.float32(thr)) & ~core)
    assert layers.mask.sum() >= 10  # the kind adds visible light ...
    assert ((lum > 0) & ~layers.mask & ~core).any()  # ... and light under the threshold
    assert layers.flare.min() >= 0


def test_starburst_spikes_reach_along_their_directions_with_colour_fringes():
    angles = [0.3 + k * np.pi / 3 for k in range(6)]
    sb = F.Starburst(angles=angles, lengths=[0.25] * 6, width=0.004, sharpness=1.0,
                     amplitude=0.5, chroma=0.1, tint=np.ones(3, np.float32))
    h, w = 260, 260
    light = np.array([130.0, 130.0])
    out = F.render_starburst(sb, tuple(light), (h, w), np.ones(3, np.float32))
    L = 0.25 * np.hypot(h, w)  # 92 px
    lum = F.luminance(out)

    def at(angle, r, img=lum):
        x, y = np.round(light + r * np.array([np.cos(angle), np.sin(angle)])).astype(int)
        return img[y, x]

    for a in angles:
        assert at(a, 0.6 * L) > 0.1  # 55 px out: 0.5 x (1 - 0.6) = 0.2 on the axis
        assert at(a + np.pi / 6, 0.3 * L) < 1e-4  # nothing between the spikes
        assert at(a, 1.15 * L) == 0  # beyond the longest (red) channel
        # colour fringes: past the blue tips, before the red ones, the spike is red
        assert at(a, 0.95 * L, out[..., 0]) > 0.01 and at(a, 0.95 * L, out[..., 2]) == 0
    assert out[..., 0].sum() > out[..., 1].sum() > out[..., 2].sum()


def test_starburst_sampling_covers_its_ranges():
    cfg = F.StarburstConfig()
    counts = {len(F.sample_starburst(cfg, np.random.default_rng(s)).angles) for s in range(60)}
    assert min(counts) >= 4 and max(counts) <= 18 and len(counts) > 8
    sb = F.sample_starburst(dataclasses.replace(cfg, length_spread=(0.5, 0.5)),
                            np.random.default_rng(0))
    assert max(sb.lengths) / min(sb.lengths) > 1.2  # varied lengths


def test_ghost_chain_lies_beyond_the_centre_on_the_light_line():
    chain = F.GhostChainConfig(t=(-1.6, -0.4), count=(5, 5), amplitude=(0.3, 0.3),
                               radius=(0.02, 0.03), chroma=(0.0, 0.0), ring_prob=0.0)
    cfg = kind_cfg("ghosts", ghosts=chain, **WHITE_LIGHT)
    lens = F.sample_lens(cfg, np.random.default_rng(3))
    h, w = 120, 160
    light, centre = np.array([140.0, 20.0]), np.array([(w - 1) / 2, (h - 1) / 2])
    layers = F.render_flare(lens, tuple(light), (h, w))
    ys, xs = np.nonzero(layers.mask)
    assert len(ys) > 20
    v = light - centre
    t = ((xs - centre[0]) * v[0] + (ys - centre[1]) * v[1]) / (v @ v)
    assert t.max() < 0  # every ghost on the far side of the centre
    lum = F.luminance(layers.flare)
    for g in lens.kind_params["ghosts"].ghosts:
        x, y = np.round(centre + g.t * v).astype(int)
        if 0 <= x < w and 0 <= y < h:  # filled ghosts are bright at their centres
            assert lum[y, x] > F.MASK_THRESHOLD
    assert lum[:, : w // 2].sum() > 20 * lum[:, w // 2:].sum()  # the light is on the right


def test_ghost_chain_shapes_and_spacing():
    cfg = F.GhostChainConfig(regular_prob=1.0, spacing=(0.3, 0.3), count=(5, 5))
    chain = F.sample_ghost_chain(cfg, np.random.default_rng(0))
    np.testing.assert_allclose(np.diff([g.t for g in chain.ghosts]), 0.3)
    sides = {F.sample_ghost_chain(F.GhostChainConfig(), np.random.default_rng(s)).blades
             for s in range(60)}
    assert sides == {0, 5, 6, 7, 8, 9}


def test_anamorphic_streak_is_long_thin_and_falls_off():
    streaks = F.StreakConfig(anamorphic_prob=1.0, anamorphic_tilt=0.0, amplitude=(0.3, 0.3),
                             anamorphic_length=(1.0, 1.0), anamorphic_width=(0.004, 0.004),
                             anamorphic_saturation=(0.0, 0.0))
    lens = F.sample_lens(kind_cfg("streaks", streaks=streaks, **WHITE_LIGHT),
                         np.random.default_rng(0))
    h, w = 96, 256
    layers = F.render_flare(lens, (30.0, 48.0), (h, w))
    row = layers.mask[48]
    assert row[36:].all()  # masked from the light to the far edge: 220+ px
    assert layers.mask[:, 150].sum() <= 5  # thin across
    lum = F.luminance(layers.flare)[48]
    assert lum[40] > lum[120] > lum[250] > 0  # falls off with distance


def test_smeared_streaks_several_directions():
    streaks = F.StreakConfig(anamorphic_prob=0.0, count=(3, 3), amplitude=(0.4, 0.4),
                             length=(0.6, 0.6))
    lens = F.sample_lens(kind_cfg("streaks", streaks=streaks, **WHITE_LIGHT),
                         np.random.default_rng(1))
    st = lens.kind_params["streaks"].streaks
    assert len(st) == 3 and len({round(s.angle, 3) for s in st}) == 3
    h, w = 200, 200
    layers = F.render_flare(lens, (100.0, 100.0), (h, w))
    for s in st:  # masked 70 px out along each direction, both ways
        for sign in (1, -1):
            x, y = np.round(100 + sign * 70 * np.array([np.cos(s.angle), np.sin(s.angle)]))
            assert layers.mask[int(y), int(x)]


def test_glare_lifts_a_large_area_a_little_and_masks_only_near_the_light():
    h, w = 96, 128
    diag = np.hypot(h, w)
    cfg = kind_cfg("glare")
    yy, xx = np.mgrid[0:h, 0:w]
    for seed in range(6):
        lens = F.sample_lens(cfg, np.random.default_rng(seed))
        layers = F.render_flare(lens, (30.0, 40.0), (h, w), intensity=cfg.intensity[1])
        lum = F.luminance(layers.flare)
        assert (lum > 0.1 * F.MASK_THRESHOLD).mean() > 0.9  # nearly all the frame is lifted
        assert 0 < layers.mask.mean() < 0.5
        dist = np.hypot(xx - 30, yy - 40)[layers.mask]
        assert dist.max() < 0.45 * diag  # the glow near the light, not the veil
    # the veil and cast alone never reach the mask, however bright the light
    veil_only = dataclasses.replace(
        cfg, glare=F.VeilingGlareConfig(glow_amplitude=(1e-9, 1e-9), veil_level=(0.7, 0.7),
                                        cast_level=(0.3, 0.3)))
    lens = F.sample_lens(veil_only, np.random.default_rng(0))
    layers = F.render_flare(lens, (30.0, 40.0), (h, w), intensity=20.0)
    lum = F.luminance(layers.flare)
    assert lum.max() <= F.VEIL_CAP * F.MASK_THRESHOLD * 1.001 and not layers.mask.any()
    assert (lum > 0.5 * F.MASK_THRESHOLD).mean() > 0.5


@pytest.mark.parametrize("img", [BLACK, GREY], ids=["black", "grey"])
def test_combined_kinds_sum_their_layers_and_mask_the_sum(img):
    always = dict(scatter_prob=1.0, starburst=F.StarburstConfig(prob=1.0),
                  ghosts=F.GhostChainConfig(prob=1.0), streaks=F.StreakConfig(prob=1.0),
                  glare=F.VeilingGlareConfig(prob=1.0))
    cfg = kind_cfg(*F.KINDS, **always)
    lens = F.sample_lens(cfg, np.random.default_rng(3))
    assert lens.kinds == F.KINDS and set(lens.kind_params) == set(F.KINDS) - {"scatter"}
    light, k, bg = (50.0, 40.0), 0.6, image_to_linear(img)
    layers = F.render_flare(lens, light, (H, W), None, k, bg)
    parts = [F.render_kind(lens, kind, light, (H, W), None, k) for kind in lens.kinds]
    assert all(p.max() > 0 for p in parts)
    total = parts[0]
    for p in parts[1:]:
        total = total + p
    np.testing.assert_array_equal(layers.flare, total)
    thr = np.float32(documented_threshold(img))
    core = layers.core.max(-1) > 0
    np.testing.assert_array_equal(layers.mask, (F.luminance(total) > thr) & ~core)
    # faint layers add up: the sum is masked where no single kind would be
    union = np.any([F.luminance(p) > thr for p in parts], axis=0)
    assert (layers.mask & ~union).any() and not (union & ~layers.mask & ~core).any()
    # synthesize composes the drawn kinds for one light the same way
    _, syn = F.synthesize(img, cfg, np.random.default_rng(4), light_xy=light)
    assert syn.kinds == F.KINDS
    thr_map = F.mask_threshold(cfg, (H, W), bg)
    np.testing.assert_array_equal(
        syn.mask, (F.luminance(syn.flare) > thr_map) & ~(syn.core.max(-1) > 0))


def test_kinds_drawn_by_probability_and_never_none():
    never = dict(scatter_prob=0.0, starburst=F.StarburstConfig(prob=0.0),
                 ghosts=F.GhostChainConfig(prob=0.0), streaks=F.StreakConfig(prob=0.0),
                 glare=F.VeilingGlareConfig(prob=0.0))
    cfg = kind_cfg(*F.KINDS, **never)
    drawn = [F.sample_lens(cfg, np.random.default_rng(s)).kinds for s in range(40)]
    assert all(len(d) == 1 for d in drawn) and len(set(drawn)) == 5  # one, at random
    mixed = [F.sample_lens(kind_cfg(*F.KINDS), np.random.default_rng(s)).kinds
             for s in range(40)]
    assert len({len(d) for d in mixed}) >= 3  # default: varied combinations
    assert F.FlareConfig().kinds == F.KINDS  # training data: every kind
    lens = F.sample_lens(kind_cfg("scatter"), np.random.default_rng(0))
    assert lens.kinds == ("scatter",) and lens.kind_params == {}
    assert F.FlareConfig.unseen().kinds == ("scatter",)


def test_unknown_kind_is_a_user_error():
    with pytest.raises(UserError, match=r"^--kinds 'starburst,sun': unknown flare kind 'sun'; "
                       r"allowed kinds: starburst, ghosts, streaks, glare, scatter$"):
        F.parse_kinds("starburst,sun")
    with pytest.raises(UserError, match="FlareConfig.kinds"):
        F.FlareConfig(kinds=("starburst", "halo"))
    with pytest.raises(UserError, match="empty"):
        F.parse_kinds(" , ")
    assert F.parse_kinds(" ghosts, glare,ghosts") == ("ghosts", "glare")


def test_kind_probs_change_how_often_a_kind_is_drawn():
    probs = F.parse_kind_probs("streaks=0.9, scatter=0.1")
    assert probs == {"streaks": 0.9, "scatter": 0.1}
    cfg = F.FlareConfig().with_kind_probs(probs)
    assert cfg.kind_prob("streaks") == 0.9 and cfg.kind_prob("scatter") == 0.1
    assert cfg.kind_prob("ghosts") == F.FlareConfig().kind_prob("ghosts")
    assert F.FlareConfig().kind_prob("streaks") == 0.35  # the default is untouched
    rng = np.random.default_rng(0)
    drawn = [flare_lens._draw_kinds(cfg, rng) for _ in range(400)]
    assert sum("streaks" in d for d in drawn) / 400 > 0.8
    assert sum("scatter" in d for d in drawn) / 400 < 0.2
    for bad, msg in (("streaks=1.5", "between 0 and 1"), ("streaks", "KIND=P"),
                     ("sun=0.5", "unknown flare kind 'sun'")):
        with pytest.raises(UserError, match=msg):
            F.parse_kind_probs(bad)


def test_summary_of_every_kind_is_json():
    import json

    always = dict(scatter_prob=1.0, starburst=F.StarburstConfig(prob=1.0),
                  ghosts=F.GhostChainConfig(prob=1.0), streaks=F.StreakConfig(prob=1.0),
                  glare=F.VeilingGlareConfig(prob=1.0))
    lens = F.sample_lens(kind_cfg(*F.KINDS, **always), np.random.default_rng(0))
    s = json.loads(json.dumps(lens.summary()))
    assert s["kinds"] == list(F.KINDS) and set(s["kind_params"]) == set(F.KINDS) - {"scatter"}
    assert len(s["kind_params"]["ghosts"]["ghosts"]) == len(lens.kind_params["ghosts"].ghosts)


def test_each_kind_is_its_own_module_with_its_config_parameters_sampler_and_renderer():
    """pipeline/flare/: every kind but ``scatter`` lives in a module of its own name holding
    its config (the type of FlareConfig's field of that name), the sampler a lens draws its
    parameters with, and a renderer; ``scatter`` (FlareConfig's flat fields) has its own."""
    import importlib

    from pipeline.flare.lens import _SAMPLERS

    fields = {f.name: f for f in dataclasses.fields(F.FlareConfig)}
    assert set(_SAMPLERS) == set(F.KINDS) - {"scatter"}
    for kind, sampler in _SAMPLERS.items():
        mod = importlib.import_module(f"pipeline.flare.{kind}")
        config = type(getattr(F.FlareConfig(), kind))
        assert config is getattr(mod, config.__name__)
        assert fields[kind].default_factory is config
        assert sampler.__module__ == mod.__name__
        params = sampler(config(), np.random.default_rng(0))
        assert type(params).__module__ == mod.__name__
        assert any(n.startswith("render_") and callable(getattr(mod, n)) for n in vars(mod))
    scatter = importlib.import_module("pipeline.flare.scatter")
    assert callable(scatter.psf_bank) and callable(scatter._render_lens_scatter)
