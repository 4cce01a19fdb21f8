"""A probe of the glow the FMG stops short of: two ways of finding it, scored (a diagnosis).

    python benchmarks/glow_probe.py SYNTH WS [--out JSON]

The sample's video shows a white haze where the sun stood in its photos, and the sample's
true masks put in at render time clear most of it (docs/history/fill.md, "Novel frames'
network sources from the de-flared photos"): the FMG's masks stop short of each light's
faint outer glow. Two ways of marking that glow, each added to WS's masks (the mask
stage's, WS/images the size of SYNTH's photos, e.g. a copy of `SYNTH/eval.ws` after
`deflare-scene mask`), are scored against SYNTH's true masks (``benchmarks/mask_shape.py``'s
scores: flare IoU, recall, precision, the share of the added light left outside the mask,
the flare region's fill ceiling), with the share of the view each adds and the share of
that on true flare; and where the true flare pixels the masks miss lie, by distance from
the light:

- ``ring`` (one photo): about each light the mask holds (its largest saturated part,
  ``marked_lights``), the ``quantile`` of each one-pixel ring's linear luminance over the
  angles (the glow plus the scene's darker part) is fitted by a lens glow
  ``a (1 + (r / w)^2)^-p`` over a floor, the rings above the fit weighed down (a bright
  scene patch lies over the glow, never under it); a pixel is glow where the fit passes the
  synthesizer's mask rule against the scene under it (``max(0.012, 0.1 x background)``, linear
  luminance), connected to the light's marked region.
- ``views`` (the other photos): the mask stage's cross-check consensus
  (``pipeline.crosscheck.view_consensus``: the nearest photos warped in through plane-sweep
  depth, their masks respected); about each marked light, the median over each two-pixel
  ring of the view's luminance above the consensus (pixels the consensus reaches, outside
  the mask), less its median beyond ``reach`` (an offset of the whole view), made
  non-increasing outwards; the same rule and connection.

The eighty-ninth session's finding (docs/history/fmg.md, "Eighty-ninth session"): both add
marks mostly off the true flare, so neither became a mask option.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pipeline.colour import LUMA, srgb_to_linear  # noqa: E402

ABS, REL = 0.012, 0.1
"""The synthesizer's mask rule (``pipeline.flare``: ``MASK_THRESHOLD``, ``MASK_RELATIVE``)."""
BANDS = (0.0, 0.05, 0.1, 0.2, 2.0)
"""Distances from the light (fractions of the diagonal) by which the true flare pixels the
mask stage misses are counted (``missed_by_distance``, from SYNTH's ``light_xy``)."""


def ring_profile(lum: np.ndarray, x: float, y: float, radius: int, quantile: float,
                 min_cover: float, angles: int = 360) -> np.ndarray:
    """[radius] the ``quantile`` over angles of linear luminance ``lum`` [H, W] on each ring
    of one pixel about (x, y), NaN where fewer than ``min_cover`` of its angles lie inside
    the image."""
    h, w = lum.shape
    theta = np.linspace(0, 2 * np.pi, angles, endpoint=False, dtype=np.float32)
    r = np.arange(radius, dtype=np.float32)
    map_x = x + np.cos(theta)[:, None] * r[None]
    map_y = y + np.sin(theta)[:, None] * r[None]
    pol = cv2.remap(lum.astype(np.float32), map_x, map_y, cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan)
    inside = (map_x >= 0) & (map_x <= w - 1) & (map_y >= 0) & (map_y <= h - 1)
    pol = np.where(inside, pol, np.nan)
    cover = inside.mean(0)
    with np.errstate(all="ignore"):
        prof = np.nanquantile(np.where(cover[None] > 0, pol, 0.0), quantile, axis=0)
    return np.where(cover >= min_cover, prof, np.nan).astype(np.float32)


def glow_profile(prof: np.ndarray, start: int, widths: np.ndarray,
                 powers: tuple[float, ...] = (1.0, 1.5, 2.0), above: float = 0.1,
                 iters: int = 4) -> np.ndarray:
    """[R] the glow at each radius fitted to a ring profile (``ring_profile``) from ``start``
    outwards: ``a (1 + (r / w)^2)^-p + b`` (a lens's glow fades as a power of the distance;
    ``b`` the scene's darker part), ``w`` from ``widths`` (pixels) and ``p`` from
    ``powers``, ``a`` and ``b`` by least squares weighted against the rings above the fit
    (``above``: a bright scene patch lies over the glow, never under it); the fit with the
    least weighted error wins. Zero where no fit has ``a`` > 0."""
    r = np.arange(len(prof), dtype=np.float64)
    sel = np.isfinite(prof) & (r >= start)
    out = np.zeros(len(prof), np.float32)
    if sel.sum() < 8:
        return out
    rr, q = r[sel], prof[sel].astype(np.float64)
    best = (np.inf, 0.0, None)
    for w in widths:
        for pw in powers:
            shape = (1.0 + (rr / w) ** 2) ** -pw
            design = np.stack([shape, np.ones_like(shape)], 1)
            wt = np.ones_like(q)
            for _ in range(iters):
                sw = np.sqrt(wt)[:, None]
                coef, *_ = np.linalg.lstsq(design * sw, q * sw[:, 0], rcond=None)
                res = q - design @ coef
                wt = np.where(res > 0, above, 1.0)
            err = float((wt * res ** 2).sum() / wt.sum())
            if coef[0] > 0 and err < best[0]:
                best = (err, float(coef[0]), (w, pw))
    if best[2] is None:
        return out
    w, pw = best[2]
    out[:] = best[1] * (1.0 + (r / w) ** 2) ** -pw
    return out


def marked_lights(img: np.ndarray, marks: np.ndarray, saturated: float = 0.98,
                  max_light: float = 0.003, min_light: int = 2) -> list[tuple[float, float, float]]:
    """(x, y, radius) of the lights the mask ``marks`` [H, W] bool holds in sRGB ``img``
    [H, W, 3] 0..1: in each marked region, its largest saturated part (any channel >=
    ``saturated``) of ``min_light`` pixels up to ``max_light`` of the image. Unlike the flare
    rays' lights, no isolation test: a light inside a bright glow is what is looked for."""
    n, regions = cv2.connectedComponents(marks.astype(np.uint8), connectivity=8)
    sat = ((img.max(-1) >= saturated) & marks).astype(np.uint8)
    m, labels, stats, cents = cv2.connectedComponentsWithStats(sat, connectivity=8)
    best: dict[int, tuple[int, float, float]] = {}
    for i in range(1, m):
        a = int(stats[i, cv2.CC_STAT_AREA])
        if a < min_light or a > max_light * sat.size:
            continue
        x, y = map(float, cents[i])
        reg = int(regions[labels == i][0])
        if a > best.get(reg, (0,))[0]:
            best[reg] = (a, x, y)
    return [(x, y, float(np.sqrt(a / np.pi))) for a, x, y in best.values()]


def _connected_to(cand: np.ndarray, marks: np.ndarray, x: float, y: float) -> np.ndarray:
    """The pixels of ``cand`` outside ``marks`` in the 8-connected part holding (x, y)."""
    h, w = cand.shape
    n, labels = cv2.connectedComponents(cand.astype(np.uint8), connectivity=8)
    lab = labels[min(h - 1, max(0, int(round(y)))), min(w - 1, max(0, int(round(x))))]
    return (labels == lab) & ~marks if n > 1 and lab > 0 else np.zeros((h, w), bool)


def ring_glow(img: np.ndarray, marks: np.ndarray, quantile: float = 0.25,
              reach: float = 0.35, min_cover: float = 0.25, smooth: float = 0.02
              ) -> np.ndarray:
    """[H, W] bool: the ``ring`` probe's glow (module docstring) about the marked lights of
    sRGB ``img`` [H, W, 3] 0..1 with mask ``marks``; never on ``marks``."""
    h, w = marks.shape
    out = np.zeros((h, w), bool)
    diag = float(np.hypot(h, w))
    lum = srgb_to_linear(img.astype(np.float32)) @ LUMA.astype(np.float32)
    yy, xx = np.mgrid[:h, :w].astype(np.float32)
    radius = max(2, int(reach * diag))
    widths = np.geomspace(0.005, 0.15, 12) * diag
    for x, y, rad in marked_lights(img, marks):
        prof = ring_profile(lum, x, y, radius, quantile, min_cover)
        glow = glow_profile(prof, min(radius - 1, int(np.ceil(rad)) + 2), widths)
        if not glow.any():
            continue
        d = np.hypot(xx - x, yy - y)
        g = np.interp(d, np.arange(radius), glow, right=0.0).astype(np.float32)
        bg = cv2.GaussianBlur(np.clip(lum - g, 0, None), (0, 0), max(1.0, smooth * diag))
        cand = (g > np.maximum(ABS, REL * bg)) | (marks & (d <= radius))
        out |= _connected_to(cand, marks, x, y)
    return out


def views_glow(img: np.ndarray, marks: np.ndarray, lum_view: np.ndarray,
               lum_consensus: np.ndarray, support: np.ndarray, reach: float = 0.35,
               ring: int = 2, min_share: float = 0.2) -> np.ndarray:
    """[H, W] bool: the ``views`` probe's glow (module docstring) about the marked lights of
    sRGB ``img`` with mask ``marks``, from the view's and its neighbours' consensus linear
    luminance and the consensus' ``support`` (``pipeline.crosscheck.Consensus``); a ring
    counts where the consensus reaches ``min_share`` of its pixels."""
    h, w = marks.shape
    out = np.zeros((h, w), bool)
    judged = (support >= 2) & ~marks
    if not judged.any():
        return out
    excess = lum_view - lum_consensus
    offset_all = float(np.median(excess[judged]))
    yy, xx = np.mgrid[:h, :w].astype(np.float32)
    radius = max(2, int(reach * float(np.hypot(h, w))))
    for x, y, rad in marked_lights(img, marks):
        d = np.hypot(xx - x, yy - y)
        ri = d.astype(int)
        far = judged & (d >= radius)
        offset = float(np.median(excess[far])) if far.sum() > 100 else offset_all
        counts = np.bincount(ri[ri < radius], minlength=radius)
        sel = judged & (ri < radius)
        r_sel, e_sel = ri[sel], excess[sel] - offset
        glow = np.zeros(radius, np.float32)
        level, seen = np.inf, False
        for r0 in range(int(rad) + 1, radius, ring):
            v = e_sel[(r_sel >= r0) & (r_sel < r0 + ring)]
            if len(v) >= max(8, min_share * counts[r0:r0 + ring].sum()):
                level, seen = min(level, max(0.0, float(np.median(v)))), True
            glow[r0:r0 + ring] = level if seen else 0.0
        if not seen:
            continue
        g = np.interp(d, np.arange(radius), glow, right=0.0).astype(np.float32)
        cand = (g > np.maximum(ABS, REL * np.clip(lum_view - g, 0, None))) | (marks & (d < radius))
        out |= _connected_to(cand, marks, x, y)
    return out


def main(argv: list[str] | None = None) -> int:
    from benchmarks.mask_shape import shape_scores
    from pipeline.crosscheck import view_consensus
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("synth", type=Path)
    ap.add_argument("ws", type=Path)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    split = json.loads((a.synth / "split.json").read_text())
    stems = [s for s in split["train"] if (a.ws / "masks" / f"{s}.png").is_file()]
    masks = {s: cv2.imread(str(a.ws / "masks" / f"{s}.png"), cv2.IMREAD_GRAYSCALE) > 0
             for s in stems}
    cons = dict(view_consensus(Workspace(a.ws), masks))
    arms = {"mask stage": [], "ring": [], "views": []}
    added = {"ring": np.zeros(3), "views": np.zeros(3)}  # added, added on true, pixels
    missed = np.zeros(len(BANDS) - 1)  # true pixels the mask stage misses, by distance
    views = {}
    for s in stems:
        flared = cv2.imread(str(a.ws / "images" / f"{s}.png"), cv2.IMREAD_COLOR)
        clean = cv2.imread(str(a.synth / "clean" / f"{s}.png"), cv2.IMREAD_COLOR)
        truth = cv2.imread(str(a.synth / "masks_gt" / f"{s}.png"), cv2.IMREAD_GRAYSCALE) > 0
        m, c = masks[s], cons[s]
        rgb = flared[..., ::-1].astype(np.float32) / 255
        probes = {"ring": ring_glow(rgb, m),
                  "views": views_glow(rgb, m, c.lum_view, c.lum, c.support)}
        arms["mask stage"].append((m, truth, flared, clean))
        light = split.get("views", {}).get(s, {}).get("light_xy")
        if light is not None:
            yy, xx = np.mgrid[:m.shape[0], :m.shape[1]]
            d = np.hypot(xx - light[0], yy - light[1]) / np.hypot(*m.shape)
            missed += np.histogram(d[truth & ~m], bins=BANDS)[0]
        views[s] = {}
        for k, g in probes.items():
            arms[k].append((m | g, truth, flared, clean))
            added[k] += [g.sum(), (g & truth).sum(), g.size]
            views[s][k] = {"added": float(g.mean()),
                           "added_on_flare": float((g & truth).sum() / g.sum()) if g.any()
                           else None}
        print(s, " ".join(f"{k} +{v['added']:.3f}" for k, v in views[s].items()))
    scores = {k: shape_scores(p, [0])["0"] for k, p in arms.items()}
    for k, (n, on, px) in added.items():
        scores[k]["added"] = n / px
        scores[k]["added_on_flare"] = on / n if n else None
    for k, v in scores.items():
        print(f"{k}: iou {v['iou']:.3f} light_left {v['light_left']:.3f} "
              f"ceiling {v['flare_psnr_ceiling']:.2f}")
    bands = [f"{lo}-{hi}" for lo, hi in zip(BANDS[:-1], BANDS[1:], strict=True)]
    share = missed / missed.sum() if missed.sum() else missed
    print("missed true pixels by distance from the light (diagonals):",
          " ".join(f"{b}: {v:.3f}" for b, v in zip(bands, share, strict=True)))
    write_result(a.out, {"synth": str(a.synth), "workspace": str(a.ws), "scores": scores,
                         "missed_by_distance": dict(zip(bands, map(float, share), strict=True)),
                         "views": views})
    return 0


if __name__ == "__main__":
    sys.exit(main())
