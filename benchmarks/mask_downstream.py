"""Benchmark of FMG weights by what their masks do to the de-flared photos.

Flare IoU scores a mask; a user sees the de-flared photo. For each synth scene
(`deflare-scene synth` folder with an evaluated `eval.ws`), the variant's fine-tuned GN-FR is
kept, its workspace is copied once per weight file into WORK, the mask stage is rerun there
with those weights (rays on, each file's calibrated cut, as `deflare-scene mask` does), and
the de-flared inputs are re-rendered (`render --path inputs`, default settings) and scored
against the clean photos over the flared views: whole-photo PSNR and SSIM, PSNR inside the
true flare. Only the masks change; which views trained and on what is the variant's.

    python benchmarks/mask_downstream.py SYNTH [SYNTH ...] --weights A.safetensors \
        --weights B.safetensors --work DIR --out docs/results/mask_downstream_X.json
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from itertools import product
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", type=Path, nargs="+")
    ap.add_argument("--weights", type=Path, action="append", required=True)
    ap.add_argument("--variant", default="gnfr")
    ap.add_argument("--eval-ws", type=Path, default=None,
                    help="the eval workspace, with one scene (default SCENE/eval.ws)")
    ap.add_argument("--cuts", default="",
                    help="comma-separated probability cuts to score each weight file at "
                         "(default: the file's calibrated cut only)")
    ap.add_argument("--work", type=Path, required=True,
                    help="scratch folder for the copied workspaces (reused when present)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.eval_ws is not None and len(a.scenes) > 1:
        ap.error("--eval-ws goes with one scene")
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from pipeline import mask, render
    from pipeline.provenance import sha256, write_result
    from pipeline.workspace import Workspace
    from workflows.research.eval.scene import flared_views, load_synth
    from workflows.research.eval.scoring import score_views

    cuts = [float(c) for c in a.cuts.split(",") if c] or [None]
    rows = []
    for scene_dir in a.scenes:
        scene = load_synth(scene_dir)
        src = (a.eval_ws or scene_dir / "eval.ws") / "variants" / a.variant
        if not (src / "model").is_dir():
            raise SystemExit(f"{src} has no fine-tuned model: run `deflare-scene eval "
                             f"{scene_dir}` first")
        stems = flared_views(scene)
        for (i, w), cut in product(enumerate(a.weights), cuts):
            tag = "" if cut is None else f"_cut{cut:g}"
            dest = a.work / f"{scene_dir.name}_{i}_{w.parent.name}{tag}" / a.variant
            if not dest.exists():
                shutil.copytree(src, dest, symlinks=True)
            ws = Workspace(dest)
            mask.run(mask.MaskConfig(weights=w, threshold=cut), ws, force=True)
            t0 = time.perf_counter()
            render.run(render.RenderConfig(path="inputs"), ws, force=True)
            r = score_views(scene, ws.deflared, stems, with_region=True)
            row = {"scene": scene_dir.name, "weights": str(w), "sha256": sha256(w),
                   "cut": mask.resolve_threshold(mask.MaskConfig(threshold=cut), w),
                   "psnr": round(r["psnr"], 3), "psnr_flare": round(r["psnr_flare"], 3),
                   "ssim": round(r["ssim"], 4),
                   "render_s": round(time.perf_counter() - t0, 1)}
            rows.append(row)
            print(scene_dir.name, w, f"cut {row['cut']:g}: PSNR {row['psnr']:.2f}, flare region "
                  f"{row['psnr_flare']:.2f}, SSIM {row['ssim']:.4f}", flush=True)
    write_result(a.out, {"variant": a.variant, "scored_views": "flared views of each scene",
                         "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
