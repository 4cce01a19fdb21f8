"""How much faster does ``render --bf16`` make the CPU's video frames, and what does it change?

    python benchmarks/render_bf16.py --workspace WS [--frames 6] [--repeats 2] [--out ...]

The render stage renders the workspace's ``interpolate`` path (``--frames`` frames, one
process of one thread, the stage's defaults otherwise) in a scratch workspace sharing WS's
stages, alternately as it is (fp32 on the CPU) and with ``bf16`` (GN-FR's forward pass under
``torch.autocast("cpu", dtype=torch.bfloat16)``, as CUDA always renders), ``--repeats`` times
each; the fastest pass of each counts. The bf16 frames are compared with the fp32
frames value by value: PSNR between them, the largest difference in 8-bit levels and the
share of values that differ. The record says whether this CPU has native bf16
(``gnfr.renderer.native_bf16``): without it bf16 is emulated and slower. Run under
``ONEDNN_MAX_CPU_ISA=AVX2 ATEN_CPU_CAPABILITY=avx2`` it measures a CPU without native bf16
(the record keeps both).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workspace", type=Path, required=True,
                    help="A workspace with a fine-tuned model and its depth maps.")
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.frames < 1 or a.repeats < 1:
        raise SystemExit("--frames and --repeats: give at least 1")
    from workflows.threads import apply_thread_policy

    apply_thread_policy(1)  # one thread, as each of the render's processes runs
    import cv2
    import numpy as np
    import torch

    from benchmarks.render_speed import frame_diff, frame_pixels
    from gnfr.renderer import native_bf16
    from pipeline import render
    from pipeline.provenance import write_result
    from workflows.research.bench import scratch_workspace

    cv2.setNumThreads(1)
    best = {"fp32": math.inf, "bf16": math.inf}
    frames = {}
    with scratch_workspace(a.workspace, "deflare-bf16-") as (base, ckpt, ws):
        for rep in range(a.repeats):
            for mode in ("fp32", "bf16"):
                rc = render.RenderConfig(path="interpolate", frames=a.frames, device="cpu",
                                         workers=1, checkpoint=str(ckpt), bf16=mode == "bf16")
                t0 = time.perf_counter()
                render.run(rc, ws, force=True)
                s = (time.perf_counter() - t0) / a.frames
                best[mode] = min(best[mode], s)
                print(f"pass {rep + 1}, {mode}: {s:.2f} s per frame", flush=True)
                if rep == 0:
                    frames[mode] = frame_pixels(ws.render_dir("interpolate"))
    x, y = frames["fp32"], frames["bf16"]
    largest, differing = frame_diff(x, y)
    mse = float(np.mean([((x[k].astype(float) - y[k].astype(float)) ** 2).mean() for k in x]))
    rec = {"workspace": str(base.root), "checkpoint": str(ckpt), "frames": a.frames,
           "repeats": a.repeats, "native_bf16": native_bf16(),
           # set to emulate an older CPU (docs/performance.md, "bf16 on the CPU")
           "onednn_max_cpu_isa": os.environ.get("ONEDNN_MAX_CPU_ISA"),
           "aten_cpu_capability": torch.backends.cpu.get_cpu_capability(),
           "s_per_frame": best, "speedup": best["fp32"] / best["bf16"],
           "psnr_bf16_vs_fp32": 10 * math.log10(255 ** 2 / max(mse, 1e-12)),
           "max_abs_diff": largest,
           "share_of_values_differing": differing / sum(v.size for v in x.values())}
    print(f"fp32 {best['fp32']:.2f} s, bf16 {best['bf16']:.2f} s per frame "
          f"({rec['speedup']:.2f}x; native bf16: {rec['native_bf16']}); bf16 frames "
          f"{rec['psnr_bf16_vs_fp32']:.1f} dB from fp32, at most {rec['max_abs_diff']} levels")
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
