"""Benchmark of the render stage's speed settings on the CPU: chunk size and processes.

Rays per forward pass (``--chunk``) and the processes that render the frames (``--workers``).

    python benchmarks/render_speed.py --workspace WS [--chunks 128,256] [--workers 1,2] \
        [--frames 12] [--repeats 3] [--threads N] [--out docs/results/render_speed_cpu.json]

The render stage renders the workspace's ``interpolate`` path (``--frames`` frames, the stage's
defaults otherwise) once per (chunk, workers) pair, in a scratch workspace of hard links under
the system temp folder (WS is only read), the pairs interleaved ``--repeats`` times: the
fastest pass of each counts (on a shared machine a pass measures the load of its moment as
much as the setting). A frame's time is the stage's wall time over the frames (the processes'
start, the model's load and the sources' encoding included, as a user's render pays them).
The frames of every pair are compared with the first pair's, pixel for pixel: these are speed
settings, not quality ones, and the record says how far any pixel moved (``max_abs_diff``, in
8-bit levels) and how many did (``pixels_differing``).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def parse_counts(text: str, name: str) -> list[int]:
    """'64,128,256' -> [64, 128, 256]; a one-line error naming ``name`` for anything else."""
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        values = []
    if not values or min(values) < 1 or len(set(values)) != len(values):
        raise SystemExit(f"{name} {text!r}: give distinct positive integers, e.g. 1,2")
    return values


def frame_pixels(folder: Path):
    """{name: uint8 array} of the PNG frames in ``folder``."""
    import cv2

    return {p.name: cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in sorted(folder.glob("*.png"))}


def frame_diff(a: dict, b: dict) -> tuple[int, int]:
    """(largest difference in 8-bit levels, values that differ) between two renders of the
    same frames; (-1, -1) when the frame names differ."""
    import numpy as np

    if a.keys() != b.keys():
        return -1, -1
    d = [np.abs(a[k].astype(int) - b[k].astype(int)) for k in a]
    return max((int(x.max()) for x in d), default=0), sum(int((x > 0).sum()) for x in d)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workspace", type=Path, required=True,
                    help="A workspace with a fine-tuned model (and its depth maps).")
    ap.add_argument("--chunks", default="256")
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=None,
                    help="torch threads (default: torch's, the cores)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    pairs = [(c, w) for c in parse_counts(a.chunks, "--chunks")
             for w in parse_counts(a.workers, "--workers")]
    if a.frames < 1 or a.repeats < 1:
        raise SystemExit("--frames and --repeats: give at least 1")
    from workflows.threads import apply_thread_policy

    apply_thread_policy(a.threads)  # before torch loads (workflows/threads.py)
    import torch

    from pipeline import render
    from pipeline.provenance import write_result
    from workflows.research.bench import scratch_workspace

    best = {p: math.inf for p in pairs}
    passes: dict[tuple, list[float]] = {p: [] for p in pairs}
    diffs: dict[tuple, tuple[int, int]] = {}
    with scratch_workspace(a.workspace, "deflare-speed-") as (base, ckpt, ws):
        first = None
        for rep in range(a.repeats):
            for c, w in pairs:
                rc = render.RenderConfig(path="interpolate", frames=a.frames, device="cpu",
                                         chunk=c, workers=w, checkpoint=str(ckpt))
                t0 = time.perf_counter()
                render.run(rc, ws, force=True)
                s = (time.perf_counter() - t0) / a.frames
                passes[c, w].append(s)
                best[c, w] = min(best[c, w], s)
                print(f"pass {rep + 1}, chunk {c}, workers {w}: {s:.2f} s per frame",
                      flush=True)
                if rep == 0:
                    px = frame_pixels(ws.render_dir("interpolate"))
                    first = first or px
                    diffs[c, w] = frame_diff(first, px)
    ref = pairs[0]
    rec = {"workspace": str(base.root), "checkpoint": str(ckpt), "frames": a.frames,
           "repeats": a.repeats, "torch_threads": torch.get_num_threads(),
           "rows": [{"chunk": c, "workers": w, "s_per_frame": best[c, w],
                     "all_s_per_frame": passes[c, w], "max_abs_diff": diffs[c, w][0],
                     "pixels_differing": diffs[c, w][1]} for c, w in pairs],
           "diff_against": {"chunk": ref[0], "workers": ref[1]}}
    for row in rec["rows"]:
        print(f"chunk {row['chunk']:5d}, workers {row['workers']}: {row['s_per_frame']:.2f} s "
              f"per frame (fastest of {a.repeats}); against chunk {ref[0]}, workers {ref[1]}: "
              f"{row['pixels_differing']} values differ, by at most {row['max_abs_diff']}")
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
