"""Training and evaluation of the FMG (flare mask PSPNet) on synthetic composites.

``train(cfg)`` owns the loop: AdamW with poly learning-rate decay, the 5:1 weighted BCE,
a checkpoint every ``ckpt_every`` steps in ``out`` (``checkpoint.safetensors`` with fp32
weights + ``optimizer.pt`` with optimizer state and step, read back with
``torch.load(weights_only=True)``), so a rerun with the same ``out`` resumes. It ends by
writing ``out/fmg.safetensors`` (fp16, config in the metadata) and ``out/metrics.json``.
``evaluate(weights, ...)`` scores mIoU / mAcc on held-out composites, with the default flare
settings and with ``FlareConfig.unseen()``.
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from pipeline.errors import UserError
from pipeline.progress import info
from pipeline.workspace import atomic_path, atomic_write_json

REPO = Path(__file__).resolve().parents[1]


def default_data() -> Path:
    """The shared photo folder: $DEFLARE_SHARED_DATA or ../shared/data beside the repo."""
    return Path(os.environ.get("DEFLARE_SHARED_DATA", REPO.parent / "shared" / "data"))


@dataclass
class FMGTrainConfig:
    """Options of `deflare-scene fmg train`."""

    out: Path
    """Run folder: checkpoints, log.jsonl, fmg.safetensors, metrics.json."""
    data: Path = field(default_factory=default_data)
    """Folder with backgrounds/ and scenes/ (images found recursively)."""
    iters: int = 3000
    """Optimizer steps."""
    batch: int = 8
    """Composites per step."""
    size: int = 256
    """Composite side (pixels)."""
    widths: tuple[int, ...] = (32, 64, 128, 256)
    """Backbone stage widths (ResNet-18: 64,128,256,512)."""
    depths: tuple[int, ...] = (2, 2, 2, 2)
    """BasicBlocks per stage (ResNet-18: 2,2,2,2; ResNet-34: 3,4,6,3)."""
    head_width: int = 128
    """Channels of the head conv after pyramid pooling."""
    lr: float = 2e-3
    """Peak AdamW learning rate (poly decay, power 0.9, after a short warm-up)."""
    weight_decay: float = 1e-4
    ckpt_every: int = 100
    """Steps between checkpoints."""
    eval_every: int = 500
    """Steps between validation scores (on ``val_count`` held-out composites)."""
    val_count: int = 32
    night_prob: float = 0.0
    """Probability of a night-darkened training background (``CompositeConfig``)."""
    streak_prob: float = 0.0
    """Probability of long streaks on a flared training composite (``CompositeConfig``)."""
    seed: int = 0
    device: str = "auto"


def _device(name: str) -> str:
    import torch

    return ("cuda" if torch.cuda.is_available() else "cpu") if name == "auto" else name


def _sources(data: Path, size: int, night_prob: float = 0.0, streak_prob: float = 0.0):
    from pipeline import flare as fl
    from pipeline.fmg_data import (
        CompositeConfig,
        CompositeSource,
        load_backgrounds,
        split_backgrounds,
    )

    train_p, val_p = split_backgrounds(data)
    comp = CompositeConfig(size=size, night_prob=night_prob, streak_prob=streak_prob)
    tr = CompositeSource(load_backgrounds(train_p, comp.preload_side), fl.FlareConfig(), comp)
    va = load_backgrounds(val_p, comp.preload_side)
    return tr, va, comp, (len(train_p), len(val_p))


def score(model, images, masks, batch: int = 8, refine: bool = False,
          cut: float = 0.5) -> dict[str, float]:
    """mIoU / mAcc of ``model`` on images [N, 3, S, S] with masks [N, 1, S, S] (pooled),
    flare where the probability exceeds ``cut``."""
    import torch

    from gnfr.fmg import confusion, seg_metrics

    conf = torch.zeros(2, 2, dtype=torch.long)
    model.eval()
    dev = next(model.parameters()).device
    with torch.no_grad():
        for i in range(0, len(images), batch):
            x = images[i:i + batch].to(dev)
            p = torch.sigmoid(model(x)).cpu()
            if refine:
                p = _refine_batch(x.cpu(), p)
            conf += confusion(p > cut, masks[i:i + batch] > 0.5)
    return seg_metrics(conf)


def _refine_batch(x, p):
    import torch

    from pipeline.mask import refine_probs

    out = []
    for xi, pi in zip(x, p, strict=True):
        bgr = (xi.permute(1, 2, 0).numpy()[..., ::-1] * 255).astype(np.uint8)
        out.append(torch.from_numpy(refine_probs(bgr, pi[0].numpy()))[None])
    return torch.stack(out)


# --------------------------------------------------------------------------- checkpoints
def save_checkpoint(out: Path, model, opt, step: int) -> None:
    import torch
    from safetensors.torch import save_file

    sd = {k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()}
    with atomic_path(out / "checkpoint.safetensors") as tmp:
        save_file(sd, str(tmp), metadata={"config": model.cfg.to_json(), "step": str(step)})
    with atomic_path(out / "optimizer.pt") as tmp:
        torch.save({"optimizer": opt.state_dict(), "step": step}, tmp)


def load_checkpoint(out: Path, model, opt) -> int:
    """Restore weights and optimizer from ``out``; returns the step (0 when none)."""
    import torch
    from safetensors.torch import load_file

    ck, op = out / "checkpoint.safetensors", out / "optimizer.pt"
    if not (ck.is_file() and op.is_file()):
        return 0
    try:
        model.load_state_dict(load_file(str(ck)))
        state = torch.load(op, map_location="cpu", weights_only=True)
        opt.load_state_dict(state["optimizer"])
    except (RuntimeError, KeyError, ValueError) as e:
        raise UserError(f"checkpoint in {out} does not match this configuration ({e!r:.120}):"
                        " use another --out or the same options as the first run") from None
    return int(state["step"])


def _lr(cfg: FMGTrainConfig, step: int) -> float:
    warm = min(1.0, (step + 1) / 50)
    return cfg.lr * warm * max(0.0, 1 - step / max(cfg.iters, 1)) ** 0.9


# --------------------------------------------------------------------------- train
def train(cfg: FMGTrainConfig) -> dict:
    """Train (or resume) an FMG; returns the final metrics."""
    import torch

    from gnfr.fmg import FMGConfig, build_fmg, fmg_loss, save_fmg
    from pipeline.fmg_data import fixed_set

    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    dev = _device(cfg.device)
    torch.manual_seed(cfg.seed)
    src, val_bgs, comp, counts = _sources(Path(cfg.data), cfg.size, cfg.night_prob,
                                          cfg.streak_prob)
    info(f"fmg train: {counts[0]} training photos, {counts[1]} held out, device {dev}")
    model = build_fmg(FMGConfig(widths=tuple(cfg.widths), depths=tuple(cfg.depths),
                                head_width=cfg.head_width)).to(dev)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    step = load_checkpoint(out, model, opt)
    if step:
        info(f"fmg train: resuming at step {step}")
    from pipeline.fmg_data import CompositeSource

    val = fixed_set(CompositeSource(val_bgs, src.flare_cfg, comp), cfg.val_count, 12345)
    rng = np.random.default_rng([cfg.seed, step])
    t0, log = time.time(), out / "log.jsonl"
    while step < cfg.iters:
        model.train()
        x, y = src.batch(cfg.batch, rng)
        for g in opt.param_groups:
            g["lr"] = _lr(cfg, step)
        loss = fmg_loss(model(x.to(dev)), y.to(dev))
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        step += 1
        rec = {"step": step, "loss": round(float(loss.detach()), 5),
               "s": round(time.time() - t0, 1)}
        if step % cfg.eval_every == 0 or step == cfg.iters:
            rec.update({f"val_{k}": round(v, 4) for k, v in score(model, *val).items()})
            info(f"step {step}: loss {rec['loss']:.4f} val mIoU {rec['val_mIoU']:.3f} "
                 f"mAcc {rec['val_mAcc']:.3f}")
        with open(log, "a") as f:
            f.write(json.dumps(rec) + "\n")
        if step % cfg.ckpt_every == 0 or step == cfg.iters:
            save_checkpoint(out, model, opt, step)
    meta = {"iters": str(cfg.iters), "train": json.dumps(asdict(cfg), default=str)}
    with atomic_path(out / "fmg.safetensors") as tmp:
        save_fmg(tmp, model.cpu(), extra=meta)
    metrics = evaluate(out / "fmg.safetensors", Path(cfg.data), count=cfg.val_count * 2,
                       size=cfg.size)
    atomic_write_json(out / "metrics.json", metrics)
    return metrics


# --------------------------------------------------------------------------- evaluate
def evaluate(weights: Path, data: Path, count: int = 64, seed: int = 2024,
             refine: bool = False, size: int = 256) -> dict:
    """mIoU / mAcc on ``count`` held-out composites (scenes in HELDOUT_SCENES + held-out
    backgrounds) at the cut the mask stage uses (the weights' calibrated one, else 0.5),
    for the default flare settings, ``FlareConfig.unseen()`` and default
    settings with night backgrounds (half) and streaks (all) (``night_streak``)."""
    from pipeline import flare as fl
    from pipeline.fmg_data import (
        CompositeConfig,
        CompositeSource,
        fixed_set,
        load_backgrounds,
        split_backgrounds,
    )
    from pipeline.mask import MaskConfig, load_fmg_weights, resolve_threshold

    model = load_fmg_weights(Path(weights))
    cut = resolve_threshold(MaskConfig(), Path(weights))  # the mask stage's default cut
    comp = CompositeConfig(size=size)
    bgs = load_backgrounds(split_backgrounds(Path(data))[1], comp.preload_side)
    res = {"weights": str(weights), "count": count, "size": size, "seed": seed, "cut": cut}
    extra = CompositeConfig(size=size, night_prob=0.5, streak_prob=1.0)
    rows = (("default", fl.FlareConfig(), comp, False),
            ("unseen", fl.FlareConfig.unseen(), comp, False),
            ("night_streak", fl.FlareConfig(), extra, True))
    for name, fcfg, c, extras in rows:
        imgs, masks = fixed_set(CompositeSource(bgs, fcfg, c), count, seed, extras)
        frac = {"flare_pixels": round(float(masks.mean()), 4)}
        res[name] = {**score(model, imgs, masks, cut=cut), **frac}
        if refine:
            res[name + "_refined"] = {**score(model, imgs, masks, refine=True, cut=cut),
                                      **frac}
    return res


def format_metrics(m: dict) -> str:
    rows = ["| flare settings | mIoU | mAcc | IoU flare | flare pixels |", "|---|---|---|---|---|"]
    for k, v in m.items():
        if isinstance(v, dict):
            rows.append(f"| {k} | {v['mIoU']:.3f} | {v['mAcc']:.3f} | {v['IoU_flare']:.3f} | "
                        f"{v.get('flare_pixels', math.nan):.3f} |")
    if "cut" in m:
        rows.append(f"(flare where the probability exceeds {m['cut']:g})")
    return "\n".join(rows)


# --------------------------------------------------------------------------- calibrate
CALIBRATION_CUTS = tuple(round(0.3 + 0.05 * i, 2) for i in range(14))  # 0.30 .. 0.95
CALIBRATION_TIE = 0.002
"""Flare-IoU differences this small are sampling noise of a 96-composite set."""


def calibrate(weights: Path, data: Path, count: int = 96, seed: int = 7, size: int = 256,
              cuts: tuple[float, ...] = CALIBRATION_CUTS) -> dict:
    """Sweep the probability cut on fresh evaluation composites drawn from the *training*
    backgrounds and scenes (held-out scenes and backgrounds stay out: the cut is not tuned
    on anything an evaluation scores), with night backgrounds and streaks on a share of them.

    Per cut: flare IoU, mIoU and the ratio of marked to true flare pixels. ``best`` is the
    cut of highest flare IoU; cuts within ``CALIBRATION_TIE`` of it count as tied and the
    one marking closest to the true flare area wins (the 10 % rule counts area).
    The weighted BCE (flare 5:1) makes the network over-mark at 0.5, and the View
    Sampler's 10 % rule counts mask pixels, so an uncalibrated cut drops views whose true
    flare is under 10 %."""
    import torch

    from pipeline import flare as fl
    from pipeline.fmg_data import (
        CompositeConfig,
        CompositeSource,
        fixed_set,
        load_backgrounds,
        split_backgrounds,
    )
    from pipeline.mask import load_fmg_weights

    model = load_fmg_weights(Path(weights)).eval()
    comp = CompositeConfig(size=size, night_prob=0.25, streak_prob=0.5)
    src = CompositeSource(load_backgrounds(split_backgrounds(Path(data))[0], comp.preload_side),
                          fl.FlareConfig(), comp)
    imgs, masks = fixed_set(src, count, seed, extras=True)
    with torch.no_grad():
        probs = torch.cat([torch.sigmoid(model(imgs[i:i + 8])) for i in range(0, count, 8)])
    from gnfr.fmg import confusion

    truth = masks > 0.5
    rows = []
    for c in cuts:
        (tn, fp), (fn, tp) = confusion(probs > c, truth).tolist()
        iou_f, iou_c = tp / max(tp + fp + fn, 1), tn / max(tn + fp + fn, 1)
        rows.append({"cut": c, "iou_flare": round(iou_f, 4),
                     "miou": round((iou_f + iou_c) / 2, 4),
                     "marked_over_true": round((tp + fp) / max(tp + fn, 1), 3)})
    top = max(r["iou_flare"] for r in rows)
    near = [r for r in rows if r["iou_flare"] >= top - CALIBRATION_TIE]
    best = min(near, key=lambda r: abs(r["marked_over_true"] - 1.0))["cut"]
    return {"weights": str(weights), "count": count, "seed": seed, "size": size,
            "true_flare_fraction": round(float(truth.float().mean()), 4), "rows": rows,
            "best": best}


def format_calibration(res: dict) -> str:
    lines = [f"{res['count']} training-side composites, true flare fraction "
             f"{res['true_flare_fraction']}",
             "| cut | flare IoU | mIoU | marked / true |", "|---|---|---|---|"]
    for r in res["rows"]:
        mark = " (best)" if r["cut"] == res["best"] else ""
        lines.append(f"| {r['cut']:.2f}{mark} | {r['iou_flare']:.3f} | {r['miou']:.3f} | "
                     f"{r['marked_over_true']:.2f} |")
    return "\n".join(lines)


def write_threshold(weights: Path, cut: float) -> None:
    """Store ``cut`` as the weights' calibrated ``threshold`` metadata (tensors unchanged;
    the file is replaced atomically)."""
    from gnfr.checkpoint import replace_metadata

    replace_metadata(weights, {"threshold": f"{cut:g}"})
