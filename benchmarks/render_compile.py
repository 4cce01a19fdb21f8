"""Benchmark of `render --compile`: GN-FR's rays eager against torch.compile, same run.

    python benchmarks/render_compile.py [--preset quick] [--rays 16384] [--device cpu] \
        [--out docs/results/render_compile_cpu.json]

A random model of the preset (speed does not depend on the weights) renders ``--rays`` rays
of a 504x378 frame of the bench's synthetic scene in the render stage's chunks, padded to
one shape as the stage does with --compile. Reported: the compile time (the first compiled
pass minus the fastest compiled one; inductor's caches off unless ``--warm-cache``, so it is
what a first render pays) and the fastest of ``--repeats`` passes of each.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="quick")
    ap.add_argument("--rays", type=int, default=16384)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--warm-cache", action="store_true",
                    help="Let inductor reuse compiled kernels of earlier runs (default: a cold "
                    "compile, what a first render pays).")
    a = ap.parse_args(argv)
    import os

    if not a.warm_cache:
        os.environ["TORCHINDUCTOR_FORCE_DISABLE_CACHES"] = "1"
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    import torch

    from gnfr.model import GNFR
    from gnfr.renderer import SourceViews, render_rays
    from gnfr.train import PRESETS
    from pipeline.provenance import write_result
    from pipeline.render import default_chunk
    from workflows.research.bench import _frame_rays, _sources, synthetic_scene

    tcfg = PRESETS[a.preset]
    scene = synthetic_scene(10, (504, 378))
    torch.manual_seed(0)
    model = GNFR(tcfg.model).to(a.device).eval()
    imgs, K, masks, c2w = _sources(scene, tcfg, (504, 378), 6)
    _, o, d = _frame_rays(504, 378, a.rays, scene.c2w[6].float(), a.device)
    near, far = torch.full((len(o),), 1.0), torch.full((len(o),), 4.5)
    ids = torch.arange(6)
    chunk = default_chunk(a.device)

    def one(m) -> float:
        if a.device.startswith("cuda"):
            torch.cuda.synchronize()
        t0 = time.perf_counter()
        render_rays(m, src, ids, o, d, near, far, tcfg.samples, chunk=chunk, with_depth=False,
                    pad=True)
        if a.device.startswith("cuda"):
            torch.cuda.synchronize()
        return time.perf_counter() - t0

    with torch.inference_mode():
        src = SourceViews.encode(model, imgs, K, c2w, masks, a.device)
        one(model)  # warm-up
        eager = [one(model)]
        compiled = torch.compile(model, dynamic=False)
        first = one(compiled)
        comp = []
        for _ in range(a.repeats):
            comp.append(one(compiled))
            eager.append(one(model))
    rec = {"preset": a.preset, "rays": len(o), "chunk": chunk, "samples": tcfg.samples,
           "compile_cache": "warm" if a.warm_cache else "disabled (cold compile)",
           "device": a.device, "eager_s": min(eager), "compiled_s": min(comp),
           "speedup": min(eager) / min(comp), "compile_s": first - min(comp),
           "eager_all_s": eager, "compiled_all_s": comp,
           "ms_per_ray": {"eager": 1e3 * min(eager) / len(o),
                          "compiled": 1e3 * min(comp) / len(o)}}
    print(f"{len(o)} rays: eager {min(eager):.2f} s, compiled {min(comp):.2f} s "
          f"({rec['speedup']:.2f}x), compiling took {rec['compile_s']:.0f} s", flush=True)
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
