"""Masking loss and View Sampler rules."""

from __future__ import annotations

import torch

from gnfr.losses import masked_mse
from gnfr.view_sampler import eval_sources, target_stems, train_sources


def test_masking_loss_gives_no_gradient_on_flare_pixels():
    pred = torch.rand(10, 3, requires_grad=True)
    target = torch.rand(10, 3)
    flare = torch.tensor([1, 0, 0, 1, 0, 0, 0, 1, 0, 0.0])
    loss = masked_mse(pred, target, flare)
    loss.backward()
    assert torch.all(pred.grad[flare == 1] == 0)
    assert torch.all(pred.grad[flare == 0].abs().sum(1) > 0)
    keep = flare == 0
    assert torch.allclose(loss, (pred[keep] - target[keep]).square().mean())
    # changing a flare pixel's target changes nothing
    t2 = target.clone()
    t2[0] += 5
    assert torch.equal(masked_mse(pred, t2, flare), loss)
    assert float(masked_mse(pred, target, torch.ones(10))) == 0.0


RANKED = [f"v{i}" for i in range(30)]  # nearest first
FLARE = {s: (0.5 if i % 3 == 0 else 0.01 * i) for i, s in enumerate(RANKED)}


def test_train_sources_prefer_least_flared_within_the_pool():
    g = torch.Generator().manual_seed(0)
    for _ in range(50):
        src = train_sources(RANKED, FLARE, g)
        assert 8 <= len(src) <= 12 and len(set(src)) == len(src)
        idx = [RANKED.index(s) for s in src]
        assert idx == sorted(idx)  # nearest first
        pool = RANKED[:max(idx) + 1]
        left_out = [s for s in pool if s not in src]
        # every view left out of the pool's nearest part is at least as flared
        assert all(FLARE[o] >= max(FLARE[s] for s in src) - 1e-12 for o in left_out)
    near = train_sources(RANKED, FLARE, g, use_flare=False)
    assert near == RANKED[:len(near)]


def test_eval_sources_deterministic_nearest_least_flared():
    a = eval_sources(RANKED, FLARE, n=10, pool=20)
    assert a == eval_sources(RANKED, FLARE, n=10, pool=20)
    assert len(a) == 10 and all(RANKED.index(s) < 20 for s in a)
    assert all(FLARE[s] < 0.5 for s in a)  # the heavily flared views are dropped
    aligned = eval_sources(RANKED, [FLARE[s] for s in RANKED], n=10, pool=20)
    assert aligned == a


def test_flared_views_are_never_targets_unless_ablated():
    fl = {"a": 0.0, "b": 0.1, "c": 0.11, "d": 0.9}
    assert target_stems(fl, 0.1) == ["a", "b"]
    assert target_stems(fl, 0.1, use_flare=False) == ["a", "b", "c", "d"]
