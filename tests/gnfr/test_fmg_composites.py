"""FMG training data: flared composites and their masks, frame and night composites, hard
negatives, kinds left out and the photo splits."""

from __future__ import annotations

import numpy as np
import pytest
import torch


def test_composites_mark_visible_flare_not_core():
    from pipeline import flare as fl
    from pipeline.fmg_data import CompositeConfig, composite_flare, warp_layers

    rng = np.random.default_rng(3)
    img = np.full((96, 96, 3), 0.25, np.float32)
    flared, mask = composite_flare(img, fl.FlareConfig(), CompositeConfig(size=96), rng)
    assert flared.shape == img.shape and mask.shape == (96, 96) and mask.any()
    diff = np.abs(flared - img).max(axis=2)
    assert diff[mask].mean() > 3 * diff[~mask].mean()
    # one affine moves flare, core and mask alike; the core is never in the mask
    lens = fl.sample_lens(fl.FlareConfig(), rng)
    layers = fl.render_flare(lens, (48.0, 48.0), (96, 96), None, 1.0)
    m = np.array([[1, 0, 10], [0, 1, -5]], np.float32)  # shift 10 right, 5 up
    w = warp_layers(layers, m, 96)
    assert np.array_equal(w.mask[:-5, 10:], layers.mask[5:, :-10])
    assert np.allclose(w.core[:-5, 10:], layers.core[5:, :-10])
    assert not (w.mask & (w.core.max(axis=2) > 0)).any()


def test_composites_with_clean_are_the_same_draws_and_score_a_perfect_fill():
    """``with_clean`` gives the same composites and masks, and each photo as its exposure
    shows it without the flare; the fill ceiling is the flare-region PSNR with the marked
    pixels made clean: everything marked, nothing left; nothing marked, the flared photos'
    own; a hole the marks enclose is marked by ``holes_filled``."""
    from pipeline import flare as fl
    from pipeline.fmg_data import CompositeConfig, CompositeSource, fixed_set
    from pipeline.metrics import PSNR_CAP
    from workflows.research.fmg_eval import fill_ceiling, fill_error, holes_filled

    rng = np.random.default_rng(0)
    bgs = [(rng.random((120, 150, 3)) * 160).astype(np.uint8) for _ in range(3)]
    src = CompositeSource(bgs, fl.FlareConfig(noise=(0.0, 0.0)), CompositeConfig(size=64))
    x, y = fixed_set(src, 4, 7)
    x2, y2, clean = fixed_set(src, 4, 7, with_clean=True)
    assert torch.equal(x, x2) and torch.equal(y, y2) and clean.shape == x.shape
    true = y > 0.5
    diff = (x - clean).abs().amax(1, keepdim=True)
    assert true.any() and diff[true].mean() > 5 * diff[~true].mean()
    everything = fill_error(x, clean, torch.ones_like(true), true)
    assert everything[0] == 0 and fill_ceiling(*everything) == PSNR_CAP
    nothing = fill_error(x, clean, torch.zeros_like(true), true)
    q = [np.round(np.clip(t.numpy().astype(np.float64), 0, 1) * 255) / 255 for t in (x, clean)]
    mse = ((q[0] - q[1]) ** 2).sum(1)[true.numpy()[:, 0]].sum() / (3 * true.sum().item())
    assert fill_ceiling(*nothing) == pytest.approx(-10 * np.log10(mse))
    assert fill_ceiling(0.0, 0.0) is None
    ring = torch.zeros(1, 1, 9, 9, dtype=torch.bool)
    ring[0, 0, 2:7, 2:7] = True
    ring[0, 0, 4, 4] = False  # the light's core, unmarked inside its glow
    filled = holes_filled(ring)
    assert filled[0, 0, 4, 4] and filled.sum() == 25 and not filled[0, 0, 0, 0]


def test_flare_canvas_draws_a_window_of_a_larger_frame():
    """flare_canvas 1 draws as before (the same lens, light and intensity from the stream);
    2 renders the lens for a frame twice the side and keeps a window holding the light, so
    the flare spans twice the pixels it would in the composite's own frame."""
    from pipeline import flare as fl
    from pipeline.fmg_data import CompositeConfig, draw_flare, window_layers

    cfg = fl.FlareConfig(kinds=("starburst",), light_outside_prob=0.0)
    S = 96
    one = draw_flare(cfg, CompositeConfig(size=S), S, np.random.default_rng(4))
    rng = np.random.default_rng(4)  # the old draw, by hand
    lens = fl.sample_lens(cfg, rng)
    light = fl.sample_light_xy(cfg, (S, S), rng)
    k = float(np.exp(rng.uniform(*np.log(cfg.intensity))))
    ref = fl.render_flare(lens, light, (S, S), rng, k)
    assert np.array_equal(one.mask, ref.mask) and np.allclose(one.flare, ref.flare)
    two = draw_flare(cfg, CompositeConfig(size=S, flare_canvas=2.0), S, np.random.default_rng(4))
    assert two.flare.shape == (S, S, 3) and two.mask.shape == (S, S)
    lx, ly = two.light_xy
    assert 0 <= lx < S and 0 <= ly < S  # the light was in the larger frame: it is kept
    # the same lens drawn at twice the frame: its spikes are twice as long
    big = fl.render_flare(lens, (2 * light[0], 2 * light[1]), (2 * S, 2 * S), None, k)
    assert big.mask.sum() > 2.5 * ref.mask.sum()
    # a window is a plain crop, positions moved with it
    w = window_layers(big, 10, 20, S)
    assert np.array_equal(w.mask, big.mask[20:20 + S, 10:10 + S])
    assert w.light_xy == (2 * light[0] - 10, 2 * light[1] - 20)


def test_frame_composites_draw_flare_for_the_whole_photo():
    """frame_prob: a window of the photo at its own scale, the lens rendered for the whole
    photo about the photo's centre (ghosts on the line through it, as synth lays them out),
    the light inside the window; no draw and no change at frame_prob 0."""
    from pipeline import flare as fl
    from pipeline.fmg_data import (
        CompositeConfig,
        CompositeSource,
        draw_frame_flare,
        fixed_set,
        frame_crop,
        frame_window,
    )

    S, hw = 64, (96, 160)
    assert frame_window(np.zeros((48, 160, 3), np.uint8), S, np.random.default_rng(0)) is None
    for seed in range(20):
        x0, y0 = frame_window(np.zeros((*hw, 3), np.uint8), S, np.random.default_rng(seed))
        assert 0 <= x0 <= hw[1] - S and 0 <= y0 <= hw[0] - S
    cfg = fl.FlareConfig(kinds=("starburst", "ghosts"), light_outside_prob=0.0)
    win = (60, 16)  # holds the photo's centre, (79.5, 47.5), off the window's own
    got = draw_frame_flare(cfg, hw, win, S, np.random.default_rng(7))
    rng = np.random.default_rng(7)  # the same draw by hand: the whole photo, then the window
    lens = fl.sample_lens(cfg, rng)
    light = (win[0] + S * float(rng.uniform(0.1, 0.9)), win[1] + S * float(rng.uniform(0.1, 0.9)))
    k = float(np.exp(rng.uniform(*np.log(cfg.intensity))))
    whole = fl.render_flare(lens, light, hw, rng, k)
    assert got.mask.shape == (S, S) and got.mask.any()
    assert np.array_equal(got.mask, whole.mask[16:16 + S, 60:60 + S])
    assert np.allclose(got.flare, whole.flare[16:16 + S, 60:60 + S])
    lx, ly = got.light_xy
    assert 0.1 * S <= lx <= 0.9 * S and 0.1 * S <= ly <= 0.9 * S
    # about the window's own centre the ghosts would fall elsewhere: the photo's centre counts
    own = fl.render_flare(lens, (lx, ly), (S, S), None, k)
    assert not np.array_equal(own.mask, got.mask)

    bgs = [np.random.default_rng(i).integers(0, 255, (*hw, 3), dtype=np.uint8) for i in range(3)]
    flat = dict(jitter=0.0, distractor_prob=0.0, negative_prob=0.0, clean_negative_prob=0.0,
                flare_prob=1.0)
    framed = CompositeSource(bgs, cfg, CompositeConfig(size=S, frame_prob=1.0, **flat))
    for seed in range(4):
        img, mask = framed.sample(np.random.default_rng(seed))
        assert img.shape == (S, S, 3) and mask.shape == (S, S) and mask.any()
    # the window is the photo's own pixels, not resized (mirrored or not)
    flips = set()
    for seed in range(8):
        crop = frame_crop(bgs[0], (30, 20), S, np.random.default_rng(seed))
        ref = bgs[0][20:20 + S, 30:30 + S] / 255.0
        flips.add(bool(np.allclose(crop, ref[:, ::-1])))
        assert crop.dtype == np.float32
        assert np.allclose(crop, ref) or np.allclose(crop, ref[:, ::-1])
    assert flips == {True, False}
    plain = CompositeSource(bgs, cfg, CompositeConfig(size=S, **flat))
    a = plain.sample(np.random.default_rng(11))
    b = CompositeSource(bgs, cfg, CompositeConfig(size=S, frame_prob=0.0, **flat)).sample(
        np.random.default_rng(11))
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not np.array_equal(a[1], framed.sample(np.random.default_rng(11))[1])
    # validation composites (train=False) never use frames: one set for every run
    va, vb = fixed_set(plain, 3, 5), fixed_set(framed, 3, 5)
    assert torch.equal(va[0], vb[0]) and torch.equal(va[1], vb[1])


def test_night_glare_scales_the_glare_of_night_composites(monkeypatch):
    """`fmg train --night-glare`: night composites draw their flare from a config whose
    glare kind is that many times as likely (capped at 1); day composites, and every
    composite at 1, from the training flare itself."""
    import pipeline.fmg_data as fd

    cfg = fd.training_flare()
    bgs = [np.full((120, 120, 3), 40, np.uint8)]
    used = []
    real = fd.composite_flare

    def spy(img, flare_cfg, *a, **k):
        used.append(flare_cfg)
        return real(img, flare_cfg, *a, **k)

    monkeypatch.setattr(fd, "composite_flare", spy)
    flat = {"size": 64, "flare_prob": 1.0, "distractor_prob": 0.0, "negative_prob": 0.0}
    cases = ((1.0, 0.0, 0.0), (1.0, 2.0, 0.8), (1.0, 5.0, 1.0), (0.0, 0.0, 0.4), (1.0, 1.0, 0.4))
    for night_prob, night_glare, glare in cases:
        used.clear()
        src = fd.CompositeSource(bgs, cfg, fd.CompositeConfig(
            night_prob=night_prob, night_glare=night_glare, **flat))
        src.sample(np.random.default_rng(1))
        assert used[0].kind_prob("glare") == pytest.approx(glare)
        assert used[0].kind_prob("streaks") == cfg.kind_prob("streaks")
    assert cfg.kind_prob("glare") == pytest.approx(0.4)


def test_night_backgrounds_and_hard_negatives():
    from pipeline import flare as fl
    from pipeline.fmg_data import (
        HARD_NEGATIVES,
        CompositeConfig,
        CompositeSource,
        add_hard_negatives,
        darken_night,
    )

    rng = np.random.default_rng(5)
    comp = CompositeConfig(size=96, night_prob=1.0)
    img = np.full((96, 96, 3), 0.6, np.float32)
    dark = darken_night(img, comp, rng)
    assert dark.shape == img.shape and dark.max() < 0.6 and dark[..., 2].min() >= dark[..., 0].max()
    # every kind of hard negative paints something bright (or reflects it), in range
    base = np.random.default_rng(1).uniform(0.02, 0.2, (96, 96, 3)).astype(np.float32)
    base[:40] = 0.9  # a bright top half for the reflection to mirror
    for kind in HARD_NEGATIVES:
        out = add_hard_negatives(base, np.random.default_rng(2), (kind,))
        assert out.shape == base.shape and out.dtype == np.float32, kind
        assert out.min() >= 0 and out.max() <= 1, kind
        assert np.abs(out - base).max() > 0.1, kind
    lamp = add_hard_negatives(np.zeros((96, 96, 3), np.float32), np.random.default_rng(3),
                              ("lamp",))
    assert fl.luminance(lamp).max() > 0.5  # a bright light, no flare around it
    # hard negatives are never labelled flare
    bgs = [np.full((120, 120, 3), 40, np.uint8)]
    clean = CompositeConfig(size=96, flare_prob=0.0, clean_negative_prob=1.0,
                            distractor_prob=0.0)
    x, y = CompositeSource(bgs, comp=clean).batch(4, np.random.default_rng(4))
    assert not y.any() and float(x.max()) > 0.5
    # the evaluation set does not depend on the training-only options
    a = CompositeSource(bgs, comp=CompositeConfig(size=96)).batch(2, np.random.default_rng(1),
                                                                  train=False)
    b = CompositeSource(bgs, comp=clean).batch(2, np.random.default_rng(1), train=False)
    assert torch.equal(a[0], b[0]) and torch.equal(a[1], b[1]) and a[1].any()


def test_cloud_negatives_are_white_clouds_on_blue_sky_above_the_untouched_ground():
    """``clouds``: from the top down, a blue sky with white, near-neutral clouds covering part
    of it; the bottom of the photo (below the horizon) is the photo's own."""
    from pipeline.fmg_data import add_hard_negatives

    base = np.random.default_rng(1).uniform(0.05, 0.3, (128, 128, 3)).astype(np.float32)
    for seed in range(6):
        out = add_hard_negatives(base, np.random.default_rng(seed), ("clouds",))
        top = out[:16].reshape(-1, 3)
        white = (top.min(1) > 0.75) & (top.max(1) - top.min(1) < 0.15)
        blue = (top[:, 2] > top[:, 0] + 0.15) & ~white
        assert white.mean() > 0.01 and blue.mean() > 0.2, seed
        assert (white | blue).mean() > 0.8, seed  # the rest: the clouds' soft edges
        np.testing.assert_allclose(out[-4:], base[-4:], atol=2e-3)


def test_backlit_negatives_are_dark_leaves_in_front_of_a_glow_that_lies_behind_them():
    """``backlit``: a tree crown at night in front of a lamp's glow: inside what it paints
    there are bright gaps (the glow) and dark leaves (which the glow does not brighten, unlike
    lens glare); the glow stays behind the crown (part of the photo is left as it was)."""
    from pipeline.fmg_data import add_hard_negatives

    base = np.full((128, 128, 3), 0.1, np.float32)
    painted = 0
    for seed in range(8):
        out = add_hard_negatives(base, np.random.default_rng(seed), ("backlit",))
        changed = np.abs(out - base).max(-1) > 0.02
        if not changed.any():
            continue
        painted += 1
        assert (~changed).mean() > 0.02, seed  # a crown, not a wash over the whole frame
        v = out[changed].max(-1)
        assert (v > 0.3).mean() > 0.01 and (v < 0.2).mean() > 0.2, seed
    assert painted >= 6


def test_training_flare_leaves_kinds_out():
    from pipeline import flare as fl
    from pipeline.errors import UserError
    from pipeline.fmg_data import training_flare

    assert training_flare().kinds == fl.KINDS
    assert training_flare(("streaks",)).kinds == tuple(k for k in fl.KINDS if k != "streaks")
    with pytest.raises(UserError, match="--without"):
        training_flare(("lasers",))
    with pytest.raises(UserError, match="no kind"):
        training_flare(fl.KINDS)


def test_split_keeps_test_and_dev_photos_out_of_training(tmp_path):
    """Test and development photos never train; a photo with real flare is in no part."""
    from pipeline.fmg_data import HELDOUT_BACKGROUNDS, REAL_FLARE_PHOTOS, split_backgrounds
    from pipeline.scene_splits import FMG_DEV_SCENES, HELDOUT_SCENES, TEST_SCENES

    assert not set(FMG_DEV_SCENES) & set(TEST_SCENES)
    flared_scene, flared_stem = REAL_FLARE_PHOTOS[0].split("/")
    for rel in [f"scenes/{HELDOUT_SCENES[0]}/a.jpg", "scenes/et/sub/b.png",
                f"scenes/{FMG_DEV_SCENES[0]}/images/c.jpg",
                f"backgrounds/x/{HELDOUT_BACKGROUNDS[0]}.png", "backgrounds/y.jpg",
                "backgrounds/notes.txt", f"scenes/{flared_scene}/{flared_stem}.JPG"]:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(b"")
    parts = split_backgrounds(tmp_path)
    assert sorted(p.name for p in parts.train) == ["b.png", "y.jpg"]
    assert [p.name for p in parts.dev] == ["c.jpg"]
    assert sorted(p.name for p in parts.test) == sorted(["a.jpg",
                                                        f"{HELDOUT_BACKGROUNDS[0]}.png"])


def test_hard_negative_pool_is_respected():
    """``CompositeConfig.negatives`` limits what is painted; `fmg train --negatives` defaults
    to every kind."""
    from pipeline import fmg_data as fd
    from workflows.research.fmg_train import FMGTrainConfig

    assert FMGTrainConfig.__dataclass_fields__["negatives"].default == fd.DEFAULT_NEGATIVES
    choices = FMGTrainConfig.__dataclass_fields__["negatives"].metadata["choices"]
    assert set(choices) == set(fd.HARD_NEGATIVES)  # clouds and backlit can be asked for
    from workflows.research.fmg_eval import FMGEvalConfig  # literals, for the CLI's ast read

    assert FMGEvalConfig.__dataclass_fields__["negatives"].metadata["choices"] == choices
    img = np.full((64, 64, 3), 0.2, np.float32)
    calls = []
    saved = dict(fd._NEGATIVES)
    try:
        for k in fd.HARD_NEGATIVES:
            fd._NEGATIVES[k] = lambda lin, rng, k=k: calls.append(k)
        rng = np.random.default_rng(0)
        for _ in range(40):
            fd.add_hard_negatives(img, rng, pool=("sky", "wall"))
        assert set(calls) == {"sky", "wall"}
        calls.clear()
        for _ in range(40):
            fd.add_hard_negatives(img, rng)
        assert "neon" in calls and set(calls) == set(fd.DEFAULT_NEGATIVES)
        assert not set(calls) & set(fd.OPTIONAL_NEGATIVES)  # options only
    finally:
        fd._NEGATIVES.update(saved)
