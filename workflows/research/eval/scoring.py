"""PSNR / SSIM of every method against the clean images, and the masks against masks_gt."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline import metrics
from pipeline.images import read_gray, read_image
from pipeline.progress import info
from pipeline.scene_splits import HELDOUT_SCENES
from pipeline.workspace import Workspace
from pipeline.ws_files import read_flare, read_mask
from workflows.research.eval.config import LABELS, EvalConfig
from workflows.research.eval.provenance import budget, method_provenance, run_provenance
from workflows.research.eval.scene import SynthScene, flared_views, truth_mask


def read_bgr(path: Path, shape: tuple[int, int] | None = None) -> np.ndarray:
    """[H, W, 3] uint8 BGR, area-resized to ``shape`` (h, w) when given."""
    return read_image(path, bgr=True, size=None if shape is None else (shape[1], shape[0]),
                      fix="rerun `deflare-scene eval`")



def score_views(scene: SynthScene, folder: Path, stems: list[str],
                with_region: bool) -> dict:
    """PSNR / SSIM of ``folder/<stem>.png`` against SCENE/clean (resized to the
    prediction's size), and with ``with_region`` the PSNR inside the true flare mask."""
    per = {}
    for s in stems:
        pred = read_bgr(folder / f"{s}.png")
        gt = read_bgr(scene.root / "clean" / f"{s}.png", pred.shape[:2])
        rec = {"psnr": metrics.psnr(pred, gt), "ssim": metrics.ssim(pred, gt)}
        if with_region:
            rec["psnr_flare"] = metrics.masked_psnr(pred, gt,
                                                    truth_mask(scene, s, pred.shape[:2]))
        per[s] = rec
    return {**summarise(per), "views": per}


def summarise(per: dict) -> dict:
    """Means over views of every score (views where a score is None are skipped)."""
    keys = sorted({k for r in per.values() for k in r})
    out = {}
    for k in keys:
        vals = [r[k] for r in per.values() if r.get(k) is not None]
        out[k] = float(np.mean(vals)) if vals else None
    return out



def fmg_scores(scene: SynthScene, ws: Workspace) -> dict:
    """The workspace masks against masks_gt on the training views (mIoU etc.)."""
    per = {}
    for s in scene.train:
        per[s] = metrics.mask_scores(read_mask(ws, s), truth_mask(scene, s))
    return {**summarise(per), "views": per}



def score_all(cfg: EvalConfig, scene: SynthScene, base: Workspace, methods: dict) -> dict:
    """results.json: the scene, the budget, provenance, mask scores and every method's
    scores."""
    info("eval: scoring")
    results = {"scene": str(scene.root), "origin": scene.origin,
               "origin_is_heldout_scene": scene.origin in HELDOUT_SCENES,
               "train_views": scene.train, "heldout_views": scene.heldout,
               "cameras": "ground truth (no pose noise)", "masks": cfg.masks,
               "budget": budget(cfg), "provenance": run_provenance(base), "methods": {}}
    results["mask_scores"] = fmg_scores(scene, base)
    results["mask_threshold"] = read_flare(base).threshold
    flared = flared_views(scene) or scene.train
    results["scored_input_views"] = flared
    for name, method in methods.items():
        row = {"label": LABELS[name],
               "inputs": score_views(scene, method["inputs"], flared, with_region=True)}
        if "heldout" in method:
            row["heldout"] = score_views(scene, method["heldout"], scene.heldout,
                                         with_region=False)
        if "train" in method:
            row["train"] = method["train"]
        row["provenance"] = method_provenance(name, method, base)
        results["methods"][name] = row
    return results


def floor_scores(photos: Path, deflared: Path, flared: Path, clean: Path, masks_gt: Path,
                 min_pixels: int = 50) -> dict:
    """The product floor's measures (tests/workflows/test_oneshot.py, on the sample): per view
    with at least ``min_pixels`` true flare pixels at the de-flared size, the flare-region
    PSNR gain of ``deflared/<stem>.png`` over ``flared/<stem>.png`` (the decoded photo) and
    the mean excess (0-255) of each over the truth there. ``clean`` and ``masks_gt`` hold the
    truth at any size (area- and nearest-resized to the de-flared photo's)."""
    import cv2

    views = {}
    for p in sorted(photos.iterdir()):
        out_path = deflared / f"{p.stem}.png"
        if not out_path.exists():
            continue
        out = read_bgr(out_path)
        h, w = out.shape[:2]
        fl = read_bgr(flared / f"{p.stem}.png", (h, w))
        truth = read_bgr(clean / f"{p.stem}.png", (h, w))
        m = cv2.resize(read_gray(masks_gt / f"{p.stem}.png"), (w, h),
                       interpolation=cv2.INTER_NEAREST) > 127
        if m.sum() < min_pixels:
            continue
        views[p.stem] = {
            "gain": metrics.masked_psnr(out, truth, m) - metrics.masked_psnr(fl, truth, m),
            "excess_out": float((out.astype(float) - truth)[m].mean()),
            "excess_in": float((fl.astype(float) - truth)[m].mean())}
    if not views:
        return {"views": {}}
    col = {k: [v[k] for v in views.values()] for k in ("gain", "excess_out", "excess_in")}
    return {"views": views, "mean_gain": float(np.mean(col["gain"])),
            "min_gain": float(min(col["gain"])),
            "excess_out": float(np.mean(col["excess_out"])),
            "excess_in": float(np.mean(col["excess_in"])),
            "excess_ratio": float(np.mean(col["excess_out"]) / np.mean(col["excess_in"]))}
