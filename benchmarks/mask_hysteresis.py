"""Flare IoU per kind when the FMG's weak pixels joined to a confident region are kept too.

A hysteresis cut, as edge detectors use: a pixel is flare where the network's probability
is above the weights' cut, or above a lower cut ``--lows`` and 8-connected to such a pixel
(``pipeline.mask.confirmed_regions``), so that a spike's or streak's fainter length could be
kept without the isolated weak marks. For each kind of flare alone this scores ``--count``
composites (256 px, night backgrounds on ``--night`` of them, the flare rays added as the
mask stage adds them) at the plain cut and at each lower cut: flare IoU and the share of
pixels marked outside the flare. ``--split train`` draws the composites on the FMG's
training photos (fresh flare, photos it has seen), which leaves the development photos for a
rule; ``dev`` and ``test`` as `fmg eval`.

    python benchmarks/mask_hysteresis.py [--split train] [--lows 0.6,0.5,0.4,0.3,0.2] --out J
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def hysteresis(probs, cut: float, low: float | None):
    """[H, W] bool: ``probs > cut``, with ``low`` also the regions of ``probs > low`` that
    hold a pixel above ``cut``."""
    from pipeline.mask import confirmed_regions

    strong = probs > cut
    return strong if low is None else confirmed_regions(probs > low, strong, "first")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--weights", type=Path, default=ROOT / "gnfr/weights/fmg.safetensors")
    ap.add_argument("--data", type=Path, default=None,
                    help="default: $DEFLARE_SHARED_DATA or ../shared/data")
    ap.add_argument("--split", choices=("train", "dev", "test"), default="train")
    ap.add_argument("--lows", default="0.6,0.5,0.4,0.3,0.2")
    ap.add_argument("--count", type=int, default=24)
    ap.add_argument("--night", type=float, default=0.3)
    ap.add_argument("--seed", type=int, default=777)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()
    import torch

    from gnfr.fmg import predict_probs
    from pipeline import flare as fl
    from pipeline.errors import UserError
    from pipeline.fmg_data import (
        CompositeConfig,
        CompositeSource,
        fixed_set,
        load_backgrounds,
        split_backgrounds,
    )
    from pipeline.mask import load_fmg_weights
    from pipeline.provenance import sha256, write_result
    from workflows.research.fmg_eval import default_data, ray_batch, weights_info

    try:
        data = a.data or default_data()
        model = load_fmg_weights(a.weights)
        cut = weights_info(a.weights)["cut"]
        lows = [None] + [float(x) for x in a.lows.split(",") if x]
        comp = CompositeConfig(size=256, night_prob=a.night)
        bgs = load_backgrounds(getattr(split_backgrounds(data), a.split), comp.preload_side)
        if not bgs:
            raise UserError(f"{data}: no readable {a.split} photos")
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    model.eval()
    kinds = {}
    for i, kind in enumerate(fl.KINDS):
        imgs, masks = fixed_set(CompositeSource(bgs, fl.FlareConfig(kinds=(kind,)), comp),
                                a.count, a.seed + i, extras=True)
        rays = ray_batch(imgs).numpy()[:, 0]
        with torch.no_grad():
            probs = torch.cat([predict_probs(model, imgs[j:j + 8], 256, (1.0,))
                               for j in range(0, len(imgs), 8)]).numpy()[:, 0]
        truth = masks.numpy()[:, 0] > 0.5
        row = {}
        for low in lows:
            marked = [hysteresis(p, cut, low) | r for p, r in zip(probs, rays, strict=True)]
            tp = sum(int((m & t).sum()) for m, t in zip(marked, truth, strict=True))
            fp = sum(int((m & ~t).sum()) for m, t in zip(marked, truth, strict=True))
            fn = int(truth.sum()) - tp
            row["cut" if low is None else f"low {low:g}"] = {
                "flare_iou": round(tp / max(tp + fp + fn, 1), 4),
                "marked_outside": round(fp / truth.size, 5)}
        kinds[kind] = row
        print(kind, "  ".join(f"{k}: {v['flare_iou']:.3f}" for k, v in row.items()), flush=True)
    if a.out:
        write_result(a.out, {"weights": str(a.weights), "weights_sha256": sha256(a.weights),
                             "cut": cut, "split": a.split, "count": a.count,
                             "night": a.night, "seed": a.seed, "rays": True, "kinds": kinds})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
