"""Masking loss and View Sampler rules."""

from __future__ import annotations

import pytest
import torch

from gnfr.losses import masked_mse
from gnfr.view_sampler import (
    FLARE_TOLERANCE,
    eval_sources,
    pick_sources,
    target_stems,
    train_sources,
)


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
    assert float(masked_mse(pred, target, torch.ones(10)).detach()) == 0.0


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
        # no source is more flared than a view left out by more than the tolerance
        worst = max(FLARE[s] for s in src)
        assert all(FLARE[o] >= worst - FLARE_TOLERANCE - 1e-9 for o in left_out)
    near = train_sources(RANKED, FLARE, g, use_flare=False)
    assert near == RANKED[:len(near)]


def test_random_sources_vary_inside_the_pool_and_keep_the_flare_rule():
    """GNT's draw: on a clean line of views the sources are no longer always the nearest N,
    they stay inside the round(k*N) pool, and a heavily flared view still loses."""
    clean = dict.fromkeys(LINE, 0.0) | {"v01": 0.3}
    g = torch.Generator().manual_seed(0)
    draws = [train_sources(LINE, clean, g, (4, 4), (2.0, 2.0), random_pick=True)
             for _ in range(40)]
    assert len({tuple(d) for d in draws}) > 10                # not one fixed set
    for d in draws:
        idx = [LINE.index(s) for s in d]
        assert len(d) == 4 and idx == sorted(idx) and max(idx) < 8  # pool of 8, nearest first
        assert "v01" not in d                                # 30 % flared: resolved
    assert {s for d in draws for s in d} == set(LINE[:8]) - {"v01"}
    nearest = train_sources(LINE, clean, g, (4, 4), (2.0, 2.0))
    assert nearest == ["v00", "v02", "v03", "v04"]           # the default draw is unchanged
    ablated = train_sources(LINE, clean, g, (4, 4), (2.0, 2.0), use_flare=False,
                            random_pick=True)
    assert len(ablated) == 4 and all(LINE.index(s) < 8 for s in ablated)
    with pytest.raises(ValueError, match="permutation"):
        pick_sources(["a", "b"], [0.0, 0.0], 1, preference=[0, 0])


def test_eval_sources_deterministic_nearest_least_flared():
    a = eval_sources(RANKED, FLARE, n=10, pool=20)
    assert a == eval_sources(RANKED, FLARE, n=10, pool=20)
    assert len(a) == 10 and all(RANKED.index(s) < 20 for s in a)
    assert all(FLARE[s] < 0.5 for s in a)  # the heavily flared views are dropped
    aligned = eval_sources(RANKED, [FLARE[s] for s in RANKED], n=10, pool=20)
    assert aligned == a


LINE = [f"v{i:02d}" for i in range(24)]  # 24 views in a line, nearest first


def test_near_views_within_tolerance_beat_far_clean_ones():
    # the toy case of issue 13: the 12 nearest 0.1-0.4% flared, the 12 far ones clean
    fl = {s: (0.001 + 0.003 * i / 11 if i < 12 else 0.0) for i, s in enumerate(LINE)}
    assert eval_sources(LINE, fl, n=12, pool=24) == LINE[:12]
    assert eval_sources(LINE, fl, n=10, pool=20) == LINE[:10]
    g = torch.Generator().manual_seed(0)
    for _ in range(20):
        src = train_sources(LINE, fl, g, n_range=(8, 12))
        assert src == LINE[:len(src)]


def test_a_heavily_flared_near_view_loses_to_a_far_clean_one():
    fl = dict.fromkeys(LINE, 0.0) | {"v00": 0.3, "v03": 0.3}
    got = eval_sources(LINE, fl, n=4, pool=24)
    assert got == ["v01", "v02", "v04", "v05"]


def test_fractions_under_equal_below_count_as_none():
    # lund's case: every view under the 10 % rule, the nearest ones more flared
    fl = {s: (0.09 if i < 3 else 0.05) for i, s in enumerate(LINE[:13])}
    assert eval_sources(LINE[:13], fl, n=10, pool=20) == LINE[3:13]  # strict: near ones out
    assert eval_sources(LINE[:13], fl, n=10, pool=20, equal_below=0.1) == LINE[:10]
    # a view above the line still gives way to a cleaner far one
    fl["v01"] = 0.3
    got = eval_sources(LINE[:13], fl, n=10, pool=20, equal_below=0.1)
    assert "v01" not in got and got == [s for s in LINE[:11] if s != "v01"]
    # exactly at the line counts as under it
    assert eval_sources(["a", "b"], {"a": 0.1, "b": 0.0}, n=1, equal_below=0.1) == ["a"]


def test_tolerance_boundary_both_ways():
    pool = ["near", "far"]
    t = FLARE_TOLERANCE
    # a difference of at most the tolerance counts as equal: the near view wins
    for near_f, far_f in ((t, 0.0), (t / 2, 0.0), (0.05 + t, 0.05), (0.0, 0.01)):
        assert pick_sources(pool, [near_f, far_f], 1) == ["near"]
    # a difference above it is resolved: the cleaner, farther view wins
    assert pick_sources(pool, [t + 1e-4, 0.0], 1) == ["far"]
    assert pick_sources(pool, [0.05 + t + 1e-4, 0.05], 1) == ["far"]
    # the tolerance is a parameter: 0 gives the strict least-flared choice
    assert pick_sources(pool, [0.003, 0.0], 1, tolerance=0.0) == ["far"]
    assert eval_sources(pool, [0.003, 0.0], n=1, tolerance=0.0) == ["far"]
    assert eval_sources(pool, [0.003, 0.0], n=1) == ["near"]


def test_source_choice_is_deterministic_and_nearest_first():
    fl = [0.3, 0.0, 0.015, 0.05, 0.0, 0.2, 0.01, 0.0, 0.04, 0.0]
    stems = [f"s{i}" for i in range(10)]
    a = pick_sources(stems, fl, 5)
    assert a == pick_sources(list(stems), list(fl), 5) == eval_sources(stems, fl, 5, 10)
    assert a == ["s1", "s2", "s4", "s6", "s7"]  # s0 (30%) and s3 (5%) resolved, s5 too
    assert [stems.index(s) for s in a] == sorted(stems.index(s) for s in a)
    g1, g2 = torch.Generator().manual_seed(3), torch.Generator().manual_seed(3)
    assert ([train_sources(stems, fl, g1, (3, 5)) for _ in range(10)]
            == [train_sources(stems, fl, g2, (3, 5)) for _ in range(10)])


def test_flared_views_are_never_targets_unless_ablated():
    fl = {"a": 0.0, "b": 0.1, "c": 0.11, "d": 0.9}
    assert target_stems(fl, 0.1) == ["a", "b"]
    assert target_stems(fl, 0.1, use_flare=False) == ["a", "b", "c", "d"]
    from gnfr.view_sampler import is_target  # the rule target_stems and views.json apply

    assert is_target(0.1, 0.1) and not is_target(0.11, 0.1) and is_target(0.11, 0.2)


def test_psnr_caps_agree_across_layers():
    """gnfr's training PSNR and pipeline.metrics' PSNR: the same cap and the same values."""
    from gnfr.losses import PSNR_CAP, mse_to_psnr
    from pipeline import metrics

    assert PSNR_CAP == metrics.PSNR_CAP
    for mse in (0.0, 1e-12, 1e-10):
        assert mse_to_psnr(mse) == metrics.mse_to_psnr(mse) == PSNR_CAP
    for mse in (1e-9, 1e-3, 0.04, 1.0):
        assert abs(mse_to_psnr(torch.tensor(mse)) - metrics.mse_to_psnr(mse)) < 1e-4
