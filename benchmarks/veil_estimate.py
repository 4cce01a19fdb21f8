"""Whether the neighbouring photos can measure the veil a flare leaves outside its mask.

    python benchmarks/veil_estimate.py SYNTH WS [--neighbours 4] [--band 0.15]
        [--smooth 0.02] [--smooth 0.05] [--out RESULT.json]

Synthetic flare adds light beyond the pixels its mask marks (a veil: 2.4-4.3 sRGB levels on
the mean of each of lund's views, ``benchmarks/exposure_roundtrip.py``'s ``flare_outside``),
and the fine-tune learns it as the scene's colour (docs/history/gnfr.md, "Sixty-eighth
session"). The card's "Next" named a lever: an estimate of that veil subtracted from the
colours near each mask. The scene does not move with the camera and the veil does, so the
estimate this script tries is the view minus its neighbours' consensus colour
(``pipeline.photo_fill.photo_fill``: the ``--neighbours`` nearest photos warped into the
view by WS's depth, their own masks respected, gains matched to the view's unmarked pixels),
in linear light, averaged by a Gaussian of ``--smooth`` x the long side over the pixels two
or more neighbours reach, and never negative (flare only adds light).

For each view of WS (a workspace of the synth scene after its mask and depth stages, e.g.
an ``fmg_photo_ab.py`` arm's), over the band of unmarked pixels within ``--band`` x the long
side of WS's mask (the arm's masks, as the fine-tune sees them):

- ``veil``: the true veil, the photo minus SYNTH's clean photo (mean sRGB levels);
- ``offset_band`` and ``offset_far``: the photo minus the consensus (mean sRGB levels) in the
  band and beyond it (``offset_far``: where no veil lies, the consensus's own error);
- per ``--smooth``, ``psnr_before`` / ``psnr_after``: the band's PSNR against the clean
  photo as photographed and with the estimate subtracted, and ``rms_veil`` / ``rms_error``:
  the true veil's RMS in the band and the estimate's RMS error against it (linear light).

Nothing is written into SYNTH or WS.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def view_row(photo: np.ndarray, clean: np.ndarray, mask: np.ndarray, consensus: np.ndarray,
             reached: np.ndarray, band: float, smooths: list[float]) -> dict:
    """One view's numbers (module docstring): ``photo``, ``clean``, ``consensus`` [H, W, 3]
    sRGB in [0, 1], ``mask`` [H, W] bool (the view's flare mask), ``reached`` [H, W] bool
    (two or more neighbours reach the pixel)."""
    import cv2

    from pipeline.colour import linear_to_srgb, srgb_to_linear
    from pipeline.metrics import masked_psnr
    from pipeline.render.flare_layer import lowpass

    long_side = max(mask.shape)
    out = ~mask
    if mask.any():
        dist = cv2.distanceTransform(out.astype(np.uint8), cv2.DIST_L2, 5) / long_side
        near = out & (dist < band)
    else:
        near = np.zeros_like(out)
    far = out & ~near
    lvl = 255.0
    row: dict = {"mask_share": float(mask.mean()), "band_share": float(near.mean()),
                 "reached_band": float(reached[near].mean()) if near.any() else None}
    row["veil"] = float((photo - clean)[near].mean() * lvl) if near.any() else None
    both = near & reached
    row["offset_band"] = float((photo - consensus)[both].mean() * lvl) if both.any() else None
    fr = far & reached
    row["offset_far"] = float((photo - consensus)[fr].mean() * lvl) if fr.any() else None
    if not near.any():
        return row
    p, c, cl = srgb_to_linear(photo), srgb_to_linear(consensus), srgb_to_linear(clean)
    wgt = (reached & out).astype(np.float32)
    ex = np.where(wgt[..., None] > 0, p - c, 0).astype(np.float32)
    for s in smooths:
        num, den = lowpass(ex, s), lowpass(wgt[..., None], s)
        est = np.maximum(num / np.maximum(den, 1e-3), 0) * (den > 0.05) * near[..., None]
        after = linear_to_srgb(np.clip(p - est, 0, 1))
        veil = (p - cl)[near]
        row[f"smooth_{s:g}"] = {
            "psnr_before": masked_psnr(photo, clean, near),
            "psnr_after": masked_psnr(after, clean, near),
            "rms_veil": float(np.sqrt(np.mean(veil ** 2))),
            "rms_error": float(np.sqrt(np.mean((est[near] - veil) ** 2)))}
    return row


def main(argv: list[str] | None = None) -> int:
    import cv2

    from pipeline.depth import load_views, nearest_views
    from pipeline.photo_fill import photo_fill
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("synth", type=Path)
    ap.add_argument("ws", type=Path)
    ap.add_argument("--neighbours", type=int, default=4)
    ap.add_argument("--band", type=float, default=0.15)
    ap.add_argument("--smooth", type=float, action="append")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    smooths = a.smooth or [0.02, 0.05]
    ws = Workspace(a.ws)
    cams = read_cameras(ws)
    views = load_views(ws, cams, cams.stems, with_depth=True)
    near = nearest_views(cams, a.neighbours)
    rows = {}
    for s in cams.stems:
        f = a.synth / "clean" / f"{s}.png"
        v = views[s]
        if not f.is_file() or v.valid is None or v.depth is None:
            continue
        clean = cv2.imread(str(f), cv2.IMREAD_COLOR)[..., ::-1].astype(np.float32) / 255
        pf = photo_fill(v.K, v.c2w, v.size, [views[n] for n in near[s]], reference=v.image,
                        ref_valid=v.valid, dense=False)
        reached = pf.support >= 2
        rows[s] = view_row(v.image, clean, ~v.valid, np.nan_to_num(pf.colour), reached,
                           a.band, smooths)
        r = rows[s]
        print(s, f"veil {r['veil'] if r['veil'] is None else round(r['veil'], 2)}",
              f"offset band/far {r['offset_band']} / {r['offset_far']}",
              *(f"{k}: {r[k]['psnr_before']:.2f}->{r[k]['psnr_after']:.2f}"
                for k in r if k.startswith("smooth_")))
    write_result(a.out, {"synth": str(a.synth), "workspace": str(a.ws),
                         "neighbours": a.neighbours, "band": a.band, "smooth": smooths,
                         "views": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
