"""View Sampler (GN-FR): which views may be targets and which views serve as sources.

Inputs are plain data: for each view a list of the other views ranked nearest first and a
flare fraction per view (fraction of mask pixels that are flare). torch is imported only by
the training draw, so the rules (``is_target``, ``pick_sources``) load without it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import torch

MAX_FLARE = 0.1
"""A view with a larger flare fraction is never a training target (paper: 10%)."""

FLARE_TOLERANCE = 0.02
"""Flare fractions that differ by at most this much (2 percentage points) count as equal when
sources are chosen, and the nearer view wins. Differences this small are below what the
masks resolve: the shipped FMG marks up to 0.4% of clean held-out photos and 1.6% (max 4.5%)
of clean sunlit ones, and reads 9-10% of true flare as 8-16% depending on its cut
(gnfr/weights/fmg.md), so a view 0.3% flared is no worse a source than one 0.0% flared."""

_SLACK = 1e-9
"""Float slack so that a difference of exactly ``tolerance`` counts as equal."""


def _fractions(ranked: Sequence[str], flare: Mapping[str, float] | Sequence[float]) -> list:
    if isinstance(flare, Mapping):
        return [float(flare.get(s, 0.0)) for s in ranked]
    return [float(f) for f in flare]


def pick_sources(pool: Sequence[str], fracs: Sequence[float], n: int,
                 tolerance: float = FLARE_TOLERANCE,
                 preference: Sequence[int] | None = None) -> list[str]:
    """The n sources of ``pool`` (views nearest first, flare fractions ``fracs`` aligned
    with it), returned nearest first. The one rule every source choice goes through.

    Flare fractions that differ by at most ``tolerance`` count as equal, and among equals
    the nearer view wins. Greedily, n times: of the remaining views take the NEAREST one
    whose fraction is within ``tolerance`` of the cleanest remaining view. Hence:

    - when every fraction in the pool is within ``tolerance`` of the cleanest, the n
      nearest are chosen (a view 0.3% flared is not traded for a far one 0.0% flared);
    - a view nearer than a chosen one is left out only when it was more flared than the
      cleanest view still available at that pick by more than ``tolerance``;
    - no chosen view is more flared than a view left out by more than ``tolerance``.

    Deterministic: no randomness, ties in distance keep the pool order. ``preference`` (a
    permutation of the pool's indices) replaces "nearest" in the rule above by "first in
    ``preference``": a random permutation is GNT's random choice of sources inside the pool,
    with the flare rule kept.
    """
    if len(fracs) != len(pool):
        raise ValueError(f"{len(pool)} views but {len(fracs)} flare fractions")
    if preference is not None and sorted(preference) != list(range(len(pool))):
        raise ValueError(f"preference must be a permutation of 0..{len(pool) - 1}")
    left = list(range(len(pool)) if preference is None else preference)
    picked = []
    for _ in range(min(n, len(pool))):
        cut = min(fracs[i] for i in left) + tolerance + _SLACK
        i = next(i for i in left if fracs[i] <= cut)
        picked.append(i)
        left.remove(i)
    return [pool[i] for i in sorted(picked)]


def eval_sources(ranked_stems: Sequence[str], flare_fractions, n: int = 10,
                 pool: int = 20, tolerance: float = FLARE_TOLERANCE,
                 equal_below: float = 0.0) -> list[str]:
    """Deterministic render/eval sources: ``n`` of the ``pool`` nearest views chosen by
    :func:`pick_sources` (nearest first). ``flare_fractions``: {stem: f} or a list aligned
    with ``ranked_stems``. Views whose fraction is at most ``equal_below`` count as
    flare-free in that choice (so the nearest of them win): with ``MAX_FLARE`` every view
    the target rule would train on is an equally good source, and only views above it give
    way to cleaner far ones."""
    ranked = list(ranked_stems)[:pool]
    fracs = _fractions(ranked, flare_fractions if isinstance(flare_fractions, Mapping)
                       else list(flare_fractions)[:pool])
    fracs = [0.0 if f <= equal_below + _SLACK else f for f in fracs]
    return pick_sources(ranked, fracs, n, tolerance)


def train_sources(ranked_stems: Sequence[str], flare_fractions, generator: torch.Generator,
                  n_range: tuple[int, int] = (8, 12), k_range: tuple[float, float] = (1.0, 3.0),
                  use_flare: bool = True, tolerance: float = FLARE_TOLERANCE,
                  random_pick: bool = False) -> list[str]:
    """Training sources for one target: N whole in ``n_range``, k uniform in ``k_range``;
    N of the round(k*N) nearest chosen by :func:`pick_sources`, preferring the nearer views
    or, with ``random_pick`` (GNT's draw), views in a random order. With ``use_flare=False``
    (the no-view-sampler ablation) the N nearest views regardless of flare, or N random
    ones of the pool with ``random_pick``."""
    import torch

    n = int(torch.randint(n_range[0], n_range[1] + 1, (1,), generator=generator))
    k = k_range[0] + (k_range[1] - k_range[0]) * float(torch.rand(1, generator=generator))
    ranked = list(ranked_stems)
    pool = ranked[:max(n, round(k * n))]
    order = (torch.randperm(len(pool), generator=generator).tolist() if random_pick
             else None)
    if not use_flare:
        return [pool[i] for i in sorted(order[:n])] if random_pick else ranked[:n]
    fracs = _fractions(pool, flare_fractions if isinstance(flare_fractions, Mapping)
                       else list(flare_fractions)[:len(pool)])
    return pick_sources(pool, fracs, n, tolerance, order)


def is_target(fraction: float, max_flare: float = MAX_FLARE) -> bool:
    """The target rule: a view with more flare than ``max_flare`` never trains (the one
    definition; views.json's ``target`` flags are written with it)."""
    return bool(fraction <= max_flare)


def target_stems(flare_fractions: Mapping[str, float], max_flare: float = MAX_FLARE,
                 use_flare: bool = True) -> list[str]:
    """Views that may be training targets by :func:`is_target` (every view when
    ``use_flare`` is False, the ablation)."""
    return [s for s, f in flare_fractions.items() if not use_flare or is_target(f, max_flare)]
