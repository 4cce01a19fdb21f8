"""Benchmark of FMG weights by what their masks do to the de-flared photos.

Flare IoU scores a mask; a user sees the de-flared photo. For each synth scene
(`deflare-scene synth` folder with an evaluated `eval.ws`), the variant's fine-tuned GN-FR is
kept, its workspace is copied once per weight file into WORK, the mask stage is rerun there
with those weights (rays on, each file's calibrated cut, as `deflare-scene mask` does), and
the de-flared inputs are re-rendered (`render --path inputs`, default settings) and scored
against the clean photos over the flared views: whole-photo PSNR and SSIM, PSNR inside the
true flare. Only the masks change; which views trained and on what is the variant's.
``--truth M`` adds an arm whose masks are the scene's true flare by the mask rule with its
thresholds times M (``workflows.research.eval.scene.truth_mask_at``; M = 1 is about
masks_gt, larger M leaves the faint outer flare unmarked), given to the mask stage as
``--masks`` (as a user's own masks): what the fill makes of a perfect segmenter of each
definition of flare. ``--combine and,or`` adds, for each weight file, arms whose masks are
its masks AND / OR the true flare at 1x: no false marks (the core of the light, which the
truth leaves out, included) / no missed flare, to learn which of a network's errors costs
the photos more. Every row also says how its masks match masks_gt (flare IoU, share of
the flared views marked).

    python benchmarks/mask_downstream.py SYNTH [SYNTH ...] --weights A.safetensors \
        --weights B.safetensors [--truth 1 --truth 2] --work DIR \
        --out docs/results/mask_downstream_X.json
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from itertools import product
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def copy_of(src: Path, work: Path, variant: str, name: str):
    """The evaluated variant ``src`` copied to WORK/name/variant (reused when present)."""
    from pipeline.workspace import Workspace

    dest = work / name / variant
    if not dest.exists():
        shutil.copytree(src, dest, symlinks=True)
    return Workspace(dest)


def true_flare(cache: dict, scene, ws, m: float) -> dict:
    """{stem: the true flare at ``m`` times the mask rule's thresholds} of the workspace's
    views, read once per scene into ``cache``."""
    from pipeline.ws_files import view_stems
    from workflows.research.eval.scene import truth_mask_at

    if m not in cache:
        cache[m] = {s: truth_mask_at(scene, s, m) for s in view_stems(ws)}
    return cache[m]


def given_masks(folder: Path, ws, masks: dict) -> None:
    """Hand ``masks`` {stem: [H, W] bool} to the workspace's mask stage as a user's masks
    (written to ``folder``/given_masks)."""
    from pipeline import mask
    from pipeline.workspace import atomic_imwrite

    given = folder / "given_masks"
    given.mkdir(parents=True, exist_ok=True)
    for stem, m in masks.items():
        atomic_imwrite(given / f"{stem}.png", m.astype("uint8") * 255)
    mask.run(mask.MaskConfig(masks_dir=given), ws, force=True)


def score(scene, stems: list[str], truth: dict, ws, row: dict, label: str) -> dict:
    """``row`` with the workspace's masks against ``truth`` (flare IoU pooled over
    ``stems``, mean share marked) and its re-rendered de-flared inputs scored."""
    from pipeline import render
    from pipeline.ws_files import read_mask
    from workflows.research.eval.scoring import score_views

    marks = {s: read_mask(ws, s) for s in stems}
    inter = sum(int((marks[s] & truth[s]).sum()) for s in stems)
    union = sum(int((marks[s] | truth[s]).sum()) for s in stems)
    t0 = time.perf_counter()
    render.run(render.RenderConfig(path="inputs"), ws, force=True)
    r = score_views(scene, ws.deflared, stems, with_region=True)
    row = {**row, "flare_iou": round(inter / max(union, 1), 4),
           "marked": round(float(np.mean([m.mean() for m in marks.values()])), 5),
           "psnr": round(r["psnr"], 3), "psnr_flare": round(r["psnr_flare"], 3),
           "ssim": round(r["ssim"], 4), "render_s": round(time.perf_counter() - t0, 1)}
    print(row["scene"], label, f": flare IoU {row['flare_iou']:.3f}, PSNR {row['psnr']:.2f}, "
          f"flare region {row['psnr_flare']:.2f}, SSIM {row['ssim']:.4f}", flush=True)
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", type=Path, nargs="+")
    ap.add_argument("--weights", type=Path, action="append", default=[])
    ap.add_argument("--truth", type=float, action="append", default=[],
                    help="an arm with the true flare at this multiple of the mask rule's "
                         "thresholds as the masks (repeatable)")
    ap.add_argument("--variant", default="gnfr")
    ap.add_argument("--eval-ws", type=Path, default=None,
                    help="the eval workspace, with one scene (default SCENE/eval.ws)")
    ap.add_argument("--cuts", default="",
                    help="comma-separated probability cuts to score each weight file at "
                         "(default: the file's calibrated cut only)")
    ap.add_argument("--combine", default="",
                    help="comma-separated: and, or (each weight file's masks with the true "
                         "flare at 1x)")
    ap.add_argument("--work", type=Path, required=True,
                    help="scratch folder for the copied workspaces (reused when present)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.eval_ws is not None and len(a.scenes) > 1:
        ap.error("--eval-ws goes with one scene")
    if not a.weights and not a.truth:
        ap.error("give at least one --weights or --truth arm")
    if any(m <= 0 for m in a.truth):
        ap.error("--truth must be above 0")
    combine = [c for c in a.combine.split(",") if c]
    if set(combine) - {"and", "or"}:
        ap.error(f"--combine {a.combine}: must be and, or or both")
    if combine and not a.weights:
        ap.error("--combine combines each --weights arm's masks with the truth: give --weights")
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from pipeline import mask
    from pipeline.provenance import sha256, write_result
    from pipeline.ws_files import read_mask, view_stems
    from workflows.research.eval.scene import (
        flared_views,
        load_synth,
        truth_mask,
    )

    cuts = [float(c) for c in a.cuts.split(",") if c] or [None]
    rows = []
    for scene_dir in a.scenes:
        scene = load_synth(scene_dir)
        src = (a.eval_ws or scene_dir / "eval.ws") / "variants" / a.variant
        if not (src / "model").is_dir():
            raise SystemExit(f"{src} has no fine-tuned model: run `deflare-scene eval "
                             f"{scene_dir}` first")
        stems = flared_views(scene)
        arms = [(f"{scene_dir.name}_{i}_{w.parent.name}"
                 + ("" if cut is None else f"_cut{cut:g}"), w, cut)
                for (i, w), cut in product(enumerate(a.weights), cuts)]
        arms += [(f"{scene_dir.name}_truth{m:g}", m, None) for m in a.truth]
        truth = {s: truth_mask(scene, s) for s in stems}
        truth_at: dict[float, dict] = {}  # {M: {stem: mask}}, each read once per scene
        for name, arm, cut in arms:
            ws = copy_of(src, a.work, a.variant, name)
            if isinstance(arm, Path):
                mask.run(mask.MaskConfig(weights=arm, threshold=cut), ws, force=True)
                row = {"scene": scene_dir.name, "weights": str(arm), "sha256": sha256(arm),
                       "cut": mask.resolve_threshold(mask.MaskConfig(threshold=cut), arm)}
                label = f"{arm} cut {row['cut']:g}"
                own = {s: read_mask(ws, s) for s in view_stems(ws)}
                rows.append(score(scene, stems, truth, ws, row, label))
                for how in combine:
                    cname = f"{name}_{how}_truth"
                    cws = copy_of(src, a.work, a.variant, cname)
                    t1 = true_flare(truth_at, scene, ws, 1.0)
                    given_masks(a.work / cname, cws, {s: (own[s] & t1[s]) if how == "and"
                                                      else (own[s] | t1[s]) for s in own})
                    rows.append(score(scene, stems, truth, cws,
                                      {**row, "combine": f"{how} true flare 1x"},
                                      f"{label} {how} the true flare"))
            else:
                given_masks(a.work / name, ws, true_flare(truth_at, scene, ws, arm))
                rows.append(score(scene, stems, truth, ws,
                                  {"scene": scene_dir.name, "truth_scale": arm},
                                  f"true flare at {arm:g}x the mask rule's thresholds"))
    write_result(a.out, {"variant": a.variant, "scored_views": "flared views of each scene",
                         "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
