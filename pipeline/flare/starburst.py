"""Kind ``starburst``: aperture-diffraction spikes from the light, evenly spaced in angle.

Its config (:class:`StarburstConfig`, the ranges), the parameters one lens draws from it
(:class:`Starburst`, :func:`sample_starburst`) and the renderer of the linear light it adds
(:func:`render_starburst`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.flare.common import _along_across, _line_band, _loguniform, _uniform, hsv_rgb


@dataclass
class StarburstConfig:
    """Ranges of the aperture-diffraction starburst (kind ``starburst``): thin spikes from the
    light, evenly spaced in angle. Lengths and widths are fractions of the image diagonal."""

    prob: float = 0.5
    """Probability that a lens has a starburst (when it is one of several ``kinds``)."""
    spikes: tuple[int, int] = (4, 18)
    """Number of spikes (rays from the light), inclusive."""
    angle_jitter: float = 0.03
    """Std (radians) of each spike's angle about the even spacing."""
    length: tuple[float, float] = (0.05, 0.5)
    """Log-uniform. Length ``L`` of the longest spike (green channel)."""
    length_spread: tuple[float, float] = (0.0, 0.6)
    """How unequal the spikes are: each is ``L x U(1 - spread, 1)`` long."""
    width: tuple[float, float] = (0.0008, 0.004)
    """Log-uniform. Gaussian sigma across a spike at the light (at least 0.6 pixel); spikes
    taper to half of it at their tips."""
    sharpness: tuple[float, float] = (1.0, 4.0)
    """Exponent ``p`` of the fall-off along a spike, ``(1 - s / L)^p``: high is bright near the
    light and faint along most of the spike."""
    amplitude: tuple[float, float] = (0.08, 1.0)
    """Log-uniform. Linear value of a spike at the light, at intensity 1."""
    chroma: tuple[float, float] = (0.0, 0.12)
    """Colour fringes: red spikes are ``1 + chroma`` times as long as green, blue ``1 - chroma``."""
    saturation: tuple[float, float] = (0.0, 0.2)
    """Saturation of a random tint of the whole starburst."""


@dataclass
class Starburst:
    """One lens's diffraction starburst (kind ``starburst``; see :class:`StarburstConfig`)."""

    angles: list[float]
    """Direction of each spike (radians; x right, y down)."""
    lengths: list[float]
    """Length of each spike (green channel), fraction of the diagonal."""
    width: float
    """Gaussian sigma across the spikes at the light, fraction of the diagonal."""
    sharpness: float
    """Exponent ``p`` of the fall-off ``(1 - s / L)^p`` along a spike."""
    amplitude: float
    """Linear value at the light at intensity 1."""
    chroma: float
    """Red spikes are ``1 + chroma`` times as long as green, blue ``1 - chroma``."""
    tint: np.ndarray
    """[3] linear RGB tint (max 1)."""


def sample_starburst(cfg: StarburstConfig, rng: np.random.Generator) -> Starburst:
    """Draw a starburst from ``cfg``'s ranges."""
    n = int(rng.integers(cfg.spikes[0], cfg.spikes[1] + 1))
    angles = (rng.uniform(0, 2 * np.pi) + 2 * np.pi * np.arange(n) / n
              + rng.normal(0.0, cfg.angle_jitter, n))
    longest = _loguniform(rng, cfg.length)
    spread = _uniform(rng, cfg.length_spread)
    return Starburst(
        angles=angles.tolist(), lengths=(longest * rng.uniform(1 - spread, 1, n)).tolist(),
        width=_loguniform(rng, cfg.width), sharpness=_uniform(rng, cfg.sharpness),
        amplitude=_loguniform(rng, cfg.amplitude), chroma=_uniform(rng, cfg.chroma),
        tint=hsv_rgb(rng.uniform(0, 360), _uniform(rng, cfg.saturation)))


def render_starburst(p: Starburst, light_xy: tuple[float, float], size_hw: tuple[int, int],
                     rgb: np.ndarray) -> np.ndarray:
    """[H, W, 3] spikes from the light: along a spike (distance ``s``, channel length
    ``L_c``) ``a (1 - s / L_c)^p``, across it Gaussian with sigma ``w (1 - s / 2 L_c)``;
    rounded at the light."""
    H, W = size_hw
    diag = float(np.hypot(H, W))
    out = np.zeros((H, W, 3), np.float32)
    w0 = max(p.width * diag, 0.6)
    colour = (p.amplitude * np.asarray(p.tint) * rgb).astype(np.float32)
    stretch = (1 + p.chroma, 1.0, 1 - p.chroma)
    for angle, length in zip(p.angles, p.lengths, strict=True):
        L = max(length * diag, 1.0)
        ys, xs = _line_band(light_xy, angle, (0.0, L * max(stretch)), 4 * w0, size_hw)
        if len(ys) == 0:
            continue
        s, d = _along_across(ys, xs, light_xy, angle)
        d2 = d * d + np.minimum(s, 0) ** 2  # behind the light: distance to the light
        s = np.maximum(s, 0)
        for c in range(3):
            t = np.minimum(s / np.float32(L * stretch[c]), 1)
            w = np.float32(w0) * (1 - 0.5 * t)
            val = (1 - t) ** np.float32(p.sharpness) * np.exp(-0.5 * d2 / (w * w))
            out[ys, xs, c] += colour[c] * val
    return out
