"""Synthetic flare on a fine-tune's sources only (``--source-flare``): the twins and the draw."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch

from pipeline.finetune import FinetuneConfig, run
from pipeline.source_flare import flared_twin, flared_twins, scene_cameras, twin_seed
from pipeline.training_scenes import load_workspace
from tests.pipeline.test_finetune import TINY, masked_workspace

KINDS = ("starburst", "ghosts", "streaks", "glare")  # no PSF bank to build


@pytest.fixture(scope="module")
def masked(tmp_path_factory):
    """Five temple views with flare masks of growing size (``masked_workspace``)."""
    return masked_workspace(tmp_path_factory.mktemp("temple") / "ws")


def test_scene_cameras_are_the_scene_views(masked):
    scene = load_workspace(masked.root)
    cams = scene_cameras(scene)
    assert cams.stems == scene.stems
    f = cams.frames[2]
    assert (f.width, f.height) == (scene.images.shape[-1], scene.images.shape[-2])
    assert np.allclose(f.c2w, scene.c2w[2].numpy()) and np.allclose(f.K, scene.K[2].numpy())
    assert f.near == pytest.approx(float(scene.near[2]))


def test_a_flared_twin_adds_masked_light_and_keeps_the_scene(masked):
    """Every view keeps its own mask and gains the twin's; the twin only adds light (the
    round trip through linear light moves a pixel by one level at most), much of it where
    its mask is; the scene itself is untouched; a seed draws the same twin again and
    another seed another."""
    scene = load_workspace(masked.root)
    before = scene.images.clone()
    twin = flared_twin(scene, 5, KINDS)
    assert torch.equal(scene.images, before)
    assert twin.stems == scene.stems and twin.name.endswith("~flare5")
    own = scene.masks.bool()
    assert (twin.masks.bool() | ~own).all()  # the photos' own flare stays marked
    added = twin.masks.bool() & ~own
    assert added.flatten(1).any(1).sum() >= 3, "the light reaches most views"
    diff = twin.images.int() - scene.images.int()
    assert int(diff.min()) >= -1
    lift = diff.float().mean(1, keepdim=True)
    assert float(lift[added].mean()) > 8.0
    assert float(lift[added].mean()) > 4 * float(lift[~twin.masks.bool()].mean())
    again = flared_twin(scene, 5, KINDS)
    assert torch.equal(again.images, twin.images) and torch.equal(again.masks, twin.masks)
    other = flared_twin(scene, 6, KINDS)
    assert not torch.equal(other.images, twin.images)
    names = [t.name for t in flared_twins(scene, 0, 2, KINDS)]
    assert names == [f"{scene.name}~flare{twin_seed(0, j)}" for j in range(2)]
    assert len({twin_seed(s, j) for s in range(3) for j in range(4)}) == 12


def test_finetune_source_flare_reads_twins_as_sources_and_the_scene_as_targets(
        masked, tmp_path, monkeypatch):
    """--source-flare 0.5: the run draws its twins once; the steps take every target from
    the scene itself and about half of them read a twin's sources; the stage records it;
    two processes share the steps as well; without it no twin is drawn."""
    import shutil

    import gnfr.train
    import pipeline.finetune as ft
    import pipeline.source_flare as sf

    ws = type(masked)(tmp_path / "ws")
    shutil.copytree(masked.root, ws.root)
    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=24, ckpt_every=100))
    monkeypatch.setattr(sf, "TWINS", 2)
    real_twins = sf.flared_twins
    monkeypatch.setattr(sf, "flared_twins", lambda sc, seed, n: real_twins(sc, seed, n, KINDS))
    banks, targets, read = {}, [], []
    real_prep, real_sample, real_sources = ft.prepare_sources, ft.sample_batch, \
        gnfr.train.batch_sources

    def prep(model, scene, cfg, device):
        bank, cache = real_prep(model, scene, cfg, device)
        banks[id(bank)] = scene.name
        return bank, cache

    def sample(scene, cfg, gen):
        targets.append(scene.name)
        return real_sample(scene, cfg, gen)

    def sources(model, batch, bank, cache, device):
        read.append(banks[id(bank)])
        return real_sources(model, batch, bank, cache, device)

    monkeypatch.setattr(ft, "prepare_sources", prep)
    monkeypatch.setattr(ft, "sample_batch", sample)
    monkeypatch.setattr(gnfr.train, "batch_sources", sources)
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", workers=1,
                       source_flare=0.5), ws)
    plain = ws.root.name
    assert sorted(banks.values()) == sorted([plain] + [f"{plain}~flare{twin_seed(0, j)}"
                                                       for j in range(2)])
    assert set(targets) == {plain} and len(targets) == 24
    assert len(read) == 24 and 6 <= sum(n != plain for n in read) <= 18
    assert len({n for n in read if n != plain}) == 2
    assert ws.stage_record("finetune")["params"]["train"]["source_flare"] == 0.5
    # the helpers of two processes are given the twins' banks too
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", workers=2,
                       source_flare=0.5, seed=1), ws)
    assert ws.model_file.is_file()
    assert ws.stage_record("finetune")["params"]["train"]["seed"] == 1
    banks.clear(), read.clear()
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", workers=1), ws)
    assert list(banks.values()) == [plain] and set(read) == {plain}


def test_finetune_flare_flag_grows_the_shipped_start_and_records_the_flag(masked, tmp_path,
                                                                          monkeypatch):
    """--flare-flag: ``--init auto`` still starts from the shipped weights (grown by the
    flag's input), the model's file carries the flag (render rebuilds it from the file),
    and the stage records it."""
    import shutil

    import gnfr.train
    from gnfr.checkpoint import load_model, read_metadata
    from gnfr.train import QUICK
    from pipeline.finetune import WEIGHTS_DIR

    ws = type(masked)(tmp_path / "ws")
    shutil.copytree(masked.root, ws.root)
    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(QUICK, iters=2, ckpt_every=100))
    run(FinetuneConfig(preset="quick", device="cpu", workers=1, flare_flag=True), ws)
    cfg, meta = read_metadata(ws.model_file)
    assert cfg.flare_flag is True and cfg == replace(QUICK.model, flare_flag=True)
    assert meta["provenance"]["init"]["weights"] == str(WEIGHTS_DIR / "gnfr.safetensors")
    assert load_model(ws.model_file).config.flare_flag is True
    assert ws.stage_record("finetune")["params"]["train"]["model"]["flare_flag"] is True
