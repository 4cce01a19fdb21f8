"""Render time per frame on CPU, with and without the source-feature cache.

    python benchmarks/render_frame.py                       # quick model, 504x378 + 1008x756
    python benchmarks/render_frame.py --source-scale 1      # sources at full resolution
    python benchmarks/render_frame.py --preset paper --rays 512

"with cache" is what the render stage does: every source view is encoded once for the
whole path, so a frame costs only its rays (the encoding is shared by all frames).
"without cache" is GNT's reference renderer: the frame's sources are encoded again for
every frame, so a frame costs its rays plus encoding its ``--views`` sources. Rays are
timed on ``--rays`` pixels of the frame and scaled to the whole frame (the cost is linear
in rays: fixed chunks); encoding is timed on the real source count and size. Weights are
random (speed does not depend on them). Writes JSON to --out and prints a table.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import torch

REPO = Path(__file__).resolve().parents[1]


def look_at_ring(n: int) -> torch.Tensor:
    """[n, 4, 4] OpenCV cameras on an arc looking at the origin."""
    import numpy as np

    from gnfr.paths import look_at

    th = np.linspace(-0.4, 0.4, n)
    eyes = np.stack([np.sin(th), np.zeros(n), -np.cos(th)], 1) * 2.0
    return torch.tensor(np.stack([look_at(e, np.zeros(3), np.array([0, -1.0, 0]))
                                  for e in eyes]), dtype=torch.float32)


def bench_size(model, W: int, H: int, args) -> dict:
    from gnfr.geometry import image_pixels, pixel_rays
    from gnfr.renderer import SourceViews, render_rays

    V = args.views
    s = args.source_scale
    h, w = max(8, round(H * s)), max(8, round(W * s))
    f = 0.9 * W
    K = torch.tensor([[f, 0, W / 2], [0, f, H / 2], [0, 0, 1.0]])
    Ks = K.clone()
    Ks[0] *= w / W
    Ks[1] *= h / H
    c2w = look_at_ring(V + 1)
    g = torch.Generator().manual_seed(0)
    imgs = torch.rand(V, 3, h, w, generator=g)
    masks = (torch.rand(V, 1, h, w, generator=g) > 0.95).float()
    t0 = time.perf_counter()
    src = SourceViews.encode(model, imgs, Ks[None].expand(V, 3, 3), c2w[:V], masks, "cpu")
    encode_s = time.perf_counter() - t0
    pix = image_pixels(H, W)
    pix = pix[torch.randperm(len(pix), generator=g)[: args.rays]]
    o, d = pixel_rays(K, c2w[V], pix)
    n = len(o)
    render_rays(model, src, torch.arange(V), o[:64], d[:64], torch.full((64,), 1.0),
                torch.full((64,), 3.0), args.samples, chunk=args.chunk)  # warm-up
    t0 = time.perf_counter()
    render_rays(model, src, torch.arange(V), o, d, torch.full((n,), 1.0),
                torch.full((n,), 3.0), args.samples, chunk=args.chunk)
    per_ray = (time.perf_counter() - t0) / n
    rays_s = per_ray * W * H
    return {"size": f"{W}x{H}", "sources": f"{V} x {w}x{h}", "ms_per_ray": 1e3 * per_ray,
            "encode_s": encode_s, "frame_cached_s": rays_s,
            "frame_uncached_s": rays_s + encode_s,
            "uncached_over_cached": (rays_s + encode_s) / rays_s}


def main() -> None:
    from gnfr.model import GNFR
    from gnfr.train import PRESETS

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", choices=sorted(PRESETS))
    ap.add_argument("--sizes", default="504x378,1008x756")
    ap.add_argument("--rays", type=int, default=1024, help="rays timed per size")
    ap.add_argument("--views", type=int, default=None, help="sources (default: preset)")
    ap.add_argument("--samples", type=int, default=None, help="default: preset")
    ap.add_argument("--source-scale", type=float, default=None, help="default: preset")
    ap.add_argument("--chunk", type=int, default=1024)
    ap.add_argument("--threads", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--out", default=str(REPO / "benchmarks" / "results" / "render_frame.json"))
    args = ap.parse_args()
    cfg = PRESETS[args.preset]
    args.views = args.views or cfg.eval_views
    args.samples = args.samples or cfg.samples
    args.source_scale = args.source_scale or cfg.source_scale
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    model = GNFR(cfg.model).eval()
    rows = []
    with torch.inference_mode():
        for size in args.sizes.split(","):
            W, H = (int(v) for v in size.split("x"))
            rows.append(bench_size(model, W, H, args))
            r = rows[-1]
            print(f"{r['size']:>10}  sources {r['sources']:>14}  {r['ms_per_ray']:.3f} ms/ray  "
                  f"encode {r['encode_s']:.2f} s  frame: cached {r['frame_cached_s']:.1f} s, "
                  f"re-encoding {r['frame_uncached_s']:.1f} s "
                  f"(x{r['uncached_over_cached']:.3f})", flush=True)
    rec = {"preset": args.preset, "threads": args.threads, "samples": args.samples,
           "views": args.views, "source_scale": args.source_scale, "rays_timed": args.rays,
           "cpu_load_1min": os.getloadavg()[0], "rows": rows}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(rec, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
