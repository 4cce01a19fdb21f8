"""gnfr.ray_split: a step's rays shared by processes gives the whole batch's gradient."""

from __future__ import annotations

import copy
from dataclasses import replace

import pytest
import torch

from gnfr.model import GNFR
from gnfr.ray_split import (
    MIN_RAYS,
    HelperDied,
    NoSharedMemory,
    RaySplit,
    add_grads,
    from_wire,
    grad_size,
    part_step,
    parts,
    ray_slices,
    tensor_bytes,
    to_wire,
    view_groups,
    write_grads,
)
from gnfr.train import TINY, add_parts, make_optimizer, prepare_sources, sample_batch, train_step
from tests.gnfr.test_fit import tiny_scene

CFG = replace(TINY, rays=48, samples=6, edge_rays=0.5)


@pytest.fixture(scope="module")
def scene():
    return tiny_scene()


def test_ray_slices_cover_the_rays_in_near_equal_parts():
    for rays, n in [(128, 2), (127, 2), (10, 3), (5, 5)]:
        sl = ray_slices(rays, n)
        got = [i for s in sl for i in range(rays)[s]]
        assert got == list(range(rays))
        sizes = [s.stop - s.start for s in sl]
        assert max(sizes) - min(sizes) <= 1
    assert parts(128, 2) == 2 and parts(128, 16) == 128 // MIN_RAYS
    assert parts(MIN_RAYS * 2 - 1, 4) == 1 and parts(8, 4) == 1


def test_batch_crosses_the_wire_unchanged(scene):
    b = sample_batch(scene, CFG, torch.Generator().manual_seed(1))
    back = from_wire(to_wire(b))
    assert back.target == b.target
    for name in ("sources", "rays_o", "rays_d", "t", "rgb", "flare", "weight"):
        assert torch.equal(getattr(back, name), getattr(b, name)), name


@pytest.mark.parametrize("cached", [False, True])
def test_parts_add_up_to_the_whole_batch(scene, cached):
    """Three parts' gradients (flare-masked, edge-weighted rays; the encoder trained or
    frozen) add up to the whole batch's, and their sums to its loss, psnr and all_flared."""
    cfg = replace(CFG, cached_features=cached)
    torch.manual_seed(0)
    model = GNFR(cfg.model)
    bank, cache = prepare_sources(model, scene, cfg, "cpu")
    gen = torch.Generator().manual_seed(3)
    batch = next(b for b in (sample_batch(scene, cfg, gen) for _ in range(50))
                 if 0 < b.flare.sum() < len(b.flare))  # a target with flare where rays fall
    assert batch.flare is not None and batch.flare.sum() > 0 and batch.weight is not None
    whole = part_step(model, batch, slice(0, len(batch.rgb)), 0, bank, cache, cfg)
    want = {n: p.grad.clone() for n, p in model.named_parameters() if p.grad is not None}
    buf, acc = torch.zeros(grad_size(model)), torch.zeros(grad_size(model))
    sums = []
    for rows in ray_slices(len(batch.rgb), 3):
        sums.append(part_step(model, batch, rows, 0, bank, cache, cfg))
        write_grads(model, buf)
        acc += buf
    model.zero_grad(set_to_none=True)
    add_grads(model, acc)
    for n, p in model.named_parameters():
        if n in want:
            assert torch.allclose(p.grad, want[n], rtol=1e-4, atol=1e-7), n
        elif p.requires_grad:
            assert not p.grad.any(), n
    assert cached == (not any(n.startswith("encoder.") for n in want))
    got = add_parts(sums)
    assert got["loss"] == pytest.approx(whole["loss"], rel=1e-5)
    assert got["psnr"] == pytest.approx(whole["psnr"], abs=1e-4)
    assert got["all_flared"] == pytest.approx(whole["all_flared"], abs=1e-6)


def test_view_groups_share_the_views_the_first_least():
    for views, n in [(7, 2), (5, 3), (1, 2), (8, 4)]:
        groups = view_groups(views, n)
        assert [i for g in groups for i in range(views)[g]] == list(range(views))
        sizes = [g.stop - g.start for g in groups]
        assert sizes[0] == min(sizes) and max(sizes) - min(sizes) <= 1


@pytest.mark.parametrize("cached", [False, True])
def test_two_processes_step_as_one(scene, cached):
    """Steps with a helper process taking half of each batch's rays leave the same weights
    and the same logged numbers as steps in one process (to float rounding), and the helper
    sees each update (its half of the next step is computed with the new weights). Plain
    SGD: Adam's step would turn rounding-level gradients into steps of the full rate."""
    cfg = replace(CFG, cached_features=cached)
    torch.manual_seed(0)
    model = GNFR(cfg.model)
    twin, start = copy.deepcopy(model), copy.deepcopy(model)
    bank, cache = prepare_sources(model, scene, cfg, "cpu")
    bank2, cache2 = prepare_sources(twin, scene, cfg, "cpu")
    opt, opt2 = sgd(model), sgd(twin)
    g1, g2 = torch.Generator().manual_seed(4), torch.Generator().manual_seed(4)
    with RaySplit(twin, [(bank2, cache2)], cfg, 2) as split:
        assert len(split.helpers) == 1 and split.helpers[0].process.is_alive()
        for step in range(3):
            a = train_step(model, opt, sample_batch(scene, cfg, g1), bank, cache, cfg, step)
            b = train_step(twin, opt2, sample_batch(scene, cfg, g2), bank2, cache2, cfg, step,
                           split=split)
            assert list(a) == list(b)
            for k in ("loss", "psnr", "all_flared"):
                assert b[k] == pytest.approx(a[k], rel=1e-4, abs=1e-6), (step, k)
        helper = split.helpers[0].process
    assert not helper.is_alive()  # stopped on leaving
    for (n, p), q in zip(model.named_parameters(), twin.parameters(), strict=True):
        assert torch.allclose(p, q, rtol=1e-5, atol=1e-7), n
    moved = [not torch.equal(p, q) for p, q in zip(twin.parameters(), start.parameters(),
                                                    strict=True)]
    assert sum(moved) > len(moved) // 2  # the steps trained


def test_two_process_runs_repeat_bitwise(scene):
    """Each process's share of the rays and views is fixed and the sums are taken in a fixed
    order: two runs of the same steps in two processes end with the same weights."""
    ends = []
    for _ in range(2):
        torch.manual_seed(0)
        model = GNFR(CFG.model)
        bank, cache = prepare_sources(model, scene, CFG, "cpu")
        opt, gen = make_optimizer(model, CFG), torch.Generator().manual_seed(2)
        with RaySplit(model, [(bank, cache)], CFG, 2) as split:
            for step in range(3):
                train_step(model, opt, sample_batch(scene, CFG, gen), bank, cache, CFG, step,
                           split=split)
        ends.append(copy.deepcopy(model.state_dict()))
    assert all(torch.equal(ends[0][k], ends[1][k]) for k in ends[0])


def sgd(model: GNFR) -> torch.optim.SGD:
    """``make_optimizer``'s groups (their names set the rates) under plain SGD."""
    groups = make_optimizer(model, CFG).param_groups
    return torch.optim.SGD([{k: g[k] for k in ("params", "lr", "name")} for g in groups])


def test_a_helper_that_dies_is_reported(scene):
    torch.manual_seed(0)
    model = GNFR(CFG.model)
    bank, cache = prepare_sources(model, scene, CFG, "cpu")
    opt = make_optimizer(model, CFG)
    gen = torch.Generator().manual_seed(0)
    with RaySplit(model, [(bank, cache)], CFG, 2) as split:
        train_step(model, opt, sample_batch(scene, CFG, gen), bank, cache, CFG, 0, split=split)
        split.helpers[0].process.kill()
        split.helpers[0].process.join()
        with pytest.raises(HelperDied, match="exit code -9.*out of memory"):
            train_step(model, opt, sample_batch(scene, CFG, gen), bank, cache, CFG, 1,
                       split=split)


def test_a_bank_the_helpers_lack_is_refused(scene):
    torch.manual_seed(0)
    model = GNFR(CFG.model)
    bank, cache = prepare_sources(model, scene, CFG, "cpu")
    other, _ = prepare_sources(model, scene, CFG, "cpu")
    with (RaySplit(model, [(bank, cache)], CFG, 2) as split,
          pytest.raises(ValueError, match="not one the helpers were given")):
        split.step(model, sample_batch(scene, CFG, torch.Generator()), other, None)
    with pytest.raises(ValueError, match="2 or more"):
        RaySplit(model, [(bank, cache)], CFG, 1)


def test_tensor_bytes_counts_each_storage_once():
    a = torch.zeros(10)
    assert tensor_bytes(a, [a, a[2:]], (a.view(2, 5),)) == 40
    assert tensor_bytes(a, torch.zeros(3, dtype=torch.float64)) == 64


def test_too_little_shared_memory_is_said_before_anything_moves(scene, monkeypatch):
    """With less free shared memory than the split would use (Docker's 64 MB /dev/shm on a
    large capture), entering raises NoSharedMemory naming both sizes, starts no helper and
    leaves the parameters where they were."""
    import gnfr.ray_split as rs

    torch.manual_seed(0)
    model = GNFR(CFG.model)
    bank, cache = prepare_sources(model, scene, CFG, "cpu")
    monkeypatch.setattr(rs, "free_shared_memory", lambda: 1000)
    split = RaySplit(model, [(bank, cache)], CFG, 2)
    with pytest.raises(NoSharedMemory, match=r"need \d+ MB of shared memory and .* has 0 MB"):
        split.__enter__()
    assert not split.helpers
    assert not any(p.is_shared() for p in model.parameters())
