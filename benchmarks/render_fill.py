"""Benchmark of seconds per novel frame: GN-FR everywhere against the hybrid fill, one run.

GN-FR everywhere is ``--fill network`` (24 uniform samples); the hybrid fill warps photos by
depth and renders GN-FR at 1/4 size on the rest with depth-guided samples. The workspace
needs a fine-tuned model and WS/depth.

    python benchmarks/render_fill.py WS --frames 3 --out docs/results/render_fill.json

Frames are cameras of the interpolate path (the one-shot's video path) at the decoded size
and at twice it (about 1008 px wide for a 504 px workspace). Each configuration renders the
same frames into a temporary folder; the timing is the render stage's own wall time divided
by the frames, sources encoded once per run as the stage does.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workspace", type=Path)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--scales", default="1,2", help="Frame sizes as multiples of the decoded size.")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    import numpy as np

    from gnfr.paths import PathCamera, path_to_json
    from pipeline import render
    from pipeline.cameras import load_cameras
    from pipeline.workspace import Workspace, atomic_write_json

    ws = Workspace.open(a.workspace)
    cams = load_cameras(ws.cameras_json)
    cfg0 = render.RenderConfig(path="interpolate", frames=max(a.frames * 4, 8))
    path_cams, _ = render.novel_path(cfg0, cams, "cpu")
    pick = np.linspace(0, len(path_cams) - 1, a.frames).round().astype(int)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scale in (float(s) for s in a.scales.split(",")):
            pcs = []
            for i in pick:
                pc = path_cams[i]
                W, H = round(pc.width * scale), round(pc.height * scale)
                K = np.asarray(pc.K, float).copy()
                K[:2] *= scale
                pcs.append(PathCamera(f"f{i:03d}", K, pc.c2w, W, H))
            pj = Path(tmp) / f"bench_x{scale:g}.json"
            atomic_write_json(pj, path_to_json(pcs))
            for fill in ("network", "hybrid"):
                cfg = replace(render.RenderConfig(path=str(pj), fill=fill), scale=None)
                t0 = time.perf_counter()
                render.run(cfg, ws, force=True)
                dt = (time.perf_counter() - t0) / len(pcs)
                rows.append({"size": [pcs[0].width, pcs[0].height], "fill": fill,
                             "s_per_frame": round(dt, 2)})
                print(f"{pcs[0].width}x{pcs[0].height} {fill}: {dt:.1f} s/frame", flush=True)
    from pipeline.provenance import write_result

    rec = {"workspace": str(ws.root), "frames": int(len(pick)), "rows": rows}
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
