"""The render stage with and without malloc's settings (``gnfr.malloc``), timed and compared.

Time, kernel time, page faults, and the frames compared pixel for pixel.

    python benchmarks/malloc_ab.py --workspace WS [--frames 6] [--repeats 3] [--workers 2] \
        [--path interpolate] [--out docs/results/malloc_ab_cpu.json]

Each pass runs `deflare-scene render SCRATCH --path PATH --frames N --force` in a fresh
process (malloc's settings last a process's life), once with ``DEFLARE_MALLOC=keep`` and
once without, the two arms alternating ``--repeats`` times in a scratch workspace of hard links
(``workflows.research.bench.scratch_workspace``: WS is only read). Per pass: the wall time,
and from the finished processes' resource usage (the render process and its frame workers)
the user and kernel CPU seconds and the minor page faults. The fastest pass of each arm
counts for time; the frames of the settings' first pass are compared with the first pass
without them: an allocator setting must not move a pixel.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

ARMS = ("off", "on")
"""``off``: glibc's malloc as it is (the default); ``on``: ``DEFLARE_MALLOC=keep``."""
CLI = "from workflows.cli import main; raise SystemExit(main())"


def render_pass(ws: Path, ckpt: Path, arm: str, frames: int, workers: int,
                path: str) -> dict:
    """One render of ``frames`` frames of ``path`` in a fresh process: wall seconds, the
    processes' user and kernel seconds and minor page faults."""
    env = {k: v for k, v in os.environ.items() if k != "DEFLARE_MALLOC"}
    if arm == "on":
        env["DEFLARE_MALLOC"] = "keep"
    cmd = [sys.executable, "-c", CLI, "render", str(ws), "--path", path, "--frames",
           str(frames), "--force", "--checkpoint", str(ckpt), "--device", "cpu",
           "--workers", str(workers)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {"arm": arm, "wall_s": wall, "user_s": after.ru_utime - before.ru_utime,
            "kernel_s": after.ru_stime - before.ru_stime,
            "minor_faults": after.ru_minflt - before.ru_minflt}


def summary(passes: list[dict]) -> dict:
    """Per arm: the fastest pass's wall time and the medians of the rest of its numbers."""
    import statistics

    out = {}
    for arm in ARMS:
        mine = [p for p in passes if p["arm"] == arm]
        out[arm] = {"fastest_wall_s": min(p["wall_s"] for p in mine),
                    **{f"median_{k}": statistics.median(p[k] for p in mine)
                       for k in ("wall_s", "user_s", "kernel_s", "minor_faults")}}
    out["fastest_wall_ratio_on_off"] = out["on"]["fastest_wall_s"] / out["off"]["fastest_wall_s"]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workspace", type=Path, required=True,
                    help="A workspace with a fine-tuned model (and its depth maps).")
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--path", default="interpolate", choices=("interpolate", "spiral"))
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.frames < 1 or a.repeats < 1 or a.workers < 1:
        raise SystemExit("--frames, --repeats and --workers: give at least 1")
    from benchmarks.render_speed import frame_diff, frame_pixels
    from pipeline.provenance import write_result
    from workflows.research.bench import scratch_workspace

    passes, first = [], {}
    with scratch_workspace(a.workspace, "deflare-malloc-") as (base, ckpt, ws):
        for rep in range(a.repeats):
            for arm in ARMS if rep % 2 == 0 else ARMS[::-1]:
                p = render_pass(ws.root, ckpt, arm, a.frames, a.workers, a.path)
                passes.append({"pass": rep + 1, **p})
                print(f"pass {rep + 1}, {arm}: {p['wall_s']:.1f} s, kernel {p['kernel_s']:.1f} s, "
                      f"{p['minor_faults']} page faults", flush=True)
                if arm not in first:
                    first[arm] = frame_pixels(ws.render_dir(a.path))
    largest, differing = frame_diff(first["off"], first["on"])
    rec = {"workspace": str(base.root), "checkpoint": str(ckpt), "frames": a.frames,
           "path": a.path, "workers": a.workers, "repeats": a.repeats, "passes": passes,
           "summary": summary(passes), "max_abs_diff": largest, "values_differing": differing}
    s = rec["summary"]
    print(f"fastest pass: {s['on']['fastest_wall_s']:.1f} s with the settings, "
          f"{s['off']['fastest_wall_s']:.1f} s without ({s['fastest_wall_ratio_on_off']:.3f}x); "
          f"median page faults {s['on']['median_minor_faults']:.0f} against "
          f"{s['off']['median_minor_faults']:.0f}; frames: {differing} values differ, by at "
          f"most {largest}")
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
