"""Where a GN-FR training step spends its time (CPU or CUDA).

    python benchmarks/train_step.py                  # quick preset, 10 views at 1008x756
    python benchmarks/train_step.py --preset paper --steps 3

Runs each mode in its own process (so peak memory is per mode) and prints one JSON line
per mode: end-to-end, cached features, and the plain fp32 reference path; then rays/s of
render_rays with the preset's model. Synthetic textured images; timings exclude the first
(warm-up) step.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code
from workflows.threads import apply_thread_policy

apply_thread_policy()  # before torch loads (workflows/threads.py)

import torch  # noqa: E402

from workflows.research.bench import synthetic_scene  # noqa: E402


def run_mode(preset: str, mode: str, steps: int, views: int, size: int) -> dict:
    from gnfr.fit import StepInput, Trainer
    from gnfr.train import PRESETS, prepare_sources, sample_batch

    cfg = PRESETS[preset]
    cfg = replace(cfg, cached_features=mode == "cached", reference=mode == "reference")
    device = torch.device("cuda" if torch.cuda.is_available() else "cpu")
    scene = synthetic_scene(views, (size, round(size * 0.75)))
    torch.manual_seed(0)
    from gnfr.model import GNFR

    model = GNFR(cfg.model).to(device)
    tr = Trainer(model, cfg, gen=torch.Generator().manual_seed(0))
    t0 = time.perf_counter()
    bank, cache = prepare_sources(model, scene, cfg, device)
    prep = time.perf_counter() - t0
    times = []
    for _ in range(steps + 1):
        inp = StepInput(sample_batch(scene, cfg, tr.gen), bank, cache)
        if device.type == "cuda":
            torch.cuda.synchronize()
        t = time.perf_counter()
        tr.train_one(inp)
        if device.type == "cuda":
            torch.cuda.synchronize()
        times.append(time.perf_counter() - t)
    step_s = sum(times[1:]) / steps
    peak = (torch.cuda.max_memory_allocated() / 2**20 if device.type == "cuda"
            else resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    return {"preset": preset, "mode": mode, "device": device.type,
            "threads": torch.get_num_threads(), "step_s": round(step_s, 4),
            "it_per_s": round(1 / step_s, 3), "prepare_s": round(prep, 2),
            "peak_mib": round(peak), "projected_iters_s": round(cfg.iters * step_s)}


def render_speed(preset: str, views: int, size: int, n_rays: int) -> dict:
    from gnfr.geometry import image_pixels, pixel_rays
    from gnfr.model import GNFR
    from gnfr.renderer import SourceViews, render_rays
    from gnfr.train import PRESETS, downscale

    cfg = PRESETS[preset]
    scene = synthetic_scene(views, (size, round(size * 0.75)))
    model = GNFR(cfg.model).eval()
    imgs, K, masks, _ = downscale(scene, cfg.source_scale)
    t = time.perf_counter()
    src = SourceViews.encode(model, imgs, K, scene.c2w.float(), masks, "cpu")
    enc = time.perf_counter() - t
    H, W = scene.images.shape[-2:]
    pix = image_pixels(H, W)[torch.randperm(H * W, generator=torch.Generator().manual_seed(0))
                             [:n_rays]]
    o, d = pixel_rays(scene.K[0].float(), scene.c2w[0].float(), pix)
    ids = torch.arange(1, min(views, cfg.eval_views + 1))
    near, far = torch.full((n_rays,), 1.5), torch.full((n_rays,), 4.5)
    t = time.perf_counter()
    render_rays(model, src, ids, o, d, near, far, cfg.samples)
    dt = time.perf_counter() - t
    return {"preset": preset, "mode": "render_rays", "encode_all_views_s": round(enc, 2),
            "rays_per_s": round(n_rays / dt, 1), "source_views": len(ids),
            "samples": cfg.samples}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="quick")
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--views", type=int, default=10)
    ap.add_argument("--size", type=int, default=1008, help="image width (height = 3/4)")
    ap.add_argument("--rays", type=int, default=2048, help="rays for the render timing")
    ap.add_argument("--mode", default=None, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.mode == "render":
        print(json.dumps(render_speed(a.preset, a.views, a.size, a.rays)), flush=True)
        return
    if a.mode:
        print(json.dumps(run_mode(a.preset, a.mode, a.steps, a.views, a.size)), flush=True)
        return
    results = []
    for mode in ("end-to-end", "cached", "reference", "render"):
        out = subprocess.run([sys.executable, __file__, "--mode", mode, *sys.argv[1:]],
                             capture_output=True, text=True, check=True)
        line = out.stdout.strip().splitlines()[-1]
        print(line, flush=True)
        results.append(json.loads(line))
    e2e, ref = results[0], results[2]
    print(json.dumps({"reference_over_default_step_time": round(ref["step_s"] / e2e["step_s"],
                                                                3)}))


if __name__ == "__main__":
    main()
