"""Benchmark of decode and pose on the real scenes of ../shared/data.

Decode throughput, pose time/registration, pose accuracy, and the pose stage's overhead
over plain pycolmap.

    python benchmarks/pose_decode.py                          # everything (several minutes)
    python benchmarks/pose_decode.py --only decode
    python benchmarks/pose_decode.py --only pose --scenes kermit --max-size 1008
    python benchmarks/pose_decode.py --only accuracy

Writes a JSON record to --out (default benchmarks/results/pose_decode.json) and prints a
table. "plain" is pycolmap's extract_features + match_exhaustive + incremental_mapping
called directly on the same decoded images, with the same threads and no stage around it.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("DEFLARE_SHARED_DATA", REPO.parent / "shared" / "data"))


def decode_throughput(tmp: Path, max_size: int) -> dict:
    """images/s of the decode stage on JPEGs (sceaux_castle 2832x2128, cyprus 1500x1000)
    and on DNGs (Blackmagic 4128x2176 Bayer x3, canon_eos_6d linear DNG)."""
    from pipeline import decode

    out = {}
    dng = tmp / "dng"
    dng.mkdir()
    for i in range(3):
        shutil.copy(DATA / "raw" / "Blackmagic.dng", dng / f"bm{i}.dng")
    shutil.copy(DATA / "raw" / "canon_eos_6d.dng", dng / "canon.dng")
    for label, folder in (("jpeg_sceaux_2832x2128", DATA / "scenes" / "sceaux_castle"),
                          ("jpeg_cyprus_1500x1000", DATA / "scenes" / "cyprus"),
                          ("dng_4_files", dng)):
        n = len(decode.list_photos(folder))
        t = time.perf_counter()
        decode.run(decode.DecodeConfig(max_size=max_size), folder, tmp / f"{label}.ws")
        dt = time.perf_counter() - t
        out[label] = {"images": n, "seconds": round(dt, 2), "images_per_s": round(n / dt, 2)}
    return out


def plain_pycolmap(decoded: Path, tmp: Path, threads: int) -> dict:
    """Extract + exhaustive match + incremental mapping with pycolmap, nothing else."""
    import pycolmap

    db, sparse = tmp / "plain.db", tmp / "plain_sparse"
    sparse.mkdir()
    pycolmap.logging.minloglevel = 2
    t = time.perf_counter()
    ext = pycolmap.FeatureExtractionOptions()
    ext.num_threads = threads
    pycolmap.extract_features(str(db), str(decoded), extraction_options=ext)
    t1 = time.perf_counter()
    match = pycolmap.FeatureMatchingOptions()
    match.num_threads = threads
    pycolmap.match_exhaustive(str(db), match)
    t2 = time.perf_counter()
    opts = pycolmap.IncrementalPipelineOptions()
    opts.num_threads = threads
    recs = pycolmap.incremental_mapping(str(db), str(decoded), str(sparse), opts)
    t3 = time.perf_counter()
    best = max((r.num_reg_images() for r in recs.values()), default=0)
    return {"seconds": round(t3 - t, 2), "extract": round(t1 - t, 2),
            "match": round(t2 - t1, 2), "map": round(t3 - t2, 2), "registered": best}


def pose_scene(scene: str, tmp: Path, max_size: int, threads: int, plain: bool) -> dict:
    from pipeline import decode, pose
    from pipeline.workspace import Workspace

    src = DATA / "scenes" / scene
    ws = decode.run(decode.DecodeConfig(max_size=max_size), src, tmp / f"{scene}.ws")
    t = time.perf_counter()
    try:
        pose.run(pose.PoseConfig(num_threads=threads), ws)
        ok = True
    except Exception as e:  # noqa: BLE001 - a failed pose is a result here, not a crash
        ok = str(e)
    dt = time.perf_counter() - t
    report = json.loads(Workspace.open(ws.root).colmap_report.read_text())
    rec = {"scene": scene, "images": report["images"], "registered": report["registered"],
           "seconds": round(dt, 2), "stage_seconds": report.get("seconds"),
           "points3D": report["num_points3D"], "ok": ok,
           "reproj_px": round(report["mean_reprojection_error"] or 0, 3)}
    if plain:
        (tmp / f"{scene}.plain").mkdir()
        rec["plain"] = plain_pycolmap(ws.decoded, tmp / f"{scene}.plain", threads)
    return rec


def temple_accuracy(tmp: Path, threads: int) -> dict:
    """Camera centres vs Middlebury ground truth (P = K[R t]) after a Umeyama similarity."""
    from pipeline import colmap_io, decode, pose
    from pipeline.cameras import load_cameras
    from tests.fixtures import read_temple_par

    src = DATA / "scenes" / "temple"
    ws = decode.run(decode.DecodeConfig(max_size=640), src, tmp / "temple.ws")
    pose.run(pose.PoseConfig(num_threads=threads), ws)
    par = read_temple_par(src / "templeSR_par.txt")
    frames = load_cameras(ws.cameras_json).frames
    est = np.stack([f.center for f in frames])
    gt = np.stack([-par[f.name][1].T @ par[f.name][2] for f in frames])
    s, R, t = colmap_io.umeyama(est, gt)
    err = np.linalg.norm(s * est @ R.T + t - gt, axis=1)
    radius = np.linalg.norm(gt - gt.mean(0), axis=1).max()
    ang = [np.degrees(np.arccos(np.clip((R @ f.c2w[:3, 2]) @ par[f.name][1][2], -1, 1)))
           for f in frames]
    return {"registered": len(frames), "images": 16,
            "centre_err_rms_pct_radius": round(100 * float(np.sqrt((err ** 2).mean())) / radius,
                                               3),
            "centre_err_max_pct_radius": round(100 * float(err.max()) / radius, 3),
            "axis_err_max_deg": round(float(max(ang)), 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", choices=["decode", "pose", "accuracy"], action="append")
    ap.add_argument("--scenes", nargs="+", default=["kermit", "sceaux_castle", "cyprus"])
    ap.add_argument("--max-size", type=int, default=1008)
    ap.add_argument("--threads", type=int, default=-1)
    ap.add_argument("--no-plain", action="store_true", help="skip the plain pycolmap runs")
    ap.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results" /
                    "pose_decode.json")
    args = ap.parse_args()
    only = set(args.only or ["decode", "pose", "accuracy"])
    res: dict = {"max_size": args.max_size, "threads": args.threads, "cpus": os.cpu_count()}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        if "decode" in only:
            res["decode"] = decode_throughput(tmp, args.max_size)
            print(json.dumps(res["decode"], indent=1))
        if "pose" in only:
            res["pose"] = []
            for scene in args.scenes:
                r = pose_scene(scene, tmp, args.max_size, args.threads, not args.no_plain)
                res["pose"].append(r)
                print(json.dumps(r))
        if "accuracy" in only:
            res["temple"] = temple_accuracy(tmp, args.threads)
            print(json.dumps(res["temple"]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(res, indent=2) + "\n")
    print(f"written {args.out}")


if __name__ == "__main__":
    main()
