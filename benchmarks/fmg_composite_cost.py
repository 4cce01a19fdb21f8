"""What FMG training composites cost to draw and what they hold, per setting of the loader.

    python benchmarks/fmg_composite_cost.py [--data ../shared/data] [--count 150] \
        [--out docs/results/fmg_composite_cost.json]

A GPU run of `fmg train` waits on its loader processes (``--workers``), so the milliseconds one
composite takes on one thread set how many steps a lent GPU can make. For M's recipe (night
0.35, the thin kinds at 0.7) and its variants (``--flare-canvas 2``, ``--frame-prob 0.5`` and
1), this draws ``count`` training composites from every fifth training photo, one thread, and
reports milliseconds per composite, the share with marked flare and the mean share of a
composite's pixels marked.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SETTINGS = {"composites": {}, "flare_canvas 2": {"flare_canvas": 2.0},
            "frame_prob 0.5": {"frame_prob": 0.5}, "frame_prob 1": {"frame_prob": 1.0}}
"""The loader settings compared (``CompositeConfig`` fields beside M's recipe)."""


def measure(backgrounds, comp_fields: dict, count: int, seed: int = 0) -> dict:
    """Draw ``count`` training composites (after two unmeasured ones) with M's recipe and
    ``comp_fields``; ms per composite, flared share, mean marked share."""
    import numpy as np

    from pipeline.fmg_data import CompositeConfig, CompositeSource, training_flare

    src = CompositeSource(backgrounds, training_flare((), {"starburst": 0.7, "ghosts": 0.7,
                                                            "streaks": 0.7}),
                          CompositeConfig(night_prob=0.35, **comp_fields))
    rng = np.random.default_rng(seed)
    for _ in range(2):
        src.sample(rng)
    t = time.perf_counter()
    masks = [src.sample(rng)[1] for _ in range(count)]
    ms = (time.perf_counter() - t) / count * 1000
    return {"ms_per_composite": round(ms, 1),
            "flared_share": round(sum(bool(m.any()) for m in masks) / count, 3),
            "marked_share": round(float(np.mean([m.mean() for m in masks])), 4)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--count", type=int, default=150)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.count < 1:
        ap.error("--count: at least 1")
    import torch

    from pipeline.errors import UserError
    from pipeline.fmg_data import load_backgrounds, split_backgrounds
    from pipeline.provenance import write_result

    torch.set_num_threads(1)
    try:
        photos = split_backgrounds(a.data).train[::5]
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    backgrounds = load_backgrounds(photos, 512)
    rows = {}
    for name, fields in SETTINGS.items():
        rows[name] = measure(backgrounds, fields, a.count)
        print(f"{name}: {rows[name]}", flush=True)
    write_result(a.out, {"photos": len(backgrounds), "count": a.count, "settings": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
