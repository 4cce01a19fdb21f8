"""The de-flared photos' true flare region split by who fills it: the photos or the network.

    python benchmarks/fill_parts.py WS --truth TRUTH [--render NAME=FOLDER ...] --out JSON

For every flared photo of the workspace WS this recomputes the hybrid fill's decision as
`render --path inputs` makes it at today's defaults (the photos warped by depth, their
weight, the ring check; ``pipeline.render.inputs``) and splits the photo's true flare region
(``TRUTH/masks_gt``) into the pixels the photos fill (weight >= 0.5), those the network
renders and those outside the blend. Each ``--render`` folder of de-flared photos (default:
``WS/deflared``) is scored against ``TRUTH/clean`` on each part (PSNR of the pooled squared
error, per photo and over all photos). It also counts the network's rays in the flare
regions whose depth-guided band the render would use, and how many of them lie in a region
the ring check turned down (docs/history/fill.md, "Where the sample's gap comes from").
TRUTH is a folder with ``clean/`` and ``masks_gt/`` (a `synth` scene, or the sample's
``samples/cyprus_truth``).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PARTS = ("photos", "network", "outside")


def _psnr(err: float, n: int) -> float | None:
    return None if n == 0 else round(float(-10 * np.log10(max(err / n, 1e-12))), 3)


def fill_parts(ws_path: Path, truth: Path, renders: dict[str, Path]) -> dict:
    """{"views": {stem: {...}}, "pooled": {...}, "rays": {...}} (module docstring)."""
    from pipeline.errors import UserError
    from pipeline.images import read_image
    from pipeline.render.config import INPUTS_MIN_BLOB, RenderConfig
    from pipeline.render.fill import photo_views
    from pipeline.render.inputs import input_blend, input_photo_fill, network_pixels
    from pipeline.render.plan import plan_jobs, resolve_fill
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras, read_decoded, read_mask_file, read_views

    if not (ws_path / "cameras.json").is_file():
        raise UserError(f"{ws_path}: not a posed workspace (no cameras.json); pass the "
                        "workspace whose de-flared photos are scored")
    ws = Workspace(ws_path)
    for name, folder in renders.items():
        if not folder.is_dir():
            raise UserError(f"{folder}: no such folder of de-flared photos ({name})")
    if not (truth / "clean").is_dir() or not (truth / "masks_gt").is_dir():
        raise UserError(f"{truth}: no clean/ and masks_gt/ in it; pass a synth scene or the "
                        "sample's truth folder")
    cams, views = read_cameras(ws), read_views(ws)
    cfg = resolve_fill(replace(RenderConfig(path="inputs"), depth_min_blob=INPUTS_MIN_BLOB,
                               n_sources=10), "cpu", novel=False)
    _, _, jobs = plan_jobs(cfg, ws, cams, views, "cpu")
    photos = photo_views(ws, cams, jobs, cfg)
    pooled = {(p, r): [0.0, 0] for p in PARTS for r in renders}
    rays = {"guided": 0, "guided_rejected": 0}
    out = {}
    for job in jobs:
        fr = job.camera
        s = fr.stem
        photo = read_decoded(ws, s)
        size = (photo.shape[1], photo.shape[0])
        alpha, ring = input_blend(fr, cfg, ws, size, size)
        region = alpha > 0.5 / 255
        if not region.any() or not (truth / "masks_gt" / f"{s}.png").is_file():
            continue
        _, wgt, depth, rejected = input_photo_fill(job, cfg, ws, photos, photo, region, ring)
        guided = network_pixels(region, wgt, ring) & (depth > fr.near) & (depth < fr.far)
        rays["guided"] += int(guided.sum())
        rays["guided_rejected"] += int((guided & rejected).sum())
        m = read_mask_file(truth / "masks_gt" / f"{s}.png", size=size)
        gt = read_image(truth / "clean" / f"{s}.png", size=size).astype(np.float32) / 255
        sel = {"photos": m & region & (wgt >= 0.5), "network": m & region & (wgt < 0.5),
               "outside": m & ~region}
        row = {f"share_{p}": round(float(sel[p].sum() / max(m.sum(), 1)), 4) for p in PARTS}
        for name, folder in renders.items():
            img = read_image(folder / f"{s}.png", size=size).astype(np.float32) / 255
            for p in PARTS:
                e = float(((img[sel[p]] - gt[sel[p]]) ** 2).sum())
                n = 3 * int(sel[p].sum())
                row[f"{p}_{name}"] = _psnr(e, n)
                pooled[(p, name)][0] += e
                pooled[(p, name)][1] += n
        out[s] = row
    rays["rejected_share"] = round(rays["guided_rejected"] / max(rays["guided"], 1), 4)
    return {"views": out,
            "pooled": {f"{p}_{r}": _psnr(*pooled[(p, r)]) for p in PARTS for r in renders},
            "rays": rays}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", type=Path)
    ap.add_argument("--truth", type=Path, required=True)
    ap.add_argument("--render", action="append", default=[],
                    help="NAME=FOLDER of de-flared photos to score (default: WS/deflared)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError
    from pipeline.provenance import write_result

    try:
        renders = {}
        for r in a.render or [f"deflared={a.ws / 'deflared'}"]:
            if "=" not in r:
                raise UserError(f"--render {r}: give NAME=FOLDER")
            name, folder = r.split("=", 1)
            renders[name] = Path(folder)
        rec = fill_parts(a.ws, a.truth, renders)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print("pooled", rec["pooled"], "rays", rec["rays"])
    write_result(a.out, {"ws": str(a.ws), "truth": str(a.truth),
                         "renders": {k: str(v) for k, v in renders.items()}, **rec})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
