"""Ghost lines: faint flare regions kept because they sit on a light's ghost line.

A lens's ghosts are images of the aperture reflected between its surfaces; for a lens
centred on its axis every ghost of a light lies on the straight line through the light and
the optical centre (the image centre of an undistorted pinhole photo), on either side of the
centre (``pipeline.flare.GhostChainConfig`` draws them so). The FMG finds the core and glow
of a light well but gives ghosts far from it low probabilities (a chain of faint discs over
the scene looks like scene): on nine one-kind development scenes with ghosts, about a third
of the true ghost pixels sit between a probability of 0.1 and the cut, a third under 0.1
(docs/history/fmg.md, "Thirty-third session"). The rule (``ghost_line_mask``):

1. **Lights**: as the flare rays find them (``pipeline.flare_rays.find_lights``: small,
   compact, isolated saturated regions), the ``max_lights`` largest. A light within
   ``min_offset`` of the centre defines no line (every direction would do).
2. **Candidates**: the connected regions of the FMG's probabilities above ``low`` (below
   the calibrated cut, so that the FMG's own weak responses become candidates), from
   ``min_area`` to ``max_area`` of the image.
3. **On the line**: a candidate is kept when its centroid lies within ``along`` times its
   radius (the radius of a disc of its area; at least ``min_offset_px``) of the line of
   a light, and it is not the light's own glow (its centroid farther from the light than
   ``clear`` times its radius plus the light's radius), and at least ``min_chain`` such
   candidates lie on that light's line.

It adds nothing to a photo without a saturated light or without weak FMG responses on the
lines; scene regions that happen to lie on a light's line and that the FMG half-believes
are flare are its false marks. The mask stage adds it to the FMG's mask with
``mask --ghost-lines``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.options import option


@dataclass
class GhostConfig:
    """Parameters of the ghost-line rule (module docstring)."""

    low: float = option(0.25, gt=0, lt=1)
    """FMG probability above which a region is a candidate ghost."""
    along: float = option(0.5, gt=0)
    """Largest distance of a candidate's centroid from a light's line, in the candidate's
    radii (a ghost is centred on the line)."""
    min_offset_px: float = option(3.0, ge=0)
    """... but at least this many pixels."""
    min_area: float = option(1e-4, ge=0, lt=1)
    """Smallest candidate, as a fraction of the image."""
    max_area: float = option(0.05, gt=0, le=1)
    """Largest candidate, as a fraction of the image (a ghost is a disc of at most a few
    percent of the diagonal)."""
    clear: float = option(2.0, ge=0)
    """A candidate whose centroid is within this many of its radii (plus the light's own)
    of the light is the light's glow, not a ghost (the FMG's own cut decides there)."""
    min_offset: float = option(0.02, ge=0)
    """A light within this fraction of the diagonal from the centre defines no line."""
    max_lights: int = option(2, ge=1)
    """Lights whose lines are used (the largest)."""
    min_chain: int = option(2, ge=1)
    """Fewest candidates on one light's line for any of them to be kept (a lens makes a
    chain of ghosts; a lone weak region on a line is more often scene): with 1 the rule
    marked 0.64 % of the clean development photos instead of 0.55 % (docs/history/fmg.md,
    "Thirty-third session")."""


def line_distance(px: np.ndarray, py: np.ndarray, a: tuple[float, float],
                  b: tuple[float, float]) -> np.ndarray:
    """Distance of points (px, py) from the infinite line through ``a`` and ``b``."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    n = float(np.hypot(dx, dy))
    return np.abs((px - a[0]) * dy - (py - a[1]) * dx) / max(n, 1e-9)


def ghost_line_mask(probs: np.ndarray, lights: list[tuple[float, float, float]],
                    centre: tuple[float, float] | None = None,
                    cfg: GhostConfig | None = None) -> np.ndarray:
    """[H, W] bool: the candidate regions of ``probs`` [H, W] (FMG probabilities) that sit on
    the line through one of ``lights`` ((x, y, radius) in ``probs``' pixels, largest first)
    and ``centre`` (default the image centre); module docstring."""
    cfg = cfg or GhostConfig()
    h, w = probs.shape
    out = np.zeros((h, w), bool)
    c = centre if centre is not None else ((w - 1) / 2.0, (h - 1) / 2.0)
    diag = float(np.hypot(h, w))
    lines = [(x, y, r) for x, y, r in lights[:cfg.max_lights]
             if np.hypot(x - c[0], y - c[1]) >= cfg.min_offset * diag]
    if not lines:
        return out
    n, lab, stats, cents = cv2.connectedComponentsWithStats(
        (probs > cfg.low).astype(np.uint8), connectivity=8)
    if n <= 1:
        return out
    area = stats[1:, cv2.CC_STAT_AREA].astype(np.float64)
    radius = np.sqrt(area / np.pi)
    cx, cy = cents[1:, 0], cents[1:, 1]
    sized = (area >= cfg.min_area * h * w) & (area <= cfg.max_area * h * w)
    keep = np.zeros(n, bool)
    for x, y, r in lines:
        on = line_distance(cx, cy, (x, y), c) <= np.maximum(cfg.along * radius,
                                                             cfg.min_offset_px)
        away = np.hypot(cx - x, cy - y) >= cfg.clear * radius + r
        chain = sized & on & away
        if chain.sum() >= cfg.min_chain:
            keep[1:] |= chain
    return keep[lab]
