"""Frame-to-frame image motion of the video's interpolate path, with turns timed two ways.

    python benchmarks/path_motion.py WS [WS ...] [--frames 48] [--stride 8] \
        [--paths-out DIR] [--flow RENDERED_FOLDER ...] --out JSON

For each workspace (posed, with WS/depth), the scene's points (every ``--stride``-th pixel
of each photo's depth map) are projected into consecutive frames of the ``interpolate``
path the render stage plans (``pipeline.render.plan.novel_path``), and a step's motion is
the median displacement of the points both frames see, as a share of the frame's width.
Per workspace and arm: the largest step, the 95th percentile, the median, the total (the
sum of the steps: how much the path moves) and the largest over the median (1: an even
pace).

Arms: ``today`` is the path the render stage plans (paced on the image motion of the
depth maps' points); ``travel`` times the same spline as before the fifty-second session
(an arc of travel plus 0.1 x the keys' spread per radian turned: ``interpolate_path``
without points); ``view`` is ``today`` with the photos toured by travel and turn together
(``render --tour view``, the fifty-sixth session's rule). ``--paths-out DIR`` writes
each as a JSON camera path, to render with ``deflare-scene render WS --path
DIR/<scene>_<arm>.json``; ``--flow FOLDER ...`` then
scores the rendered frames by their optical flow, a check that needs no depth. The rules
that judged the pace and the tour: docs/history/fill.md, "The video's pace: turns timed like
travel" and "The interpolate path's tour by travel and turn".
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def scored_points(ws, cams, stride: int) -> np.ndarray:
    """[P, 3] world points of every ``stride``-th pixel of each photo's depth map
    (``pipeline.depth.depth_points``), the points a path is scored on; a one-line error
    without depth maps."""
    from pipeline.depth import depth_points
    from pipeline.errors import UserError

    pts = depth_points(ws, cams, stride=stride, colour=False)[0]
    if not len(pts):
        raise UserError(f"{ws.depth} holds no depth maps: run `deflare-scene depth "
                        f"{ws.root}` first")
    return pts.astype(np.float64)


def step_motion(K: np.ndarray, size: tuple[int, int], poses: np.ndarray,
                pts: np.ndarray) -> np.ndarray:
    """[F - 1] median displacement, as a share of the width, of the points ``pts`` that
    consecutive cameras ``poses`` [F, 4, 4] (intrinsics ``K``, ``size`` = (W, H)) both see;
    0 where they share none. Measured in the frame's own pixels through its ``K`` (principal
    point and borders as rendered, ``pipeline.stereo.project_points``), not through the
    pacer's unit-focal projection (``gnfr.paths.image_shift``); both take the median by
    ``gnfr.paths.median_shift``."""
    from gnfr.paths import median_shift
    from pipeline.stereo import project_points

    W, H = size
    K = np.asarray(K, float)

    def project(c2w):
        xy, z = project_points(pts, K, c2w)
        seen = (z > 1e-6) & (xy[:, 0] >= 0) & (xy[:, 0] < W) & (xy[:, 1] >= 0) & (xy[:, 1] < H)
        return xy, seen

    return median_shift((project(p) for p in poses), np.zeros(len(poses) - 1)) / W


def summary(motion: np.ndarray) -> dict:
    """The pace of one path: largest step, 95th percentile, median, largest / median."""
    med = float(np.median(motion))
    return {"max": float(motion.max()), "p95": float(np.percentile(motion, 95)),
            "total": float(motion.sum()),
            "median": med, "max_over_median": float(motion.max() / med) if med > 0 else None,
            "steps": [round(float(m), 5) for m in motion]}


def arms(ws_dir: Path, frames: int, stride: int, paths_out: Path | None = None) -> dict:
    """{arm: summary} of one workspace's interpolate path; with ``paths_out`` each arm's
    path written there as a JSON camera path (``<scene>_<arm>.json``) for the render stage."""
    from gnfr import paths
    from pipeline.cameras import load_cameras
    from pipeline.render.config import RenderConfig
    from pipeline.render.plan import novel_path, scene_points
    from pipeline.workspace import Workspace

    ws = Workspace(ws_dir)
    cams = load_cameras(ws.cameras_json)
    pts = scored_points(ws, cams, stride)
    today = novel_path(RenderConfig(path="interpolate", frames=frames, fill="hybrid"), cams,
                       "cpu", scene_points(ws, cams))[0]
    K, size = today[0].K, (today[0].width, today[0].height)
    c2ws = np.stack([f.c2w for f in cams.frames])
    view = novel_path(RenderConfig(path="interpolate", frames=frames, fill="hybrid",
                                   tour="view"), cams, "cpu", scene_points(ws, cams))[0]
    poses = {"today": np.stack([p.c2w for p in today]),
             "view": np.stack([p.c2w for p in view]),
             "travel": paths.interpolate_path(c2ws, frames, closed=paths.is_surrounding(c2ws),
                                              up=paths.world_up(c2ws))}
    if paths_out is not None:
        paths_out.mkdir(parents=True, exist_ok=True)
        for arm, P in poses.items():
            cams_arm = [paths.PathCamera(f"{i:05d}", K, c, *size) for i, c in enumerate(P)]
            (paths_out / f"{scene_name(ws_dir)}_{arm}.json").write_text(
                json.dumps(paths.path_to_json(cams_arm)) + "\n")
    return {"points": int(len(pts)),
            **{arm: summary(step_motion(K, size, P, pts)) for arm, P in poses.items()}}


def scene_name(ws_dir: Path) -> str:
    """A scene's name from its workspace folder: ``X_synth/eval.ws`` -> ``X_synth``,
    ``DIR/X.ws`` -> ``X``, ``DIR/X`` -> ``X``."""
    ws_dir = Path(ws_dir).resolve()
    if ws_dir.name == "eval.ws":
        return ws_dir.parent.name
    return ws_dir.name.removesuffix(".ws")


def frame_flow(folder: Path) -> np.ndarray:
    """[F - 1] optical flow between consecutive frames of a rendered path (``folder``'s
    PNGs in order): OpenCV's DIS (medium preset) on grey frames, the median magnitude over
    the frame as a share of its width. Independent of any depth: a check on the points'."""
    import cv2

    files = sorted(Path(folder).glob("*.png"))
    if len(files) < 2:
        raise SystemExit(f"{folder}: fewer than two PNG frames")
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    prev = cv2.imread(str(files[0]), cv2.IMREAD_GRAYSCALE)
    out = []
    for f in files[1:]:
        cur = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
        flow = dis.calc(prev, cur, None)
        out.append(float(np.median(np.linalg.norm(flow, axis=-1))) / prev.shape[1])
        prev = cur
    return np.asarray(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", nargs="*", type=Path, help="posed workspaces with WS/depth")
    ap.add_argument("--frames", type=int, default=48, help="frames of the path (48: 4 s x 12)")
    ap.add_argument("--stride", type=int, default=8, help="every Nth depth pixel a point")
    ap.add_argument("--paths-out", type=Path,
                    help="write each scene's arms here as JSON camera paths")
    ap.add_argument("--flow", type=Path, nargs="+", default=[],
                    help="rendered path folders: score their frames' optical flow instead")
    ap.add_argument("--out", type=Path, help="write the records here (JSON)")
    args = ap.parse_args(argv)
    from pipeline.provenance import write_result

    rec = {"frames": args.frames, "stride": args.stride, "scenes": {}, "flow": {}}
    from pipeline.errors import UserError

    for ws in args.ws:
        try:
            r = arms(ws, args.frames, args.stride, args.paths_out)
        except UserError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        rec["scenes"][str(ws)] = r
        print(f"{ws}: {r['points']} points")
        for arm in ("travel", "today", "view"):
            s = r[arm]
            print(f"  {arm:7s} total {s['total']:.3f}  max {s['max']:.4f}  p95 "
                  f"{s['p95']:.4f}  median {s['median']:.4f}  max/median "
                  f"{s['max_over_median']:.2f}")
    for folder in args.flow:
        s = summary(frame_flow(folder))
        rec["flow"][str(folder)] = s
        print(f"{folder}: flow max {s['max']:.4f}  p95 {s['p95']:.4f}  median "
              f"{s['median']:.4f}  max/median {s['max_over_median']:.2f}")
    write_result(args.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
