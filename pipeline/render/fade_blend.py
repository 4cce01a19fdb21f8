"""How a frame's renders with other frames' sources are cross-faded into it
(``RenderConfig.source_fade``, ``RenderConfig.fade_blend``).

A frame near a change of sources is rendered once with its own choice and once with each
other choice in its window (``plan.fade_sources``); the renders are of one camera, but each
choice of sources puts the scene's edges a little elsewhere (its depth, its photos). Three
ways to join them:

- ``mix``: the weighted mean, pixel by pixel. Where the renders are misaligned this is a
  double image (the fifty-third session's kermit, docs/history/fill.md).
- ``align``: each other render is first warped onto the frame's own by the optical flow
  between them (OpenCV's DIS), so the colours are faded over the frame's own geometry.
- ``morph``: both are warped to the geometry in between, the weighted mean of the flows
  (view morphing, as frame interpolation does it: each image is sampled at the flow's
  fraction from the output pixel), so the geometry moves over the fade's frames as the
  colours do.

The flow between two renders is kept only where it passes a forward-backward check (the
two flows cancel to within ``CONSISTENT``); elsewhere it is zero, and the renders are mixed
there as ``mix`` does.
"""

from __future__ import annotations

import numpy as np

MODES = ("mix", "align", "morph")

CONSISTENT = (0.01, 0.5)
"""A flow is kept where |f + b|^2 < 0.01 (|f|^2 + |b|^2) + 0.5 (pixels^2), b the flow back
sampled where f lands (Sundaram et al.'s check)."""


def _grey8(img: np.ndarray) -> np.ndarray:
    """An RGB uint8 or uint16 image as 8-bit grey (DIS takes 8-bit)."""
    import cv2

    g = cv2.cvtColor(np.ascontiguousarray(img), cv2.COLOR_RGB2GRAY)
    if g.dtype != np.uint8:
        g = (g.astype(np.float32) * (255.0 / np.iinfo(img.dtype).max)).round().astype(np.uint8)
    return g


def checked_flow(a: np.ndarray, b: np.ndarray, dis=None) -> np.ndarray:
    """The flow [H, W, 2] (float32, pixels) from image ``a`` to image ``b`` (a(p) looks like
    b(p + flow(p))), zero where it fails the forward-backward check (``CONSISTENT``) or leaves
    the image."""
    import cv2

    if dis is None:
        dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    ga, gb = _grey8(a), _grey8(b)
    fw, bw = dis.calc(ga, gb, None), dis.calc(gb, ga, None)
    H, W = ga.shape
    gx, gy = np.meshgrid(np.arange(W, dtype=np.float32), np.arange(H, dtype=np.float32))
    mx, my = gx + fw[..., 0], gy + fw[..., 1]
    back = cv2.remap(bw, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    k, c = CONSISTENT
    ok = ((fw + back) ** 2).sum(-1) < k * ((fw ** 2).sum(-1) + (back ** 2).sum(-1)) + c
    ok &= (mx >= 0) & (mx <= W - 1) & (my >= 0) & (my <= H - 1)
    return np.where(ok[..., None], fw, 0.0).astype(np.float32)


def _sample(img: np.ndarray, gx: np.ndarray, gy: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """``img`` (float64 out) sampled at each pixel plus ``shift`` [H, W, 2]."""
    import cv2

    out = cv2.remap(img.astype(np.float32), gx + shift[..., 0], gy + shift[..., 1],
                    cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.astype(np.float64)


def blend_renders(own: np.ndarray, others: list[tuple[np.ndarray, float]],
                  mode: str = "mix") -> np.ndarray:
    """A frame's image from its own render (weight 1 - the others') and its renders with
    other frames' sources, each with its weight: ``mode`` one of ``MODES`` (above). The
    result has ``own``'s dtype; ``mix`` is the plain weighted mean, rounded."""
    if mode not in MODES:
        raise ValueError(f"fade blend {mode!r}: use one of {', '.join(MODES)}")
    w_own = 1.0 - sum(w for _, w in others)
    if mode == "mix" or not others:
        acc = own.astype(np.float64) * w_own
        for img, w in others:
            acc += w * img.astype(np.float64)
    else:
        H, W = own.shape[:2]
        gx, gy = np.meshgrid(np.arange(W, dtype=np.float32), np.arange(H, dtype=np.float32))
        flows = [checked_flow(own, img) for img, _ in others]
        mid = np.zeros((H, W, 2), np.float32)
        if mode == "morph":  # the geometry in between: the flows' weighted mean
            for f, (_, w) in zip(flows, others, strict=True):
                mid += np.float32(w) * f
        acc = w_own * _sample(own, gx, gy, -mid)
        for f, (img, w) in zip(flows, others, strict=True):
            acc += w * _sample(img, gx, gy, f - mid)
    return np.clip(np.rint(acc), 0, np.iinfo(own.dtype).max).astype(own.dtype)
