"""Properties of the physically based flare synthesizer (pipeline/flare.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pipeline import flare as F

# a small bank keeps every test fast; the physics is the same as the default's
SMALL = dict(psf_size=128, n_psfs=3, n_wavelengths=9, dust_count=(5, 20))


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("DEFLARE_CACHE", str(tmp_path / "cache"))
    F._BANKS.clear()
    yield
    F._BANKS.clear()


def small_cfg(**kw) -> F.FlareConfig:
    return F.FlareConfig(**{**SMALL, **kw})


def test_srgb_linear_round_trip_and_monotonic():
    x = np.linspace(0, 1, 1001, dtype=np.float32)
    lin = F.srgb_to_linear(x)
    assert np.all(np.diff(lin) > 0)
    assert abs(lin[500] - 0.2140) < 1e-3  # sRGB 0.5 is about 21% linear
    np.testing.assert_allclose(F.linear_to_srgb(lin), x, atol=2e-6)


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
    F._BANKS.clear()
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
    expect = F.srgb_to_linear(img / 255.0) + layers.flare + layers.core
    ok = expect < 0.999  # where nothing clipped
    assert ok.mean() > 0.3 and (~ok).any()
    np.testing.assert_allclose(F.srgb_to_linear(out)[ok], expect[ok], atol=1e-5)
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
