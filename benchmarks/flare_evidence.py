"""Flare evidence across views, an experiment the product does not use: FMG, evidence, fused.

    python benchmarks/flare_evidence.py --scene SYNTH [--scene SYNTH ...] \
        [--clean WS ...] --work DIR [--out JSON]

The idea (issue 10, item 4): flare is made by the lens, so it moves with the camera; the
scene does not. For a view, the neighbouring photos (their own flare masks respected) are
warped into it through the scene's depth (``pipeline.photo_fill``: the neighbours' depth
maps splatted into the view, occlusion checked, gains matched to the view's unmarked
pixels) and fused to a robust consensus colour. Where ``min_support`` neighbours agree, a
pixel whose linear luminance exceeds the (max-filtered) consensus by more than
``max(abs_threshold, rel_threshold x consensus)``, the synthesizer's own mask rule applied
to view minus scene, is flare evidence; small regions are dropped. The fused mask is the
union with the FMG mask.

SYNTH is a folder written by `deflare-scene synth` (flared photos, ``masks_gt``); its
training views are posed with the ground-truth cameras in DIR/<name>.ws, masked by the
shipped FMG (`mask`) and given depth (`depth`), as the one-shot does. Per scene, pooled over
its flared views: flare IoU, mIoU and mAcc of each method. WS is a posed workspace of clean
photos: `mask` and `depth` run in it, and the share of pixels each method marks is reported
(every marked pixel there is a false alarm). The result (docs/history/fill.md, "Evidence across
views") is why the product does not use it.
"""

from __future__ import annotations

import argparse
import itertools
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

from pipeline.crosscheck import Consensus, consensus, excess_over_consensus
from pipeline.flare import MASK_RELATIVE, MASK_THRESHOLD

METHODS = ("fmg", "evidence", "fused")



@dataclass
class EvidenceConfig:
    """How flare evidence across views is found."""

    neighbours: int = 4
    """Nearest posed views warped into each view."""
    min_support: int = 2
    """Neighbours that must agree on the scene's colour before a pixel is judged."""
    abs_threshold: float = MASK_THRESHOLD
    """Linear-luminance excess over the consensus that counts as flare (absolute part)."""
    rel_threshold: float = MASK_RELATIVE
    """... and relative part (fraction of the consensus luminance)."""
    slack: int = 2
    """Radius (pixels at the view's size) of the max filter on the consensus luminance."""
    min_area: float = 2e-4
    """Evidence regions smaller than this fraction of the view are dropped."""
    agree: float = 0.08
    """Colour difference (max channel, 0..1) within which neighbours agree."""


SWEEP = {"abs_threshold": (MASK_THRESHOLD, 0.06), "rel_threshold": (MASK_RELATIVE, 0.25, 0.5),
         "slack": (2, 4), "min_support": (2, 3), "min_area": (2e-4, 2e-3)}
"""The settings ``--sweep`` tries (every combination)."""


def judge(c: Consensus, cfg: EvidenceConfig) -> np.ndarray:
    """[H, W] bool flare evidence: where ``min_support`` neighbours agree and the view is
    brighter than their max-filtered consensus by more than the mask rule's threshold;
    opened by 3x3 and without regions under ``min_area``."""
    judged, excess, thr = excess_over_consensus(c, cfg.min_support, cfg.abs_threshold,
                                                cfg.rel_threshold, cfg.slack)
    mask = judged & (excess > thr)
    mask = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    return drop_small(mask, cfg.min_area)


def drop_small(mask: np.ndarray, min_area: float) -> np.ndarray:
    """[H, W] bool: ``mask`` without 8-connected regions under ``min_area`` of the image."""
    m = np.ascontiguousarray(mask, np.uint8)
    if min_area <= 0 or not m.any():
        return m.astype(bool)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= min_area * m.size
    keep[0] = False
    return keep[labels]


def _confusion(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """[[tn, fp], [fn, tp]] counts of two [H, W] bool masks."""
    return np.array([[np.sum(~pred & ~truth), np.sum(pred & ~truth)],
                     [np.sum(~pred & truth), np.sum(pred & truth)]], np.int64)


def _scores(c: np.ndarray) -> dict:
    (tn, fp), (fn, tp) = c.tolist()
    iou_f, iou_c = tp / max(tp + fp + fn, 1), tn / max(tn + fp + fn, 1)
    acc_f, acc_c = tp / max(tp + fn, 1), tn / max(tn + fp, 1)
    return {"IoU_flare": round(iou_f, 4), "mIoU": round((iou_f + iou_c) / 2, 4),
            "mAcc": round((acc_f + acc_c) / 2, 4),
            "marked": round((tp + fp) / max(c.sum(), 1), 5)}


def view_data(ws, cfg: EvidenceConfig) -> dict:
    """{stem: (FMG mask, Consensus)} for every posed view of ``ws`` (mask and depth run)."""
    from pipeline.depth import load_views, nearest_views
    from pipeline.ws_files import read_cameras, read_mask

    cams = read_cameras(ws)
    views = load_views(ws, cams, cams.stems, with_depth=True)
    near = nearest_views(cams, cfg.neighbours)
    return {s: (read_mask(ws, s), consensus(views[s], [views[n] for n in near[s]], cfg.agree))
            for s in cams.stems}


def settings(sweep: bool) -> list[EvidenceConfig]:
    """The default setting, then (``sweep``) every combination of ``SWEEP``."""
    out = [EvidenceConfig()]
    if sweep:
        keys = list(SWEEP)
        out += [EvidenceConfig(**dict(zip(keys, vals, strict=True)))
                for vals in itertools.product(*SWEEP.values())]
    return out


def prepare(ws, depth_cfg=None) -> None:
    """The one-shot's mask and depth stages, with their defaults (the depth stage with
    ``depth_cfg``, a ``pipeline.depth.DepthConfig``, when given)."""
    from pipeline import depth, mask

    mask.run(mask.MaskConfig(), ws)
    depth.run(depth_cfg or depth.DepthConfig(), ws)


def flared_views(root: Path, work: Path, cfg: EvidenceConfig, depth_cfg=None):
    """For each flared view of the synth scene ``root`` (posed with its true cameras in
    ``work``, `mask` and `depth` run, the latter with ``depth_cfg``): (FMG mask, Consensus,
    true mask)."""
    from pipeline.ws_files import read_mask_file
    from workflows.research.eval.scene import load_synth
    from workflows.research.eval.workspaces import build_workspace

    ws = build_workspace(load_synth(root), work / f"{root.name}.ws")
    prepare(ws, depth_cfg)
    for s, (fmg, cons) in view_data(ws, cfg).items():
        h, w = fmg.shape
        gt = read_mask_file(root / "masks_gt" / f"{s}.png", size=(w, h))
        if gt.any():
            yield fmg, cons, gt


def score_scene(root: Path, work: Path, cfgs: list[EvidenceConfig]) -> dict:
    """Pooled over the flared views of a synth scene: the FMG's scores, and per setting the
    evidence's and the fused mask's."""
    fmg_c = np.zeros((2, 2), np.int64)
    ev_c = np.zeros((len(cfgs), 2, 2), np.int64)
    fu_c = np.zeros((len(cfgs), 2, 2), np.int64)
    views = 0
    for fmg, cons, gt in flared_views(root, work, cfgs[0]):
        views += 1
        fmg_c += _confusion(fmg, gt)
        for i, cfg in enumerate(cfgs):
            ev = judge(cons, cfg)
            ev_c[i] += _confusion(ev, gt)
            fu_c[i] += _confusion(ev | fmg, gt)
    return {"views": views, "flare_pixels": round(float(fmg_c[1].sum() / max(fmg_c.sum(), 1)), 5),
            "fmg": _scores(fmg_c),
            "settings": [{"config": asdict(c), "evidence": _scores(ev_c[i]),
                          "fused": _scores(fu_c[i])} for i, c in enumerate(cfgs)]}


def clean_stats(v: list[float]) -> dict:
    """Mean and max of per-view marked shares, and how many views are over 10 %."""
    return {"views": len(v), "mean": round(float(np.mean(v)), 5),
            "max": round(float(np.max(v)), 5), "over_10pct": int(sum(x > 0.1 for x in v))}


def score_clean(path: Path, cfgs: list[EvidenceConfig]) -> dict:
    """Share of pixels marked on a clean posed workspace: the FMG's, and per setting the
    evidence's and the fused mask's (mean and max over views, views over 10 %)."""
    from pipeline.workspace import Workspace

    ws = Workspace(path)
    prepare(ws)

    data = view_data(ws, cfgs[0])
    fmg = [float(m.mean()) for m, _ in data.values()]
    rows = []
    for cfg in cfgs:
        ev = [judge(c, cfg) for _, c in data.values()]
        fused = [float((e | m).mean()) for e, (m, _) in zip(ev, data.values(), strict=True)]
        rows.append({"config": asdict(cfg), "evidence": clean_stats([float(e.mean()) for e in ev]),
                     "fused": clean_stats(fused)})
    return {"fmg": clean_stats(fmg), "settings": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, action="append", default=[])
    ap.add_argument("--clean", type=Path, action="append", default=[])
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--sweep", action="store_true", help="also every setting of SWEEP")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from pipeline.provenance import write_result

    cfgs = settings(a.sweep)
    res = {"sweep": {k: list(v) for k, v in SWEEP.items()} if a.sweep else None,
           "scenes": {}, "clean": {}}
    for root in a.scene:
        r = res["scenes"][root.name] = score_scene(root.resolve(), a.work, cfgs)
        best = max(r["settings"], key=lambda x: x["fused"]["IoU_flare"])
        print(f"{root.name} ({r['views']} flared views, {100 * r['flare_pixels']:.1f} % flare): "
              f"flare IoU fmg {r['fmg']['IoU_flare']:.3f}; default evidence "
              f"{r['settings'][0]['evidence']['IoU_flare']:.3f}, fused "
              f"{r['settings'][0]['fused']['IoU_flare']:.3f}; best fused of "
              f"{len(cfgs)} settings {best['fused']['IoU_flare']:.3f}")
    for ws in a.clean:
        r = res["clean"][ws.name] = score_clean(ws, cfgs)
        d = r["settings"][0]
        print(f"{ws.name} (clean, marked): fmg {100 * r['fmg']['mean']:.2f} %, default "
              f"evidence {100 * d['evidence']['mean']:.2f} % (max {100 * d['evidence']['max']:.2f}"
              f" %), fused {100 * d['fused']['mean']:.2f} %")
    write_result(a.out, res)


if __name__ == "__main__":
    main()
