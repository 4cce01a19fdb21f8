"""Kind ``ghosts``: reflections of the aperture in a chain through the optical centre.

The chain lies on the line through the light and the optical centre.

Its config (:class:`GhostChainConfig`), the parameters one lens draws (:class:`GhostChain` of
:class:`Ghost`, :func:`sample_ghost_chain`) and the renderer (:func:`render_ghost_chain`).
:class:`Ghost` and its patch (:func:`_ghost_patch`) also draw the ``scatter`` kind's own few
ghosts (pipeline/flare/scatter.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.flare.common import _loguniform, _paste, _polygon_gauge, _uniform, hsv_rgb


@dataclass
class GhostChainConfig:
    """Ranges of the ghost chain (kind ``ghosts``): reflections of the aperture on the line
    through the light and the optical centre ``c``, at ``c + t (light - c)`` (``t = 1`` the
    light, 0 the centre, -1 the light mirrored through the centre). Sizes are fractions of the
    image diagonal."""

    prob: float = 0.5
    """Probability that a lens has a ghost chain (when it is one of several ``kinds``)."""
    count: tuple[int, int] = (3, 10)
    """Number of ghosts, inclusive."""
    t: tuple[float, float] = (-2.0, 1.2)
    """Range of the ghosts' positions ``t`` (below -1: beyond the mirrored light)."""
    regular_prob: float = 0.5
    """Probability of an evenly spaced chain (otherwise positions are uniform in ``t``)."""
    spacing: tuple[float, float] = (0.1, 0.45)
    """Step in ``t`` of an evenly spaced chain (shrunk to fit ``t``)."""
    sides: tuple[int, ...] = (0, 5, 6, 7, 8, 9)
    """Shapes drawn from (one per chain): 0 = circle, n = regular n-gon."""
    radius: tuple[float, float] = (0.006, 0.07)
    """Log-uniform. Radius of each ghost."""
    amplitude: tuple[float, float] = (0.02, 0.3)
    """Log-uniform. Peak linear value of each ghost at intensity 1."""
    ring_prob: float = 0.3
    """Probability that a ghost is a ring (bright rim) rather than a filled shape."""
    softness: tuple[float, float] = (0.01, 0.8)
    """Log-uniform. Edge width, fraction of the radius (0.01: hard edge, 0.8: a soft blob)."""
    hues: tuple[tuple[float, float], ...] = ((0.0, 360.0),)
    """Hue ranges (degrees) of the ghosts' tints (one range drawn per ghost)."""
    saturation: tuple[float, float] = (0.1, 0.8)
    """Saturation of the ghosts' tints."""
    chroma: tuple[float, float] = (0.0, 0.1)
    """Chromatic size spread: red radius x (1 + s), blue x (1 - s)."""


@dataclass
class Ghost:
    """One reflection ghost of a lens."""

    t: float
    """Position on the light-centre line: ``c + t (light - c)``."""
    radius: float
    """Radius, fraction of the image diagonal."""
    amplitude: float
    """Peak linear value at intensity 1."""
    tint: np.ndarray
    """[3] linear RGB tint (max 1)."""
    ring: bool
    """A ring bright at its rim instead of a filled disc."""
    softness: float
    """Edge width, fraction of the radius."""
    chroma: float
    """Chromatic size spread (R x (1 + chroma), B x (1 - chroma))."""


def _ghost_patch(g: Ghost, radius_px: float, blades: int, rotation: float) -> np.ndarray:
    """[n, n, 3] float32 ghost shape (peak about 1 x tint) centred in an odd-sized patch."""
    soft = max(g.softness * radius_px, 0.7)
    half = int(np.ceil(radius_px * (1 + g.chroma) + 2 * soft + 1))
    yy, xx = np.mgrid[-half:half + 1, -half:half + 1].astype(np.float32)
    out = np.empty((2 * half + 1, 2 * half + 1, 3), np.float32)
    gauge, factor = _polygon_gauge(xx, yy, blades, rotation)
    for ch, s in enumerate((1 + g.chroma, 1.0, 1 - g.chroma)):
        r = max(radius_px * s, 1e-3)
        sdf = gauge - np.float32(r * factor)
        alpha = np.clip(0.5 - sdf * np.float32(0.5 / soft), 0, 1)
        alpha = alpha * alpha * (3 - 2 * alpha)  # smoothstep edge
        if g.ring:  # brighter towards the rim
            rim = np.clip(1 + sdf * np.float32(1 / r), 0, 1) ** 4
            alpha *= 0.15 + 0.85 * rim
        out[..., ch] = alpha * np.float32(g.tint[ch])
    return out


@dataclass
class GhostChain:
    """One lens's ghost chain (kind ``ghosts``; see :class:`GhostChainConfig`). Each ghost's
    ``radius`` is its own (it does not grow with ``|t|``)."""

    blades: int
    """Shape of the ghosts: 0 = circle, n = regular n-gon."""
    rotation: float
    """Rotation of the polygons (radians)."""
    ghosts: list[Ghost]
    """The ghosts, in order of ``t``."""


def sample_ghost_chain(cfg: GhostChainConfig, rng: np.random.Generator) -> GhostChain:
    """Draw a ghost chain from ``cfg``'s ranges: evenly spaced (``regular_prob``) or
    uniform positions ``t``, one shape, independent sizes, tints and edges."""
    n = int(rng.integers(cfg.count[0], cfg.count[1] + 1))
    lo, hi = cfg.t
    if n > 1 and rng.random() < cfg.regular_prob:
        step = min(_uniform(rng, cfg.spacing), (hi - lo) / (n - 1))
        ts = rng.uniform(lo, hi - step * (n - 1)) + step * np.arange(n)
    else:
        ts = np.sort(rng.uniform(lo, hi, n))
    ghosts = []
    for t in ts:
        hue_lo, hue_hi = cfg.hues[int(rng.integers(len(cfg.hues)))]
        ghosts.append(Ghost(
            t=float(t), radius=_loguniform(rng, cfg.radius),
            amplitude=_loguniform(rng, cfg.amplitude),
            tint=hsv_rgb(rng.uniform(hue_lo, hue_hi), _uniform(rng, cfg.saturation)),
            ring=bool(rng.random() < cfg.ring_prob), softness=_loguniform(rng, cfg.softness),
            chroma=_uniform(rng, cfg.chroma)))
    return GhostChain(blades=int(rng.choice(cfg.sides)), rotation=float(rng.uniform(0, np.pi)),
                      ghosts=ghosts)


def render_ghost_chain(p: GhostChain, light_xy: tuple[float, float],
                       center_xy: tuple[float, float], size_hw: tuple[int, int],
                       rgb: np.ndarray, rng: np.random.Generator | None = None,
                       flicker: float = 0.0) -> np.ndarray:
    """[H, W, 3] the ghosts at ``c + t (light - c)`` (``c`` = ``center_xy``); with ``rng``,
    each ghost's amplitude flickers (log-normal sigma ``flicker``)."""
    H, W = size_hw
    diag = float(np.hypot(H, W))
    out = np.zeros((H, W, 3), np.float32)
    (lx, ly), (cx, cy) = light_xy, center_xy
    for g in p.ghosts:
        gx, gy = cx + g.t * (lx - cx), cy + g.t * (ly - cy)
        amp = g.amplitude
        if rng is not None and flicker > 0:
            amp *= float(np.exp(rng.normal(0, flicker)))
        patch = _ghost_patch(g, g.radius * diag, p.blades, p.rotation)
        half = patch.shape[0] // 2
        _paste(out, patch * (amp * rgb).astype(np.float32), int(round(gx)) - half,
               int(round(gy)) - half)
    return out
