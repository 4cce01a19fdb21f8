"""Seconds of the photo geometry (no network) on a workspace, with digests of what it made.

    python benchmarks/stereo_time.py WS --work DIR [--frames 6] [--out JSON] \
        [--set depth.FIELD=VALUE ...] [--depth-only]

Two timings, both numpy and OpenCV only (pipeline/stereo.py, pipeline/photo_fill.py):

- the depth stage: WS is copied into DIR without its depth maps (nothing of WS is changed)
  and ``deflare-scene depth`` runs there with its defaults (plane sweep of every view and the
  consistency check), or with ``--set depth.FIELD=VALUE`` (e.g. ``depth.sgm=0.1,1``); seconds
  per view and the share of pixels with a depth;
- the hybrid fill's photo share of novel frames: ``--frames`` frames spread over the video's
  interpolate path, at the render stage's default size and at half of it, warped from the
  photos through WS's own depth maps (``pipeline.render.fill.fill_from_photos``: depth
  splatting, the consensus sweep for the holes, warping, gains, fusion); seconds per frame.
  Needs a fine-tuned model in WS (the frames' sources are its); ``--depth-only`` skips it.

Each part also records a SHA-256 digest of its arrays (the depth maps and confidences; the
fill's colour, weight and depth), so two runs of the script at different commits show
whether a change of the code changed what it computes as well as how fast. The thread count
is the process's (set OMP_NUM_THREADS); OpenCV uses its own default.
"""

from __future__ import annotations

import argparse
import hashlib
import shutil
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def digest(arrays) -> str:
    """SHA-256 over the bytes, shapes and dtypes of ``arrays`` in order."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.shape}{a.dtype}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def time_depth(ws_dir: Path, work: Path, sets: list[str] | None = None) -> dict:
    """The depth stage on a copy of ``ws_dir`` without WS/depth: its defaults, or with
    ``sets`` (``depth.FIELD=VALUE``, as the one-shot command's ``--set``)."""
    from pipeline import depth
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_depth
    from workflows.oneshot import apply_overrides

    config = apply_overrides({"depth": depth.DepthConfig()}, sets or [])["depth"]
    out = work / f"{ws_dir.name}.depth"
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(ws_dir, out, symlinks=True, ignore=shutil.ignore_patterns("depth"))
    ws = Workspace(out)
    t0 = time.perf_counter()
    depth.run(config, ws, force=True)
    secs = time.perf_counter() - t0
    stems = sorted(p.stem for p in ws.depth.glob("*.npz"))
    known = np.mean([(read_depth(ws, s)[0] > 0).mean() for s in stems])
    return {"views": len(stems), "settings": sets or [], "seconds": round(secs, 2),
            "seconds_per_view": round(secs / len(stems), 3), "known": round(float(known), 4),
            "digest": digest(a for s in stems for a in read_depth(ws, s))}


def time_fill(ws_dir: Path, frames: int, scale: float | None) -> dict:
    """The hybrid fill's photo share of ``frames`` novel frames of the interpolate path."""
    from dataclasses import replace

    from pipeline.render import (
        RenderConfig,
        fill_from_photos,
        find_checkpoint,
        photo_views,
        train_meta,
    )
    from pipeline.render.plan import plan_jobs, resolve_fill
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras, read_views

    ws = Workspace(ws_dir)
    cams = read_cameras(ws)
    cfg = RenderConfig(path="interpolate", scale=scale, depth_min_blob=0.0)
    meta = train_meta(find_checkpoint(ws, None))  # the sources as the render stage picks them
    cfg = replace(cfg, n_sources=int(meta.get("eval_views") or 10),
                  sources_equal_below=cfg.equal_below(novel=True))
    cfg = resolve_fill(cfg, "cpu", novel=True)  # the novel frames' fill as render's
    _, _, jobs = plan_jobs(cfg, ws, cams, read_views(ws), "cpu")
    jobs = [jobs[i] for i in np.linspace(0, len(jobs) - 1, frames).round().astype(int)]
    photos = photo_views(ws, cams, jobs, cfg)
    arrays, secs = [], 0.0
    for j in jobs:
        pc = j.camera
        t0 = time.perf_counter()
        f = fill_from_photos(pc.K, pc.c2w, (pc.width, pc.height), j, photos, cfg, novel=True)
        secs += time.perf_counter() - t0
        arrays += [f.colour, f.weight, f.depth]
    size = [int(jobs[0].camera.width), int(jobs[0].camera.height)]
    return {"frames": len(jobs), "size": size, "seconds_per_frame": round(secs / len(jobs), 3),
            "digest": digest(arrays)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", type=Path)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--set", dest="sets", action="append", default=[],
                    metavar="depth.FIELD=VALUE", help="a depth stage option, e.g. depth.sgm=0.1,1")
    ap.add_argument("--depth-only", action="store_true",
                    help="time the depth stage only (a workspace without a fine-tuned model)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from pipeline.errors import UserError
    from pipeline.provenance import write_result

    for need in ("cameras.json",) if a.depth_only else ("cameras.json", "depth"):
        if not (a.ws / need).exists():
            print(f"error: {a.ws / need} is missing: run `deflare-scene pose` and "
                  f"`deflare-scene depth` on {a.ws} first", file=sys.stderr)
            return 2
    if a.frames < 1:
        print("error: --frames must be at least 1", file=sys.stderr)
        return 2
    a.work.mkdir(parents=True, exist_ok=True)
    try:
        rec = {"depth_stage": time_depth(a.ws, a.work, a.sets),
               "fill": [] if a.depth_only else [time_fill(a.ws, a.frames, s)
                                                for s in (None, 0.5)]}
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    d = rec["depth_stage"]
    print(f"{a.ws.name}: depth stage {d['seconds_per_view']:.2f} s per view "
          f"({d['views']} views, depth on {100 * d['known']:.1f} % of the pixels)"
          + ("; photo fill " if rec["fill"] else "") + ", ".join(
              f"{f['seconds_per_frame']:.2f} s per frame at {f['size'][0]}x{f['size'][1]}"
              for f in rec["fill"]))
    write_result(a.out, {"workspace": str(a.ws), **rec})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
