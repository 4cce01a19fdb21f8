"""Frame-to-frame image motion of the video's interpolate path, with turns timed two ways.

    python benchmarks/path_motion.py WS [WS ...] [--frames 48] [--stride 8] --out JSON

For each workspace (posed, with WS/depth), the scene's points (every ``--stride``-th pixel
of each photo's depth map) are projected into consecutive frames of the ``interpolate``
path the render stage plans (``pipeline.render.plan.novel_path``), and a step's motion is
the median displacement of the points both frames see, as a share of the frame's width.
Per workspace and arm: the largest step, the 95th percentile, the median, and the largest
over the median (1: an even pace).

Arms: ``today`` is the path the render stage plans; ``travel`` times the same spline as
before the fifty-second session (an arc of travel plus 0.1 x the keys' spread per radian of
turning, i.e. ``interpolate_path``'s ``turn_depth`` at 0.1 x the spread). The rule that
judged them: docs/history/fill.md, "The video's pace: turns timed like travel".
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def scene_points(ws, cams, stride: int) -> np.ndarray:
    """[P, 3] world points of every ``stride``-th pixel of each photo's depth map."""
    from pipeline.errors import UserError
    from pipeline.stereo import backproject
    from pipeline.ws_files import read_depth

    pts = []
    for f in cams.frames:
        if not ws.depth_path(f.stem).is_file():
            continue
        depth = read_depth(ws, f.stem)[0]
        K = np.asarray(f.K, float).copy()
        K[0] *= depth.shape[1] / f.width
        K[1] *= depth.shape[0] / f.height
        p = backproject(K, np.asarray(f.c2w, float), depth)[::stride, ::stride]
        pts.append(p[depth[::stride, ::stride] > 0])
    if not pts:
        raise UserError(f"{ws.depth} holds no depth maps: run `deflare-scene depth "
                        f"{ws.root}` first")
    return np.concatenate(pts).astype(np.float64)


def step_motion(K: np.ndarray, size: tuple[int, int], poses: np.ndarray,
                pts: np.ndarray) -> np.ndarray:
    """[F - 1] median displacement, as a share of the width, of the points ``pts`` that
    consecutive cameras ``poses`` [F, 4, 4] (intrinsics ``K``, ``size`` = (W, H)) both see;
    0 where they share none."""
    W, H = size

    def project(c2w):
        w2c = np.linalg.inv(c2w)
        cam = pts @ w2c[:3, :3].T + w2c[:3, 3]
        z = cam[:, 2]
        uv = cam @ np.asarray(K, float).T
        xy = uv[:, :2] / np.where(np.abs(uv[:, 2:]) < 1e-12, 1e-12, uv[:, 2:])
        seen = (z > 1e-6) & (xy[:, 0] >= 0) & (xy[:, 0] < W) & (xy[:, 1] >= 0) & (xy[:, 1] < H)
        return xy, seen

    out = np.zeros(len(poses) - 1)
    prev = project(poses[0])
    for i in range(1, len(poses)):
        cur = project(poses[i])
        both = prev[1] & cur[1]
        if both.any():
            out[i - 1] = float(np.median(np.linalg.norm(cur[0][both] - prev[0][both], axis=1)))
        prev = cur
    return out / W


def summary(motion: np.ndarray) -> dict:
    """The pace of one path: largest step, 95th percentile, median, largest / median."""
    med = float(np.median(motion))
    return {"max": float(motion.max()), "p95": float(np.percentile(motion, 95)),
            "median": med, "max_over_median": float(motion.max() / med) if med > 0 else None,
            "steps": [round(float(m), 5) for m in motion]}


def arms(ws_dir: Path, frames: int, stride: int) -> dict:
    """{arm: summary} of one workspace's interpolate path."""
    from gnfr import paths
    from pipeline.cameras import load_cameras
    from pipeline.render.config import RenderConfig
    from pipeline.render.plan import novel_path
    from pipeline.workspace import Workspace

    ws = Workspace(ws_dir)
    cams = load_cameras(ws.cameras_json)
    pts = scene_points(ws, cams, stride)
    today = novel_path(RenderConfig(path="interpolate", frames=frames, fill="hybrid"), cams,
                       "cpu")[0]
    K, size = today[0].K, (today[0].width, today[0].height)
    c2ws = np.stack([f.c2w for f in cams.frames])
    spread = float(np.linalg.norm(np.ptp(c2ws[:, :3, 3], axis=0))) or 1.0
    travel = paths.interpolate_path(c2ws, frames, closed=paths.is_surrounding(c2ws),
                                    up=paths.world_up(c2ws), turn_depth=0.1 * spread)
    return {"points": int(len(pts)),
            "turn_depth": paths.typical_depth([f.near for f in cams.frames],
                                              [f.far for f in cams.frames]),
            "spread": spread,
            "today": summary(step_motion(K, size, np.stack([p.c2w for p in today]), pts)),
            "travel": summary(step_motion(K, size, travel, pts))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", nargs="+", type=Path, help="posed workspaces with WS/depth")
    ap.add_argument("--frames", type=int, default=48, help="frames of the path (48: 4 s x 12)")
    ap.add_argument("--stride", type=int, default=8, help="every Nth depth pixel a point")
    ap.add_argument("--out", type=Path, help="write the records here (JSON)")
    args = ap.parse_args(argv)
    from pipeline.provenance import write_result

    rec = {"frames": args.frames, "stride": args.stride, "scenes": {}}
    for ws in args.ws:
        r = arms(ws, args.frames, args.stride)
        rec["scenes"][str(ws)] = r
        print(f"{ws}: turn depth {r['turn_depth']:.3f} (spread {r['spread']:.3f})")
        for arm in ("travel", "today"):
            s = r[arm]
            print(f"  {arm:7s} max {s['max']:.4f}  p95 {s['p95']:.4f}  median "
                  f"{s['median']:.4f}  max/median {s['max_over_median']:.2f}")
    write_result(args.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
