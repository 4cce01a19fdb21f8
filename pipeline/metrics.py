"""Image quality metrics on [0, 1] images (numpy / OpenCV): PSNR, masked PSNR, SSIM, IoU.

Images are float arrays [H, W] or [H, W, C] with values in [0, 1] (``to_float`` converts
uint8). PSNR of identical images is infinite mathematically; here it is capped at
``PSNR_CAP`` dB so tables and JSON stay finite. SSIM is Wang et al. 2004 ("Image quality
assessment: from error visibility to structural similarity"): an 11x11 Gaussian window of
sigma 1.5, K1 = 0.01, K2 = 0.03, dynamic range L = 1, statistics computed per channel over
the valid (un-padded) part of the image and the SSIM map averaged over pixels and channels,
as in the authors' reference code and ``skimage.metrics.structural_similarity(...,
gaussian_weights=True, use_sample_covariance=False)``.
"""

from __future__ import annotations

import cv2
import numpy as np

PSNR_CAP = 100.0
"""PSNR reported for (numerically) identical images, in dB."""


def to_float(img: np.ndarray) -> np.ndarray:
    """uint8 -> float64 in [0, 1]; float input is returned as float64 unchanged."""
    if img.dtype == np.uint8:
        return img.astype(np.float64) / 255.0
    return np.asarray(img, np.float64)


def _check(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b = to_float(a), to_float(b)
    if a.shape != b.shape:
        raise ValueError(f"image shapes differ: {a.shape} vs {b.shape}")
    return a, b


def mse_to_psnr(mse: float) -> float:
    """PSNR in dB of a mean squared error on [0, 1] data, capped at ``PSNR_CAP``."""
    if mse <= 10.0 ** (-PSNR_CAP / 10.0):
        return PSNR_CAP
    return float(-10.0 * np.log10(mse))


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR (dB) of two images [H, W(, C)] in [0, 1] (or uint8), over every pixel."""
    a, b = _check(a, b)
    return mse_to_psnr(float(np.mean((a - b) ** 2)))


def masked_psnr(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float | None:
    """PSNR over the pixels where ``mask`` [H, W] is true (all channels of those pixels).

    Returns None when the mask is empty (nothing to score).
    """
    a, b = _check(a, b)
    m = np.asarray(mask).astype(bool)
    if m.shape != a.shape[:2]:
        raise ValueError(f"mask shape {m.shape} does not match image {a.shape[:2]}")
    if not m.any():
        return None
    return mse_to_psnr(float(np.mean((a[m] - b[m]) ** 2)))


def _gaussian_filter(x: np.ndarray, ksize: int, sigma: float) -> np.ndarray:
    """'valid' Gaussian filtering of [H, W] (the border where the window does not fit is
    cropped, as in Wang et al.'s reference implementation)."""
    g = cv2.getGaussianKernel(ksize, sigma, cv2.CV_64F)
    out = cv2.sepFilter2D(x, cv2.CV_64F, g, g, borderType=cv2.BORDER_REFLECT)
    r = ksize // 2
    return out[r:x.shape[0] - r, r:x.shape[1] - r]


def ssim(a: np.ndarray, b: np.ndarray, ksize: int = 11, sigma: float = 1.5,
         k1: float = 0.01, k2: float = 0.03) -> float:
    """Mean SSIM of two images [H, W(, C)] in [0, 1] (or uint8), channels averaged."""
    a, b = _check(a, b)
    if min(a.shape[:2]) < ksize:
        raise ValueError(f"SSIM needs images of at least {ksize}x{ksize}, got {a.shape[:2]}")
    if a.ndim == 2:
        a, b = a[..., None], b[..., None]
    c1, c2 = (k1 * 1.0) ** 2, (k2 * 1.0) ** 2
    vals = []
    for c in range(a.shape[2]):
        x, y = np.ascontiguousarray(a[..., c]), np.ascontiguousarray(b[..., c])
        mx, my = _gaussian_filter(x, ksize, sigma), _gaussian_filter(y, ksize, sigma)
        sxx = _gaussian_filter(x * x, ksize, sigma) - mx * mx
        syy = _gaussian_filter(y * y, ksize, sigma) - my * my
        sxy = _gaussian_filter(x * y, ksize, sigma) - mx * my
        num = (2 * mx * my + c1) * (2 * sxy + c2)
        den = (mx * mx + my * my + c1) * (sxx + syy + c2)
        vals.append(float(np.mean(num / den)))
    return float(np.mean(vals))


def iou(pred: np.ndarray, true: np.ndarray) -> float | None:
    """Intersection over union of two boolean masks [H, W]; None when both are empty."""
    p, t = np.asarray(pred).astype(bool), np.asarray(true).astype(bool)
    union = np.logical_or(p, t).sum()
    if union == 0:
        return None
    return float(np.logical_and(p, t).sum() / union)


def mask_scores(pred: np.ndarray, true: np.ndarray) -> dict:
    """Binary segmentation scores of one view: IoU of the flare class, of the clear class,
    their mean (mIoU over the two classes, as the GN-FR paper reports FMG) and accuracy."""
    p, t = np.asarray(pred).astype(bool), np.asarray(true).astype(bool)
    flare, clear = iou(p, t), iou(~p, ~t)
    both = [v for v in (flare, clear) if v is not None]
    return {"iou_flare": flare, "iou_clear": clear,
            "miou": float(np.mean(both)) if both else None,
            "accuracy": float(np.mean(p == t))}
