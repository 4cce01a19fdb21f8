"""Kind ``glare``: veiling glare around the light and over the frame.

A glow around the light, a broad low-contrast veil and a colour cast that stay under the
mask threshold.

Its config (:class:`VeilingGlareConfig`), the parameters one lens draws
(:class:`VeilingGlare`, :func:`sample_veiling_glare`) and the renderer
(:func:`render_veiling_glare`)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.colour import LUMA
from pipeline.flare.common import VEIL_CAP, _loguniform, _uniform, hsv_rgb


@dataclass
class VeilingGlareConfig:
    """Ranges of the veiling glare (kind ``glare``): a glow around the light
    ``a (1 + (d / w)^2)^-2``, a broad low-contrast veil ``(1 + (d / W)^2)^-1`` and a uniform
    colour cast. Veil and cast together stay below ``VEIL_CAP`` x the absolute mask
    threshold in luminance at any intensity, so only the glow near the light is ever
    masked. Sizes are fractions of the image diagonal."""

    prob: float = 0.4
    """Probability that a lens has veiling glare (when it is one of several ``kinds``)."""
    glow_amplitude: tuple[float, float] = (0.02, 0.3)
    """Log-uniform. Peak linear value of the glow at intensity 1."""
    glow_width: tuple[float, float] = (0.02, 0.1)
    """Half-width ``w`` of the glow."""
    veil_level: tuple[float, float] = (0.2, 0.7)
    """Peak luminance of the veil at intensity 1, fraction of the absolute mask threshold."""
    veil_width: tuple[float, float] = (0.3, 1.5)
    """Half-width ``W`` of the veil (1 or more: it covers the frame)."""
    cast_level: tuple[float, float] = (0.0, 0.3)
    """Luminance of the uniform colour cast at intensity 1, fraction of the threshold."""
    saturation: tuple[float, float] = (0.05, 0.5)
    """Saturation of the veil's and cast's tint (any hue); the glow takes half of it."""


@dataclass
class VeilingGlare:
    """One lens's veiling glare (kind ``glare``; see :class:`VeilingGlareConfig`)."""

    glow_amplitude: float
    """Peak linear value of the glow at intensity 1."""
    glow_width: float
    """Half-width of the glow, fraction of the diagonal."""
    veil_level: float
    """Peak luminance of the veil at intensity 1, fraction of the absolute mask threshold."""
    veil_width: float
    """Half-width of the veil, fraction of the diagonal."""
    cast_level: float
    """Luminance of the uniform colour cast at intensity 1, fraction of the threshold."""
    tint: np.ndarray
    """[3] linear RGB tint of veil and cast (max 1); the glow's is half as saturated."""


def sample_veiling_glare(cfg: VeilingGlareConfig, rng: np.random.Generator) -> VeilingGlare:
    """Draw a veiling glare from ``cfg``'s ranges."""
    return VeilingGlare(
        glow_amplitude=_loguniform(rng, cfg.glow_amplitude),
        glow_width=_uniform(rng, cfg.glow_width), veil_level=_uniform(rng, cfg.veil_level),
        veil_width=_uniform(rng, cfg.veil_width), cast_level=_uniform(rng, cfg.cast_level),
        tint=hsv_rgb(rng.uniform(0, 360), _uniform(rng, cfg.saturation)))


def render_veiling_glare(p: VeilingGlare, light_xy: tuple[float, float],
                         size_hw: tuple[int, int], rgb: np.ndarray,
                         threshold: float) -> np.ndarray:
    """[H, W, 3] glow ``(1 + (d / w)^2)^-2`` + veil ``(1 + (d / W)^2)^-1`` + uniform cast.

    Veil and cast are set in units of the absolute mask ``threshold`` (luminance) and scaled
    down together where needed so that their sum stays below ``VEIL_CAP x threshold``: they
    lift a large area a little and never enter the mask on their own.
    """
    H, W = size_hw
    diag = float(np.hypot(H, W))
    tint = np.asarray(p.tint, np.float32)
    unit = tint * rgb / float(LUMA @ tint)  # luminance ~ that of rgb
    veil_rgb = p.veil_level * threshold * unit
    cast_rgb = p.cast_level * threshold * unit
    lum = float(LUMA @ (veil_rgb + cast_rgb))
    if lum > VEIL_CAP * threshold:
        scale = VEIL_CAP * threshold / lum
        veil_rgb, cast_rgb = veil_rgb * scale, cast_rgb * scale
    glow_rgb = p.glow_amplitude * (0.5 + 0.5 * tint) * rgb
    x2 = ((np.arange(W, dtype=np.float32) - np.float32(light_xy[0])) / np.float32(diag)) ** 2
    y2 = ((np.arange(H, dtype=np.float32) - np.float32(light_xy[1])) / np.float32(diag)) ** 2
    q = y2[:, None] + x2[None, :]  # (d / diagonal)^2
    g = 1 / (1 + q / np.float32(p.glow_width ** 2))
    veil = 1 / (1 + q / np.float32(p.veil_width ** 2))
    out = cv2.transform((g * g)[..., None], glow_rgb.astype(np.float32)[:, None])
    out += cv2.transform(veil[..., None], veil_rgb.astype(np.float32)[:, None])
    out += cast_rgb.astype(np.float32)
    return out
