"""Properties and hand values of pipeline.metrics (PSNR, masked PSNR, SSIM, mask IoU)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import metrics


def _img(seed: int = 0, shape=(48, 64, 3)) -> np.ndarray:
    """A smooth random image in [0.1, 0.9] (structure SSIM can see)."""
    import cv2

    rng = np.random.default_rng(seed)
    x = cv2.GaussianBlur(rng.random(shape), (0, 0), 2.0)
    x = (x - x.min()) / (x.max() - x.min())
    return 0.1 + 0.8 * x


def test_psnr_identical_is_capped_and_known_value():
    a = _img()
    assert metrics.psnr(a, a) == metrics.PSNR_CAP
    # uniform error 0.1 everywhere -> MSE 0.01 -> exactly 20 dB
    assert metrics.psnr(a, a + 0.1) == pytest.approx(20.0, abs=1e-9)
    # uint8 input is scaled to [0, 1]: an error of 255 levels is MSE 1 -> 0 dB
    z = np.zeros((4, 4), np.uint8)
    assert metrics.psnr(z, z + 255) == pytest.approx(0.0, abs=1e-9)


def test_masked_psnr_counts_only_masked_pixels():
    a = _img()
    b = a.copy()
    mask = np.zeros(a.shape[:2], bool)
    mask[10:20, 10:30] = True
    b[mask] += 0.1            # error inside the mask
    b[~mask] += 0.5           # a much larger error outside it must not count
    assert metrics.masked_psnr(a, b, mask) == pytest.approx(20.0, abs=1e-9)
    assert metrics.psnr(a, b) < 10.0
    assert metrics.masked_psnr(a, b, np.zeros_like(mask)) is None
    with pytest.raises(ValueError):
        metrics.masked_psnr(a, b, mask[:5])


def test_ssim_identical_is_one_and_decreases_with_noise():
    a = _img(1)
    assert metrics.ssim(a, a) == pytest.approx(1.0, abs=1e-12)
    rng = np.random.default_rng(2)
    scores = [metrics.ssim(a, np.clip(a + rng.normal(0, s, a.shape), 0, 1))
              for s in (0.01, 0.05, 0.2)]
    assert 1.0 > scores[0] > scores[1] > scores[2] > 0.0
    # symmetric
    b = np.clip(a + rng.normal(0, 0.05, a.shape), 0, 1)
    assert metrics.ssim(a, b) == pytest.approx(metrics.ssim(b, a), abs=1e-12)


def test_ssim_hand_values():
    # constant images x and y: sigma terms vanish, SSIM = (2xy + C1) / (x^2 + y^2 + C1)
    c1 = 0.01 ** 2
    x, y = 0.5, 0.25
    a, b = np.full((32, 32), x), np.full((32, 32), y)
    assert metrics.ssim(a, b) == pytest.approx((2 * x * y + c1) / (x * x + y * y + c1),
                                               rel=1e-9)
    # a pure offset keeps structure and contrast: only the luminance term drops, and with
    # the window's local means mu and mu+d it is (2 mu (mu+d) + C1) / (mu^2 + (mu+d)^2 + C1)
    rng = np.random.default_rng(3)
    z = rng.random((40, 40)) * 0.2 + 0.4
    s = metrics.ssim(z, z + 0.1)
    assert 0.9 < s < 1.0
    # contrast inversion about the mean gives negative structure correlation
    assert metrics.ssim(z, 1.0 - z) < 0.0


def test_ssim_matches_skimage_reference_value():
    """Value of skimage.metrics.structural_similarity(a, b, gaussian_weights=True,
    sigma=1.5, use_sample_covariance=False, data_range=1.0, channel_axis=2) on these
    fixed images, computed once with scikit-image 0.26 (not a dependency)."""
    a = np.linspace(0, 1, 24 * 20 * 3).reshape(24, 20, 3) ** 2
    b = np.sqrt(np.linspace(0, 1, 24 * 20 * 3).reshape(24, 20, 3))
    b[5:15, 4:12] = 0.3
    assert metrics.ssim(a, b) == pytest.approx(0.2778985110246324, abs=1e-9)


def test_mask_scores():
    t = np.zeros((10, 10), bool)
    t[:5] = True                      # 50 flare pixels
    p = np.zeros_like(t)
    p[:5, :5] = True                  # 25 of them found, no false positives
    s = metrics.mask_scores(p, t)
    assert s["iou_flare"] == pytest.approx(0.5)
    assert s["iou_clear"] == pytest.approx(50 / 75)
    assert s["miou"] == pytest.approx((0.5 + 50 / 75) / 2)
    assert s["accuracy"] == pytest.approx(0.75)
    assert metrics.mask_scores(t, t)["miou"] == 1.0
    # no flare anywhere and none predicted: only the clear class counts
    e = np.zeros_like(t)
    assert metrics.mask_scores(e, e) == {"iou_flare": None, "iou_clear": 1.0, "miou": 1.0,
                                         "accuracy": 1.0}
