"""A novel frame's pixels that none of its sources sees, filled from the rest of the frame.

Where a path camera looks past every source photo (above the photos' top edge on a turn,
beside the first photo of the tour), the points along its rays project outside every
source: GN-FR draws them from zero colours and features and paints a dark smear
(``gnfr.renderer.seen_share``). With ``RenderConfig.unseen_below`` such pixels are drawn
instead from the frame around them (OpenCV's Telea inpainting), blended in by how little of
the ray is seen."""

from __future__ import annotations

import numpy as np

SEEN_LONG_SIDE = 192
"""The seen share is computed on a grid this many pixels along the frame's long side and
resized to the frame: it changes only across the sources' frame edges, straight lines."""

INPAINT_RADIUS = 5
"""Telea's neighbourhood, in pixels of the frame."""


def seen_map(src, ids, camera, near: float, far: float, samples: int,
             long_side: int = SEEN_LONG_SIDE) -> np.ndarray:
    """[H, W] float32 in 0..1: the share of each pixel's ray (``samples`` depths between
    ``near`` and ``far``) inside at least one of the sources ``ids`` of the cache ``src``,
    for the path camera ``camera`` (K, c2w, width, height)."""
    import cv2
    import torch

    from gnfr.geometry import image_pixels, pixel_rays
    from gnfr.renderer import seen_share
    from pipeline.render.novel import low_res_camera

    W, H = int(camera.width), int(camera.height)
    K, w, h = low_res_camera(camera, min(1.0, long_side / max(W, H)))
    rays_o, rays_d = pixel_rays(torch.tensor(K, dtype=torch.float32),
                                torch.tensor(np.asarray(camera.c2w), dtype=torch.float32),
                                image_pixels(h, w))
    n = len(rays_o)
    share = seen_share(src, ids, rays_o, rays_d, torch.full((n,), float(near)),
                       torch.full((n,), float(far)), samples).numpy().reshape(h, w)
    if (w, h) == (W, H):
        return share.astype(np.float32)
    return np.clip(cv2.resize(share.astype(np.float32), (W, H),
                              interpolation=cv2.INTER_LINEAR), 0.0, 1.0)


def fill_unseen(image: np.ndarray, seen: np.ndarray, below: float) -> np.ndarray:
    """``image`` (uint8 or uint16 [H, W, 3]) with its pixels whose ``seen`` share lies under
    ``below`` inpainted from the pixels at or above it, blended in by ``1 - seen / below``
    (all of it where no sample is seen). Unchanged when no pixel lies under ``below``, or
    when every pixel does (nothing to draw from)."""
    import cv2

    if below <= 0:
        return image
    hole = seen < below
    if not hole.any() or hole.all():
        return image
    mask = hole.astype(np.uint8)
    if image.dtype == np.uint8:
        drawn = cv2.inpaint(image, mask, INPAINT_RADIUS, cv2.INPAINT_TELEA)
    else:  # 16-bit: Telea takes one channel at a time
        drawn = np.stack([cv2.inpaint(np.ascontiguousarray(image[..., c]), mask,
                                      INPAINT_RADIUS, cv2.INPAINT_TELEA)
                          for c in range(image.shape[2])], -1)
    w = np.clip(1.0 - seen / below, 0.0, 1.0)[..., None]
    out = image.astype(np.float64) * (1.0 - w) + drawn.astype(np.float64) * w
    return np.clip(np.rint(out), 0, np.iinfo(image.dtype).max).astype(image.dtype)
