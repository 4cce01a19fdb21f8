"""Exploration (fifty-first session): the frame refiner trained across scene families.

``refine_sim.py``'s refiner, trained across scenes and scored on a family it never saw.

    python benchmarks/refine_cross.py --test FAMILY --work DIR --loo DIR [--iters 1500] \
        --out JSON

A family is a development scene's flared builds (``FAMILIES``: the usual scene, seeds 10 and
11; its forty-ninth session's build, 22 and 23; its fiftieth session's, 24 and 25; arms of
today's defaults). The refiner is fitted on the left-out renders of every training camera of
the other two families' arms (``LOO/<scene>_<arm>_s<seed>``, written by ``novel_loo.py
--ws``; truth: the photos outside their flare masks, brought to the render's exposure, as in
``refine_sim.py``), then run on the test family's held-out frames and scored against the
clean truth. It asks whether the refiner's per-scene gains that did not hold
(docs/history/fill.md, "A per-scene refiner of the frames, explored") come back with more
scenes to learn from.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

FAMILIES = {base: [(base, "s50_dev_ag12", s) for s in (10, 11)]
            + [(flared, "s50_ag12", s) for s in (22, 23)]
            + [(flared + "h", "s50_ag12", s) for s in (24, 25)]
            for base, flared in (("sceaux", "sceaux_p4"), ("et", "et_p5"), ("lund", "lund_k4"))}
"""Development scene families: (scene, arm, seed) of each build's arms."""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--test", required=True, choices=sorted(FAMILIES))
    ap.add_argument("--work", type=Path, required=True, help="folder of the arms' workspaces")
    ap.add_argument("--loo", type=Path, required=True, help="folder of the left-out renders")
    ap.add_argument("--dev", type=Path, default=Path("/work/dev"),
                    help="folder of the development synth scenes (SCENE_synth)")
    ap.add_argument("--iters", type=int, default=1500)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()
    from benchmarks import refine_sim as rs
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from workflows.research.eval.scene import load_synth

    ws = {k: a.work / f"{k[0]}_{k[1]}_s{k[2]}.ws" for arms in FAMILIES.values() for k in arms}
    loo = {k: a.loo / f"{k[0]}_{k[1]}_s{k[2]}" for k in ws}
    missing = [p for k in ws for p in (ws[k], loo[k]) if not p.exists()]
    if missing:
        print(f"error: {missing[0]} is missing: run the arm, then novel_loo.py --ws WS "
              f"--frames {a.loo}/<scene>_<arm>_s<seed>", file=sys.stderr)
        return 2
    data = []
    for fam, arms in FAMILIES.items():
        if fam != a.test:
            for k in arms:
                scene = load_synth(a.dev / f"{k[0]}_synth")
                data += rs.pairs(scene, Workspace(ws[k]), loo[k], True)
    t0 = time.time()
    net = rs.train(data, a.iters, 96, 32, 0)
    train_s = time.time() - t0
    gains = {}
    for k in FAMILIES[a.test]:
        per = rs.score_heldout(net, load_synth(a.dev / f"{k[0]}_synth"),
                               ws[k] / "renders" / "heldout_cameras")
        gains[f"{k[0]}_{k[1]}_s{k[2]}"] = {
            m: float(np.mean([v["refined"][m] - v["base"][m] for v in per.values()]))
            for m in ("psnr", "ssim")}
    mean = {m: float(np.mean([v[m] for v in gains.values()])) for m in ("psnr", "ssim")}
    print(f"{a.test}: {mean['psnr']:+.3f} dB, SSIM {mean['ssim']:+.4f} ({len(data)} pairs, "
          f"trained {train_s:.0f} s)", flush=True)
    write_result(a.out, {"test": a.test, "iters": a.iters, "pairs": len(data),
                         "train_seconds": round(train_s, 1), "mean": mean, "gains": gains})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
