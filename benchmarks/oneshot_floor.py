"""The sample floor's protocol on a synthetic-flare scene: the default one-shot, small and short.

    python benchmarks/oneshot_floor.py SYNTH --work DIR [--pose-from WS] [--seeds 0,1]
        [--set STAGE.FIELD=VALUE ...] [--out JSON]

tests/workflows/test_oneshot.py::test_default_path_removes_the_flare_on_the_sample runs the
default `deflare-scene PHOTOS` on the shipped sample (a test scene) at 200 px and 150
fine-tuning steps and asks that the de-flared photos remove most of the flare's excess light
in the true flare region (``excess_ratio`` under 0.3) and gain over the flared photos there
(mean over 3 dB, every view over 1 dB). This runs the same command and the same measures
(``workflows.research.eval.scoring.floor_scores``) on a `deflare-scene synth` folder, e.g. a
development scene, once per fine-tuning seed, with extra ``--set`` options (a candidate FMG:
``--set mask.weights=W``). Structure from motion rarely registers a whole small scene at
200 px, so ``--pose-from WS`` imports the poses of the clean workspace the synth folder was
made from (its COLMAP model with pinhole cameras of the undistorted images that the synth
folder's photos are).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def pinhole_model(ws: Path, out: Path) -> Path:
    """Write WS's COLMAP model with each camera replaced by the pinhole camera of its
    undistorted image (WS/cameras.json: K, width, height) into ``out``; poses and points are
    kept (undistortion changes neither)."""
    import pycolmap

    from pipeline.cameras import load_cameras

    rec = pycolmap.Reconstruction(str(ws / "colmap" / "sparse" / "0"))
    frames = load_cameras(ws / "cameras.json").by_stem()
    for image in rec.images.values():
        f = frames[Path(image.name).stem]
        rec.cameras[image.camera_id] = pycolmap.Camera(
            model="PINHOLE", width=f.width, height=f.height, camera_id=image.camera_id,
            params=[f.K[0, 0], f.K[1, 1], f.K[0, 2], f.K[1, 2]])
    out.mkdir(parents=True, exist_ok=True)
    rec.write(str(out))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path, help="a `deflare-scene synth` folder")
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--pose-from", type=Path, default=None,
                    help="the clean workspace the synth folder was made from")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument("--max-size", type=int, default=200)
    ap.add_argument("--iters", type=int, default=150)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    import numpy as np

    from pipeline.provenance import write_result
    from workflows.cli import main as cli
    from workflows.research.eval.scoring import floor_scores

    for need in (a.scene / "photos", a.scene / "clean", a.scene / "masks_gt"):
        if not need.is_dir():
            ap.error(f"{need} is missing: SYNTH must be a `deflare-scene synth` folder")
    if a.pose_from is not None and not (a.pose_from / "colmap" / "sparse" / "0").is_dir():
        ap.error(f"--pose-from {a.pose_from} has no colmap/sparse/0: give the posed "
                 "workspace the synth folder was made from")
    sets = [x for s in a.sets for x in ("--set", s)]
    if a.pose_from is not None:
        model = pinhole_model(a.pose_from, a.work / "pinhole_model")
        sets += ["--set", f"pose.colmap_model={model}"]
    runs = {}
    for seed in (int(s) for s in a.seeds.split(",")):
        ws = a.work / f"seed{seed}.deflare"
        t = time.time()
        rc = cli([str(a.scene / "photos"), "--out", str(ws), "--max-size", str(a.max_size),
                  "--preset", "quick", "--iters", str(a.iters), "--frames", "4", "--fps", "4",
                  "--device", "cpu", "--set", "pose.num_threads=1",
                  "--set", f"finetune.seed={seed}", *sets])
        if rc != 0:
            print(f"seed {seed}: the one-shot failed (exit {rc}); see {ws}", file=sys.stderr)
            return rc
        runs[str(seed)] = {**floor_scores(a.scene / "photos", ws / "deflared", ws / "decoded",
                                          a.scene / "clean", a.scene / "masks_gt"),
                           "wall_s": round(time.time() - t, 1)}
        r = runs[str(seed)]
        print(f"seed {seed}: flare-region gain {r['mean_gain']:.2f} dB (lowest view "
              f"{r['min_gain']:.2f}), excess left {r['excess_ratio']:.3f} of the flared photos'")
    keys = ("mean_gain", "min_gain", "excess_ratio")
    rec = {"scene": str(a.scene), "sets": a.sets, "pose_from": str(a.pose_from),
           "max_size": a.max_size, "iters": a.iters, "runs": runs,
           "mean": {k: float(np.mean([r[k] for r in runs.values()])) for k in keys}}
    print("mean over seeds: " + ", ".join(f"{k} {v:.3f}" for k, v in rec["mean"].items()))
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
