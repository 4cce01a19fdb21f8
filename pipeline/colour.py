"""The sRGB transfer function (IEC 61966-2-1) both ways: the one definition every module uses.

Two precisions of one formula: the default is float32 through OpenCV's fast exp/log (flare
synthesis on whole images, many times per second); ``exact=True`` uses numpy's power in
the input's own float precision (decode's 8-bit output, where a last-bit difference could
flip a rounding). Inputs are clipped to [0, 1].
"""

from __future__ import annotations

import numpy as np

LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)
"""Rec. 709 luminance weights of linear RGB (the flare rays, streak lines and synthesizer)."""
SRGB_LINEAR_CUT = 0.0031308
"""Linear values at or below this are encoded by the linear segment (x 12.92)."""
SRGB_ENCODED_CUT = 0.04045
"""Encoded values at or below this are decoded by the linear segment (/ 12.92)."""


def fast_pow(x: np.ndarray, p: float) -> np.ndarray:
    """``x ** p`` for x > 0 (float32, any shape) via OpenCV's fast exp/log."""
    import cv2

    flat = np.maximum(x, np.float32(1e-12)).reshape(-1, 1)
    return cv2.exp(cv2.log(flat) * np.float32(p)).reshape(x.shape)


def srgb_to_linear(x: np.ndarray, exact: bool = False) -> np.ndarray:
    """sRGB-encoded values in [0, 1] (clipped) to linear light; float32, or with ``exact``
    numpy's power in the input's float precision."""
    if exact:
        x = np.clip(x, 0.0, 1.0)
        return np.where(x <= SRGB_ENCODED_CUT, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)
    x = np.clip(np.asarray(x, np.float32), 0.0, 1.0)
    hi = fast_pow((x + np.float32(0.055)) * np.float32(1 / 1.055), 2.4)
    return np.where(x <= SRGB_ENCODED_CUT, x * np.float32(1 / 12.92), hi)


def linear_to_srgb(x: np.ndarray, exact: bool = False) -> np.ndarray:
    """Linear light in [0, 1] (clipped) to sRGB encoding; float32, or with ``exact`` numpy's
    power in the input's float precision."""
    if exact:
        x = np.clip(x, 0.0, 1.0)
        return np.where(x <= SRGB_LINEAR_CUT, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    x = np.clip(np.asarray(x, np.float32), 0.0, 1.0)
    hi = np.float32(1.055) * fast_pow(x, 1 / 2.4) - np.float32(0.055)
    return np.where(x <= SRGB_LINEAR_CUT, x * np.float32(12.92), hi)


_SRGB8_TO_LINEAR = None


def image_to_linear(image: np.ndarray) -> np.ndarray:
    """[H, W, 3] uint8 (0-255, a table lookup) or float sRGB in [0, 1] -> float32 linear."""
    import cv2

    global _SRGB8_TO_LINEAR
    image = np.asarray(image)
    if image.dtype == np.uint8:
        if _SRGB8_TO_LINEAR is None:
            _SRGB8_TO_LINEAR = srgb_to_linear(np.arange(256, dtype=np.float32) / 255)
        return cv2.LUT(image, _SRGB8_TO_LINEAR)
    return srgb_to_linear(image)
