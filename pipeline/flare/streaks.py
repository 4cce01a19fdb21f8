"""Kind ``streaks``: long streaks through the light, anamorphic or smeared.

An anamorphic streak, or smeared-lens / windshield streaks in one or several directions.

Its config (:class:`StreakConfig`), the parameters one lens draws (:class:`Streaks` of
:class:`Streak`, :func:`sample_streaks`) and the renderer (:func:`render_streaks`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.flare.common import _along_across, _line_band, _loguniform, _uniform, hsv_rgb


@dataclass
class StreakConfig:
    """Ranges of long broad streaks (kind ``streaks``) through the light: an anamorphic
    (horizontal, thin, bluish) streak, or smeared-lens / windshield streaks in one or several
    directions. Along a streak the light falls off as ``0.7 exp(-|s| / L) + 0.3 exp(-|s| /
    0.1 L)``; across it is Gaussian, its sigma widening as ``w (1 + spread |s| / L)``.
    Lengths and widths are fractions of the image diagonal."""

    prob: float = 0.35
    """Probability that a lens has streaks (when it is one of several ``kinds``)."""
    anamorphic_prob: float = 0.5
    """Probability that the streak is anamorphic rather than smeared."""
    anamorphic_tilt: float = 3.0
    """Largest tilt of an anamorphic streak from the horizontal (degrees)."""
    anamorphic_length: tuple[float, float] = (0.4, 2.0)
    """Log-uniform. Fall-off length ``L`` of an anamorphic streak (1 or more: it crosses the
    frame)."""
    anamorphic_width: tuple[float, float] = (0.001, 0.005)
    """Log-uniform. Sigma ``w`` across an anamorphic streak at the light (at least 0.6 px)."""
    anamorphic_hues: tuple[float, float] = (190.0, 235.0)
    """Hue range (degrees) of an anamorphic streak's tint (blues)."""
    anamorphic_saturation: tuple[float, float] = (0.2, 0.8)
    """Saturation of an anamorphic streak's tint."""
    count: tuple[int, int] = (1, 4)
    """Number of smeared streaks (directions uniform in angle), inclusive."""
    length: tuple[float, float] = (0.15, 1.0)
    """Log-uniform. Fall-off length ``L`` of a smeared streak."""
    width: tuple[float, float] = (0.004, 0.02)
    """Log-uniform. Sigma ``w`` across a smeared streak at the light."""
    spread: tuple[float, float] = (0.3, 3.0)
    """Widening of a smeared streak with distance (anamorphic streaks: a tenth of it)."""
    saturation: tuple[float, float] = (0.0, 0.3)
    """Saturation of a smeared streak's tint (any hue)."""
    amplitude: tuple[float, float] = (0.03, 0.4)
    """Log-uniform. Linear value at the light at intensity 1 (further smeared streaks x
    U(0.3, 1))."""


@dataclass
class Streak:
    """One streak through the light (see :class:`StreakConfig`)."""

    angle: float
    """Direction (radians; 0 = horizontal)."""
    length: float
    """Fall-off length ``L``, fraction of the diagonal."""
    width: float
    """Gaussian sigma ``w`` across it at the light, fraction of the diagonal."""
    spread: float
    """Widening with distance: sigma ``w (1 + spread |s| / L)``."""
    amplitude: float
    """Linear value at the light at intensity 1."""
    tint: np.ndarray
    """[3] linear RGB tint (max 1)."""


@dataclass
class Streaks:
    """One lens's streaks (kind ``streaks``)."""

    anamorphic: bool
    """One thin horizontal (anamorphic) streak, else smeared streaks."""
    streaks: list[Streak]


STREAK_FLOOR = 1e-5
"""Linear value below which a streak's tail is not drawn (far under any mask threshold)."""


def sample_streaks(cfg: StreakConfig, rng: np.random.Generator) -> Streaks:
    """Draw streaks from ``cfg``'s ranges: anamorphic (``anamorphic_prob``) or smeared."""
    if rng.random() < cfg.anamorphic_prob:
        tilt = np.deg2rad(rng.uniform(-cfg.anamorphic_tilt, cfg.anamorphic_tilt))
        return Streaks(anamorphic=True, streaks=[Streak(
            angle=float(tilt), length=_loguniform(rng, cfg.anamorphic_length),
            width=_loguniform(rng, cfg.anamorphic_width), spread=0.1 * _uniform(rng, cfg.spread),
            amplitude=_loguniform(rng, cfg.amplitude),
            tint=hsv_rgb(_uniform(rng, cfg.anamorphic_hues),
                         _uniform(rng, cfg.anamorphic_saturation)))])
    streaks: list[Streak] = []
    for i in range(int(rng.integers(cfg.count[0], cfg.count[1] + 1))):
        amp = (_loguniform(rng, cfg.amplitude) if i == 0
               else streaks[0].amplitude * rng.uniform(0.3, 1.0))
        streaks.append(Streak(
            angle=float(rng.uniform(0, np.pi)), length=_loguniform(rng, cfg.length),
            width=_loguniform(rng, cfg.width), spread=_uniform(rng, cfg.spread),
            amplitude=float(amp), tint=hsv_rgb(rng.uniform(0, 360), _uniform(rng, cfg.saturation))))
    return Streaks(anamorphic=False, streaks=streaks)


def render_streaks(p: Streaks, light_xy: tuple[float, float], size_hw: tuple[int, int],
                   rgb: np.ndarray) -> np.ndarray:
    """[H, W, 3] straight streaks through the light, both ways: along (distance ``s``)
    ``a (0.7 exp(-|s| / L) + 0.3 exp(-|s| / 0.1 L))``, across Gaussian with sigma
    ``w (1 + spread |s| / L)``; drawn until the value falls below ``STREAK_FLOOR``."""
    H, W = size_hw
    diag = float(np.hypot(H, W))
    out = np.zeros((H, W, 3), np.float32)
    for st in p.streaks:
        colour = (st.amplitude * np.asarray(st.tint) * rgb).astype(np.float32)
        L, w0 = max(st.length * diag, 1.0), max(st.width * diag, 0.6)
        reach = L * float(np.log(max(0.7 * float(colour.max()) / STREAK_FLOOR, 1.0)))
        if reach <= 0:
            continue
        half = 4 * w0 * (1 + st.spread * reach / L)
        ys, xs = _line_band(light_xy, st.angle, (-reach, reach), half, size_hw)
        if len(ys) == 0:
            continue
        s, d = _along_across(ys, xs, light_xy, st.angle)
        s = np.abs(s)
        w = np.float32(w0) * (1 + np.float32(st.spread / L) * s)
        along = 0.7 * np.exp(-s / np.float32(L)) + 0.3 * np.exp(-s / np.float32(0.1 * L))
        val = along * np.exp(-0.5 * (d / w) ** 2)
        out[ys, xs] += val[:, None] * colour
    return out
