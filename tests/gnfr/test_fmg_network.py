"""FMG (PSPNet) network: shapes, the 5:1 weighted loss, metrics, prediction passes, weight
files, a CPU overfit and the fine decoder on thin lines."""

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
