"""How long do the de-flared photos take to render with N sources each?

    python benchmarks/inputs_sources_time.py --workspace WS [--sources 6,12] [--repeats 2]
        [--out RESULT.json]

The render stage renders WS's de-flared photos (`render --path inputs`, one process of one
thread, the stage's defaults otherwise) in a scratch workspace sharing WS's stages, once per
count of ``--sources`` (``RenderConfig.n_sources``) in turn, ``--repeats`` times over; the
fastest pass of each count is recorded, in seconds for all the photos and per photo. WS is
not written to. The sixty-seventh session's default of 12 sources for the de-flared photos
(``pipeline.render.config.INPUTS_SOURCES``) was priced with it (docs/history/gnfr.md).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workspace", type=Path, required=True,
                    help="A workspace with a fine-tuned model, masks and depth maps.")
    ap.add_argument("--sources", default="6,12", help="source counts, comma-separated")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from benchmarks.render_speed import parse_counts

    counts = parse_counts(a.sources, "--sources")
    if a.repeats < 1:
        raise SystemExit("--repeats: give at least 1")
    from workflows.threads import apply_thread_policy

    apply_thread_policy(1)  # one thread, as each of the render's processes runs
    import cv2

    from pipeline import render
    from pipeline.provenance import write_result
    from pipeline.ws_files import read_cameras
    from workflows.research.bench import scratch_workspace

    cv2.setNumThreads(1)
    best = {n: math.inf for n in counts}
    with scratch_workspace(a.workspace, "deflare-sources-") as (base, ckpt, ws):
        photos = len(read_cameras(ws).stems)
        for rep in range(a.repeats):
            for n in counts:
                rc = render.RenderConfig(path="inputs", n_sources=n, device="cpu", workers=1,
                                         checkpoint=str(ckpt))
                t0 = time.perf_counter()
                render.run(rc, ws, force=True)
                best[n] = min(best[n], time.perf_counter() - t0)
                print(f"pass {rep + 1}, {n} sources: {best[n]:.1f} s", flush=True)
    rec = {"workspace": str(base.root), "checkpoint": str(ckpt), "photos": photos,
           "repeats": a.repeats, "seconds": {str(n): round(s, 2) for n, s in best.items()},
           "seconds_per_photo": {str(n): round(s / photos, 3) for n, s in best.items()}}
    print(", ".join(f"{n} sources {s:.1f} s" for n, s in best.items()) + f" ({photos} photos)")
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
