"""How a workspace's flare masks sit on a synth scene's true flare, beyond IoU.

    python benchmarks/mask_shape.py SYNTH WS [WS ...] [--grow 0,2,4,8] [--out JSON]

For each workspace (its WS/masks, e.g. the eval workspaces `deflare-scene eval SYNTH --masks
fmg --fmg-weights W` writes) and each grow radius (the masks dilated by that many pixels, a
square window), pooled over SYNTH's flared training views:
- flare IoU, recall (share of the true flare marked), precision (share of the marks on true
  flare) and the marked area as a multiple of the true area;
- ``light_left``: the share of the light the flare added (the flared photo minus the clean
  one, clipped at 0, summed over the 8-bit sRGB channels) that falls outside the mask, i.e.
  what stays in the photo where the mask does not reach.
- ``flare_psnr_ceiling``: the PSNR inside the true flare (as ``eval``'s ``psnr_flare``, 8-bit
  sRGB scaled to 0-1) of the flared photo with every marked pixel replaced by the clean one:
  the best a fill could do with these masks. IoU and ``light_left`` count a missed pixel by
  its area or its added light; this counts it by its squared error, as the photos are scored,
  so a few missed saturated pixels weigh more than a faint rim;
- ``left_saturated``: the share of that ceiling's squared error in pixels the flared photo
  has saturated (a channel at 250 or more), e.g. a light's core left unmarked.
A tight mask (high precision, low recall) leaves more of the added light outside it; a mask
that overreaches the flare's rim leaves less. The sixteenth session's untested hypothesis
(gnfr/weights/fmg.md) was that the shipped FMG's blobs leave less light outside than J's
outlines; this measures it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


SATURATED = 250
"""An 8-bit channel at or above this is taken as saturated (``left_saturated``)."""


def grown(mask: np.ndarray, r: int) -> np.ndarray:
    """``mask`` dilated by ``r`` pixels (a (2r+1)-square window); itself for r = 0."""
    if r <= 0:
        return mask
    return cv2.dilate(mask.astype(np.uint8), np.ones((2 * r + 1, 2 * r + 1), np.uint8)) > 0


def shape_scores(pairs, grows: list[int]) -> dict:
    """{grow: scores} pooled over ``pairs`` of (mask, true mask, flared, clean) arrays
    (bool [H, W], bool [H, W], uint8 [H, W, 3], uint8 [H, W, 3])."""
    from workflows.research.fmg_eval import fill_ceiling, squared_error

    # inter, union, true, marked, light outside, squared error left in the true flare (sum
    # over the channels), the part of it on saturated pixels
    acc = {r: np.zeros(7) for r in grows}
    light = 0.0
    for m, t, flared, clean in pairs:
        added = np.clip(flared.astype(np.float64) - clean.astype(np.float64), 0, None).sum(-1)
        sq = squared_error(flared, clean)
        sat = (flared >= SATURATED).any(-1)
        light += added.sum()
        for r in grows:
            g = grown(m, r)
            left = t & ~g
            acc[r] += [(g & t).sum(), (g | t).sum(), t.sum(), g.sum(), added[~g].sum(),
                       sq[left].sum(), sq[left & sat].sum()]
    out = {}
    for r, (inter, union, true, marked, left, err, err_sat) in acc.items():
        out[str(r)] = {"iou": inter / union if union else None,
                       "recall": inter / true if true else None,
                       "precision": inter / marked if marked else None,
                       "marked_over_true": marked / true if true else None,
                       "light_left": left / light if light else None,
                       # nothing left: infinite here, as this file has always said it
                       "flare_psnr_ceiling": (float("inf") if true and not err
                                              else fill_ceiling(err, 3 * true)),
                       "left_saturated": err_sat / err if err else 0.0}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path, help="a `deflare-scene synth` folder")
    ap.add_argument("workspaces", type=Path, nargs="+", help="workspaces with WS/masks")
    ap.add_argument("--grow", default="0,2,4,8", help="comma-separated dilation radii (px)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_mask
    from workflows.research.eval.scene import flared_views, load_synth, photo_path, truth_mask
    from workflows.research.eval.scoring import read_bgr

    scene = load_synth(a.scene)
    grows = sorted({int(g) for g in a.grow.split(",") if g.strip()})
    stems = flared_views(scene)
    rows = []
    for wdir in a.workspaces:
        ws = Workspace(wdir)

        def pairs(ws=ws):
            for s in stems:
                m = read_mask(ws, s)
                size = m.shape[:2]
                t = truth_mask(scene, s)
                if t.shape != size:
                    t = cv2.resize(t.astype(np.uint8), size[::-1],
                                   interpolation=cv2.INTER_NEAREST) > 0
                yield (m, t, read_bgr(photo_path(scene.root, s), size),
                       read_bgr(scene.root / "clean" / f"{s}.png", size))

        res = shape_scores(pairs(), grows)
        rows.append({"workspace": str(wdir), "scores": res})
        for r in grows:
            x = res[str(r)]
            print(f"{wdir} grow {r}: IoU {x['iou']:.3f} recall {x['recall']:.3f} precision "
                  f"{x['precision']:.3f} marked {x['marked_over_true']:.2f}x true, added light "
                  f"outside the mask {x['light_left']:.3f}, flare PSNR of a perfect fill "
                  f"{x['flare_psnr_ceiling']:.2f} ({x['left_saturated']:.2f} of its error on "
                  f"saturated pixels)", flush=True)
    write_result(a.out, {"scene": str(a.scene), "views": stems, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
