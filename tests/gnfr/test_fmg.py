"""FMG (PSPNet): shapes, the 5:1 weighted loss, metrics, weight files, a CPU overfit."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from gnfr.fmg import (
    FMGConfig,
    build_fmg,
    confusion,
    fmg_loss,
    load_fmg,
    predict_probs,
    save_fmg,
    seg_metrics,
    tiny_config,
    work_shape,
)
from tests.conftest import shared


@pytest.mark.parametrize("hw", [(64, 64), (37, 53), (8, 8), (101, 66)])
def test_pspnet_output_shape(hw):
    torch.manual_seed(0)
    model = build_fmg(tiny_config()).eval()
    x = torch.rand(2, 3, *hw)
    y = model(x)
    assert y.shape == (2, 1, *hw) and torch.isfinite(y).all()


def test_backbone_output_stride_8_and_ppm_width():
    cfg = FMGConfig(widths=(8, 16, 24, 32), depths=(1, 2, 1, 1), head_width=8)
    model = build_fmg(cfg).eval()
    feats = model.backbone(torch.rand(1, 3, 96, 128))
    assert feats.shape == (1, 32, 12, 16)
    assert model.ppm(feats).shape == (1, 32 + 4 * 8, 12, 16)
    # dilation, not stride, in the last two stages
    assert model.backbone.layer4[-1].conv2.dilation == (4, 4)
    assert model.backbone.layer3[-1].conv2.dilation == (2, 2)


def test_default_config_is_resnet18_sized():
    n = sum(p.numel() for p in build_fmg().parameters())
    assert 10e6 < n < 25 * 2**20 / 2  # fp16 file under 25 MiB


def test_weighted_bce_matches_manual():
    torch.manual_seed(1)
    logits = torch.randn(2, 1, 5, 7)
    target = (torch.rand(2, 1, 5, 7) > 0.7).float()
    p = torch.sigmoid(logits).double()
    t = target.double()
    manual = -(5 * t * torch.log(p) + (1 - t) * torch.log(1 - p)).mean()
    assert fmg_loss(logits, target).item() == pytest.approx(manual.item(), rel=1e-5)
    # flare pixels weigh exactly 5x: same per-pixel BCE, one flare vs one clear pixel
    z = torch.zeros(1, 1, 1, 2)
    per_pixel = F.binary_cross_entropy_with_logits(z, torch.tensor([[[[1.0, 0.0]]]]),
                                                   reduction="none")
    assert per_pixel[0, 0, 0, 0] == pytest.approx(per_pixel[0, 0, 0, 1].item())
    lf = fmg_loss(z[..., :1], torch.ones(1, 1, 1, 1))
    ln = fmg_loss(z[..., :1], torch.zeros(1, 1, 1, 1))
    assert lf.item() == pytest.approx(5 * ln.item())


def test_dice_term_weighs_thin_flare_like_large_flare():
    target = torch.zeros(2, 1, 16, 16)
    target[0, :, 8, 2:14] = 1  # a thin line of 12 pixels
    target[1, :, 2:14, 2:14] = 1  # a block of 144
    logits = torch.full_like(target, -6.0)  # both missed entirely
    bce = fmg_loss(logits, target)
    with_dice = fmg_loss(logits, target, dice=1.0)
    assert with_dice.item() == pytest.approx(bce.item() + 1.0, abs=0.02)  # Dice ~1 for each
    # perfect on the block, missed on the thin line: Dice still charges about a half
    logits[1] = torch.where(target[1] > 0, 6.0, -6.0)
    extra = fmg_loss(logits, target, dice=1.0) - fmg_loss(logits, target)
    assert extra.item() == pytest.approx(0.5, abs=0.02)
    # clean composites add no Dice term (it would be a constant 1)
    clean = torch.zeros(1, 1, 4, 4)
    z = torch.zeros(1, 1, 4, 4)
    assert fmg_loss(z, clean, dice=3.0).item() == pytest.approx(fmg_loss(z, clean).item())


def test_seg_metrics_definitions():
    target = torch.tensor([0, 0, 0, 0, 1, 1, 1, 0])
    pred = torch.tensor([0, 0, 1, 0, 1, 1, 0, 0])
    m = seg_metrics(confusion(pred, target))
    # no-flare: TP 4, FP 1, FN 1 -> IoU 4/6, acc 4/5; flare: TP 2, FP 1, FN 1 -> 2/4, 2/3
    assert m["mIoU"] == pytest.approx((4 / 6 + 2 / 4) / 2)
    assert m["mAcc"] == pytest.approx((4 / 5 + 2 / 3) / 2)
    assert m["IoU_flare"] == pytest.approx(0.5)
    perfect = seg_metrics(confusion(target, target))
    assert perfect["mIoU"] == 1.0 and perfect["mAcc"] == 1.0


def test_work_shape_and_predict_probs_size():
    assert work_shape(480, 640, 512) == (384, 512)
    assert all(v % 8 == 0 for v in work_shape(333, 517, 256))
    model = build_fmg(tiny_config())
    x = torch.rand(1, 3, 75, 99)
    p = predict_probs(model, x, long_side=64)
    assert p.shape == (1, 1, 75, 99)
    # the network ran at the working size (48 x 64) and its probabilities were upsampled
    with torch.no_grad():
        small = F.interpolate(x, size=(48, 64), mode="bilinear", align_corners=False,
                              antialias=True)
        want = F.interpolate(torch.sigmoid(model.eval()(small)), size=(75, 99),
                             mode="bilinear", align_corners=False)
    assert torch.allclose(p, want, atol=1e-6)


def test_predict_probs_averages_its_scales():
    torch.manual_seed(1)
    model = build_fmg(tiny_config())
    x = torch.rand(2, 3, 75, 99)
    one = predict_probs(model, x, long_side=64)
    assert torch.equal(predict_probs(model, x, long_side=64, scales=(1.0,)), one)
    smaller = predict_probs(model, x, long_side=48)  # 0.75 x 64: the second scale's run
    both = predict_probs(model, x, long_side=64, scales=(1.0, 0.75))
    assert both.shape == one.shape
    assert torch.allclose(both, (one + smaller) / 2, atol=1e-6)
    assert not torch.allclose(both, one, atol=1e-4)  # the second scale changed something
    with pytest.raises(ValueError, match="no scales"):
        predict_probs(model, x, long_side=64, scales=())



def test_predict_probs_pads_keep_the_lowest_of_its_passes():
    """`mask --pads`: each padded pass is the network on the input padded at every edge by
    PAD_SHARE of its long side and cropped back; the result is the lowest of the plain pass
    and those; no pads is the plain pass; an unknown padding is refused."""
    from gnfr.fmg import PAD_SHARE, padded_probs

    torch.manual_seed(3)
    model = build_fmg(tiny_config()).eval()
    x = torch.rand(2, 3, 48, 64)
    with torch.no_grad():
        plain = torch.sigmoid(model(x))
        n = round(PAD_SHARE * 64)
        passes = [torch.sigmoid(model(F.pad(x, (n, n, n, n), mode=m)))[..., n:-n, n:-n]
                  for m in ("reflect", "constant")]
        got = padded_probs(model, x, ("reflect", "constant"))
        assert torch.equal(padded_probs(model, x), plain)
    assert torch.allclose(got, torch.minimum(plain, torch.minimum(*passes)), atol=1e-6)
    assert (got <= plain + 1e-7).all() and not torch.allclose(got, plain, atol=1e-4)
    both = predict_probs(model, x, long_side=64, pads=("reflect", "constant"))
    assert torch.allclose(both, got, atol=1e-6)  # at its own size no resampling
    assert torch.equal(predict_probs(model, x, long_side=64, pads=()),
                       predict_probs(model, x, long_side=64))
    with pytest.raises(ValueError, match="unknown padding"):
        padded_probs(model, x, ("wrap",))
    from gnfr.fmg import PAD_MODES
    from pipeline.mask import MaskConfig

    assert MaskConfig().pads == PAD_MODES  # the literal the CLI reads (no torch there)


def test_predict_probs_pair_is_both_runs_from_one_plain_pass():
    """`mask --pads-keep regions`' two maps: the plain one is predict_probs without pads,
    the other with them, at one scale and averaged over two (resampled), the plain pass
    run once per scale."""
    from gnfr.fmg import predict_probs_pair

    torch.manual_seed(4)
    model = build_fmg(tiny_config()).eval()
    x = torch.rand(1, 3, 60, 80)
    pads = ("reflect", "replicate")
    for scales in ((1.0,), (1.0, 0.75)):
        plain, agreed = predict_probs_pair(model, x, 48, scales, pads)
        assert torch.equal(plain, predict_probs(model, x, 48, scales))
        assert torch.equal(agreed, predict_probs(model, x, 48, scales, pads))
        assert not torch.equal(plain, agreed)
    calls = []
    model.register_forward_hook(lambda *a: calls.append(1))
    predict_probs_pair(model, x, 48, (1.0, 0.75), pads)
    assert len(calls) == 2 * (1 + len(pads))
    same = predict_probs_pair(model, x, 48, (1.0,), ())
    assert same[0] is same[1]  # no pads: one map, resampled once


def test_save_load_roundtrip_fp16(tmp_path):
    torch.manual_seed(2)
    cfg = tiny_config()
    model = build_fmg(cfg).eval()
    path = save_fmg(tmp_path / "w.safetensors", model, extra={"note": "x"})
    loaded = load_fmg(path)
    assert loaded.cfg == cfg
    x = torch.rand(1, 3, 32, 40)
    with torch.no_grad():
        assert torch.allclose(model(x), loaded(x), atol=2e-2)
    with pytest.raises(FileNotFoundError):
        load_fmg(tmp_path / "missing.safetensors")
    (tmp_path / "junk.safetensors").write_bytes(b"junk")
    with pytest.raises(ValueError):
        load_fmg(tmp_path / "junk.safetensors")


def composites(n: int, size: int = 96, seed: int = 0):
    """n flared composites of kermit views (pipeline.fmg_data) and their masks."""
    from pipeline.fmg_data import CompositeConfig, CompositeSource, find_images, load_backgrounds

    paths = find_images(shared("scenes", "kermit"))[:3]
    src = CompositeSource(load_backgrounds(paths, 160), comp=CompositeConfig(size=size))
    return src.batch(n, np.random.default_rng(seed), train=False)


def _fit(model, x, y, steps: int, lr: float = 1e-2) -> list[float]:
    """``steps`` Adam steps of the FMG loss on one batch; the losses."""
    opt = torch.optim.Adam(model.parameters(), lr=lr)
    model.train()
    losses = []
    for _ in range(steps):
        loss = fmg_loss(model(x), y)
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(float(loss.detach()))
    return losses


def _flare_iou(model, x, y) -> float:
    """Flare IoU of ``model`` (eval mode, logit cut 0) on one batch."""
    model.eval()
    with torch.no_grad():
        return seg_metrics(confusion(model(x) > 0, y > 0.5))["IoU_flare"]


def test_tiny_fmg_overfits_composites():
    torch.manual_seed(0)
    x, y = composites(4)
    assert 0.005 < float(y.mean()) < 0.8  # every composite has some flare, not all flare
    model = build_fmg(tiny_config())
    iou0 = _flare_iou(model, x, y)
    losses = _fit(model, x, y, 80)
    assert np.mean(losses[-5:]) < 0.5 * np.mean(losses[:5])
    iou1 = _flare_iou(model, x, y)
    assert iou1 > max(0.5, iou0 + 0.2), (iou0, iou1)


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


def _tiny_data(tmp_path):
    """A data folder with one photo in each part: training (scenes/et, a background),
    development (the FMG's dev scene) and test (a test scene)."""
    import shutil

    from pipeline.scene_splits import FMG_DEV_SCENES

    kermit = shared("scenes", "kermit")
    data = tmp_path / "data"
    for sub, name in (("scenes/kermit", "kermit000.jpg"), ("scenes/et", "kermit001.jpg"),
                      ("backgrounds/misc", "kermit002.jpg"),
                      (f"scenes/{FMG_DEV_SCENES[0]}", "kermit003.jpg")):
        (data / sub).mkdir(parents=True)
        shutil.copy(kermit / name, data / sub / name)
    return data


def test_fmg_train_cli_resumes_and_evaluates(tmp_path, capsys):
    import json

    from workflows.cli import main

    data = _tiny_data(tmp_path)
    out = tmp_path / "run"
    args = ["fmg", "train", "--out", str(out), "--data", str(data), "--batch", "2",
            "--size", "64", "--widths", "8,8,16,16", "--depths", "1,1,1,1", "--head-width",
            "16", "--ckpt-every", "1", "--eval-every", "100", "--val-count", "2"]
    assert main([*args, "--iters", "2"]) == 0
    assert main([*args, "--iters", "3", "--workers", "1"]) == 0  # resumes at step 2
    steps = [json.loads(line)["step"] for line in (out / "log.jsonl").read_text().splitlines()]
    assert steps == [1, 2, 3]
    # a resume under other settings (here a kind left out) is refused, naming the option,
    # before anything is trained or written
    capsys.readouterr()
    assert main([*args, "--iters", "4", "--without", "ghosts"]) == 2
    assert "was started with --without none (now ghosts)" in capsys.readouterr().err
    # --night-glare at 1 is the run as started (the option's value before it existed);
    # another value is another run
    assert main([*args, "--iters", "4", "--night-glare", "0.5"]) == 2
    assert "was started with --night-glare none (now 0.5)" in capsys.readouterr().err
    assert len((out / "log.jsonl").read_text().splitlines()) == 3
    metrics = json.loads((out / "metrics.json").read_text())
    from workflows.research.fmg_eval import evaluate

    # the file holds the final model's scores on the development part (val-count 2, doubled)
    again = evaluate(out / "fmg.safetensors", data, count=4, size=64, split="dev")
    assert metrics["split"] == "dev"
    for row in ("default", "unseen", "night"):
        assert metrics[row]["mIoU"] == pytest.approx(again[row]["mIoU"], abs=1e-9)
        assert metrics[row]["flare_pixels"] == again[row]["flare_pixels"] > 0
    model = load_fmg(out / "fmg.safetensors")
    assert model.cfg.widths == (8, 8, 16, 16)
    assert main(["fmg", "eval", "--weights", str(out / "fmg.safetensors"), "--data", str(data),
                 "--count", "2", "--size", "64", "--out", str(tmp_path / "m.json")]) == 0
    assert json.loads((tmp_path / "m.json").read_text())["count"] == 2
    # calibrate: sweep the cut on development composites and store the chosen one
    from safetensors.torch import load_file

    from gnfr.fmg import read_fmg_metadata

    w = out / "fmg.safetensors"
    before = load_file(str(w))
    assert main(["fmg", "calibrate", "--weights", str(w), "--data", str(data), "--count", "4",
                 "--write", "--out", str(tmp_path / "cal.json")]) == 0
    cal = json.loads((tmp_path / "cal.json").read_text())
    marked = [r["marked_over_true"] for r in cal["rows"]]
    assert all(a >= b for a, b in zip(marked, marked[1:], strict=False))  # higher: no more
    assert cal["best"] in [r["cut"] for r in cal["rows"]]
    assert float(read_fmg_metadata(w)["threshold"]) == cal["best"]
    after = load_file(str(w))
    assert before.keys() == after.keys() and all(torch.equal(before[k], after[k]) for k in before)



def test_leave_one_kind_out_trains_and_scores(tmp_path, monkeypatch):
    """A leave-one-kind-out run at tiny size: trains without a kind (recorded in the
    weights), then `fmg eval --per-kind` scores it on that kind beside another model."""
    import json

    from gnfr.fmg import read_fmg_metadata
    from pipeline import flare as fl
    from workflows.cli import main

    data = _tiny_data(tmp_path)
    tiny = ["--data", str(data), "--iters", "2", "--batch", "2", "--size", "64", "--widths",
            "8,8,16,16", "--depths", "1,1,1,1", "--head-width", "16", "--eval-every", "100",
            "--val-count", "2"]
    assert main(["fmg", "train", "--out", str(tmp_path / "loo"), "--without", "streaks",
                 *tiny]) == 0
    loo = tmp_path / "loo" / "fmg.safetensors"
    meta = read_fmg_metadata(loo)
    assert meta["without"] == "streaks" and "streaks" not in meta["kinds"].split(",")
    # --init starts a run from other weights of the same shape
    assert main(["fmg", "train", "--out", str(tmp_path / "all"), "--init", str(loo),
                 *tiny]) == 0
    allw = tmp_path / "all" / "fmg.safetensors"
    assert read_fmg_metadata(allw)["without"] == ""
    assert read_fmg_metadata(allw)["total_iters"] == "4"
    assert main(["fmg", "eval", "--per-kind", "--weights", str(allw), "--loo", str(loo),
                 "--data", str(data), "--count", "2", "--size", "64",
                 "--out", str(tmp_path / "k.json")]) == 0
    res = json.loads((tmp_path / "k.json").read_text())
    assert list(res["kinds"]) == list(fl.KINDS)
    for kind, row in res["kinds"].items():
        assert row["flare_pixels"] > 0
        assert ("without" in row) == (kind == "streaks")
    assert res["kinds"]["streaks"]["without"]["steps"] == 2
    # --ray-min / --ray-opposite reach the ray rule the scores use, and are recorded
    import pipeline.flare_rays as fr

    seen, real = [], fr.ray_mask
    monkeypatch.setattr(fr, "ray_mask", lambda img, cfg=None: seen.append(cfg) or real(img, cfg))
    assert main(["fmg", "eval", "--per-kind", "--weights", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64", "--rays", "--ray-min", "1",
                 "--ray-opposite", "8", "--out", str(tmp_path / "r.json")]) == 0
    assert seen and all((c.min_rays, c.opposite) == (1, 8.0) for c in seen)
    rule = json.loads((tmp_path / "r.json").read_text())["ray_rule"]
    assert (rule["min_rays"], rule["opposite"]) == (1, 8.0)
    # --ghost-lines: every composite's mask goes through the ghost-line rule, recorded
    import pipeline.flare_ghosts as fg

    ghosts_seen, real_g = [], fg.ghost_line_mask
    monkeypatch.setattr(fg, "ghost_line_mask", lambda p, lights, centre=None, cfg=None:
                        ghosts_seen.append(cfg) or real_g(p, lights, centre, cfg))
    assert main(["fmg", "eval", "--per-kind", "--weights", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64", "--ghost-lines",
                 "--out", str(tmp_path / "g.json")]) == 0
    assert len(ghosts_seen) == 2 * len(fl.KINDS)  # two composites per kind
    assert json.loads((tmp_path / "g.json").read_text())["ghost_lines"]["min_chain"] == 2
    assert json.loads((tmp_path / "k.json").read_text())["ghost_lines"] is None
    # --negatives: flare-free composites with each named negative, the rays' rule recorded
    assert main(["fmg", "eval", "--negatives", "backlit,lamp", "--weights", str(allw),
                 "--data", str(data), "--count", "2", "--size", "64", "--split", "dev",
                 "--rays", "--out", str(tmp_path / "n.json")]) == 0
    neg = json.loads((tmp_path / "n.json").read_text())
    assert list(neg["negatives"]) == ["backlit", "lamp"] and neg["split"] == "dev"
    assert neg["ray_rule"] is not None and neg["count"] == 2
    assert all(0 <= r["mean"] <= r["max"] <= 1 for r in neg["negatives"].values())
    # the overview image of masks on photos
    jpg = tmp_path / "overlay.jpg"
    photo = data / "scenes/kermit/kermit000.jpg"
    assert main(["fmg", "overlay", str(photo), "--weights", str(allw),
                 "--weights", str(loo), "--out", str(jpg), "--work-size", "64",
                 "--json", str(tmp_path / "o.json")]) == 0
    import cv2

    assert cv2.imread(str(jpg)).shape[1] == 3 * 480
    shares = json.loads((tmp_path / "o.json").read_text())["marked"]
    assert sorted(shares) == sorted(f"{photo.name} {w}" for w in (allw, loo))
    assert all(0 <= v <= 1 for v in shares.values())
    # --fill-holes marks what each mask encloses too: never less, and recorded
    assert main(["fmg", "overlay", str(photo), "--weights", str(allw),
                 "--weights", str(loo), "--out", str(jpg), "--work-size", "64",
                 "--fill-holes", "--json", str(tmp_path / "oh.json")]) == 0
    filled = json.loads((tmp_path / "oh.json").read_text())
    assert filled["fill_holes"] is True
    assert all(filled["marked"][k] >= v for k, v in shares.items())
    ghosts_seen.clear()
    assert main(["fmg", "overlay", str(photo), "--weights", str(allw), "--out", str(jpg),
                 "--work-size", "64", "--ghost-lines"]) == 0
    assert len(ghosts_seen) == 1 and cv2.imread(str(jpg)).shape[1] == 2 * 480
    # --pads: the regions the padded runs agree on, as the mask stage's default keeps them
    from pipeline.images import read_image
    from pipeline.mask import fmg_probs_pair, load_fmg_weights, regions_touching
    from workflows.research.fmg_eval import real_flare_overview, weights_info

    pads = ("reflect", "constant")
    got = {(p, k): real_flare_overview((allw,), (photo,), jpg, 64, pads=p, pads_keep=k)
           for p, k in (((), "pixels"), (pads, "pixels"), (pads, "regions"))}
    model, img = load_fmg_weights(allw), read_image(photo, bgr=True)
    plain, agreed = fmg_probs_pair(model, [img], 64, (1.0,), pads)
    cut = weights_info(allw)["cut"]
    key = f"{photo.name} {allw}"
    assert got[(), "pixels"][key] == pytest.approx((plain[0] > cut).mean())
    assert got[pads, "pixels"][key] == pytest.approx((agreed[0] > cut).mean())
    assert got[pads, "regions"][key] == pytest.approx(
        regions_touching(plain[0] > cut, agreed[0] > cut).mean())
    assert got[pads, "pixels"][key] <= got[pads, "regions"][key] <= got[(), "pixels"][key]
    # every score has its fill ceiling; --fill-holes scores the masks with holes filled
    assert all(r["weights"]["flare_psnr_ceiling"] > 0 for r in res["kinds"].values())
    assert res["fill_holes"] is False
    assert main(["fmg", "eval", "--per-kind", "--weights", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64", "--fill-holes",
                 "--out", str(tmp_path / "h.json")]) == 0
    holes = json.loads((tmp_path / "h.json").read_text())
    assert holes["fill_holes"] is True
    for kind, row in holes["kinds"].items():  # filling only adds marks: the ceiling only rises
        assert (row["weights"]["flare_psnr_ceiling"]
                >= res["kinds"][kind]["weights"]["flare_psnr_ceiling"] - 1e-9)
    assert main(["fmg", "eval", "--fill-holes", "--weights", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64"]) != 0  # --fill-holes needs --per-kind
    # weights trained on every kind cannot stand in for a leave-one-kind-out model
    assert main(["fmg", "eval", "--per-kind", "--loo", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64"]) != 0


def _thin_lines(n: int, size: int = 64, seed: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
    """Dim textured images with 1-px bright lines at random angles; target = the lines."""
    g = torch.Generator().manual_seed(seed)
    x = 0.3 * torch.rand(n, 3, size, size, generator=g)
    y = torch.zeros(n, 1, size, size)
    t = torch.linspace(0, 1, 4 * size)
    for i in range(n):
        for _ in range(2):
            p0, p1 = torch.rand(2, 2, generator=g) * (size - 1)
            pts = (p0[None] + t[:, None] * (p1 - p0)[None]).round().long()
            y[i, 0, pts[:, 1], pts[:, 0]] = 1.0
    return torch.where(y > 0, torch.ones_like(x), x), y


def test_fine_decoder_starts_at_the_pspnet_and_outlines_thin_lines():
    torch.manual_seed(0)
    plain = build_fmg(tiny_config())
    fine = build_fmg(FMGConfig(**{**tiny_config().__dict__, "skip_width": 8}))
    missing, unexpected = fine.load_state_dict(plain.state_dict(), strict=False)
    assert not unexpected and missing and all(k.startswith("decoder.") for k in missing)
    x, y = _thin_lines(6)
    plain.eval(), fine.eval()
    with torch.no_grad():  # zero-initialised corrections: the coarse logits, upsampled twice
        coarse = plain.head(plain.ppm(plain.backbone((x - plain.mean) / plain.std)))
        mid = F.interpolate(coarse, size=(16, 16), mode="bilinear", align_corners=False)
        want = F.interpolate(mid, size=(64, 64), mode="bilinear", align_corners=False)
        assert torch.allclose(fine(x), want, atol=1e-5)

    _fit(plain, x, y, 60)
    _fit(fine, x, y, 60)
    iou_plain, iou_fine = _flare_iou(plain, x, y), _flare_iou(fine, x, y)
    assert iou_fine > max(0.3, iou_plain + 0.15), (iou_plain, iou_fine)


def test_fmg_train_flare_prob_sets_the_share_of_clean_composites():
    """`fmg train --flare-prob` reaches the composites: 0 gives only clean training
    composites (empty masks), 1 flare on most (an invisible draw leaves a mask empty)."""
    from pathlib import Path
    from unittest import mock

    import pipeline.fmg_data as fd
    from workflows.research.fmg_train import FMGTrainConfig, _sources

    assert FMGTrainConfig.__dataclass_fields__["flare_prob"].default == 0.8
    bgs = [np.random.default_rng(i).uniform(0.1, 0.6, (96, 128, 3)).astype(np.float32)
           for i in range(3)]
    split = fd.PhotoSplit(train=[Path("a")], dev=[], test=[])
    with mock.patch.object(fd, "split_backgrounds", return_value=split), \
            mock.patch.object(fd, "load_backgrounds", return_value=bgs), \
            mock.patch("workflows.research.fmg_train._part_backgrounds", return_value=[]):
        shares = {}
        for p in (0.0, 1.0):
            src, _, comp, _ = _sources(Path("unused"), 64, flare_prob=p)
            assert comp.flare_prob == p
            rng = np.random.default_rng(0)
            shares[p] = np.mean([src.sample(rng)[1].any() for _ in range(12)])
    assert shares[0.0] == 0.0 and shares[1.0] > 0.5, shares


def test_a_run_from_init_resumed_without_it_still_counts_the_init_steps(tmp_path):
    """Steps are counted from scratch: a run started with --init records the init file's
    steps in its checkpoint, so resuming it without --init still adds them."""
    from gnfr.fmg import read_fmg_metadata
    from workflows.cli import main

    data = _tiny_data(tmp_path)
    args = ["fmg", "train", "--data", str(data), "--batch", "2", "--size", "64", "--widths",
            "8,8,16,16", "--depths", "1,1,1,1", "--head-width", "16", "--ckpt-every", "1",
            "--eval-every", "100", "--val-count", "2"]
    assert main([*args, "--out", str(tmp_path / "a"), "--iters", "2"]) == 0
    init = tmp_path / "a" / "fmg.safetensors"
    assert main([*args, "--out", str(tmp_path / "b"), "--iters", "2", "--init", str(init)]) == 0
    assert read_fmg_metadata(tmp_path / "b" / "checkpoint.safetensors")["init_iters"] == "2"
    assert main([*args, "--out", str(tmp_path / "b"), "--iters", "3"]) == 0  # no --init
    assert read_fmg_metadata(tmp_path / "b" / "checkpoint.safetensors")["init_iters"] == "2"
    assert read_fmg_metadata(tmp_path / "b" / "fmg.safetensors")["total_iters"] == "5"


def test_overlay_columns_are_named_by_the_file_or_its_run():
    from pathlib import Path

    from workflows.research.fmg_eval import weights_label

    assert weights_label(Path("gnfr/weights/fmg_candidate_L.safetensors")) == "fmg_candidate_L"
    assert weights_label(Path("gnfr/weights/fmg.safetensors")) == "weights/fmg"
    assert weights_label(Path("/runs/k2/best.safetensors")) == "k2/best"
    assert weights_label(Path("fmg.safetensors")) == "fmg"


def test_overlay_labels_name_every_option_that_added_marks():
    from pathlib import Path

    from pipeline.flare_rays import RayConfig
    from workflows.research.fmg_eval import overlay_label

    w = Path("gnfr/weights/fmg.safetensors")
    assert overlay_label(w, 0.0541, False, None, False, False) == "weights/fmg: 5.4 %"
    assert (overlay_label(w, 0.07, True, RayConfig(cores=True), True, True)
            == "weights/fmg + rays + light cores + ghost lines + pads: 7.0 %")
    assert (overlay_label(w, 0.07, True, RayConfig(lines=True), False, False)
            == "weights/fmg + rays + streak lines: 7.0 %")
    assert (overlay_label(w, 0.07, False, None, False, True, holes=True)
            == "weights/fmg + pads + holes filled: 7.0 %")
    # cores or lines without rays add nothing, so the label does not claim them
    assert (overlay_label(w, 0.07, False, RayConfig(cores=True), False, False)
            == "weights/fmg: 7.0 %")


def test_export_checkpoint_gives_weights_that_load_and_count_their_steps(tmp_path):
    """A run cut short (a lent GPU given back) leaves fp16 weights from its checkpoint."""
    from workflows.research.fmg_eval import weights_info
    from workflows.research.fmg_train import export_checkpoint, save_checkpoint

    torch.manual_seed(0)
    model = build_fmg(tiny_config())
    opt = torch.optim.AdamW(model.parameters(), lr=1e-3)
    save_checkpoint(tmp_path, model, opt, 7, init_steps=100)
    dest = export_checkpoint(tmp_path, tmp_path / "fmg.safetensors")  # the recorded init
    assert weights_info(dest)["steps"] == 107
    assert weights_info(export_checkpoint(tmp_path, tmp_path / "b.safetensors",
                                          init_steps=5))["steps"] == 12
    back = load_fmg(dest)
    for (k, a), (_, b) in zip(model.state_dict().items(), back.state_dict().items(),
                              strict=True):
        if a.is_floating_point():
            assert torch.allclose(a, b.float(), atol=2e-3, rtol=2e-3), k
    from pipeline.errors import UserError
    with pytest.raises(UserError, match="no checkpoint"):
        export_checkpoint(tmp_path / "empty", tmp_path / "x.safetensors")
    with pytest.raises(UserError, match="no best.safetensors"):
        export_checkpoint(tmp_path, tmp_path / "x.safetensors", best=True)


def test_fmg_train_keeps_the_weights_of_best_validation(tmp_path, monkeypatch):
    """``best.safetensors`` holds the weights of the step whose validation flare IoU was
    highest (the first such step on a tie: only a strictly higher score replaces it), kept
    across a resume, and exports like the checkpoint."""
    from safetensors.torch import load_file

    import workflows.research.fmg_train as ft
    from gnfr.fmg import read_fmg_metadata
    from workflows.cli import main

    scores = iter([0.2, 0.5, 0.3, 0.5, 0.4, 0.6, 0.1])  # best: step 2, then step 6
    states = {}
    real = ft.score

    def fake(model, *val, **kw):
        out = real(model, *val, **kw)
        if kw:  # the end-of-run evaluation, not the training loop's validation
            return out
        states[len(states) + 1] = {k: v.detach().clone() for k, v in model.state_dict().items()}
        return {**out, "IoU_flare": next(scores)}

    monkeypatch.setattr(ft, "score", fake)
    data = _tiny_data(tmp_path)
    out = tmp_path / "run"
    args = ["fmg", "train", "--out", str(out), "--data", str(data), "--batch", "2",
            "--size", "64", "--widths", "8,8,16,16", "--depths", "1,1,1,1", "--head-width",
            "16", "--ckpt-every", "1", "--eval-every", "1", "--val-count", "2"]

    def best():
        meta = read_fmg_metadata(out / "best.safetensors")
        kept = load_file(str(out / "best.safetensors"))
        same = all(torch.equal(kept[k], states[int(meta["step"])][k].cpu()) for k in kept)
        return int(meta["step"]), float(meta["val_IoU_flare"]), same

    assert main([*args, "--iters", "4"]) == 0
    assert best() == (2, 0.5, True)
    assert main([*args, "--iters", "7", "--workers", "1"]) == 0  # resumes at step 4
    assert best() == (6, 0.6, True)
    # the steps' weights differ, so matching step 6's is a real check
    assert any(not torch.equal(states[6][k], states[7][k]) for k in states[6])
    dest = ft.export_checkpoint(out, tmp_path / "best16.safetensors", best=True)
    exported, kept = load_file(str(dest)), load_file(str(out / "best.safetensors"))
    assert exported.keys() == kept.keys()
    assert all(torch.allclose(exported[k].float(), kept[k].float(), atol=2e-3, rtol=2e-3)
               for k in kept if kept[k].is_floating_point())
    assert read_fmg_metadata(dest)["iters"] == "6"


def test_train_batches_from_workers_do_not_depend_on_their_number():
    """`fmg train --workers N`: step s's composites come from a generator seeded by
    (seed, s), so 1 or 2 worker processes give the same batches, a run resumed at step s
    draws what the uninterrupted run drew there, and different steps differ."""
    import pipeline.fmg_data as fd
    from pipeline.flare import FlareConfig
    from workflows.research.fmg_train import TrainBatches

    bgs = [np.random.default_rng(i).uniform(0.1, 0.6, (96, 128, 3)).astype(np.float32)
           for i in range(3)]
    src = fd.CompositeSource(bgs, FlareConfig(), fd.CompositeConfig(size=48))
    runs = {}
    for workers in (1, 2):
        b = TrainBatches(src, 2, seed=3, workers=workers)
        b.begin(5)
        try:
            runs[workers] = [b.next() for _ in range(3)]  # steps 5, 6, 7
        finally:
            b.close()
    resumed = TrainBatches(src, 2, seed=3, workers=1)
    resumed.begin(6)
    try:
        at6 = resumed.next()
    finally:
        resumed.close()
    for (x1, y1), (x2, y2) in zip(runs[1], runs[2], strict=True):
        assert x1.shape == (2, 3, 48, 48) and torch.equal(x1, x2) and torch.equal(y1, y2)
    assert torch.equal(at6[0], runs[1][1][0]) and torch.equal(at6[1], runs[1][1][1])
    assert not torch.equal(runs[1][0][0], runs[1][1][0])
    # in-process drawing (workers 0) is the original single stream
    inproc = TrainBatches(src, 2, seed=3, workers=0)
    inproc.begin(5)
    x0, _ = inproc.next()
    ref, _ = src.batch(2, np.random.default_rng([3, 5]))
    assert torch.equal(x0, ref)


def test_fmg_train_with_bad_data_or_init_stops_with_one_line_and_makes_no_folder(tmp_path,
                                                                                  capsys):
    import cv2

    from workflows.cli import main

    (tmp_path / "data" / "backgrounds").mkdir(parents=True)
    cv2.imwrite(str(tmp_path / "data" / "backgrounds" / "a.png"),
                np.full((64, 64, 3), 90, np.uint8))
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(b"not weights")
    for extra in (["--data", str(tmp_path / "missing")],
                  ["--data", str(tmp_path / "data"), "--init", str(bad)]):
        assert main(["fmg", "train", "--out", str(tmp_path / "run"), "--iters", "1",
                     "--size", "64", "--batch", "1", *extra]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and err.strip().splitlines()[-1].startswith("error:")
        assert not (tmp_path / "run").exists()


def test_negative_fractions_counts_marks_on_flare_free_composites(tmp_path, monkeypatch):
    """`fmg eval --negatives`: every composite is flare-free with the named negative painted,
    so a network that marks everything scores 100 % and one that marks nothing 0 %."""
    import torch

    import pipeline.fmg_data as fd
    from workflows.research import fmg_eval

    painted = []

    real = fd.add_hard_negatives
    monkeypatch.setattr(fd, "add_hard_negatives",
                        lambda img, rng, kinds: painted.append(kinds) or real(img, rng, kinds))
    monkeypatch.setattr(fmg_eval, "_part_backgrounds",
                        lambda data, size, split: [np.full((80, 80, 3), 90, np.uint8)])

    class Const(torch.nn.Module):
        def __init__(self, v):
            super().__init__()
            self.v = torch.nn.Parameter(torch.tensor(float(v)))

        def forward(self, x):
            return self.v.expand(x.shape[0], 1, *x.shape[2:])

    for logit, want in ((20.0, 1.0), (-20.0, 0.0)):
        monkeypatch.setattr("pipeline.mask.load_fmg_weights", lambda p, c=Const(logit): c)
        monkeypatch.setattr(fmg_eval, "weights_info", lambda p: {"cut": 0.5})
        res = fmg_eval.negative_fractions(tmp_path / "w.safetensors", tmp_path,
                                          ("backlit", "lamp"), count=3, size=32)
        assert set(res["negatives"]) == {"backlit", "lamp"}
        for r in res["negatives"].values():
            assert r["mean"] == want and r["over_1pct"] == (3 if want else 0)
    assert painted.count(("backlit",)) == 6 and painted.count(("lamp",)) == 6
    assert "| backlit | 3 | 0.00 %" in fmg_eval.format_negatives(res)


def test_fmg_eval_clean_with_pads_keeps_what_the_padded_runs_agree_on(tmp_path):
    """`fmg eval --clean --pads`: each clean photo's marks are the pixels every padded run
    marks (the mask stage's default), with --pads-keep regions the plain run's regions they
    agree on, a subset of the plain run's; the paddings are recorded."""
    import cv2

    from pipeline.mask import fmg_probs_pair, regions_touching
    from workflows.research.fmg_eval import clean_fractions, weights_info

    torch.manual_seed(5)
    weights = save_fmg(tmp_path / "w.safetensors", build_fmg(tiny_config()))
    rng = np.random.default_rng(0)
    (tmp_path / "scenes" / "s").mkdir(parents=True)
    for i in range(2):
        img = cv2.GaussianBlur(rng.integers(0, 255, (48, 64, 3), dtype=np.uint8), (9, 9), 3)
        cv2.imwrite(str(tmp_path / "scenes" / "s" / f"p{i}.png"), img)
    cut = weights_info(weights)["cut"]
    pads = ("reflect", "constant")
    got = {p: clean_fractions(weights, tmp_path, 64, scenes=("scenes/s",), pads=p,
                              pads_keep="regions") for p in ((), pads)}
    assert got[pads]["pads"] == list(pads) and got[()]["pads"] == []
    assert got[pads]["pads_keep"] == "regions" and got[()]["pads_keep"] is None
    pixels = clean_fractions(weights, tmp_path, 64, scenes=("scenes/s",), pads=pads)
    from pipeline.mask import load_fmg_weights

    model = load_fmg_weights(weights)
    for i in range(2):
        img = cv2.imread(str(tmp_path / "scenes" / "s" / f"p{i}.png"))
        plain, agreed = fmg_probs_pair(model, [img], 64, (1.0,), pads)
        want = regions_touching(plain[0] > cut, agreed[0] > cut).mean()
        per_view = got[pads]["scenes"]["scenes/s"]["per_view"]
        assert per_view[f"p{i}.png"] == pytest.approx(want)
        assert per_view[f"p{i}.png"] <= got[()]["scenes"]["scenes/s"]["per_view"][f"p{i}.png"]
        assert pixels["scenes"]["scenes/s"]["per_view"][f"p{i}.png"] == pytest.approx(
            (agreed[0] > cut).mean())
