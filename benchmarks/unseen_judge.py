"""Score a render option against the default on leave-one-out and held-out frames.

    python benchmarks/novel_loo.py SCENE --heldout --frames DIR/SCENE_NAME/ARM/heldout ...
    python benchmarks/novel_loo.py SCENE --non-targets --frames DIR/SCENE_NAME/ARM/loo ...
    python benchmarks/unseen_judge.py DIR --scenes /work/dev/X_synth,... --baseline base \
        --candidate unseen [--seeds 5,6,7] [--level 1] [--scene-tolerance 0.05] \
        [--ssim-tolerance 0.001] [--out JSON]

Each scene's frames of the two arms (``DIR/<scene>/<arm>/{heldout,loo}/<stem>.png``, as
``novel_loo.py --frames`` keeps them; with ``--seeds``, one model per seed:
``DIR/<scene>/<arm>/s<seed>/{heldout,loo}/``) are scored against the scene's clean photos:
whole frames (PSNR and SSIM per frame, averaged over a seed's frames, then over the seeds),
and the region where the arms' frames differ (by more than ``--level`` 8-bit levels in some
channel), pooled over the scene's frames of every seed (one MSE over every region pixel).
The rule: (a) the region's PSNR rises on the mean of the scenes that have a region and on
at least two of the three; (b) the whole frames' PSNR, averaged over the scenes, falls by
no more than 0.01 dB (and, with ``--scene-tolerance``, on no scene by more than that); with
``--ssim-tolerance``, (c) their SSIM, averaged the same way, falls by no more than that.
Written for `render --unseen-below` (docs/history/fill.md, "Where no source sees": the
defaults, one model per scene), used again for `render --from-deflared` ("Novel frames'
network sources from the de-flared photos": seeds 5-7, ``--level 1``, 0.05 and 0.001).
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


def score_scene(scene: Path, pairs: list[tuple[Path, Path]], level: int = 0) -> dict:
    """The two arms' frames of one scene against its clean photos: ``pairs`` holds each
    seed's (baseline folder, candidate folder)."""
    from pipeline.metrics import mse_to_psnr, psnr, ssim
    from workflows.research.eval.scoring import read_bgr

    whole = {"baseline": [], "candidate": []}
    sharp = {"baseline": [], "candidate": []}
    sq = {"baseline": 0.0, "candidate": 0.0}
    n_region = n_pixels = n_frames = 0
    for base, cand in pairs:
        seed = {"baseline": ([], []), "candidate": ([], [])}
        frames = sorted(base.glob("*/*.png"))
        if not frames:
            raise SystemExit(f"unseen_judge: no frames in {base}/*/")
        n_frames += len(frames)
        for fb in frames:
            fc = cand / fb.relative_to(base)
            b, c = read_bgr(fb), read_bgr(fc)
            gt = read_bgr(scene / "clean" / fb.name, b.shape[:2])
            for arm, img in (("baseline", b), ("candidate", c)):
                seed[arm][0].append(psnr(img, gt))
                seed[arm][1].append(ssim(img, gt))
            b, c, gt = (x.astype(np.float64) for x in (b, c, gt))
            region = np.abs(b - c).max(-1) > level
            n_region += int(region.sum())
            n_pixels += region.size
            for arm, img in (("baseline", b), ("candidate", c)):
                sq[arm] += float(((img - gt)[region] ** 2).sum())
        for arm in whole:
            whole[arm].append(float(np.mean(seed[arm][0])))
            sharp[arm].append(float(np.mean(seed[arm][1])))
    rec = {"frames": n_frames, "region_share": n_region / max(n_pixels, 1),
           "whole": {k: float(np.mean(v)) for k, v in whole.items()},
           "ssim": {k: float(np.mean(v)) for k, v in sharp.items()}}
    if len(pairs) > 1:
        rec["whole_per_seed"] = whole
    if n_region:
        rec["region"] = {k: mse_to_psnr(v / (3 * n_region) / 255.0 ** 2)
                         for k, v in sq.items()}
    return rec


def judge(scenes: dict, scene_tolerance: float | None = None,
          ssim_tolerance: float | None = None) -> dict:
    with_region = [r for r in scenes.values() if "region" in r]
    gains = [r["region"]["candidate"] - r["region"]["baseline"] for r in with_region]
    per_scene = [r["whole"]["candidate"] - r["whole"]["baseline"] for r in scenes.values()]
    whole = float(np.mean(per_scene))
    a = bool(gains) and float(np.mean(gains)) > 0 and sum(g > 0 for g in gains) >= 2
    b = whole >= -WHOLE_TOLERANCE and (scene_tolerance is None
                                       or min(per_scene) >= -scene_tolerance)
    rec = {"region_gain_mean": float(np.mean(gains)) if gains else None,
           "region_gains": gains, "whole_gain_mean": whole, "a": a, "b": b}
    passed = a and b
    if ssim_tolerance is not None:
        s = float(np.mean([r["ssim"]["candidate"] - r["ssim"]["baseline"]
                           for r in scenes.values()]))
        rec["ssim_gain_mean"] = s
        rec["c"] = s >= -ssim_tolerance
        passed = passed and rec["c"]
    rec["passed"] = passed
    return rec


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", type=Path)
    ap.add_argument("--scenes", required=True, help="comma-separated synth scene folders")
    ap.add_argument("--baseline", default="base")
    ap.add_argument("--candidate", default="unseen")
    ap.add_argument("--seeds", default=None, help="comma-separated: one model per seed")
    ap.add_argument("--level", type=int, default=0,
                    help="8-bit levels the arms' frames must differ by to be region")
    ap.add_argument("--scene-tolerance", type=float, default=None)
    ap.add_argument("--ssim-tolerance", type=float, default=None)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.provenance import write_result

    seeds = [f"s{s.strip()}" for s in a.seeds.split(",")] if a.seeds else [""]
    scenes = {}
    for s in a.scenes.split(","):
        scene = Path(s)
        name = scene.name
        pairs = [(a.dir / name / a.baseline / k, a.dir / name / a.candidate / k) for k in seeds]
        scenes[name] = score_scene(scene, pairs, a.level)
    rec = {"baseline": a.baseline, "candidate": a.candidate, "seeds": a.seeds,
           "level": a.level, "scenes": scenes,
           "rule": judge(scenes, a.scene_tolerance, a.ssim_tolerance)}
    print(json.dumps(rec, indent=1))
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
