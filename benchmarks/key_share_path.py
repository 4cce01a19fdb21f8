"""How much each frame of the video leans to its nearest photo, and what a twin does to it.

    python benchmarks/key_share_path.py WS [WS ...] [--frames 48] [--twin 0.1] [--out JSON]

On the CPU a video frame near a photo's camera leans to that photo (``render --key-blend``,
0.5: ``pipeline.render.fill.key_share``): fully at the camera, to none at the key blend
times the distance from that camera to the nearest other source. When the nearest photo has
a twin taken from (almost) the same spot, as three of the sample's four pairs do, that
distance is the twin's, a few hundredths of the views' usual spacing, and the lean is gone
a few thousandths of a unit from the camera.

For each workspace (fine-tuned, with ``views.json`` from `select`) this plans the default
interpolate path and, for every frame, chooses its sources as `render` does
(``pipeline.render.sources.novel_sources`` at today's defaults), orders them nearest first
and reports: the nearest source and its distance, the key share as rendered, and the share
the frame would have if the spacing were measured past the photos standing within
``--twin`` times the median distance between the capture's cameras of the nearest one (what
``render --key-spot`` does, the CPU default since the eighty-first session; this reports the
key blend's reach both ways whatever the workspace's render used). Reads cameras only: no
network, no depth.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np


def frame_share(at: np.ndarray, centres: list, reach: float, same_spot: float) -> dict:
    """A frame at ``at`` whose sources stand at ``centres`` (nearest first): its distance to
    the nearest, the spacing ``pipeline.render.fill.key_share`` measures (to the nearest
    other source) and its share, and the same with the spacing measured past the sources
    within ``same_spot`` of the nearest (``render --key-spot``)."""
    from pipeline.render.fill import key_share, key_spacing

    views = [SimpleNamespace(c2w=np.c_[np.eye(3), np.asarray(c, float)]) for c in centres]
    at = np.asarray(at, float)
    return {"distance": float(np.linalg.norm(at - views[0].c2w[:3, 3])),
            "spacing": key_spacing(views), "share": key_share(at, views, reach),
            "spacing_past_twins": key_spacing(views, same_spot),
            "share_past_twins": key_share(at, views, reach, same_spot=same_spot)}


def shares(ws_dir: Path, frames: int, twin: float) -> dict:
    """The per-frame record of one workspace (see the module's docstring)."""
    from pipeline.cameras import load_cameras
    from pipeline.render import find_checkpoint, train_meta
    from pipeline.render.config import RenderConfig
    from pipeline.render.plan import (
        median_camera_distance,
        novel_path,
        resolve_fill,
        scene_points,
    )
    from pipeline.render.sources import novel_sources
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_views

    ws = Workspace(ws_dir)
    cams = load_cameras(ws.cameras_json)
    views = read_views(ws)
    cfg = resolve_fill(RenderConfig(path="interpolate", frames=frames, fill="hybrid"), "cpu",
                       novel=True)
    eval_views = train_meta(find_checkpoint(ws, None)).get("eval_views")
    cfg = replace(cfg, n_sources=cfg.source_count(eval_views))  # as `render` resolves it
    reach = float(cfg.key_blend or 0.0)
    path = novel_path(cfg, cams, "cpu", scene_points(ws, cams))[0]
    centre = {f.stem: np.asarray(f.c2w, float)[:3, 3] for f in cams.frames}
    same_spot = twin * median_camera_distance(cams)

    rows = []
    for cam in path:
        at = np.asarray(cam.c2w, float)[:3, 3]
        srcs = novel_sources(at, cams, views, cfg)
        near = sorted(srcs, key=lambda s: float(np.linalg.norm(centre[s] - at)))
        rows.append({"frame": cam.name, "nearest": near[0],
                     **frame_share(at, [centre[s] for s in near], reach, same_spot)})
    s = np.array([r["share"] for r in rows])
    p = np.array([r["share_past_twins"] for r in rows])
    return {"key_blend": reach, "same_spot": same_spot, "frames": rows,
            "mean_share": float(s.mean()), "mean_share_past_twins": float(p.mean()),
            "frames_share_lost": int(((p - s) > 0.25).sum())}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", nargs="+", type=Path,
                    help="fine-tuned workspaces (views.json, the model's source count)")
    ap.add_argument("--frames", type=int, default=48, help="frames of the path (48: 4 s x 12)")
    ap.add_argument("--twin", type=float, default=0.1,
                    help="photos within this times the median distance between the cameras "
                         "of the nearest count as one spot")
    ap.add_argument("--out", type=Path, help="write the records here (JSON)")
    args = ap.parse_args(argv)
    from pipeline.errors import UserError
    from pipeline.provenance import write_result

    rec = {"frames": args.frames, "twin": args.twin, "scenes": {}}
    for ws in args.ws:
        try:
            r = shares(ws, args.frames, args.twin)
        except UserError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        rec["scenes"][str(ws)] = r
        print(f"{ws}: one spot within {r['same_spot']:.4f}; mean share "
              f"{r['mean_share']:.2f}, past twins {r['mean_share_past_twins']:.2f}; "
              f"{r['frames_share_lost']} of "
              f"{len(r['frames'])} frames lean over 0.25 less than past their twins")
    write_result(args.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
