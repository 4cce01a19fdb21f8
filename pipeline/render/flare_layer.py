"""Keep the photo's own detail inside its flare region: subtract a smooth flare layer.

Flare is light added to the scene's light. Much of it (veiling glare, the glow around a
light, dirty-aperture scatter) is smooth, and the scene's texture stays visible through it;
a fill (GN-FR, or photos warped by depth) has the scene's colours but rarely its finest
detail. So inside the blend region the de-flared photo is the photo minus a flare layer,

    layer = max(0, G_sigma * (photo - fill))          (linear light)
    out   = photo - layer

where G_sigma is a Gaussian of ``smooth`` x the long side. The layer is blurred over the
whole image with the zeros outside the blend region left in (not normalised by the mask),
so small or thin flare regions lose only part of their difference; on the development
scenes this beat a mask-normalised layer (docs/history/fill.md, "The flare layer: measured
(sixth session)").
Where the photo is clipped (the flare's saturated core) it holds no scene detail and the
fill stays. The layer is never negative: flare only adds light.

With ``local`` > 0 the layer is also capped by the photo's difference from the fill blurred at
that much smaller scale, ``min(G_smooth * d, G_local * d)``: the glow around a light falls off
faster than the wide Gaussian, which otherwise carries the core's large difference into the
dark surroundings and subtracts it there (a black halo around the light); detail finer than
the local scale is still kept.
"""

from __future__ import annotations

import numpy as np

from pipeline.colour import linear_to_srgb, srgb_to_linear

SMOOTH_SIZE = 256
"""The layer is blurred at this long side and resized back (it is smooth by construction;
this keeps a large Gaussian cheap on full-resolution photos)."""
CLIPPED = 0.95
"""A pixel with any channel at or above this (sRGB-encoded) counts as clipped."""


LOCAL_SIZE = 1024
"""Working long side of the ``local`` cap's blur: a few pixels wide, it needs more resolution
than the layer's, but not a full-resolution photo's (the same for decoded photos)."""


def lowpass(x: np.ndarray, smooth: float, size: int = SMOOTH_SIZE) -> np.ndarray:
    """[H, W, C] float32 blurred by a Gaussian of ``smooth`` x the long side (computed at a
    long side of ``size`` at most and resized back)."""
    import cv2

    h, w = x.shape[:2]
    k = min(1.0, size / max(h, w))
    small = x if k == 1 else cv2.resize(x, (max(1, round(w * k)), max(1, round(h * k))),
                                        interpolation=cv2.INTER_AREA)
    out = cv2.GaussianBlur(small, (0, 0), smooth * max(small.shape[:2]))
    if k < 1:
        out = cv2.resize(out, (w, h), interpolation=cv2.INTER_LINEAR)
    return out.reshape(x.shape)  # OpenCV drops a single channel


def layer_scale(cfg) -> float:
    """The flare layer's scale for a render config: ``flare_layer`` when only the flare
    region is blended (``blend mask``), 0 (off) when the whole image is rendered."""
    return cfg.flare_layer if cfg.blend == "mask" else 0.0


def clipped_pixels(photo_srgb: np.ndarray, channels: str = "any") -> np.ndarray:
    """[H, W] bool: pixels with ``channels`` ("any" or "all") at or above ``CLIPPED``, grown
    by a few pixels (the clipped core's blooming edge carries no detail either). "any" also
    counts a bright blue sky or a saturated colour; "all" only white (the flare's core)."""
    import cv2

    r = max(2, round(0.004 * max(photo_srgb.shape[:2])))
    top = photo_srgb.max(-1) if channels == "any" else photo_srgb.min(-1)
    hot = (top >= CLIPPED).astype(np.uint8)
    return cv2.dilate(hot, np.ones((2 * r + 1, 2 * r + 1), np.uint8)) > 0


ADAPT_LEVELS = 5
"""Widths an adaptive layer chooses from: ``smooth`` / 2**j, j < ADAPT_LEVELS."""


def adaptive_layer(diff: np.ndarray, region: np.ndarray, smooth: float, adapt: float
                   ) -> np.ndarray:
    """The flare layer with a width per connected part of ``region`` (8-connected): a part of
    area A gets a Gaussian of ``adapt`` x sqrt(A / pi) pixels, rounded to the nearest of
    ``smooth`` / 2**j of the long side (j < ADAPT_LEVELS) and never wider than ``smooth``. A
    compact ghost is then measured at its own scale, not averaged with the clean pixels
    around it; a wide glare keeps the wide layer. ``diff`` [H, W, 3] (zero outside the
    region); returns the blurred (signed) difference."""
    import cv2

    n, labels, stats, _ = cv2.connectedComponentsWithStats(region.astype(np.uint8),
                                                           connectivity=8)
    long_side = max(region.shape)
    want = adapt * np.sqrt(stats[:, cv2.CC_STAT_AREA] / np.pi) / (smooth * long_side)
    level = np.clip(np.round(-np.log2(np.maximum(want, 1e-9))), 0, ADAPT_LEVELS - 1)
    level = level.astype(int)
    out = np.zeros_like(diff)
    for j in np.unique(level[1:]):
        part = (level == j)[labels] & region
        out += lowpass(diff * part[..., None], smooth / 2**j)
    return out


def subtract_flare_layer(photo: np.ndarray, filled: np.ndarray, alpha: np.ndarray,
                         smooth: float, linear: bool = False,
                         local: float = 0.0, clipped: str = "any",
                         adapt: float = 0.0) -> np.ndarray:
    """The de-flared photo with the photo's detail kept inside the blend region.

    photo, filled: [H, W, 3] float in [0, 1], the photo and the photo with its flare
    region replaced by the fill (same encoding: sRGB, or linear light with ``linear``);
    alpha: [H, W] blend weight of the fill (0 outside the region). Returns the same
    encoding. ``smooth`` <= 0 returns ``filled`` unchanged. ``local`` > 0 caps the layer by
    the difference blurred at that fraction of the long side (at ``LOCAL_SIZE`` at most).
    ``clipped``: which pixels keep the fill (:func:`clipped_pixels`' ``channels``).
    ``adapt`` > 0: each connected part of the blend region gets its own layer width,
    ``adapt`` x its equivalent radius (at most ``smooth``; :func:`adaptive_layer`).
    """
    if smooth <= 0 or not (alpha > 0).any():
        return filled
    if linear:
        p, f = photo.astype(np.float32), filled.astype(np.float32)
        srgb = linear_to_srgb(p)
    else:
        p, f = srgb_to_linear(photo), srgb_to_linear(filled)
        srgb = photo
    d = p - f
    layer = (adaptive_layer(d, alpha > 0, smooth, adapt) if adapt > 0
             else lowpass(d, smooth))
    if local > 0:
        layer = np.minimum(layer, lowpass(d, local, LOCAL_SIZE))
    layer = np.maximum(layer, 0.0)
    w = (alpha * ~clipped_pixels(srgb, clipped)).astype(np.float32)[..., None]
    out = f * (1 - w) + np.clip(p - layer, 0.0, 1.0) * w
    return out if linear else linear_to_srgb(out)


def apply_flare_layer(photo: np.ndarray, filled: np.ndarray, alpha: np.ndarray, cfg,
                      linear: bool = False) -> np.ndarray:
    """:func:`subtract_flare_layer` with a render config's flare-layer settings (scale,
    ``flare_layer_local``, ``clipped``, ``flare_layer_adapt``): the one place the render's
    options reach it, for decoded-size and full-resolution de-flared photos alike."""
    return subtract_flare_layer(photo, filled, alpha, layer_scale(cfg), linear,
                                local=cfg.flare_layer_local, clipped=cfg.clipped,
                                adapt=cfg.flare_layer_adapt)
