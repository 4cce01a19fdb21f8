"""GNT's view and ray transformers, with GN-FR's Point Sampler in the view attention.

The view transformer is vector attention across source views (with the Point Sampler); the
ray transformer is multi-head self-attention along each ray.

Shapes: R rays, S samples per ray, V source views, C channels (model width).

Point Sampler (GN-FR). ``attend`` [R, S, V] is True where a view may be attended: the point
projects inside the view, in front of it and (with the Point Sampler) not on flare. Views
that may not be attended get -inf logits *before* the softmax, so their weight is exactly
zero and the remaining weights of each point sum to one. Rule for a point attended by no
view (see ``attention_mask``): it falls back to validity-only attention (flare ignored), or
with the ``darkest`` fallback to the darker half of the views that see it; a
point valid in no view at all attends every view uniformly as in GNT (its colour then comes
from the ray transformer's context). The same mask decides which views enter the max-pooled
initial query.
"""

from __future__ import annotations

import math

import torch
import torch.nn as nn
import torch.nn.functional as F

FLARE_FALLBACKS = ("valid", "darkest")
"""What a point on flare in every view that sees it attends: ``valid``, every view that sees
it (GN-FR's Point Sampler with the validity fallback); ``darkest``, the darker half of them
(at least one) by the mean of the colour sampled there. Flare adds light, so of views that
all show flare at a point, the darkest carry the least of it (their exposures matched)."""


def attention_mask(valid: torch.Tensor, flared: torch.Tensor | None,
                   rgb: torch.Tensor | None = None,
                   fallback: str = "valid") -> tuple[torch.Tensor, torch.Tensor]:
    """Which views each point attends, with the documented fallbacks.

    valid: [R, S, V] bool (inside image, in front); flared: [R, S, V] bool or None; rgb:
    [R, S, V, 3] the colours sampled there (needed by ``fallback="darkest"``).
    Returns attend [R, S, V] bool and all_flared [R, S] bool (the point was valid in some
    view but on flare in every valid one, so it fell back to ``fallback``'s views,
    ``FLARE_FALLBACKS``). Points valid nowhere get an all-True row (uniform attention, GNT
    behaviour).
    """
    if fallback not in FLARE_FALLBACKS:
        raise ValueError(f"flare fallback {fallback!r}: expected one of {FLARE_FALLBACKS}")
    if flared is None:
        attend = valid
        all_flared = torch.zeros(valid.shape[:2], dtype=torch.bool, device=valid.device)
    else:
        clean = valid & ~flared
        any_valid = valid.any(-1, keepdim=True)
        all_flared = any_valid[..., 0] & ~clean.any(-1)
        seen = valid if fallback == "valid" else darker_half(valid, rgb)
        attend = torch.where(all_flared[..., None], seen, clean)
    attend = attend | ~attend.any(-1, keepdim=True)
    return attend, all_flared


def darker_half(valid: torch.Tensor, rgb: torch.Tensor | None) -> torch.Tensor:
    """[R, S, V] bool: of each point's valid views, the ceil(n / 2) darkest by the mean of
    ``rgb`` [R, S, V, 3] there (ties broken by view order); no valid view, none."""
    if rgb is None:
        raise ValueError("the 'darkest' flare fallback needs the sampled colours")
    lum = rgb.float().mean(-1).masked_fill(~valid, float("inf"))
    rank = lum.argsort(dim=-1, stable=True).argsort(dim=-1)  # 0 = darkest valid view
    keep = (valid.sum(-1, keepdim=True) + 1) // 2
    return valid & (rank < keep)


def masked_max(x: torch.Tensor, attend: torch.Tensor) -> torch.Tensor:
    """Max over views of the attended views only. x: [R, S, V, C]; attend: [R, S, V]."""
    neg = torch.finfo(x.dtype).min
    return x.masked_fill(~attend[..., None], neg).amax(dim=2)


class FeedForward(nn.Module):
    def __init__(self, dim: int, hidden: int, dropout: float):
        super().__init__()
        self.net = nn.Sequential(nn.Linear(dim, hidden), nn.ReLU(), nn.Dropout(dropout),
                                 nn.Linear(hidden, dim), nn.Dropout(dropout))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


def vector_attention(q: torch.Tensor, k: torch.Tensor, v: torch.Tensor, pos: torch.Tensor,
                     attend: torch.Tensor, attn_fc: nn.Module) -> torch.Tensor:
    """GNT subtraction attention across views with the Point Sampler mask.

    q: [R, S, C]; k, v, pos: [R, S, V, C]; attend: [R, S, V] bool (at least one True per
    point). Returns [R, S, C] = sum_V (v + pos) * softmax_V(attn_fc(k - q + pos)).
    """
    logits = attn_fc(k - q[:, :, None, :] + pos).float()
    logits = logits.masked_fill(~attend[..., None], float("-inf"))
    w = torch.softmax(logits, dim=2).to(v.dtype)
    return ((v + pos) * w).sum(dim=2)


class ViewTransformer(nn.Module):
    """Pre-norm block: vector attention across source views, then a 4x FFN."""

    def __init__(self, dim: int, ff_mult: int = 4, dropout: float = 0.0):
        super().__init__()
        hid = max(dim // 8, 4)
        self.norm1, self.norm2 = nn.LayerNorm(dim), nn.LayerNorm(dim)
        self.q_fc = nn.Linear(dim, dim, bias=False)
        self.k_fc = nn.Linear(dim, dim, bias=False)
        self.v_fc = nn.Linear(dim, dim, bias=False)
        self.pos_fc = nn.Sequential(nn.Linear(4, hid), nn.ReLU(), nn.Linear(hid, dim))
        self.attn_fc = nn.Sequential(nn.Linear(dim, hid), nn.ReLU(), nn.Linear(hid, dim))
        self.out_fc = nn.Linear(dim, dim)
        self.drop = nn.Dropout(dropout)
        self.ff = FeedForward(dim, dim * ff_mult, dropout)

    def forward(self, q: torch.Tensor, feats: torch.Tensor, rel_dir: torch.Tensor,
                attend: torch.Tensor, fused: bool = True) -> torch.Tensor:
        """q: [R, S, C]; feats: [R, S, V, C]; rel_dir: [R, S, V, 4]; attend: [R, S, V].
        ``fused=False`` runs the literal ``vector_attention``; the default computes the
        same function with the attention MLP's first layer folded into the key, query and
        position projections (no [R, S, V, C] key or key-query tensor)."""
        x = self.norm1(q)  # as in GNT, only the query is normalised
        if fused:
            att = self._folded_attention(x, feats, rel_dir, attend)
        else:
            att = vector_attention(self.q_fc(x), self.k_fc(feats), self.v_fc(feats),
                                   self.pos_fc(rel_dir), attend, self.attn_fc)
        q = q + self.drop(self.out_fc(att))
        return q + self.ff(self.norm2(q))

    def _folded_attention(self, x: torch.Tensor, feats: torch.Tensor, rel_dir: torch.Tensor,
                          attend: torch.Tensor) -> torch.Tensor:
        """vector_attention with A1 = attn_fc[0] applied by linearity:
        A1(k - q + pos) = (A1 Wk) f - (A1 Wq) x + (A1 P2) p + A1 b_p2 + b_a1, where
        p = relu(P1 rel_dir) is the position MLP's hidden layer [R, S, V, hid]. The position
        bias b_p2 is added after the sum over views (the weights sum to one per channel),
        and the mask is filled in place: fewer passes over [R, S, V, C] tensors."""
        a1, p1, p2 = self.attn_fc[0], self.pos_fc[0], self.pos_fc[2]
        ph = F.relu(p1(rel_dir))  # [R, S, V, hid]
        hk = F.linear(feats, a1.weight @ self.k_fc.weight)  # [R, S, V, hid]
        hq = F.linear(x, a1.weight @ self.q_fc.weight)  # [R, S, hid]
        hp = F.linear(ph, a1.weight @ p2.weight, a1.weight @ p2.bias + a1.bias)
        logits = self.attn_fc[2](F.relu(hk - hq[:, :, None] + hp)).float()  # [R, S, V, C]
        logits = logits.masked_fill_(~attend[..., None], float("-inf"))
        w = torch.softmax(logits, dim=2).to(feats.dtype)
        vp = self.v_fc(feats) + F.linear(ph, p2.weight)  # v + pos - b_p2
        return (vp * w).sum(dim=2) + p2.bias


class RayTransformer(nn.Module):
    """Pre-norm multi-head self-attention along the samples of each ray, then a 4x FFN."""

    def __init__(self, dim: int, heads: int = 4, ff_mult: int = 4, dropout: float = 0.0):
        super().__init__()
        self.heads = heads
        self.norm1, self.norm2 = nn.LayerNorm(dim), nn.LayerNorm(dim)
        self.qkv = nn.Linear(dim, 3 * dim, bias=False)
        self.out_fc = nn.Linear(dim, dim)
        self.drop = nn.Dropout(dropout)
        self.dropout = dropout
        self.ff = FeedForward(dim, dim * ff_mult, dropout)

    def forward(self, x: torch.Tensor, fused: bool = True,
                return_weights: bool = False) -> tuple[torch.Tensor, torch.Tensor | None]:
        """x: [R, S, C] -> ([R, S, C], weights [R, S] (mean attention each sample receives,
        sums to one per ray) when ``return_weights``)."""
        R, S, C = x.shape
        q, k, v = self.qkv(self.norm1(x)).view(R, S, 3, self.heads, C // self.heads).unbind(2)
        q, k, v = (t.transpose(1, 2) for t in (q, k, v))  # [R, h, S, d]
        weights = None
        p = self.dropout if self.training else 0.0
        if fused and not return_weights and x.device.type != "cpu":
            # on CPU the explicit product is faster for short rays (S ~ 24-64, head dim 8)
            out = F.scaled_dot_product_attention(q, k, v, dropout_p=p)
        else:
            a = torch.softmax((q @ k.transpose(-1, -2)).float() / math.sqrt(q.shape[-1]), -1)
            weights = a.mean(dim=(1, 2)) if return_weights else None  # [R, S]
            out = F.dropout(a.to(v.dtype), p, self.training) @ v
        x = x + self.drop(self.out_fc(out.transpose(1, 2).reshape(R, S, C)))
        return x + self.ff(self.norm2(x)), weights
