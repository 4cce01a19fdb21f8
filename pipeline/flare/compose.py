"""A lens rendered at a light with its exact mask, and composited onto a photo.

Every kind summed, the light's core, the mask rule; :func:`synthesize` makes one training
composite."""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from pipeline.colour import image_to_linear, linear_to_srgb
from pipeline.flare.common import _loguniform, _paste, _uniform, luminance
from pipeline.flare.config import FlareConfig
from pipeline.flare.ghosts import render_ghost_chain
from pipeline.flare.glare import render_veiling_glare
from pipeline.flare.lens import Lens, sample_lens
from pipeline.flare.scatter import _render_lens_scatter
from pipeline.flare.starburst import render_starburst
from pipeline.flare.streaks import render_streaks


@dataclass
class FlareLayers:
    """What :func:`render_flare` returns; all linear light."""

    flare: np.ndarray
    """[H, W, 3] float32: every kind of flare summed, the core excluded."""
    core: np.ndarray
    """[H, W, 3] float32: the light source itself."""
    mask: np.ndarray
    """[H, W] bool: ground-truth flare occupancy (visible flare, core excluded)."""
    light_xy: tuple[float, float] = (0.0, 0.0)
    """Light position in pixels (x right, y down; may be outside the frame)."""
    ghost_xy: list[tuple[float, float]] = field(default_factory=list)
    """Centres of the ``scatter`` kind's ghosts in pixels, in ``lens.ghosts`` order."""
    kinds: tuple[str, ...] = ()
    """The kinds of flare summed in ``flare`` (the lens's)."""


def _render_core(lens: Lens, light_xy, size_hw, diag: float) -> np.ndarray:
    """[H, W, 3] the light's saturated disc (zero when the light is outside the frame)."""
    core = np.zeros((*size_hw, 3), np.float32)
    r = lens.core_radius * diag
    half = int(np.ceil(r + 2))
    cx, cy = int(round(light_xy[0])), int(round(light_xy[1]))
    yy, xx = np.mgrid[cy - half:cy + half + 1, cx - half:cx + half + 1].astype(np.float32)
    d = np.sqrt((xx - light_xy[0]) ** 2 + (yy - light_xy[1]) ** 2)
    alpha = np.clip(r + 0.5 - d, 0, 1)[..., None]
    tint = 0.5 + 0.5 * lens.light_rgb  # the core reads close to white
    _paste(core, alpha * lens.core_level * tint, cx - half, cy - half)
    return core


def mask_threshold(cfg: FlareConfig, size_hw: tuple[int, int],
                   background_linear: np.ndarray | None = None) -> np.float32 | np.ndarray:
    """The mask rule's threshold on the flare's linear luminance: ``cfg.mask_abs_threshold``
    (default ``MASK_THRESHOLD``) alone, or with a background [H, W, 3] (linear light) the
    per-pixel [H, W] ``max(abs, mask_rel_threshold x background luminance)``, the background
    luminance first smoothed (Gaussian, ``mask_smooth`` x diagonal) so masks follow regions,
    not texture."""
    thr = np.float32(cfg.mask_abs_threshold)
    if background_linear is not None:
        bg = _smooth(luminance(background_linear), cfg.mask_smooth * float(np.hypot(*size_hw)))
        thr = np.maximum(thr, np.float32(cfg.mask_rel_threshold) * bg)
    return thr


def flare_mask(flare: np.ndarray, core: np.ndarray, cfg: FlareConfig,
               background_linear: np.ndarray | None = None) -> np.ndarray:
    """[H, W] bool: linear flare luminance > :func:`mask_threshold`, minus the core
    (wherever ``core`` is non-zero). ``flare`` is all the added flare, every kind summed."""
    thr = mask_threshold(cfg, flare.shape[:2], background_linear)
    core_any = cv2.transform(np.ascontiguousarray(core), np.ones((1, 3), np.float32)) > 0
    return (luminance(flare) > thr) & ~core_any.reshape(core.shape[:2])


def _smooth(x: np.ndarray, sigma: float) -> np.ndarray:
    """[H, W] Gaussian blur with ``sigma`` pixels, done at reduced resolution when wide."""
    if sigma <= 0.3:
        return x
    f = max(int(sigma // 2), 1)
    H, W = x.shape
    if f == 1 or min(H, W) < 8 * f:
        return cv2.GaussianBlur(x, (0, 0), sigma)
    small = cv2.resize(x, (W // f, H // f), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), sigma / f)
    return cv2.resize(small, (W, H), interpolation=cv2.INTER_LINEAR)


def render_flare(lens: Lens, light_xy: tuple[float, float], size_hw: tuple[int, int],
                 rng: np.random.Generator | None = None, intensity: float | None = None,
                 background_linear: np.ndarray | None = None,
                 center_xy: tuple[float, float] | None = None) -> FlareLayers:
    """Render ``lens`` for a point light at pixel ``light_xy`` (may be outside the frame).

    Every kind of ``lens.kinds`` (:func:`render_kind`) is added up into ``flare``; the mask
    is :func:`flare_mask` of that sum. ``intensity`` scales every kind (default 1; the core
    is the light itself and stays saturated). ``background_linear`` [H, W, 3] (the clean
    photo in linear light) only sets the mask's relative threshold. ``center_xy`` is the
    optical centre (default the image centre; pass the principal point). ``rng`` draws the
    per-render ghost flicker (``cfg.ghost_flicker``); None means no flicker.
    """
    H, W = size_hw
    k = 1.0 if intensity is None else float(intensity)
    lx, ly = float(light_xy[0]), float(light_xy[1])
    cx, cy = ((W - 1) / 2, (H - 1) / 2) if center_xy is None else center_xy
    flare, ghost_xy = None, []
    for kind in lens.kinds:
        if kind == "scatter":
            layer, ghost_xy = _render_lens_scatter(lens, (lx, ly), size_hw, k, (cx, cy), rng)
        else:
            layer = render_kind(lens, kind, (lx, ly), size_hw, rng, k, (cx, cy))
        flare = layer if flare is None else flare + layer
    if flare is None:
        flare = np.zeros((H, W, 3), np.float32)
    core = _render_core(lens, (lx, ly), size_hw, float(np.hypot(H, W)))
    mask = flare_mask(flare, core, lens.cfg, background_linear)
    return FlareLayers(flare=flare, core=core, mask=mask, light_xy=(lx, ly), ghost_xy=ghost_xy,
                       kinds=tuple(lens.kinds))


def render_kind(lens: Lens, kind: str, light_xy: tuple[float, float],
                size_hw: tuple[int, int], rng: np.random.Generator | None = None,
                intensity: float | None = None,
                center_xy: tuple[float, float] | None = None) -> np.ndarray:
    """[H, W, 3] float32: the linear light one kind of ``lens`` adds (arguments as in
    :func:`render_flare`; ``kind`` must be one of ``lens.kinds``)."""
    H, W = size_hw
    k = 1.0 if intensity is None else float(intensity)
    light = (float(light_xy[0]), float(light_xy[1]))
    centre = ((W - 1) / 2, (H - 1) / 2) if center_xy is None else center_xy
    if kind == "scatter":
        return _render_lens_scatter(lens, light, size_hw, k, centre, rng)[0]
    p = lens.kind_params[kind]
    rgb = (k * np.asarray(lens.light_rgb, np.float32)).astype(np.float32)
    if kind == "starburst":
        return render_starburst(p, light, size_hw, rgb)
    if kind == "ghosts":
        return render_ghost_chain(p, light, centre, size_hw, rgb, rng, lens.cfg.ghost_flicker)
    if kind == "streaks":
        return render_streaks(p, light, size_hw, rgb)
    if kind == "glare":
        return render_veiling_glare(p, light, size_hw, rgb, lens.cfg.mask_abs_threshold)
    raise ValueError(f"unknown flare kind {kind!r}")


def apply_flare(image_srgb: np.ndarray, layers: FlareLayers,
                rng: np.random.Generator | None = None, noise: float = 0.0,
                gain: float = 1.0) -> np.ndarray:
    """Composite flare onto a photo: ``srgb(clip(gain * (linear(photo) + flare + core) +
    noise))``.

    ``image_srgb`` [H, W, 3] uint8 (0-255) or float in [0, 1]; returns float32 sRGB in
    [0, 1] whatever the input dtype (callers quantise). ``noise`` is the std of Gaussian
    noise in linear light (needs ``rng``).
    """
    return _composite(image_to_linear(image_srgb), layers, rng, noise, gain)


def _composite(linear: np.ndarray, layers: FlareLayers, rng: np.random.Generator | None,
               noise: float, gain: float) -> np.ndarray:
    out = linear + layers.flare
    out += layers.core
    if gain != 1.0:
        out *= np.float32(gain)
    if noise > 0:
        if rng is None:
            raise ValueError("apply_flare: noise > 0 needs an rng")
        cv2.setRNGSeed(int(rng.integers(2 ** 31)))  # OpenCV's Gaussian RNG is ~3x faster
        n = np.empty_like(out)
        cv2.randn(n, 0.0, float(noise))
        out += n
    return linear_to_srgb(out)


def sample_light_xy(cfg: FlareConfig, size_hw: tuple[int, int],
                    rng: np.random.Generator) -> tuple[float, float]:
    """A light position: uniform in the frame, or (``light_outside_prob``) just outside it."""
    H, W = size_hw
    if rng.random() < cfg.light_outside_prob:
        m = cfg.light_outside_margin * float(np.hypot(H, W))
        while True:
            x, y = rng.uniform(-m, W + m), rng.uniform(-m, H + m)
            if not (0 <= x < W and 0 <= y < H):
                return float(x), float(y)
    return float(rng.uniform(0, W)), float(rng.uniform(0, H))


def sample_intensity(cfg: FlareConfig, rng: np.random.Generator) -> float:
    """A flare intensity, log-uniform in ``cfg.intensity`` (one draw of ``rng``)."""
    return _loguniform(rng, cfg.intensity)


def synthesize(image_srgb: np.ndarray, cfg: FlareConfig, rng: np.random.Generator,
               light_xy: tuple[float, float] | None = None
               ) -> tuple[np.ndarray, FlareLayers]:
    """One training composite: a fresh lens, light, intensity, gain and noise from ``cfg``.

    ``image_srgb`` [H, W, 3] uint8 or float in [0, 1]. Returns (flared sRGB float32 [H, W, 3]
    in [0, 1], the layers). The mask's threshold is relative to the photo's brightness.
    """
    linear = image_to_linear(image_srgb)
    H, W = linear.shape[:2]
    lens = sample_lens(cfg, rng)
    if light_xy is None:
        light_xy = sample_light_xy(cfg, (H, W), rng)
    k = sample_intensity(cfg, rng)
    gain = _uniform(rng, cfg.gain)
    noise = _uniform(rng, cfg.noise)
    layers = render_flare(lens, light_xy, (H, W), rng, k, linear)
    return _composite(linear, layers, rng, noise, gain), layers
