"""GN-FR masking loss and PSNR over non-flare pixels."""

from __future__ import annotations

import torch


def masked_mse(pred: torch.Tensor, target: torch.Tensor,
               flare: torch.Tensor | None, weight: torch.Tensor | None = None,
               denominator: torch.Tensor | None = None) -> torch.Tensor:
    """``|| (pred - target) * (1 - M) ||^2`` averaged over the unmasked pixels (and channels).

    pred, target: [R, 3]; flare: [R] (1 = flare pixel of the target) or None (plain MSE).
    Flare pixels contribute neither to the loss nor to its gradient; with no unmasked pixel
    the loss is 0 (still attached to the graph). ``weight`` [R]: each ray's weight in the
    average (rays drawn unevenly, ``TrainConfig.edge_rays``); None: all equal.
    ``denominator``: divide the sum by this instead of these rays' own count
    (``mse_denominator`` of a whole batch of which these rays are a part, so that the
    parts' losses add up to the whole's: ``gnfr.ray_split``).
    """
    err = (pred.float() - target.float()).square()
    keep = _keep(flare, weight)
    if denominator is None and keep is None:
        return err.mean()
    if denominator is None:
        denominator = _kept_count(keep, err.shape[1], weight is not None)
    return (err.sum() if keep is None else (err * keep[:, None]).sum()) / denominator


def _keep(flare: torch.Tensor | None, weight: torch.Tensor | None) -> torch.Tensor | None:
    """[R] each ray's share of ``masked_mse``'s sum (None: all 1)."""
    keep = None if flare is None else 1.0 - flare.float()
    if weight is not None:
        keep = weight.float() if keep is None else keep * weight.float()
    return keep


def mse_denominator(rays: int, channels: int, flare: torch.Tensor | None,
                    weight: torch.Tensor | None = None) -> torch.Tensor:
    """What ``masked_mse`` divides the sum of ``rays`` rays' squared errors by: the count of
    unmasked values (their weights' sum with ``weight``), at least one pixel's worth."""
    keep = _keep(flare, weight)
    if keep is None:
        return torch.tensor(float(rays * channels))
    return _kept_count(keep, channels, weight is not None)


def _kept_count(keep: torch.Tensor, channels: int, weighted: bool) -> torch.Tensor:
    """``keep``'s sum over the channels, at least one pixel's worth."""
    floor = 1e-12 if weighted else 1.0  # a pixel count; weights may sum under one
    return (keep.sum() * channels).clamp_min(floor)


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
