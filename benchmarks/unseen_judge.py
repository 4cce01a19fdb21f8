"""Score `render --unseen-below` against the default on leave-one-out and held-out frames.

    python benchmarks/novel_loo.py SCENE --heldout --frames DIR/SCENE_NAME/ARM/heldout ...
    python benchmarks/novel_loo.py SCENE --non-targets --frames DIR/SCENE_NAME/ARM/loo ...
    python benchmarks/unseen_judge.py DIR --scenes /work/dev/X_synth,... --baseline base \
        --candidate unseen [--out JSON]

Each scene's frames of the two arms (``DIR/<scene>/<arm>/{heldout,loo}/<stem>.png``, as
``novel_loo.py --frames`` keeps them) are scored against the scene's clean photos: whole
frames (PSNR per frame, averaged over the scene's frames), and the region where the arms'
frames differ (the candidate changes only the pixels its sources do not see), pooled over
the scene's frames (one MSE over every region pixel). The rule (docs/history/fill.md,
"Where no source sees"): (a) the region's PSNR rises on the mean of the scenes that have a
region and on at least two of the three; (b) the whole frames' PSNR, averaged over the
scenes, falls by no more than 0.01 dB.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

WHOLE_TOLERANCE = 0.01
"""dB the whole frames may fall, on the scenes' mean (part b)."""


def score_scene(scene: Path, base: Path, cand: Path) -> dict:
    """The two arms' frames of one scene against its clean photos."""
    from pipeline.metrics import mse_to_psnr, psnr
    from workflows.research.eval.scoring import read_bgr

    whole = {"baseline": [], "candidate": []}
    sq = {"baseline": 0.0, "candidate": 0.0}
    n_region = n_pixels = 0
    frames = sorted(base.glob("*/*.png"))
    for fb in frames:
        fc = cand / fb.relative_to(base)
        b, c = read_bgr(fb), read_bgr(fc)
        gt = read_bgr(scene / "clean" / fb.name, b.shape[:2])
        for arm, img in (("baseline", b), ("candidate", c)):
            whole[arm].append(psnr(img, gt))
        b, c, gt = (x.astype(np.float64) for x in (b, c, gt))
        region = np.abs(b - c).sum(-1) > 0
        n_region += int(region.sum())
        n_pixels += region.size
        for arm, img in (("baseline", b), ("candidate", c)):
            sq[arm] += float(((img - gt)[region] ** 2).sum())
    rec = {"frames": len(frames), "region_share": n_region / max(n_pixels, 1),
           "whole": {k: float(np.mean(v)) for k, v in whole.items()}}
    if n_region:
        rec["region"] = {k: mse_to_psnr(v / (3 * n_region) / 255.0 ** 2)
                         for k, v in sq.items()}
    return rec


def judge(scenes: dict) -> dict:
    with_region = [r for r in scenes.values() if "region" in r]
    gains = [r["region"]["candidate"] - r["region"]["baseline"] for r in with_region]
    whole = float(np.mean([r["whole"]["candidate"] - r["whole"]["baseline"]
                           for r in scenes.values()]))
    a = bool(gains) and float(np.mean(gains)) > 0 and sum(g > 0 for g in gains) >= 2
    b = whole >= -WHOLE_TOLERANCE
    return {"region_gain_mean": float(np.mean(gains)) if gains else None,
            "region_gains": gains, "whole_gain_mean": whole,
            "a": a, "b": b, "passed": a and b}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", type=Path)
    ap.add_argument("--scenes", required=True, help="comma-separated synth scene folders")
    ap.add_argument("--baseline", default="base")
    ap.add_argument("--candidate", default="unseen")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.provenance import write_result

    scenes = {}
    for s in a.scenes.split(","):
        scene = Path(s)
        name = scene.name
        scenes[name] = score_scene(scene, a.dir / name / a.baseline, a.dir / name / a.candidate)
    rec = {"baseline": a.baseline, "candidate": a.candidate, "scenes": scenes,
           "rule": judge(scenes)}
    print(json.dumps(rec, indent=1))
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
