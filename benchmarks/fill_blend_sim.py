"""Per-pixel blends of a hybrid novel frame with GN-FR's render, simulated from renders on disk.

    python benchmarks/fill_blend_sim.py SYNTH:WS [SYNTH:WS ...] --hybrid heldout_dds0 \\
        --hybrid-other heldout_dds0ns050 --network heldout_net --out JSON

A diagnosis, not a render option: what a per-pixel choice between the photos' pixels of a
hybrid frame and GN-FR could gain at most, before anyone builds one. For each workspace WS
of a development scene SYNTH, the held-out renders in WS/renders/<folder> are combined and
scored against SYNTH/clean. The photos' pixels are those where ``--hybrid`` and
``--hybrid-other`` (the same hybrid fill at another ``--network-scale``) are identical
(``benchmarks/fill_regions.py``). GN-FR "at a quarter" is ``--network`` (GN-FR alone at the
frame's size) area-averaged by 4 and upsampled bilinearly: the render the hybrid fill already
draws under the photos on the CPU, here for every pixel, so the quarter-scale arms are an
optimistic stand-in for what a render could do at today's cost. Arms, each a whole frame:

- ``hybrid``, ``network``: the two renders as they are;
- ``detail_q``: on the photos' pixels, GN-FR at a quarter plus the photos' detail (the photo
  minus its own quarter-scale average over the photos' pixels); elsewhere the hybrid;
- ``correct_q_C``: on the photos' pixels, the photo shifted towards GN-FR at a quarter by at
  most C (0..1 colours, per channel); elsewhere the hybrid;
- ``check_q_T``: on the photos' pixels where the photos at a quarter differ from GN-FR at a
  quarter by more than T (largest channel difference), GN-FR at a quarter; elsewhere the
  hybrid (GN-FR's vote on every photo pixel);
- ``mix_A``: on the photos' pixels A x photo + (1 - A) x GN-FR at full size, elsewhere the
  hybrid (needs GN-FR at every pixel: the cost of ``--fill network``);
- ``average``: the mean of the hybrid and GN-FR's renders (both renders' cost).

PSNR and SSIM per view, means over views, then over workspaces per scene; every arm's
difference from ``hybrid`` per scene and their mean over scenes (docs/history/fill.md,
"Per-pixel blends of the photos and GN-FR, simulated").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CORRECTIONS = (0.03, 0.06)
CHECKS = (0.02, 0.04, 0.08)
MIXES = (0.3, 0.5, 0.7)


def quarter(img: np.ndarray, where: np.ndarray | None = None, factor: int = 4) -> np.ndarray:
    """``img`` [H, W, 3] area-averaged by ``factor`` (over ``where`` [H, W] bool only, when
    given) and upsampled bilinearly to [H, W, 3] (``photo_fill.coarse_mean``, as the
    network vote sees a photo)."""
    from pipeline.photo_fill import coarse_mean

    ok = np.ones(img.shape[:2], bool) if where is None else where
    return coarse_mean(img, ok, 1 / factor)[0]


def arms(hybrid: np.ndarray, other: np.ndarray, network: np.ndarray) -> dict[str, np.ndarray]:
    """Every arm of the module's list for one frame (float32 0..1 [H, W, 3] each)."""
    photo = np.all(hybrid == other, axis=2)
    p = photo[..., None]
    net_q = quarter(network)
    hyb_q = quarter(hybrid, photo)
    out = {"hybrid": hybrid, "network": network,
           "detail_q": np.where(p, np.clip(net_q + hybrid - hyb_q, 0, 1), hybrid),
           "average": 0.5 * (hybrid + network)}
    for c in CORRECTIONS:
        out[f"correct_q_{c:g}"] = np.where(p, np.clip(hybrid + np.clip(net_q - hyb_q, -c, c),
                                                      0, 1), hybrid)
    diff = np.abs(hyb_q - net_q).max(axis=2)
    for t in CHECKS:
        out[f"check_q_{t:g}"] = np.where((photo & (diff > t))[..., None], net_q, hybrid)
    for a in MIXES:
        out[f"mix_{a:g}"] = np.where(p, a * hybrid + (1 - a) * network, hybrid)
    return out


def score_workspace(synth: Path, ws: Path, hybrid: str, other: str, network: str) -> dict:
    """{arm: {psnr, ssim}} means over the held-out views of one workspace, with the photos'
    share of the pixels."""
    import cv2

    from pipeline.errors import UserError
    from pipeline.metrics import psnr, ssim

    renders = ws / "renders"
    for f in (hybrid, other, network):
        if not (renders / f).is_dir():
            raise UserError(f"{renders / f}: no such render folder; render the held-out "
                            "cameras into it first")
    per: dict[str, dict[str, list[float]]] = {}
    share = []
    pngs = sorted((renders / hybrid).glob("*.png"))
    if not pngs:
        raise UserError(f"{renders / hybrid}: no rendered frames")
    for png in pngs:
        imgs = []
        for f in (hybrid, other, network):
            img = cv2.imread(str(renders / f / png.name))
            if img is None:
                raise UserError(f"{renders / f / png.name}: missing or unreadable")
            imgs.append(img.astype(np.float32) / 255)
        gt = cv2.imread(str(synth / "clean" / png.name))
        if gt is None:
            raise UserError(f"{synth / 'clean' / png.name}: no clean view to score against")
        h, w = imgs[0].shape[:2]
        gt = cv2.resize(gt, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32) / 255
        share.append(float(np.all(imgs[0] == imgs[1], axis=2).mean()))
        for name, img in arms(*imgs).items():
            rec = per.setdefault(name, {"psnr": [], "ssim": []})
            rec["psnr"].append(psnr(img, gt))
            rec["ssim"].append(ssim(img, gt))
    return {"views": len(pngs), "photo_share": float(np.mean(share)),
            "arms": {k: {m: float(np.mean(v)) for m, v in r.items()} for k, r in per.items()}}


def summarise(per_ws: dict[str, dict], scene_of: dict[str, str]) -> dict:
    """Per scene: each arm's mean PSNR / SSIM over its workspaces and its difference from
    ``hybrid``; ``mean``: the differences averaged over scenes."""
    scenes: dict[str, dict] = {}
    for ws, rec in per_ws.items():
        scenes.setdefault(scene_of[ws], []).append(rec)
    out: dict = {}
    for s, recs in scenes.items():
        names = recs[0]["arms"].keys()
        m = {k: {q: float(np.mean([r["arms"][k][q] for r in recs])) for q in ("psnr", "ssim")}
             for k in names}
        out[s] = {"workspaces": len(recs),
                  "photo_share": float(np.mean([r["photo_share"] for r in recs])),
                  "arms": m,
                  "gain": {k: {q: m[k][q] - m["hybrid"][q] for q in ("psnr", "ssim")}
                           for k in names}}
    names = next(iter(out.values()))["gain"].keys()
    out["mean"] = {k: {q: float(np.mean([out[s]["gain"][k][q] for s in scenes]))
                       for q in ("psnr", "ssim")} for k in names}
    return out


def main(argv: list[str] | None = None) -> int:
    from fill_regions import split_pair

    from pipeline.errors import UserError

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pairs", nargs="+", help="SYNTH:WS")
    ap.add_argument("--hybrid", default="heldout_cameras")
    ap.add_argument("--hybrid-other", default="heldout_ns050")
    ap.add_argument("--network", default="heldout_net")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    per_ws, scene_of = {}, {}
    try:
        for pair in a.pairs:
            synth, ws = split_pair(pair)
            per_ws[str(ws)] = score_workspace(synth, ws, a.hybrid, a.hybrid_other, a.network)
            scene_of[str(ws)] = synth.name
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    summary = summarise(per_ws, scene_of)
    for name, g in summary["mean"].items():
        per_scene = " ".join(f"{s} {summary[s]['gain'][name]['psnr']:+.3f}"
                             for s in summary if s != "mean")
        print(f"{name:>14}: mean {g['psnr']:+.3f} dB / SSIM {g['ssim']:+.4f} ({per_scene})")
    if a.out:
        from pipeline.provenance import write_result
        write_result(a.out, {"hybrid": a.hybrid, "hybrid_other": a.hybrid_other,
                             "network": a.network, "scenes": summary, "workspaces": per_ws})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
