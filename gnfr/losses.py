"""GN-FR masking loss and PSNR over non-flare pixels."""

from __future__ import annotations

import torch


def masked_mse(pred: torch.Tensor, target: torch.Tensor,
               flare: torch.Tensor | None, weight: torch.Tensor | None = None) -> torch.Tensor:
    """``|| (pred - target) * (1 - M) ||^2`` averaged over the unmasked pixels (and channels).

    pred, target: [R, 3]; flare: [R] (1 = flare pixel of the target) or None (plain MSE).
    Flare pixels contribute neither to the loss nor to its gradient; with no unmasked pixel
    the loss is 0 (still attached to the graph). ``weight`` [R]: each ray's weight in the
    average (rays drawn unevenly, ``TrainConfig.edge_rays``); None: all equal.
    """
    err = (pred.float() - target.float()).square()
    keep = None if flare is None else 1.0 - flare.float()
    if weight is not None:
        keep = weight.float() if keep is None else keep * weight.float()
    if keep is None:
        return err.mean()
    floor = 1.0 if weight is None else 1e-12  # a pixel count; weights may sum under one
    return (err * keep[:, None]).sum() / (keep.sum() * err.shape[1]).clamp_min(floor)


PSNR_CAP = 100.0
"""PSNR reported for a (numerically) zero error, in dB, so metric lines stay finite JSON:
the cap of ``pipeline.metrics.PSNR_CAP`` (gnfr cannot import it; a test keeps them equal)."""


def mse_to_psnr(mse: torch.Tensor | float) -> float:
    """PSNR in dB of a mean squared error on [0, 1] data, capped at ``PSNR_CAP`` (a step
    whose target rays are all flare has no error to measure)."""
    mse = float(mse)
    if mse <= 10.0 ** (-PSNR_CAP / 10.0):
        return PSNR_CAP
    return -10.0 * torch.log10(torch.tensor(mse)).item()
