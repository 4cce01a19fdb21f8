"""FMG, Flare-occupancy Mask Generation: a PSPNet that marks flare pixels.

The network (Zhao et al., "Pyramid Scene Parsing Network", 2017) is a dilated residual
backbone of ResNet-18/34 shape (BasicBlocks; the last two stages keep output stride 8 by
dilation 2 and 4 instead of striding), a pyramid pooling module (average pooling to 1x1,
2x2, 3x3 and 6x6 bins, 1x1 conv each, upsampled and concatenated with the features) and a
3x3 conv head. GN-FR segments two classes, flare / no flare; with two classes a softmax over
two logits equals a sigmoid of their difference, so the head emits ONE logit per pixel
(flare minus no-flare) and the loss is binary cross-entropy with class weights 5 (flare) : 1
(no flare) as in the paper. The light source itself is not flare (its target is 0).

Shapes: images ``[B, 3, H, W]`` sRGB in [0, 1] (normalised inside the model), logits
``[B, 1, H, W]`` at the input size (any H, W; odd sizes are fine), probabilities the same.

Weights are fp16 safetensors with the :class:`FMGConfig` as JSON in the metadata
(``save_fmg`` / ``load_fmg``). This module knows no file layout; the mask stage decides
where the weights live.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import nn

FLARE_WEIGHT = 5.0
"""Class weight of flare pixels in the BCE loss (no-flare pixels weigh 1), from the paper."""

_MEAN = (0.485, 0.456, 0.406)
_STD = (0.229, 0.224, 0.225)


@dataclass
class FMGConfig:
    """Shape of the PSPNet. Default: a ResNet-18 backbone (12.6M parameters, 24 MiB in fp16)."""

    widths: tuple[int, ...] = (64, 128, 256, 512)
    """Channels of the four residual stages (ResNet-18/34: 64, 128, 256, 512)."""
    depths: tuple[int, ...] = (2, 2, 2, 2)
    """BasicBlocks per stage (ResNet-18: 2,2,2,2; ResNet-34: 3,4,6,3)."""
    bins: tuple[int, ...] = (1, 2, 3, 6)
    """Pyramid pooling bin sizes."""
    head_width: int = 128
    """Channels of the 3x3 conv after pyramid pooling."""
    dropout: float = 0.1
    """Dropout before the classifier (training only)."""
    work_size: int = 512
    """Long side, in pixels, at which ``predict_probs`` runs the network by default."""
    skip_width: int = 0
    """Channels of the fine decoder (0: none, the paper's PSPNet). The decoder refines the
    stride-8 logits at stride 4 with the backbone's first-stage features and then at the
    input size with the image itself, so spikes and streaks a pixel or two wide can be
    outlined. Its last convolutions start at zero: a network given a new decoder starts out
    predicting what the PSPNet alone predicted (up to upsampling in two steps, not one)."""

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> FMGConfig:
        d = json.loads(text)
        for k in ("widths", "depths", "bins"):
            d[k] = tuple(d[k])
        return cls(**d)


def tiny_config() -> FMGConfig:
    """A very small FMG for tests (a few thousand parameters)."""
    return FMGConfig(widths=(8, 8, 16, 16), depths=(1, 1, 1, 1), head_width=16, work_size=64)


# --------------------------------------------------------------------------- model
class BasicBlock(nn.Module):
    """ResNet BasicBlock (two 3x3 convs) with optional stride and dilation."""

    def __init__(self, cin: int, cout: int, stride: int = 1, dilation: int = 1,
                 first_dilation: int | None = None):
        super().__init__()
        d1, d = first_dilation or dilation, dilation
        self.conv1 = nn.Conv2d(cin, cout, 3, stride, padding=d1, dilation=d1, bias=False)
        self.bn1 = nn.BatchNorm2d(cout)
        self.conv2 = nn.Conv2d(cout, cout, 3, 1, padding=d, dilation=d, bias=False)
        self.bn2 = nn.BatchNorm2d(cout)
        self.down = None
        if stride != 1 or cin != cout:
            self.down = nn.Sequential(nn.Conv2d(cin, cout, 1, stride, bias=False),
                                      nn.BatchNorm2d(cout))

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # [B, Cin, H, W] -> [B, Cout, H', W']
        y = F.relu(self.bn1(self.conv1(x)), inplace=True)
        y = self.bn2(self.conv2(y))
        return F.relu(y + (x if self.down is None else self.down(x)), inplace=True)


def _stage(cin: int, cout: int, n: int, stride: int, dilation: int) -> nn.Sequential:
    # as in dilated ResNets, the first conv of a stage keeps the previous stage's dilation
    blocks = [BasicBlock(cin, cout, stride, dilation, first_dilation=max(1, dilation // 2))]
    blocks += [BasicBlock(cout, cout, 1, dilation) for _ in range(n - 1)]
    return nn.Sequential(*blocks)


class DilatedResNet(nn.Module):
    """Residual backbone with output stride 8: [B, 3, H, W] -> [B, widths[-1], H/8, W/8]."""

    def __init__(self, cfg: FMGConfig):
        super().__init__()
        w, d = cfg.widths, cfg.depths
        self.stem = nn.Sequential(
            nn.Conv2d(3, w[0], 7, 2, 3, bias=False), nn.BatchNorm2d(w[0]), nn.ReLU(True),
            nn.MaxPool2d(3, 2, 1))                                     # stride 4
        self.layer1 = _stage(w[0], w[0], d[0], stride=1, dilation=1)  # stride 4
        self.layer2 = _stage(w[0], w[1], d[1], stride=2, dilation=1)  # stride 8
        self.layer3 = _stage(w[1], w[2], d[2], stride=1, dilation=2)  # stride 8, dilated
        self.layer4 = _stage(w[2], w[3], d[3], stride=1, dilation=4)  # stride 8, dilated

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.features(x)[1]

    def features(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(stride-4 features of the first stage, stride-8 features of the last)."""
        f4 = self.layer1(self.stem(x))
        return f4, self.layer4(self.layer3(self.layer2(f4)))


class PyramidPooling(nn.Module):
    """[B, C, h, w] -> [B, 2C, h, w]: features + one C/len(bins) map per pooled bin size."""

    def __init__(self, cin: int, bins: tuple[int, ...]):
        super().__init__()
        cb = max(1, cin // len(bins))
        self.bins = bins
        self.convs = nn.ModuleList(
            nn.Sequential(nn.Conv2d(cin, cb, 1, bias=False), nn.BatchNorm2d(cb), nn.ReLU(True))
            for _ in bins)
        self.out_channels = cin + cb * len(bins)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h, w = x.shape[-2:]
        outs = [x]
        for b, conv in zip(self.bins, self.convs, strict=True):
            y = conv(F.adaptive_avg_pool2d(x, b))
            outs.append(F.interpolate(y, size=(h, w), mode="bilinear", align_corners=False))
        return torch.cat(outs, 1)


def _conv_bn(cin: int, cout: int) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, padding=1, bias=False), nn.BatchNorm2d(cout),
                         nn.ReLU(True))


class FineDecoder(nn.Module):
    """Residual refinement of coarse logits: stride 8 -> 4 with the first-stage features,
    then -> input size with the (normalised) image. Both corrections start at zero."""

    def __init__(self, skip_in: int, width: int):
        super().__init__()
        self.skip = nn.Sequential(nn.Conv2d(skip_in, width, 1, bias=False),
                                  nn.BatchNorm2d(width), nn.ReLU(True))
        self.mid = nn.Sequential(_conv_bn(width + 1, width), _conv_bn(width, width),
                                 nn.Conv2d(width, 1, 1))
        fine = max(8, width // 2)
        self.full = nn.Sequential(nn.Conv2d(4, fine, 3, padding=1), nn.ReLU(True),
                                  nn.Conv2d(fine, fine, 3, padding=1), nn.ReLU(True),
                                  nn.Conv2d(fine, 1, 3, padding=1))
        for last in (self.mid[-1], self.full[-1]):
            nn.init.zeros_(last.weight)
            nn.init.zeros_(last.bias)

    def forward(self, coarse: torch.Tensor, f4: torch.Tensor,
                image: torch.Tensor) -> torch.Tensor:
        up = F.interpolate(coarse, size=f4.shape[-2:], mode="bilinear", align_corners=False)
        mid = up + self.mid(torch.cat([up, self.skip(f4)], 1))           # [B, 1, H/4, W/4]
        full = F.interpolate(mid, size=image.shape[-2:], mode="bilinear", align_corners=False)
        return full + self.full(torch.cat([full, image], 1))             # [B, 1, H, W]


class PSPNet(nn.Module):
    """FMG network: images [B, 3, H, W] in [0, 1] -> flare logits [B, 1, H, W]."""

    def __init__(self, cfg: FMGConfig | None = None):
        super().__init__()
        self.cfg = cfg = cfg or FMGConfig()
        self.backbone = DilatedResNet(cfg)
        self.ppm = PyramidPooling(cfg.widths[-1], cfg.bins)
        self.head = nn.Sequential(
            nn.Conv2d(self.ppm.out_channels, cfg.head_width, 3, padding=1, bias=False),
            nn.BatchNorm2d(cfg.head_width), nn.ReLU(True), nn.Dropout2d(cfg.dropout),
            nn.Conv2d(cfg.head_width, 1, 1))
        self.decoder = FineDecoder(cfg.widths[0], cfg.skip_width) if cfg.skip_width else None
        self.register_buffer("mean", torch.tensor(_MEAN).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("std", torch.tensor(_STD).view(1, 3, 1, 1), persistent=False)

    def forward(self, images: torch.Tensor) -> torch.Tensor:  # [B,3,H,W] -> [B,1,H,W]
        h, w = images.shape[-2:]
        x = (images - self.mean) / self.std
        f4, f8 = self.backbone.features(x)
        logits = self.head(self.ppm(f8))                          # [B, 1, h/8, w/8]
        if self.decoder is not None:
            return self.decoder(logits, f4, x)
        return F.interpolate(logits, size=(h, w), mode="bilinear", align_corners=False)


def build_fmg(cfg: FMGConfig | None = None) -> PSPNet:
    return PSPNet(cfg)


# --------------------------------------------------------------------------- loss / metrics
def fmg_loss(logits: torch.Tensor, target: torch.Tensor,
             flare_weight: float = FLARE_WEIGHT, dice: float = 0.0) -> torch.Tensor:
    """Class-weighted binary cross-entropy, averaged over all pixels, plus ``dice`` x the
    soft-Dice loss of the flare class.

    logits [B, 1, H, W]; target [B, 1, H, W] in {0, 1} (1 = flare). Each pixel's BCE is
    multiplied by ``flare_weight`` where the target is flare and by 1 elsewhere. The Dice
    term is ``1 - 2 sum(p t) / (sum(p) + sum(t) + 1)`` per composite with flare, averaged
    over those: a composite's thin flare weighs as much as another's large flare (clean
    composites are left to the BCE, whose Dice would be 1 whatever is marked).
    """
    target = target.to(logits.dtype)
    weight = 1.0 + (flare_weight - 1.0) * target
    loss = F.binary_cross_entropy_with_logits(logits, target, weight=weight)
    if dice:
        p = torch.sigmoid(logits).flatten(1)
        t = target.flatten(1)
        has = t.sum(1) > 0
        if has.any():
            d = 1 - 2 * (p * t).sum(1) / (p.sum(1) + t.sum(1) + 1.0)
            loss = loss + dice * d[has].mean()
    return loss


def confusion(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """[2, 2] pixel counts, rows = true class (0 no flare, 1 flare), cols = predicted.

    pred, target: bool or {0,1} tensors of one shape.
    """
    t = target.reshape(-1).long()
    p = pred.reshape(-1).long()
    return torch.bincount(t * 2 + p, minlength=4).reshape(2, 2)


def seg_metrics(conf: torch.Tensor) -> dict[str, float]:
    """Standard semantic-segmentation scores of a [2, 2] confusion matrix.

    mIoU = mean over classes of TP / (TP + FP + FN); mAcc = mean over classes of per-class
    pixel accuracy TP / (TP + FN); plus the flare-class IoU and overall pixel accuracy.
    A class absent from both prediction and truth is left out of the means.
    """
    c = conf.double()
    tp = c.diag()
    gt, pr = c.sum(1), c.sum(0)
    union = gt + pr - tp
    present = gt > 0
    iou = torch.where(union > 0, tp / union.clamp(min=1), torch.nan)
    acc = torch.where(present, tp / gt.clamp(min=1), torch.nan)
    return {"mIoU": float(iou.nanmean()), "mAcc": float(acc.nanmean()),
            "IoU_flare": float(iou[1]), "Acc_flare": float(acc[1]),
            "pixel_acc": float(tp.sum() / c.sum().clamp(min=1))}


# --------------------------------------------------------------------------- inference
def work_shape(h: int, w: int, long_side: int) -> tuple[int, int]:
    """(h, w) scaled so the long side is ``long_side``, each rounded to a multiple of 8."""
    s = long_side / max(h, w)
    return max(8, round(h * s / 8) * 8), max(8, round(w * s / 8) * 8)


SCALES = (1.0,)
"""Fractions of the working size at which ``predict_probs`` runs the network by default (one:
the working size alone)."""


PAD_MODES = ("reflect", "replicate", "constant")
"""The paddings ``predict_probs``' ``pads`` may name (``torch.nn.functional.pad``'s modes;
constant pads with black)."""

PAD_SHARE = 0.03
"""How far ``predict_probs`` pads each edge for its ``pads``: this share of the long side
of the network's input (15 pixels at 512)."""


def padded_pass(model: PSPNet, x: torch.Tensor, mode: str,
                share: float = PAD_SHARE) -> torch.Tensor:
    """Sigmoid of ``model`` on x [B, 3, h, w] padded at every edge by ``share`` of its long
    side in ``mode`` (one of ``PAD_MODES``), cropped back to [B, 1, h, w]."""
    if mode not in PAD_MODES:
        raise ValueError(f"padded_probs: unknown padding {mode!r}; known: {PAD_MODES}")
    n = max(1, round(share * max(x.shape[-2:])))
    return torch.sigmoid(model(F.pad(x, (n, n, n, n), mode=mode)))[..., n:-n, n:-n]


def padded_pair(model: PSPNet, x: torch.Tensor, pads: tuple[str, ...] = (),
                share: float = PAD_SHARE) -> tuple[torch.Tensor, torch.Tensor]:
    """(plain, agreed): sigmoid of ``model`` on x [B, 3, h, w], and the lowest of that and
    of ``padded_pass`` in each mode of ``pads`` (the same tensor when ``pads`` is empty)."""
    plain = agreed = torch.sigmoid(model(x))
    for mode in pads:
        agreed = torch.minimum(agreed, padded_pass(model, x, mode, share))
    return plain, agreed


def padded_probs(model: PSPNet, x: torch.Tensor, pads: tuple[str, ...] = (),
                 share: float = PAD_SHARE) -> torch.Tensor:
    """Sigmoid of ``model`` on x [B, 3, h, w], and with ``pads`` the lowest of that and of
    ``padded_pass`` in each of those modes: a pixel stays flare only if every padding keeps
    it so (``mask --pads``)."""
    return padded_pair(model, x, pads, share)[1]


@torch.no_grad()
def predict_probs_pair(model: PSPNet, images: torch.Tensor, long_side: int | None = None,
                       scales: tuple[float, ...] = SCALES, pads: tuple[str, ...] = ()
                       ) -> tuple[torch.Tensor, torch.Tensor]:
    """(plain, agreed) flare probabilities [B, 1, H, W] of images [B, 3, H, W]: as
    ``predict_probs`` without ``pads`` and with them, from one run of the network on each
    scale's plain input (`mask --pads-keep regions` needs both)."""
    if not scales:
        raise ValueError("predict_probs: no scales given")
    model.eval()
    h, w = images.shape[-2:]
    x = images.to(next(model.parameters()).device, torch.float32)
    maps = (0,) if not pads else (0, 1)  # no pads: the plain map is the agreed one
    totals = [0.0, 0.0]
    for k, s in enumerate(scales):
        hw = work_shape(h, w, round((long_side or model.cfg.work_size) * s))
        xs = x if hw == (h, w) else F.interpolate(x, size=hw, mode="bilinear",
                                                  align_corners=False, antialias=True)
        pair = padded_pair(model, xs, pads)
        for i in maps:
            p = pair[i] if hw == (h, w) else F.interpolate(pair[i], size=(h, w),
                                                           mode="bilinear", align_corners=False)
            totals[i] = p if k == 0 else totals[i] + p
    plain = totals[0] / len(scales)
    return plain, plain if not pads else totals[1] / len(scales)


def predict_probs(model: PSPNet, images: torch.Tensor, long_side: int | None = None,
                  scales: tuple[float, ...] = SCALES,
                  pads: tuple[str, ...] = ()) -> torch.Tensor:
    """Flare probabilities [B, 1, H, W] of images [B, 3, H, W] (sRGB in [0, 1]).

    The network runs at ``long_side`` (default ``model.cfg.work_size``) times each of
    ``scales``; each result is upsampled bilinearly to the input size and the probabilities
    are averaged over the scales (PSPNet's multi-scale testing; ``mask --scales``). With
    ``pads`` each scale's probabilities are the lowest over the input as it is and padded
    in each of those modes (``padded_probs``; ``mask --pads``).
    """
    return predict_probs_pair(model, images, long_side, scales, pads)[1]


# --------------------------------------------------------------------------- weights
def save_fmg(path: str | Path, model: PSPNet, extra: dict[str, str] | None = None,
             dtype: torch.dtype = torch.float16) -> Path:
    """Write the weights as safetensors (fp16 by default) with the config in the metadata."""
    from safetensors.torch import save_file

    sd = {k: (v.to(dtype) if v.is_floating_point() else v).contiguous().cpu()
          for k, v in model.state_dict().items()}
    meta = {"format": "pt", "model": "fmg-pspnet", "config": model.cfg.to_json(),
            **(extra or {})}
    save_file(sd, str(path), metadata=meta)
    return Path(path)


def read_fmg_metadata(path: str | Path) -> dict[str, str]:
    from safetensors import safe_open

    with safe_open(str(path), framework="pt") as f:
        return dict(f.metadata() or {})


def load_fmg(path: str | Path, device: str | torch.device = "cpu") -> PSPNet:
    """Build the model from a safetensors file written by :func:`save_fmg` (float32).

    Raises FileNotFoundError when the file is missing and ValueError when it is not an FMG
    weight file or does not match its stored config.
    """
    from safetensors.torch import load_file

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(str(path))
    try:
        meta = read_fmg_metadata(path)
        cfg = FMGConfig.from_json(meta["config"])
        sd = load_file(str(path))
    except Exception as e:  # noqa: BLE001 - any parse failure means "not an FMG file"
        raise ValueError(f"{path} is not an FMG weight file ({e!r})") from None
    model = PSPNet(cfg)
    try:
        model.load_state_dict({k: v.float() if v.is_floating_point() else v
                               for k, v in sd.items()})
    except RuntimeError as e:
        raise ValueError(f"{path} does not match its FMG config: {str(e)[:200]}") from None
    return model.to(device).eval()
