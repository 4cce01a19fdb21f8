"""How much of a flare region can the Point Sampler fill from clean source pixels?

    python benchmarks/flare_coverage.py WS SCENE [--samples 24] [--rays 2000] [--sources 6]
        [--out RESULT.json]

WS is a workspace that ran mask and select (e.g. an eval variant, EVAL/variants/gnfr);
SCENE the synth folder with ``masks_gt``. For rays through the true flare region of every
flared input view, points are placed as the renderer does (uniform in inverse depth between
the view's near and far) and projected into the sources `render --path inputs` would use;
it prints, per view, the fraction of points that land on flare (WS/masks) in every source
that sees them (``--sources``: how many, the render's ``--n-sources``; default 6, the `quick`
model's count): there the Point Sampler has nothing clean to attend to and falls back
(``finetune --flare-fallback``). Geometry only, no network; ``--out`` writes the fractions.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def coverage(ws: Path, scene: Path, samples: int = 24, rays: int = 2000,
             sources: int = 6) -> dict[str, float]:
    from pipeline.render import RenderConfig, input_sources
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras, read_mask, read_mask_file, read_views

    w = Workspace(ws)
    cams = read_cameras(w).by_stem()
    views = read_views(w).to_json()["views"]  # the JSON form render.input_sources takes
    cfg = RenderConfig(n_sources=sources, pool=20)
    masks = {s: read_mask(w, s, (f.width, f.height)) for s, f in cams.items()}
    out = {}
    for s in views:
        gt_path = scene / "masks_gt" / f"{s}.png"
        f = cams[s]
        if not gt_path.is_file():
            continue
        gt = read_mask_file(gt_path, size=(f.width, f.height))
        if not gt.any():
            continue
        ys, xs = np.nonzero(gt)
        pick = np.random.default_rng(0).choice(len(ys), min(rays, len(ys)), replace=False)
        pix = np.stack([xs[pick] + 0.5, ys[pick] + 0.5, np.ones(len(pick))], 1)
        dirs = pix @ np.linalg.inv(f.K).T @ f.c2w[:3, :3].T
        t = 1.0 / np.linspace(1.0 / f.near, 1.0 / f.far, samples)
        pts = f.c2w[:3, 3] + t[None, :, None] * dirs[:, None, :]  # [R, S, 3]
        all_flared = np.ones(pts.shape[:2], bool)
        seen = np.zeros(pts.shape[:2], bool)
        for q in input_sources(s, views, cfg):
            g = cams[q]
            w2c = np.linalg.inv(g.c2w)
            x = pts @ w2c[:3, :3].T + w2c[:3, 3]
            z = x[..., 2]
            uv = (x[..., :2] / np.maximum(z[..., None], 1e-9) * [g.K[0, 0], g.K[1, 1]]
                  + [g.K[0, 2], g.K[1, 2]])
            inside = ((z > 0) & (uv[..., 0] >= 0) & (uv[..., 0] < g.width)
                      & (uv[..., 1] >= 0) & (uv[..., 1] < g.height))
            u = np.clip(uv[..., 0].astype(int), 0, g.width - 1)
            v = np.clip(uv[..., 1].astype(int), 0, g.height - 1)
            seen |= inside
            all_flared &= masks[q][v, u] | ~inside
        out[s] = float((all_flared & seen).sum() / max(seen.sum(), 1))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workspace", type=Path)
    ap.add_argument("scene", type=Path)
    ap.add_argument("--samples", type=int, default=24)
    ap.add_argument("--rays", type=int, default=2000)
    ap.add_argument("--sources", type=int, default=6)
    ap.add_argument("--out", type=Path, default=None, help="also write the fractions here")
    a = ap.parse_args()
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from pipeline.errors import UserError

    try:
        res = coverage(a.workspace, a.scene, a.samples, a.rays, a.sources)
    except UserError as e:
        raise SystemExit(str(e)) from None
    for s, v in res.items():
        print(f"{s}: {100 * v:.1f} % of flare-region points on flare in every source")
    mean = float(np.mean(list(res.values())))
    print(f"mean over {len(res)} views: {100 * mean:.1f} %")
    if a.out is not None:
        from pipeline.provenance import write_result

        write_result(a.out, {"workspace": str(a.workspace), "scene": str(a.scene),
                             "sources": a.sources, "samples": a.samples, "rays": a.rays,
                             "views": {s: round(v, 4) for s, v in res.items()},
                             "mean": round(mean, 4)})


if __name__ == "__main__":
    main()
