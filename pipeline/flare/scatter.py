"""Kind ``scatter``: the dirty-aperture lens (PSF scattering, a few ghosts and a small halo).

Apertures with dust and scratches, their RGB point-spread functions by Fraunhofer optics
(the package docstring), the PSF bank built once per bank configuration and cached in memory
and on disk (``$DEFLARE_CACHE`` or ``~/.cache/deflare-scene``), and the renderer of a lens's
scatter layer (:func:`_render_lens_scatter`)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from pipeline.colour import fast_pow as _pow
from pipeline.flare.common import (
    LAMBDA0,
    _loguniform,
    _paste,
    _polygon_gauge,
    _scalar,
    _uniform,
    spectral_response,
)
from pipeline.flare.config import FlareConfig
from pipeline.flare.ghosts import _ghost_patch

if TYPE_CHECKING:
    from pipeline.flare.lens import Lens


def _polygon_sdf(x: np.ndarray, y: np.ndarray, radius: float, blades: int,
                 rotation: float) -> np.ndarray:
    """Approximate signed distance (pixels, negative inside) to a circle (blades 0) or a
    regular n-gon of circumradius ``radius``."""
    gauge, factor = _polygon_gauge(x, y, blades, rotation)
    return gauge - np.float32(radius * factor)


def make_aperture(size: int, radius: float, blades: int, cfg: FlareConfig,
                  rng: np.random.Generator) -> np.ndarray:
    """[size, size] float32 transmission of a dirty aperture (antialiased shape x dust x
    scratches); ``radius`` in pixels, centred on the grid."""
    c = (size - 1) / 2.0
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32) - c
    shape = np.clip(0.5 - _polygon_sdf(xx, yy, radius, blades, rng.uniform(0, np.pi)), 0, 1)
    absorb = np.zeros((size, size), np.float32)
    sh = 16  # cv2 fixed-point shift for sub-pixel drawing
    for _ in range(int(rng.integers(cfg.dust_count[0], cfg.dust_count[1] + 1))):
        r = radius * _loguniform(rng, cfg.dust_radius)
        p = c + rng.uniform(-1, 1, 2) * radius
        cv2.circle(absorb, tuple(int(v * sh) for v in p), max(int(r * sh), 1),
                   float(rng.uniform(0.3, 1.0)), -1, cv2.LINE_AA, shift=4)
    for _ in range(int(rng.integers(cfg.scratch_count[0], cfg.scratch_count[1] + 1))):
        pts = _scratch_points(c, radius, rng)
        w = _uniform(rng, cfg.scratch_width)
        cv2.polylines(absorb, [np.round(pts * sh).astype(np.int32)], False,
                      float(rng.uniform(0.5, 1.0)) * min(w, 1.0), max(int(round(w)), 1),
                      cv2.LINE_AA, shift=4)
    return (shape * (1.0 - np.clip(absorb, 0, 1))).astype(np.float32)


def _scratch_points(c: float, radius: float, rng: np.random.Generator) -> np.ndarray:
    """[P, 2] a gently curved scratch (quadratic Bezier) crossing part of the aperture."""
    p0 = c + rng.uniform(-1, 1, 2) * radius
    ang = rng.uniform(0, np.pi)
    length = radius * rng.uniform(0.3, 2.0)
    p2 = p0 + length * np.array([np.cos(ang), np.sin(ang)])
    p1 = (p0 + p2) / 2 + rng.normal(0, 0.15 * length, 2)
    s = np.linspace(0, 1, 24)[:, None]
    return (1 - s) ** 2 * p0 + 2 * (1 - s) * s * p1 + s ** 2 * p2


def aperture_psf(aperture: np.ndarray, defocus: float, cfg: FlareConfig) -> np.ndarray:
    """[S, S, 3] float32 RGB PSF of a pupil (see the package docstring); each channel sums 1.

    ``aperture`` [a, a] transmission (a <= S) is zero-padded to the S x S FFT grid (padding
    position changes only a phase ramp, not ``|FFT|^2``); ``defocus`` in waves at 550 nm.
    """
    from scipy import fft as sfft

    S, a = cfg.psf_size, aperture.shape[0]
    yy, xx = np.mgrid[0:a, 0:a].astype(np.float32) - (a - 1) / 2.0
    rho2 = (xx * xx + yy * yy) / (cfg.aperture_radius * S) ** 2
    zern = (2.0 * rho2 - 1.0).astype(np.float32)
    lams = np.linspace(380.0, 740.0, cfg.n_wavelengths)
    resp = spectral_response(lams)  # [3, L]
    out = np.zeros((S, S, 3), np.float64)
    c = S // 2  # fftshift puts the zero frequency here
    for i, lam in enumerate(lams):
        field_ = aperture * np.exp(1j * (2 * np.pi * defocus * LAMBDA0 / lam) * zern)
        psf = np.abs(sfft.fft2(field_.astype(np.complex64), s=(S, S), workers=1)) ** 2
        psf = np.fft.fftshift(psf).astype(np.float32)
        psf /= psf.sum()
        s = lam / LAMBDA0  # the grid pitch grows with lambda: magnify about the centre
        m = np.array([[s, 0, (1 - s) * c], [0, s, (1 - s) * c]], np.float32)
        psf = cv2.warpAffine(psf, m, (S, S), flags=cv2.INTER_LINEAR) / (s * s)
        out += psf[..., None] * resp[:, i]
    out = np.maximum(out, 0)
    return (out / out.sum(axis=(0, 1), keepdims=True)).astype(np.float32)


_BANKS: dict[str, np.ndarray] = {}


def cache_dir() -> Path:
    """Where PSF banks are cached: ``$DEFLARE_CACHE`` or ``~/.cache/deflare-scene``."""
    env = os.environ.get("DEFLARE_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "deflare-scene"


def build_psf_bank(cfg: FlareConfig, progress: bool = False) -> np.ndarray:
    """[n_psfs, S, S, 3] float32 RGB PSFs of random dirty apertures (not cached)."""
    rng = np.random.default_rng([cfg.bank_seed, 7919])
    S = cfg.psf_size
    radius = cfg.aperture_radius * S
    a = int(2 * np.ceil(radius) + 4)
    bank = np.zeros((cfg.n_psfs, S, S, 3), np.float32)
    items = range(cfg.n_psfs)
    if progress:
        from pipeline.progress import track
        items = track(items, "Building lens PSF bank (once)")
    for k in items:
        blades = int(rng.choice(cfg.aperture_blades))
        ap = make_aperture(a, radius, blades, cfg, rng)
        bank[k] = aperture_psf(ap, _uniform(rng, cfg.defocus_waves), cfg)
    return bank


def psf_bank(cfg: FlareConfig, progress: bool = False) -> np.ndarray:
    """The cached PSF bank of ``cfg`` ([n_psfs, S, S, 3] float32), built on first use."""
    key = cfg.bank_key()
    if key in _BANKS:
        return _BANKS[key]
    path = cache_dir() / f"psf_bank_{key}.npz"
    bank = None
    if path.is_file():
        try:
            with np.load(path) as z:
                bank = z["psfs"].astype(np.float32)
        except (OSError, ValueError, KeyError):
            bank = None  # a damaged cache file is rebuilt
    if bank is None or bank.shape != (cfg.n_psfs, cfg.psf_size, cfg.psf_size, 3):
        bank = build_psf_bank(cfg, progress)
        _save_bank(path, bank, cfg)
    _BANKS[key] = bank
    return bank


def _save_bank(path: Path, bank: np.ndarray, cfg: FlareConfig) -> None:
    from pipeline.workspace import atomic_path

    try:
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, psfs=bank, config=json.dumps(cfg.bank_fields()))
    except OSError:  # a read-only cache only costs a rebuild next time
        pass


def _render_scatter(lens: Lens, light_xy, size_hw, diag: float) -> np.ndarray:
    """[H, W, 3] the lens's PSF rotated, scaled and centred on the light (flux not applied)."""
    psf = psf_bank(lens.cfg)[lens.psf_index]
    S = psf.shape[0]
    z = lens.psf_extent * diag / S
    cos, sin = z * np.cos(lens.psf_rotation), z * np.sin(lens.psf_rotation)
    c = S // 2
    m = np.array([[cos, -sin, light_xy[0] - cos * c + sin * c],
                  [sin, cos, light_xy[1] - sin * c - cos * c]], np.float32)
    return cv2.warpAffine(psf, m, (size_hw[1], size_hw[0]), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def _render_glare(lens: Lens, light_xy, size_hw, diag: float) -> np.ndarray:
    """[H, W] glare falloff ``(1 + (d / w)^2)^-1.5`` around the light, peak 1."""
    H, W = size_hw
    w = lens.glare_width * diag
    x = ((np.arange(W, dtype=np.float32) - light_xy[0]) / w) ** 2
    y = ((np.arange(H, dtype=np.float32) - light_xy[1]) / w) ** 2
    return _pow(1.0 + y[:, None] + x[None, :], -1.5)


def _render_lens_scatter(lens: Lens, light_xy: tuple[float, float], size_hw: tuple[int, int],
                         k: float, center_xy: tuple[float, float],
                         rng: np.random.Generator | None
                         ) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """The ``scatter`` kind: ([H, W, 3] PSF scatter + the lens's ghosts + its halo, the
    ghosts' centres), exactly as the synthesizer rendered before kinds existed."""
    diag = float(np.hypot(*size_hw))
    (lx, ly), (cx, cy) = light_xy, center_xy
    flare = _render_scatter(lens, (lx, ly), size_hw, diag)  # [H, W, 3]
    flare = cv2.multiply(flare, _scalar(lens.light_rgb * (k * lens.scatter_flux)))
    glare_rgb = k * lens.glare_amplitude * lens.glare_tint * lens.light_rgb  # [3]
    glare = _render_glare(lens, (lx, ly), size_hw, diag)  # [H, W]
    flare += cv2.transform(glare[..., None], glare_rgb.astype(np.float32)[:, None])
    ghost_xy = []
    for g in lens.ghosts:
        gx, gy = cx + g.t * (lx - cx), cy + g.t * (ly - cy)
        ghost_xy.append((gx, gy))
        amp = g.amplitude * k
        if rng is not None and lens.cfg.ghost_flicker > 0:
            amp *= float(np.exp(rng.normal(0, lens.cfg.ghost_flicker)))
        radius = g.radius * diag * (0.35 + abs(g.t))
        patch = _ghost_patch(g, radius, lens.blades, lens.blade_rotation)
        half = patch.shape[0] // 2
        _paste(flare, patch * (amp * lens.light_rgb), int(round(gx)) - half,
               int(round(gy)) - half)
    return flare, ghost_xy
