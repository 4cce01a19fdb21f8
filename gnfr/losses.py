"""GN-FR masking loss and PSNR over non-flare pixels."""

from __future__ import annotations

import torch


def masked_mse(pred: torch.Tensor, target: torch.Tensor,
               flare: torch.Tensor | None) -> torch.Tensor:
    """``|| (pred - target) * (1 - M) ||^2`` averaged over the unmasked pixels (and channels).

    pred, target: [R, 3]; flare: [R] (1 = flare pixel of the target) or None (plain MSE).
    Flare pixels contribute neither to the loss nor to its gradient; with no unmasked pixel
    the loss is 0 (still attached to the graph).
    """
    err = (pred.float() - target.float()).square()
    if flare is None:
        return err.mean()
    keep = 1.0 - flare.float()
    return (err * keep[:, None]).sum() / (keep.sum() * err.shape[1]).clamp_min(1.0)


def mse_to_psnr(mse: torch.Tensor | float) -> float:
    mse = float(mse)
    return float("inf") if mse <= 0 else -10.0 * torch.log10(torch.tensor(mse)).item()
