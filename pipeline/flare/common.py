"""What every kind of flare shares: the mask rule's constants and colour and pixel helpers.

Colour helpers (spectra, black bodies, tints), random ranges, and pixel helpers (patches,
polygons, thin bands along a line).

The sRGB <-> linear pair is pipeline/colour.py's (the one pair of the project)."""

from __future__ import annotations

import colorsys

import cv2
import numpy as np

from pipeline.colour import LUMA

LAMBDA0 = 550.0  # nm, reference wavelength of the PSF grid
KINDS: tuple[str, ...] = ("starburst", "ghosts", "streaks", "glare", "scatter")
"""The kinds of flare a lens can combine (``FlareConfig.kinds``); see the package docstring
(pipeline/flare/__init__.py)."""
MASK_THRESHOLD = 0.012
"""The mask rule's absolute threshold: a pixel is flare where the linear-light luminance of
all the added flare (every kind summed, the core excluded) exceeds this, and also exceeds
``MASK_RELATIVE`` x the smoothed background luminance (``FlareConfig.mask_abs_threshold``)."""
MASK_RELATIVE = 0.1
"""The mask rule's relative threshold (``FlareConfig.mask_rel_threshold``)."""
VEIL_CAP = 0.8
"""The veiling glare's broad veil and colour cast together stay below this fraction of the
absolute mask threshold (in luminance) at any intensity, so they never enter the mask on
their own; only its glow near the light does."""


def to_float_image(image: np.ndarray) -> np.ndarray:
    """[H, W, 3] uint8 (0-255) or float (0-1) -> float32 in [0, 1]."""
    image = np.asarray(image)
    if image.dtype == np.uint8:
        return image.astype(np.float32) / 255.0
    return np.clip(image.astype(np.float32), 0.0, 1.0)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """[H, W, 3] linear RGB -> [H, W] float32 luminance (Rec. 709 weights)."""
    rgb = np.ascontiguousarray(rgb, np.float32)
    return cv2.transform(rgb, LUMA[None]).reshape(rgb.shape[:-1])


def spectral_response(wavelengths: np.ndarray) -> np.ndarray:
    """[3, L] approximate camera R, G, B sensitivities (Gaussian bands) at ``wavelengths`` nm."""
    centres = np.array([600.0, 535.0, 455.0])[:, None]
    widths = np.array([38.0, 40.0, 30.0])[:, None]
    r = np.exp(-0.5 * ((wavelengths[None] - centres) / widths) ** 2)
    r[0] += 0.15 * np.exp(-0.5 * ((wavelengths - 440.0) / 20.0) ** 2)  # red's blue bump
    return r


def blackbody_rgb(temperature: float) -> np.ndarray:
    """[3] linear RGB of a black body at ``temperature`` K through :func:`spectral_response`,
    relative to a 6500 K source (so 6500 K is white) and scaled to max 1."""
    lam = np.linspace(380.0, 740.0, 73)
    resp = spectral_response(lam)

    def planck(t: float) -> np.ndarray:
        lm = lam * 1e-9
        return 1.0 / (lm ** 5 * (np.exp(1.4388e-2 / (lm * t)) - 1.0))

    rgb = (resp @ planck(temperature)) / (resp @ planck(6500.0))
    return (rgb / rgb.max()).astype(np.float32)


def hsv_rgb(hue_deg: float, sat: float) -> np.ndarray:
    """[3] a linear-RGB tint of a hue (degrees) and saturation, max channel 1."""
    return np.array(colorsys.hsv_to_rgb((hue_deg % 360) / 360.0, sat, 1.0), np.float32)


def _uniform(rng: np.random.Generator, r: tuple[float, float]) -> float:
    return float(rng.uniform(r[0], r[1]))


def _loguniform(rng: np.random.Generator, r: tuple[float, float]) -> float:
    return float(np.exp(rng.uniform(np.log(r[0]), np.log(r[1]))))


def _polygon_gauge(x: np.ndarray, y: np.ndarray, blades: int, rotation: float
                   ) -> tuple[np.ndarray, float]:
    """(gauge, apothem factor): a circle (blades 0) or regular n-gon of circumradius ``r``
    is ``gauge <= r * factor``; ``gauge - r * factor`` is an approximate signed distance
    (pixels, negative inside). ``x``, ``y`` broadcast (float32)."""
    if blades == 0:
        return np.sqrt(x * x + y * y), 1.0
    angles = rotation + 2 * np.pi * np.arange(blades) / blades
    proj = x * float(np.cos(angles[0])) + y * float(np.sin(angles[0]))
    for a in angles[1:]:
        np.maximum(proj, x * float(np.cos(a)) + y * float(np.sin(a)), out=proj)
    return proj, float(np.cos(np.pi / blades))


def _paste(dst: np.ndarray, patch: np.ndarray, x0: int, y0: int) -> None:
    """Add ``patch`` [h, w, C] into ``dst`` [H, W, C] with its top-left at (x0, y0), clipped."""
    H, W = dst.shape[:2]
    h, w = patch.shape[:2]
    xa, ya, xb, yb = max(x0, 0), max(y0, 0), min(x0 + w, W), min(y0 + h, H)
    if xa < xb and ya < yb:
        dst[ya:yb, xa:xb] += patch[ya - y0:yb - y0, xa - x0:xb - x0]


def _scalar(rgb: np.ndarray) -> tuple[float, float, float, float]:
    """[3] -> an OpenCV per-channel scalar."""
    return (float(rgb[0]), float(rgb[1]), float(rgb[2]), 0.0)


def _line_band(origin: tuple[float, float], angle: float, s_range: tuple[float, float],
               half_width: float, size_hw: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(ys, xs) int arrays [P]: each pixel of the frame (once) within about ``half_width``
    pixels of the line through ``origin`` at ``angle``, from ``s_range[0]`` to ``s_range[1]``
    pixels along it (plus ``half_width`` at both ends)."""
    H, W = size_hw
    ux, uy = float(np.cos(angle)), float(np.sin(angle))
    steep = abs(uy) > abs(ux)  # march along the axis the line is closer to
    om, on_, um, un, nm, nn = ((origin[1], origin[0], uy, ux, H, W) if steep
                               else (origin[0], origin[1], ux, uy, W, H))
    ends = [om + s_range[0] * um, om + s_range[1] * um]
    lo = max(int(np.floor(min(ends) - half_width)), 0)
    hi = min(int(np.ceil(max(ends) + half_width)), nm - 1)
    if lo > hi:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    m = np.arange(lo, hi + 1)
    b = int(np.ceil(half_width / abs(um))) + 1  # |um| >= 0.7: the band across, in pixels
    if 2 * b + 1 >= nn:
        n = np.broadcast_to(np.arange(nn)[None], (len(m), nn))
    else:
        centre = np.round(on_ + (m - om) * (un / um))
        n = np.clip(centre, -2 * b, nn + 2 * b).astype(np.int64)[:, None] + np.arange(-b, b + 1)
    m = np.broadcast_to(m[:, None], n.shape)
    ok = (n >= 0) & (n < nn)
    m, n = m[ok], n[ok]
    return (m, n) if steep else (n, m)


def _along_across(ys: np.ndarray, xs: np.ndarray, origin: tuple[float, float],
                  angle: float) -> tuple[np.ndarray, np.ndarray]:
    """float32 [P] (distance along the direction ``angle``, signed distance across it) of
    pixels from ``origin``."""
    dx = xs.astype(np.float32) - np.float32(origin[0])
    dy = ys.astype(np.float32) - np.float32(origin[1])
    c, s = np.float32(np.cos(angle)), np.float32(np.sin(angle))
    return dx * c + dy * s, dy * c - dx * s
