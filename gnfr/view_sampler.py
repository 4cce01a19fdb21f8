"""View Sampler (GN-FR): which views may be targets and which views serve as sources.

Inputs are plain data: for each view a list of the other views ranked nearest first and a
flare fraction per view (fraction of mask pixels that are flare).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import torch

MAX_FLARE = 0.1
"""A view with a larger flare fraction is never a training target (paper: 10%)."""


def _fractions(ranked: Sequence[str], flare: Mapping[str, float] | Sequence[float]) -> list:
    if isinstance(flare, Mapping):
        return [float(flare.get(s, 0.0)) for s in ranked]
    return [float(f) for f in flare]


def _least_flared(pool: Sequence[str], fracs: Sequence[float], n: int) -> list[str]:
    """The n least-flared views of ``pool`` (ties: nearer first), in nearest-first order."""
    order = sorted(range(len(pool)), key=lambda i: (fracs[i], i))[:n]
    return [pool[i] for i in sorted(order)]


def eval_sources(ranked_stems: Sequence[str], flare_fractions, n: int = 10,
                 pool: int = 20) -> list[str]:
    """Deterministic render/eval sources: from the ``pool`` nearest views keep the ``n``
    least flared (nearest first). ``flare_fractions``: {stem: f} or a list aligned with
    ``ranked_stems``."""
    ranked = list(ranked_stems)[:pool]
    fracs = _fractions(ranked, flare_fractions if isinstance(flare_fractions, Mapping)
                       else list(flare_fractions)[:pool])
    return _least_flared(ranked, fracs, n)


def train_sources(ranked_stems: Sequence[str], flare_fractions, generator: torch.Generator,
                  n_range: tuple[int, int] = (8, 12), k_range: tuple[float, float] = (1.0, 3.0),
                  use_flare: bool = True) -> list[str]:
    """Training sources for one target: N whole in ``n_range``, k uniform in ``k_range``;
    from the round(k*N) nearest keep the N least flared. With ``use_flare=False`` (the
    no-view-sampler ablation) the N nearest views regardless of flare."""
    n = int(torch.randint(n_range[0], n_range[1] + 1, (1,), generator=generator))
    k = k_range[0] + (k_range[1] - k_range[0]) * float(torch.rand(1, generator=generator))
    ranked = list(ranked_stems)
    if not use_flare:
        return ranked[:n]
    pool = ranked[:max(n, round(k * n))]
    fracs = _fractions(pool, flare_fractions if isinstance(flare_fractions, Mapping)
                       else list(flare_fractions)[:len(pool)])
    return _least_flared(pool, fracs, n)


def target_stems(flare_fractions: Mapping[str, float], max_flare: float = MAX_FLARE,
                 use_flare: bool = True) -> list[str]:
    """Views that may be training targets: flare fraction <= ``max_flare`` (every view
    when ``use_flare`` is False, the ablation)."""
    return [s for s, f in flare_fractions.items() if not use_flare or f <= max_flare]
