"""The neighbouring photos overrule the FMG's false marks (`mask --crosscheck`, off by default).

Flare is made by the lens and moves with the camera; the scene does not. For each view the
nearest ``neighbours`` photos, their own flare masks respected, are warped into it through
plane-sweep depth (the depth stage's, computed with the FMG's masks) and fused to a
consensus colour (``pipeline.photo_fill``, gains matched to the view's unmarked pixels). A
region of the view's mask is scene that the FMG marked in this view alone, and is dropped,
when at least ``min_judged`` of its pixels have ``min_support`` neighbours that agree on the
colour there and at least ``min_confirmed`` of those pixels are no brighter than the
(max-filtered) consensus by more than the synthesizer's own mask rule
(``max(abs_threshold, rel_threshold x consensus)`` in linear luminance). Flare the
neighbours carry and mark too is never judged (their marks are excluded), and a region with
true flare in it is brighter than the consensus there, so it stays.

On the development scenes (docs/history/fmg.md, "Twenty-eighth session"; rule written
before the scores) the rule's setting removed a quarter of the marks on clean photos (0.60 %
to 0.45 % of the pixels) with flare IoU on four synth scenes within 0.005; it is not the
default: with it the de-flared photos gained 0.065 dB in the flare region (three seeds),
under the +0.10 dB a default needs.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.colour import srgb_to_linear
from pipeline.flare import MASK_RELATIVE, MASK_THRESHOLD, luminance
from pipeline.stereo import PosedView

__all__ = ["Consensus", "CrosscheckRule", "add_confirmed", "confirmed_as_scene", "consensus",
           "crosscheck", "drop_confirmed", "excess_over_consensus", "view_consensus"]


@dataclass(frozen=True)
class CrosscheckRule:
    """When the neighbours overrule a region the FMG marks (the defaults: the setting the
    development scenes chose)."""

    neighbours: int = 4
    """Nearest posed views warped into each view."""
    agree: float = 0.08
    """Colour difference (max channel, 0..1) within which neighbours agree."""
    min_support: int = 2
    """Neighbours that must agree on the scene's colour for a pixel to be judged."""
    min_judged: float = 0.3
    """Share of a region's pixels that must be judged before it can be dropped."""
    min_confirmed: float = 0.95
    """Share of the judged pixels that must be no brighter than the consensus."""
    abs_threshold: float = MASK_THRESHOLD
    """Linear-luminance excess over the consensus still counted as 'as bright' (absolute)."""
    rel_threshold: float = MASK_RELATIVE
    """... and relative part (fraction of the consensus luminance)."""
    slack: int = 2
    """Radius (pixels) of the max filter on the consensus luminance."""
    min_brighter: float = 0.3
    """Adding (``add_confirmed``): share of a candidate region's judged pixels that must be
    brighter than the consensus by the mask rule for the neighbours to confirm it as flare
    (read off exploration rows: docs/history/fmg.md, "Thirty-fourth session")."""


@dataclass
class Consensus:
    """What the neighbours agree a view's scene looks like."""

    lum_view: np.ndarray
    """[H, W] float32 linear luminance of the view."""
    lum: np.ndarray
    """[H, W] float32 linear luminance of the neighbours' consensus colour."""
    support: np.ndarray
    """[H, W] int: neighbours that agree (0 where no depth)."""


def consensus(view: PosedView, neighbours: list[PosedView], agree: float) -> Consensus:
    """The neighbours (``depth`` and ``valid`` set: their depth and flare masks) warped
    into ``view`` and fused; gains matched to the view's unmarked pixels (``valid``)."""
    from pipeline.photo_fill import photo_fill

    pf = photo_fill(view.K, view.c2w, view.size, neighbours, agree=agree,
                    reference=view.image, ref_valid=view.valid, dense=False)
    return Consensus(luminance(srgb_to_linear(view.image.astype(np.float32))),
                     luminance(srgb_to_linear(pf.colour)),
                     np.where(pf.depth > 0, pf.support, 0))


def excess_over_consensus(c: Consensus, min_support: int, abs_threshold: float,
                          rel_threshold: float, slack: int
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """[H, W] judged (``min_support`` neighbours agree), the view's linear luminance above
    their consensus max-filtered over ``slack`` pixels, and the mask rule's threshold on it
    (``max(abs_threshold, rel_threshold x consensus)``)."""
    judged = c.support >= min_support
    lum_c = np.where(judged, c.lum, 0).astype(np.float32)
    if slack > 0:
        k = 2 * slack + 1
        lum_c = cv2.dilate(lum_c, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    thr = np.maximum(np.float32(abs_threshold), np.float32(rel_threshold) * lum_c)
    return judged, c.lum_view - lum_c, thr


def confirmed_as_scene(c: Consensus, rule: CrosscheckRule) -> tuple[np.ndarray, np.ndarray]:
    """[H, W] bool pair: judged (``min_support`` neighbours agree) and, of those, no
    brighter than their max-filtered consensus by more than the mask rule's threshold."""
    judged, excess, thr = excess_over_consensus(c, rule.min_support, rule.abs_threshold,
                                                rule.rel_threshold, rule.slack)
    return judged, judged & (excess <= thr)


def drop_confirmed(marks: np.ndarray, c: Consensus, rule: CrosscheckRule) -> np.ndarray:
    """``marks`` [H, W] bool without its 8-connected regions the neighbours confirm as
    scene (module docstring)."""
    n, labels = cv2.connectedComponents(np.ascontiguousarray(marks, np.uint8), connectivity=8)
    if n <= 1:
        return marks.copy()
    judged, same = confirmed_as_scene(c, rule)
    area = np.bincount(labels.ravel(), minlength=n)
    n_j = np.bincount(labels.ravel(), weights=judged.ravel(), minlength=n)
    n_s = np.bincount(labels.ravel(), weights=same.ravel(), minlength=n)
    drop = (n_j >= rule.min_judged * area) & (n_s >= rule.min_confirmed * np.maximum(n_j, 1))
    drop[0] = False
    return marks & ~drop[labels]


def add_confirmed(candidates: np.ndarray, c: Consensus, rule: CrosscheckRule) -> np.ndarray:
    """[H, W] bool: the 8-connected regions of ``candidates`` (weak flare the network left
    out) that the neighbours confirm as flare: at least ``min_judged`` of the region's pixels
    judged and at least ``min_brighter`` of those brighter than the (max-filtered) consensus
    by the mask rule. A region no neighbour can judge is not added."""
    n, labels = cv2.connectedComponents(np.ascontiguousarray(candidates, np.uint8),
                                        connectivity=8)
    if n <= 1:
        return np.zeros(candidates.shape, bool)
    judged, excess, thr = excess_over_consensus(c, rule.min_support, rule.abs_threshold,
                                                rule.rel_threshold, rule.slack)
    area = np.bincount(labels.ravel(), minlength=n)
    n_j = np.bincount(labels.ravel(), weights=judged.ravel(), minlength=n)
    n_b = np.bincount(labels.ravel(), weights=(judged & (excess > thr)).ravel(), minlength=n)
    keep = (n_j >= rule.min_judged * area) & (n_b >= rule.min_brighter * np.maximum(n_j, 1))
    keep[0] = False
    return keep[labels]


def view_consensus(ws, masks: dict[str, np.ndarray], rule: CrosscheckRule = CrosscheckRule(),
                   label: str = "mask: cross-check"):
    """Yield (stem, Consensus) for every posed view of ``ws``: depth from the photos with
    ``masks`` as validity (the depth stage's defaults; each view's plane sweep kept in
    WS/.sweeps for the depth stage, ``pipeline.depth.sweep_views``), then the nearest
    ``rule.neighbours`` views warped into each view and fused."""
    from pipeline.depth import DepthConfig, load_views, nearest_views, sweep_views
    from pipeline.progress import track
    from pipeline.ws_files import read_cameras

    cams = read_cameras(ws)
    views = load_views(ws, cams, cams.stems, masks=masks)
    config = DepthConfig()
    ws.sweeps.mkdir(parents=True, exist_ok=True)  # kept: an interrupted mask stage and
    # the depth stage (its defaults, the same masks) take the sweeps whose keys match
    depths = sweep_views(views, cams, nearest_views(cams, config.neighbours), config,
                         ws.sweeps, False, ws, "mask: depth for the other photos' check",
                         shared=ws.sweeps)
    for s, (d, _) in depths.items():
        views[s].depth = d
    near = nearest_views(cams, rule.neighbours)
    for s in track(cams.stems, label):
        yield s, consensus(views[s], [views[n] for n in near[s]], rule.agree)


def crosscheck(ws, masks: dict[str, np.ndarray], rule: CrosscheckRule = CrosscheckRule(),
               candidates: dict[str, np.ndarray] | None = None, drop: bool = True
               ) -> dict[str, np.ndarray]:
    """{stem: mask} of every posed view of ``ws`` checked against its neighbours
    (``view_consensus``): ``masks`` without the regions they confirm as scene
    (:func:`drop_confirmed`, if ``drop``) and with the regions of ``candidates`` (if given)
    they confirm as flare (:func:`add_confirmed`). With nothing to drop and no candidate
    pixel in any view the masks come back as they are, without the depth and the warps
    (most captures without a light in frame)."""
    if not drop and not any(c is not None and c.any() for c in (candidates or {}).values()):
        return {s: m.copy() for s, m in masks.items()}
    out = {}
    for s, c in view_consensus(ws, masks, rule):
        m = drop_confirmed(masks[s], c, rule) if drop else masks[s].copy()
        if candidates is not None and candidates.get(s) is not None:
            m |= add_confirmed(candidates[s] & ~masks[s], c, rule)
        out[s] = m
    return out
