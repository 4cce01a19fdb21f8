"""Fine-tuning: overfit a tiny model on a real scene, bitwise resume, the stage and CLI."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import torch
from safetensors.torch import load_file

from gnfr.checkpoint import load_model
from gnfr.train import PRESETS, QUICK
from pipeline.finetune import FinetuneConfig, fit, run
from pipeline.training_scenes import load_workspace
from pipeline.ws_files import read_mask, read_view_image, view_stems, write_mask
from tests.fixtures import make_temple_workspace

TINY = replace(QUICK, model=replace(QUICK.model, enc_widths=(8, 16, 16), feat_ch=8, width=16,
                                    depth=2),
               rays=64, samples=12, n_views=(3, 4), eval_views=4, source_scale=0.5,
               log_every=5, ckpt_every=5, lr_encoder=2e-3, lr_transformer=1e-3)


def _metrics(path):
    return [json.loads(ln) for ln in path.read_text().splitlines()]


def test_overfit_tiny_model_on_temple_psnr_rises(tmp_path):
    ws = make_temple_workspace(tmp_path / "ws", n_views=6, scale=0.25)
    scene = load_workspace(ws.root)
    cfg = replace(TINY, iters=150, rays=64, samples=12, log_every=15, ckpt_every=1000,
                  lr_encoder=3e-3, lr_transformer=2e-3)
    fit(scene, cfg, torch.device("cpu"), ws.model, resume=False, init="scratch")
    psnr = [m["psnr"] for m in _metrics(ws.metrics_jsonl)]
    assert len(psnr) == 10
    assert np.mean(psnr[-2:]) > psnr[0] + 3.0, psnr


def masked_workspace(root):
    """Five temple views with flare masks of growing size (the last above 10%)."""
    ws = make_temple_workspace(root, n_views=5, scale=0.2)
    for i, s in enumerate(view_stems(ws)):
        m = np.zeros(read_view_image(ws, s).shape[:2], bool)
        m[: 4 + 8 * i, : 4 + 12 * i] = True
        write_mask(ws, s, m)
    return ws


def test_resume_continues_bitwise(tmp_path):
    ws = masked_workspace(tmp_path / "ws")
    scene = load_workspace(ws.root)
    cfg = replace(TINY, iters=10, model=replace(TINY.model, dropout=0.1))
    fit(scene, cfg, torch.device("cpu"), tmp_path / "straight", resume=False, init="scratch")
    fit(scene, replace(cfg, iters=5), torch.device("cpu"), tmp_path / "split", resume=False,
        init="scratch")
    fit(scene, cfg, torch.device("cpu"), tmp_path / "split", resume=True, init="scratch")
    a = load_file(str(tmp_path / "straight" / "gnfr.safetensors"))
    b = load_file(str(tmp_path / "split" / "gnfr.safetensors"))
    assert a.keys() == b.keys()
    assert all(torch.equal(a[k], b[k]) for k in a)
    ma = _metrics(tmp_path / "straight" / "metrics.jsonl")
    mb = _metrics(tmp_path / "split" / "metrics.jsonl")
    assert [m["loss"] for m in ma] == [m["loss"] for m in mb] and len(ma) == 2
    unseen = json.loads((tmp_path / "split" / "unseen.json").read_text())["views"]
    assert unseen and all(0 <= v["all_flared_fraction"] <= 1 for v in unseen.values())
    assert "cached" not in unseen  # keys are stems
    assert max(scene.flare.values()) > 0.1 and scene.stems[-1] not in unseen  # never a target


def test_finetune_stage_writes_model_and_skips_when_up_to_date(tmp_path, monkeypatch):
    import gnfr.train

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=4, ckpt_every=100))
    ws = masked_workspace(tmp_path / "ws")
    cfg = FinetuneConfig(preset="quick", init="scratch", device="cpu")
    outs = run(cfg, ws)
    assert set(outs) == {ws.model_file, ws.train_state, ws.metrics_jsonl, ws.unseen_json}
    model = load_model(ws.model_file)
    assert model.config == TINY.model
    stamp = ws.model_file.stat().st_mtime_ns
    assert run(cfg, ws) == outs  # up to date: skipped, nothing rewritten
    assert ws.model_file.stat().st_mtime_ns == stamp


def test_a_run_of_new_settings_stopped_before_its_checkpoint_starts_afresh(tmp_path,
                                                                            monkeypatch):
    """A finished fine-tune's checkpoint is not resumed by a run of other settings stopped
    before it wrote its own: the next attempt trains from step 0, not from the old steps."""
    import gnfr.train
    import pipeline.finetune as ft

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=4, ckpt_every=100))
    ws = masked_workspace(tmp_path / "ws")
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu"), ws)
    real_fit = ft.fit

    def stopped(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(ft, "fit", stopped)
    new = FinetuneConfig(preset="quick", init="scratch", device="cpu", iters=6)
    with pytest.raises(KeyboardInterrupt):
        run(new, ws)
    assert ws.stage_record("finetune")["status"] == "running" and ws.model_file.exists()
    said = []
    monkeypatch.setattr(ft, "fit", real_fit)
    monkeypatch.setattr(ft, "info", said.append)
    run(new, ws)
    assert not any(m.startswith("finetune: resuming") for m in said)
    assert any(m.startswith("finetune: starting") for m in said)
    assert [json.loads(ln)["step"] for ln in ws.metrics_jsonl.read_text().splitlines()][-1] == 6


def _select(ws, max_flare: float) -> list[str]:
    """Write WS/views.json as `select --max-flare` does; returns its targets."""
    from pipeline.ws_files import make_views, read_cameras, read_mask, write_views

    cams = read_cameras(ws)
    frac = {s: float(read_mask(ws, s).mean()) for s in cams.stems}
    views = make_views(cams.stems, cams.centers(), frac, max_flare)
    write_views(ws, views)
    return views.targets()


def test_training_targets_are_views_json_targets(tmp_path, monkeypatch):
    """finetune trains on the views views.json flags as targets (select --max-flare), not on
    a max_flare of its own: with --max-flare 0.2 the 15%-flared view trains, with 0.05 the
    9% one does not (the training config's max_flare stays 0.1 in both)."""
    import gnfr.train
    from gnfr.train import sample_batch, scene_targets

    ws = masked_workspace(tmp_path / "ws")
    stems = view_stems(ws)
    frac = {s: float(read_mask(ws, s).mean()) for s in stems}
    assert 0.1 < frac[stems[4]] < 0.2 and 0.05 < frac[stems[3]] < 0.1
    assert TINY.max_flare == 0.1
    gen = torch.Generator().manual_seed(0)
    for max_flare, expect in ((0.2, stems), (0.05, stems[:3])):
        assert _select(ws, max_flare) == expect
        scene = load_workspace(ws.root)
        assert scene_targets(scene, TINY) == expect
        drawn = {scene.stems[sample_batch(scene, TINY, gen).target] for _ in range(60)}
        assert drawn == set(expect)
    # without the View Sampler (ablation) every view is a target, whatever views.json says
    assert scene_targets(scene, replace(TINY, view_sampler=False)) == stems
    # the stage: unseen.json lists the views that were targets
    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=30, ckpt_every=100))
    _select(ws, 0.2)
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu"), ws)
    trained = json.loads(ws.unseen_json.read_text())["views"]
    assert set(trained) == set(stems)                      # the 15% view included
    # and the stage's record names the views a step could take (eval's table reads them)
    assert ws.stage_record("finetune")["targets"] == stems
    _select(ws, 0.05)
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu"), ws)
    assert ws.stage_record("finetune")["targets"] == stems[:3]


def test_shipped_pretrained_weights_load_and_start_quick_finetuning():
    from gnfr.checkpoint import read_metadata
    from pipeline.finetune import WEIGHTS_DIR, resolve, shipped_weights
    from pipeline.scene_splits import HELDOUT_SCENES

    path = WEIGHTS_DIR / "gnfr.safetensors"
    assert path.stat().st_size < 25 * 2**20
    cfg, meta = read_metadata(path)
    assert cfg == QUICK.model and meta["samples"] == QUICK.samples
    assert not set(meta["pretrain_scenes"]) & set(HELDOUT_SCENES)
    assert all(v.dtype == torch.float16 for v in load_file(str(path)).values())
    model = load_model(path)  # rebuilds from the file alone
    assert all(torch.isfinite(p).all() for p in model.parameters())
    # gnfr/weights/gnfr.md: beats scratch at equal steps on both held-out scenes -> init=auto
    # picks it for the quick architecture (and fine-tunes it end-to-end); paper's has its own
    assert meta["auto_init"] is True and shipped_weights(QUICK) == path
    assert shipped_weights(PRESETS["paper"]) == WEIGHTS_DIR / "gnfr_paper.safetensors"
    name, cfg_q = resolve(FinetuneConfig(device="cpu"), torch.device("cpu"))
    assert name == "quick" and not cfg_q.cached_features
    _, cfg_c = resolve(FinetuneConfig(device="cpu", cached_features=True), torch.device("cpu"))
    assert cfg_c.cached_features


def test_shipped_paper_weights_are_the_paper_architecture_and_its_auto_start():
    """gnfr_paper.safetensors: fp16, under 25 MiB, the paper preset's architecture, never
    trained on a held-out scene, at its recorded step; init=auto picks it for the paper
    architecture and not for quick's (its A/B in gnfr/weights/gnfr.md)."""
    from gnfr.checkpoint import read_metadata
    from pipeline.finetune import WEIGHTS_DIR, shipped_weights
    from pipeline.scene_splits import HELDOUT_SCENES

    path = WEIGHTS_DIR / "gnfr_paper.safetensors"
    assert path.stat().st_size < 25 * 2**20
    cfg, meta = read_metadata(path)
    assert cfg.architecture() == PRESETS["paper"].model.architecture()
    assert cfg.architecture() != QUICK.model.architecture()
    assert not set(meta["pretrain_scenes"]) & set(HELDOUT_SCENES)
    assert meta["step"] == meta["pretrain_steps"] == 11000 and meta["auto_init"] is True
    assert all(v.dtype == torch.float16 for v in load_file(str(path)).values())
    assert shipped_weights(PRESETS["paper"]) == path != shipped_weights(QUICK)

def test_dropout_and_random_sources_keep_the_shipped_start():
    """GNT's training details as finetune options: dropout holds no weights, so the shipped
    file still matches (init auto) and loads; another width does not."""
    import pytest

    from gnfr.checkpoint import CheckpointError, load_weights
    from gnfr.model import GNFR
    from pipeline.finetune import init_model, resolve, shipped_weights

    cpu = torch.device("cpu")
    _, cfg = resolve(FinetuneConfig(device="cpu", dropout=0.1, random_sources=True), cpu)
    assert cfg.model.dropout == 0.1 and cfg.random_sources
    assert shipped_weights(cfg) == shipped_weights(QUICK) is not None
    model, how = init_model(cfg, cpu, "auto")
    assert "pretrained" in how and model.config.dropout == 0.1
    drops = [m.p for m in model.modules() if isinstance(m, torch.nn.Dropout)]
    assert drops and all(p == 0.1 for p in drops)
    with pytest.raises(CheckpointError, match="architecture"):
        load_weights(GNFR(replace(cfg.model, width=cfg.model.width * 2)),
                     shipped_weights(QUICK))


def test_lr_scale_scales_both_learning_rates():
    """--lr-scale multiplies the preset's encoder and transformer rates, and the optimizer
    starts from the scaled rates; unset, the preset's rates stay."""
    from gnfr.model import GNFR
    from gnfr.train import make_optimizer
    from pipeline.finetune import resolve

    cpu = torch.device("cpu")
    _, plain = resolve(FinetuneConfig(device="cpu", preset="quick"), cpu)
    assert (plain.lr_encoder, plain.lr_transformer) == (QUICK.lr_encoder, QUICK.lr_transformer)
    _, half = resolve(FinetuneConfig(device="cpu", preset="quick", lr_scale=0.5), cpu)
    assert half.lr_encoder == QUICK.lr_encoder * 0.5
    assert half.lr_transformer == QUICK.lr_transformer * 0.5
    opt = make_optimizer(GNFR(half.model), half)
    assert {g["name"]: g["lr"] for g in opt.param_groups} == {
        "encoder": half.lr_encoder, "transformer": half.lr_transformer}


def _hand_written_checkpoint(out, scene, cfg, steps: int, extra: dict) -> None:
    """WS/model/ as the stage has written it since train_state.pt got its keys: weights
    with render settings in the metadata, {"step", "optimizer", "rng", **extra} beside."""
    from gnfr.checkpoint import save_model
    from gnfr.model import GNFR
    from gnfr.train import SourceBank, make_optimizer, sample_batch, train_step

    torch.manual_seed(cfg.seed)
    model = GNFR(cfg.model)
    opt, gen = make_optimizer(model, cfg), torch.Generator().manual_seed(cfg.seed)
    bank = SourceBank.of(scene, cfg.source_scale, "cpu")
    for step in range(steps):
        train_step(model, opt, sample_batch(scene, cfg, gen), bank, None, cfg, step)
    out.mkdir(parents=True, exist_ok=True)
    save_model(out / "gnfr.safetensors", model, {"step": steps, "preset": "custom",
                                                 "samples": cfg.samples})
    torch.save({"step": steps, "optimizer": opt.state_dict(),
                "rng": {"gen": gen.get_state(), "torch": torch.get_rng_state()}, **extra},
               out / "train_state.pt")


def test_resumes_a_model_folder_of_the_existing_format(tmp_path):
    ws = masked_workspace(tmp_path / "ws")
    scene = load_workspace(ws.root)
    cfg = replace(TINY, iters=5)
    unseen = torch.zeros(len(scene.stems), 2, dtype=torch.float64)
    unseen[0] = torch.tensor([0.5, 3.0], dtype=torch.float64)
    _hand_written_checkpoint(ws.model, scene, cfg, 3, {"unseen": unseen, "seconds": 100.0})
    stats = fit(scene, cfg, torch.device("cpu"), ws.model, resume=True, init="scratch")
    assert stats["steps"] == 5 and stats["train_seconds"] > 100.0
    st = torch.load(ws.train_state, weights_only=True)
    assert list(st) == ["step", "optimizer", "rng", "unseen", "seconds"] and st["step"] == 5
    assert all(int(s["step"]) == 5 for s in st["optimizer"]["state"].values())  # Adam went on
    assert int(st["unseen"][:, 1].sum()) == 3 + 2                # the saved counts went on too
    assert [m["step"] for m in _metrics(ws.metrics_jsonl)] == [5]


def test_random_sources_default_follows_the_masks(tmp_path, monkeypatch):
    """Unset, random sources go on only where no view has a marked pixel (measured on a
    flare-free development scene, docs/presets.md); --random-sources / --nearest-sources
    decide it either way."""
    import pipeline.finetune as ft

    seen = []

    def fake_fit(scene, cfg, *a, **k):
        seen.append(cfg.random_sources)
        return {}

    monkeypatch.setattr(ft, "fit", fake_fit)
    ws = make_temple_workspace(tmp_path / "ws", n_views=4, scale=0.25)
    assert ft.flare_free(ws)                                   # no mask stage yet
    views = {s: {"flare_fraction": 0.0, "source": "fmg"} for s in view_stems(ws)}
    ws.flare_json.write_text(json.dumps({"views": views}))
    assert ft.flare_free(ws)
    expect = []
    for fractions, flag, want in ((0.0, None, True), (0.0, False, False),
                                  (0.002, None, False), (0.002, True, True)):
        views[next(iter(views))]["flare_fraction"] = fractions
        ws.flare_json.write_text(json.dumps({"views": views}))
        assert ft.flare_free(ws) == (fractions == 0)
        ft.run(FinetuneConfig(device="cpu", preset="tiny", iters=1, init="scratch",
                              random_sources=flag), ws, force=True)
        expect.append(want)
    assert seen == expect


def test_holes_as_flare_trains_on_the_enclosed_core_as_flare(tmp_path, monkeypatch):
    """--holes-as-flare (the default): the scene the fine-tune trains on has each mask's
    enclosed hole marked (neither target nor source colour) while WS/masks stay as written;
    off (--no-holes-as-flare), the masks are trained on as they are. A record written before
    the option existed was trained with it off: it is up to date for off, not for the
    default."""
    import pipeline.finetune as ft

    ws = make_temple_workspace(tmp_path / "ws", n_views=4, scale=0.25)
    ring = None
    for s in view_stems(ws):
        m = np.zeros(read_view_image(ws, s).shape[:2], bool)
        m[10:30, 10:30] = True
        m[15:25, 15:25] = False                      # the light's core, unmarked
        write_mask(ws, s, m)
        ring = m
    before = {s: read_mask(ws, s).copy() for s in view_stems(ws)}
    masks = {}

    def fake_fit(scene, cfg, *a, **k):
        masks[len(masks)] = scene.masks[:, 0].numpy().astype(bool)
        return {}

    monkeypatch.setattr(ft, "fit", fake_fit)
    assert FinetuneConfig.holes_as_flare is True
    ft.run(FinetuneConfig(device="cpu", preset="tiny", iters=1, init="scratch",
                          holes_as_flare=False), ws)
    assert len(masks) == 1
    # the record an earlier version left, before these options: still up to date
    manifest = ws.root / "manifest.json"
    man = json.loads(manifest.read_text())
    rec = man["stages"]["finetune"]["params"]
    assert rec["holes_as_flare"] is False and rec["train"]["lr_restart"] == 0.0
    del rec["holes_as_flare"], rec["train"]["lr_restart"], rec["train"]["lr_restart_step"]
    manifest.write_text(json.dumps(man))
    for out in man["stages"]["finetune"]["outputs"]:  # what the real fit would have written
        (ws.root / out).parent.mkdir(exist_ok=True)
        (ws.root / out).write_bytes(b"")
    ft.run(FinetuneConfig(device="cpu", preset="tiny", iters=1, init="scratch",
                          holes_as_flare=False), ws)
    assert len(masks) == 1                               # skipped: nothing trained
    ft.run(FinetuneConfig(device="cpu", preset="tiny", iters=1, init="scratch"),
           ws)                                           # the default (on): not up to date
    rec = json.loads(manifest.read_text())["stages"]["finetune"]["params"]
    assert rec["holes_as_flare"] is True
    plain, filled = masks[0], masks[1]
    assert all(np.array_equal(m, ring) for m in plain)
    full = ring.copy()
    full[15:25, 15:25] = True
    assert all(np.array_equal(m, full) for m in filled)
    assert all(np.array_equal(read_mask(ws, s), before[s]) for s in view_stems(ws))


def test_finetune_mirror_trains_on_the_scene_and_its_mirror_image(tmp_path, monkeypatch):
    """--mirror: the steps draw batches of the scene and of its mirror image (its views
    flipped left-right), also with the steps shared by two processes; recorded in the
    stage's parameters; the run without it draws the scene alone at every step."""
    import gnfr.train
    import pipeline.finetune as ft

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=16, ckpt_every=100))
    seen = []
    real = ft.sample_batch

    def spy(scene, cfg, gen):
        seen.append((scene.name, scene.images[0, :, 0, 0].tolist()))
        return real(scene, cfg, gen)

    monkeypatch.setattr(ft, "sample_batch", spy)
    ws = masked_workspace(tmp_path / "ws")
    # in two processes: the helpers read whichever of the two scenes' banks a step draws
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", mirror=True, workers=2), ws)
    names = {n for n, _ in seen}
    assert len(names) == 2 and any(n.endswith("~mirror") for n in names)
    pixels = {n: px for n, px in seen}
    plain = next(n for n in names if not n.endswith("~mirror"))
    img = read_view_image(ws, view_stems(ws)[0])
    assert pixels[plain] == img[0, 0].tolist()                    # the top-left pixel
    assert pixels[f"{plain}~mirror"] == img[0, -1].tolist()       # the top-right one
    assert ws.stage_record("finetune")["params"]["train"]["mirror"] is True
    seen.clear()
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu"), ws)
    assert {n for n, _ in seen} == {plain} and len(seen) == 16


def test_finetune_full_res_colour_trains_on_full_size_colours_and_records_it(tmp_path,
                                                                             monkeypatch):
    """--full-res-colour (the default): the source bank keeps the views at full size while
    the encoder sees them at the preset's source scale; the model records it (so render
    samples colours the same way) and the stage's parameters do; with --no-full-res-colour
    the bank is at source scale."""
    import gnfr.train
    import pipeline.finetune as ft
    from gnfr.checkpoint import read_metadata

    monkeypatch.setitem(gnfr.train.PRESETS, "quick",
                        replace(TINY, iters=4, ckpt_every=100, source_scale=0.5))
    banks = []
    real = ft.prepare_sources

    def spy(model, scene, cfg, device):
        bank, cache = real(model, scene, cfg, device)
        banks.append((tuple(bank.images.shape[-2:]), bank.feature_scale,
                      tuple(scene.images.shape[-2:])))
        return bank, cache

    monkeypatch.setattr(ft, "prepare_sources", spy)
    ws = masked_workspace(tmp_path / "ws")
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu"), ws)  # the default
    (size, fscale, full), = banks
    assert size == full and fscale == 0.5
    assert read_metadata(ws.model_file)[1]["full_res_colour"] is True
    assert ws.stage_record("finetune")["params"]["train"]["full_res_colour"] is True
    banks.clear()
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", full_res_colour=False), ws)
    (size, fscale, full), = banks
    assert size == (full[0] // 2, full[1] // 2) and fscale == 1.0
    assert read_metadata(ws.model_file)[1]["full_res_colour"] is False


def test_finetune_flare_fallback_trains_with_it_and_records_it(tmp_path, monkeypatch):
    """--flare-fallback darkest: every training step's rays fall back to the darker half of
    the views on an all-flared point, and the model and the stage's parameters record it
    (render then uses it); the default ``valid`` leaves the model's metadata as before."""
    import gnfr.train
    from gnfr.checkpoint import read_metadata

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=3, ckpt_every=100))
    seen = []
    real = gnfr.train.forward_rays

    def spy(*a, **k):
        seen.append(k.get("flare_fallback"))
        return real(*a, **k)

    monkeypatch.setattr(gnfr.train, "forward_rays", spy)
    ws = masked_workspace(tmp_path / "ws")
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", workers=1,
                       flare_fallback="darkest"), ws)
    assert seen and set(seen) == {"darkest"}
    assert read_metadata(ws.model_file)[1]["flare_fallback"] == "darkest"
    assert ws.stage_record("finetune")["params"]["train"]["flare_fallback"] == "darkest"
    seen.clear()
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", workers=1), ws)
    assert seen and set(seen) == {"valid"}
    assert "flare_fallback" not in read_metadata(ws.model_file)[1]


def test_finetune_trains_on_one_cpu_thread_unless_told(tmp_path, monkeypatch):
    """On the CPU the fine-tune runs on CPU_THREADS (1) torch threads, or ``threads`` when
    given, and torch's own count is back after it; on CUDA it is left alone. The count is a
    speed setting: a run at another count is up to date."""
    import torch

    import pipeline.finetune as ft

    assert ft.CPU_THREADS == 1
    seen = []

    def fake_fit(*a, **k):
        seen.append(torch.get_num_threads())
        return {}

    monkeypatch.setattr(ft, "fit", fake_fit)
    ws = make_temple_workspace(tmp_path / "ws", n_views=4, scale=0.25)
    torch.set_num_threads(2)
    for threads in (None, 2):
        ft.run(FinetuneConfig(device="cpu", preset="tiny", iters=1, init="scratch",
                              threads=threads), ws, force=True)
        assert torch.get_num_threads() == 2
    assert seen == [1, 2]
    rec = ws.stage_record("finetune")
    assert "threads" not in json.dumps(rec["params"])
    assert ft.fit_threads(FinetuneConfig(threads=3), torch.device("cpu")) == 3
    assert ft.fit_threads(FinetuneConfig(), torch.device("cuda")) is None


def test_finetune_workers_default_shares_the_cpu_threads(monkeypatch):
    """Unset, ``workers`` is the threads torch would use over the fine-tune's threads, at
    most MAX_AUTO_WORKERS and never under MIN_RAYS rays a process; 1 on CUDA, with the test
    switch off, or when asked."""
    import pipeline.finetune as ft
    from gnfr.ray_split import MIN_RAYS

    cpu, cuda = torch.device("cpu"), torch.device("cuda")
    monkeypatch.setattr(ft, "AUTO_WORKERS", True)
    torch.set_num_threads(2)
    assert ft.fit_workers(FinetuneConfig(), cpu, QUICK) == 2
    assert ft.fit_workers(FinetuneConfig(threads=2), cpu, QUICK) == 1
    assert ft.fit_workers(FinetuneConfig(workers=1), cpu, QUICK) == 1
    assert ft.fit_workers(FinetuneConfig(workers=3), cpu, QUICK) == 3
    assert ft.fit_workers(FinetuneConfig(), cuda, QUICK) == 1
    assert ft.fit_workers(FinetuneConfig(workers=8), cpu, replace(QUICK, rays=3 * MIN_RAYS)) == 3
    monkeypatch.setattr(torch, "get_num_threads", lambda: 16)
    assert ft.fit_workers(FinetuneConfig(), cpu, QUICK) == ft.MAX_AUTO_WORKERS
    monkeypatch.setattr(ft, "AUTO_WORKERS", False)
    assert ft.fit_workers(FinetuneConfig(), cpu, QUICK) == 1


def test_finetune_in_two_processes_trains_as_one_and_resumes_in_one(tmp_path, monkeypatch):
    """The stage with ``workers=2`` logs the numbers one process logs (to rounding), writes
    its checkpoint, is up to date for a one-process run (a speed setting), and a run
    interrupted in two processes resumes in one; the checkpoint says how many trained it."""
    import gnfr.train
    import pipeline.finetune as ft

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=10))
    ws = masked_workspace(tmp_path / "ws")
    one = masked_workspace(tmp_path / "one")
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", workers=1), one)
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", workers=2), ws)
    a, b = _metrics(one.metrics_jsonl), _metrics(ws.metrics_jsonl)
    assert [m["step"] for m in a] == [m["step"] for m in b] == [5, 10]
    assert b[0]["loss"] == pytest.approx(a[0]["loss"], rel=1e-3)
    assert b[0]["psnr"] == pytest.approx(a[0]["psnr"], abs=0.01)
    assert "workers" not in json.dumps(ws.stage_record("finetune")["params"])
    before = ws.model_file.stat().st_mtime_ns
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", workers=1), ws)
    assert ws.model_file.stat().st_mtime_ns == before  # up to date
    # interrupted at step 5 (its checkpoint) in two processes, resumed in one
    scene, cpu = load_workspace(ws.root), torch.device("cpu")
    fit(scene, replace(TINY, iters=10), cpu, tmp_path / "straight", resume=False,
        init="scratch")
    fit(scene, replace(TINY, iters=5), cpu, tmp_path / "resumed", resume=False, init="scratch",
        workers=2)
    fit(scene, replace(TINY, iters=10), cpu, tmp_path / "resumed", resume=True, init="scratch")
    want = _metrics(tmp_path / "straight" / "metrics.jsonl")
    got = _metrics(tmp_path / "resumed" / "metrics.jsonl")
    assert [x["step"] for x in got] == [x["step"] for x in want] == [5, 10]
    for x, y in zip(got, want, strict=True):
        assert x["loss"] == pytest.approx(y["loss"], rel=1e-3)
    prov = ft.checkpoint_provenance(tmp_path / "resumed" / "gnfr.safetensors")
    assert prov["processes"] == 2 and [r["processes"] for r in prov["resumed"]] == [1]
    assert ft.checkpoint_provenance(ws.model_file)["processes"] == 2


def test_finetune_helper_death_is_one_line_and_an_interrupt_stops_the_helpers(tmp_path,
                                                                              monkeypatch):
    """A helper that dies (``HelperDied``, raised by ``RaySplit.gather``: tests/gnfr) is one
    line naming the checkpoint kept and ``--workers 1``; Ctrl-C in the trainer leaves no
    helper running."""
    from gnfr.fit import Trainer
    from gnfr.ray_split import HelperDied, RaySplit
    from pipeline.errors import UserError

    ws = masked_workspace(tmp_path / "ws")
    scene = load_workspace(ws.root)
    cfg = replace(TINY, iters=10)
    started = []
    enter = RaySplit.__enter__

    def keep(self):
        started.append(self)
        return enter(self)

    monkeypatch.setattr(RaySplit, "__enter__", keep)
    train_one = Trainer.train_one

    def died(self, *a, **k):
        if self.step == 7:
            raise HelperDied("a training process stopped without answering (exit code -9, "
                             "killed: out of memory?)")
        return train_one(self, *a, **k)

    monkeypatch.setattr(Trainer, "train_one", died)
    with pytest.raises(UserError) as e:
        fit(scene, cfg, torch.device("cpu"), tmp_path / "run", resume=False, init="scratch",
            workers=2)
    msg = str(e.value)
    assert "\n" not in msg and "checkpoint of step 5 is kept" in msg and "--workers 1" in msg
    assert started and not started[-1].helpers  # stopped and forgotten on the way out

    def interrupt(self, *a, **k):
        if self.step == 2:
            started.append([h.process for h in started[-1].helpers])
            raise KeyboardInterrupt
        return train_one(self, *a, **k)

    monkeypatch.setattr(Trainer, "train_one", interrupt)
    with pytest.raises(KeyboardInterrupt):
        fit(scene, cfg, torch.device("cpu"), tmp_path / "run2", resume=False, init="scratch",
            workers=2)
    procs = started[-1]
    assert len(procs) == 1 and not procs[0].is_alive()


def test_finetune_without_room_in_shared_memory_trains_in_one_process(tmp_path, monkeypatch,
                                                                      capsys):
    """Where the processes would not fit in the free shared memory, the fine-tune says so in
    one line and trains in one process; the checkpoint says one process trained it."""
    import gnfr.ray_split as rs
    import pipeline.finetune as ft

    monkeypatch.setattr(rs, "free_shared_memory", lambda: 1000)
    ws = masked_workspace(tmp_path / "ws")
    fit(load_workspace(ws.root), replace(TINY, iters=5), torch.device("cpu"), tmp_path / "run",
        resume=False, init="scratch", workers=2)
    err = capsys.readouterr().err
    assert "shared memory" in err and "training in one process" in err and "--shm-size" in err
    assert ft.checkpoint_provenance(tmp_path / "run" / "gnfr.safetensors")["processes"] == 1
    assert len(_metrics(tmp_path / "run" / "metrics.jsonl")) == 1


def test_finetune_bf16_trains_the_transformers_under_cpu_autocast_and_records_it(tmp_path,
                                                                                 monkeypatch,
                                                                                 capsys):
    """--bf16: every step's GN-FR forward runs under CPU bf16 autocast while the encoder
    does not, the weights stay fp32, the setting is in the stage's record (a run without it
    trains again); on a CPU without native bf16 it warns that bf16 is emulated; a record made
    before the setting existed is up to date at the fp32 default."""
    import gnfr.renderer as gr
    import gnfr.train

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=3, ckpt_every=100))
    seen = {"model": [], "encoder": []}
    real_fwd, real_enc = gr.GNFR.forward, gr.GNFR.encode

    def fwd(self, *a, **k):
        seen["model"].append(torch.is_autocast_enabled("cpu"))
        return real_fwd(self, *a, **k)

    def enc(self, *a, **k):
        seen["encoder"].append(torch.is_autocast_enabled("cpu"))
        return real_enc(self, *a, **k)

    monkeypatch.setattr(gr.GNFR, "forward", fwd)
    monkeypatch.setattr(gr.GNFR, "encode", enc)
    ws = masked_workspace(tmp_path / "ws")
    monkeypatch.setattr(gr, "native_bf16", lambda: False)
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", bf16=True), ws)
    assert "no native bf16" in " ".join(capsys.readouterr().err.split())
    assert seen["model"] and all(seen["model"]) and not any(seen["encoder"])
    assert ws.stage_record("finetune")["params"]["train"]["cpu_bf16"] is True
    assert all(t.dtype == torch.float32 for t in load_file(str(ws.model_file)).values())
    for v in seen.values():
        v.clear()
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu"), ws)  # trains again
    assert seen["model"] and not any(seen["model"])
    rec = ws.stage_record("finetune")
    del rec["params"]["train"]["cpu_bf16"]  # as written before the setting existed
    ws.update_manifest("finetune", rec)
    stamp = ws.model_file.stat().st_mtime_ns
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu"), ws)
    assert ws.model_file.stat().st_mtime_ns == stamp


def test_cpu_bf16_rule(monkeypatch):
    """bf16 on the CPU: never on CUDA, as asked when asked, else on where AUTO_BF16 says so
    and the CPU computes bf16 natively, unless DEFLARE_CPU_BF16=0 (which the test suite
    sets) keeps the default fp32."""
    import gnfr.renderer as gr

    assert gr.cpu_bf16(True, "cuda") is False and gr.cpu_bf16(None, "cuda:0") is False
    assert gr.cpu_bf16(True, "cpu") is True and gr.cpu_bf16(False, "cpu") is False
    assert gr.cpu_bf16(None, "cpu") is False  # the suite's DEFLARE_CPU_BF16=0
    for env in (None, "1", "0"):
        for auto in (False, True):
            for native in (False, True):
                with pytest.MonkeyPatch.context() as mp:
                    if env is None:
                        mp.delenv(gr.BF16_ENV, raising=False)
                    else:
                        mp.setenv(gr.BF16_ENV, env)
                    mp.setattr(gr, "AUTO_BF16", auto)
                    mp.setattr(gr, "native_bf16", lambda n=native: n)
                    want = auto and native and env != "0"
                    assert gr.cpu_bf16(None, "cpu") is want, (env, auto, native)
                    assert gr.cpu_bf16(True, "cpu") is True
    assert isinstance(gr.native_bf16(), bool)


def test_a_fine_tune_carried_without_its_state_continues_its_steps(tmp_path, monkeypatch):
    """`--init` naming this scene's own fine-tune that stopped short (weights only, as carried
    from another machine) goes on at its step count with a fresh optimizer; the same file on
    another scene, or with other settings, and a fine-tune that finished, start at step 0;
    asking for no more steps than it has is an error."""
    from gnfr.fit import Trainer
    from pipeline.errors import UserError
    from pipeline.finetune import checkpoint_provenance

    ws = masked_workspace(tmp_path / "ws")
    scene = load_workspace(ws.root)
    cfg = replace(TINY, iters=10)
    cpu = torch.device("cpu")
    train_one = Trainer.train_one

    def stop_at_5(self, *a, **k):  # an interrupt after the step-5 checkpoint
        if self.step == 5:
            raise KeyboardInterrupt
        return train_one(self, *a, **k)

    with monkeypatch.context() as m:
        m.setattr(Trainer, "train_one", stop_at_5)
        with pytest.raises(KeyboardInterrupt):
            fit(scene, cfg, cpu, tmp_path / "first", resume=False, init="scratch")
    carried = tmp_path / "carried.safetensors"
    carried.write_bytes((tmp_path / "first" / "gnfr.safetensors").read_bytes())

    stats = fit(scene, cfg, cpu, tmp_path / "go_on", resume=True, init=str(carried))
    assert stats["steps"] == 10
    st = torch.load(tmp_path / "go_on" / "train_state.pt", weights_only=True)
    assert st["step"] == 10
    assert all(int(s["step"]) == 5 for s in st["optimizer"]["state"].values())  # Adam afresh
    assert [m["step"] for m in _metrics(tmp_path / "go_on" / "metrics.jsonl")] == [10]
    prov = checkpoint_provenance(tmp_path / "go_on" / "gnfr.safetensors")
    first = checkpoint_provenance(carried)
    assert prov["resumed"][-1]["at_step"] == 5 and prov["resumed"][-1]["optimizer"] == "fresh"
    assert prov["init"] == first["init"] and prov["started"] == first["started"]
    assert prov["scene"] == first["scene"] and stats["train_seconds"] >= first["train_seconds"]

    with pytest.raises(UserError, match="give --iters above 5"):
        fit(scene, replace(cfg, iters=5), cpu, tmp_path / "no_more", resume=False,
            init=str(carried))

    other = load_workspace(make_temple_workspace(tmp_path / "other", n_views=5,
                                                 scale=0.2).root)
    fit(scene, replace(cfg, iters=5), cpu, tmp_path / "done", resume=False, init="scratch")
    finished = tmp_path / "finished.safetensors"
    finished.write_bytes((tmp_path / "done" / "gnfr.safetensors").read_bytes())
    assert checkpoint_provenance(finished)["steps_done"] == 5
    for sc, c, name, start in ((other, cfg, "other_scene", carried),
                               (scene, replace(cfg, rays=48), "rays", carried),
                               (scene, cfg, "after_a_finished_run", finished)):
        fit(sc, c, cpu, tmp_path / name, resume=False, init=str(start))
        st = torch.load(tmp_path / name / "train_state.pt", weights_only=True)
        assert all(int(s["step"]) == 10 for s in st["optimizer"]["state"].values()), name
        assert "resumed" not in checkpoint_provenance(tmp_path / name / "gnfr.safetensors")


def test_same_scene_allows_decoding_noise_not_other_photos(tmp_path):
    """A scene record matches itself with colours a fraction of a level apart (another
    decoder) and cameras equal to rounding; not with a view renamed, exposure changed by a
    level or more, a camera moved or a mask redrawn."""
    from pipeline.finetune import SAME_SCENE, same_scene, scene_record

    scene = load_workspace(masked_workspace(tmp_path / "ws").root)
    rec = scene_record(scene)
    assert same_scene(rec, rec) and not same_scene(None, rec) and not same_scene({}, rec)

    def changed(key, f):
        other = json.loads(json.dumps(rec))
        other[key] = f(other[key])
        return other

    assert same_scene(changed("mean", lambda m: [[x + 0.3 for x in v] for v in m]), rec)
    assert not same_scene(changed("mean", lambda m: [[x + 1.5 for x in v] for v in m]), rec)
    assert not same_scene(changed("stems", lambda s: [*s[:-1], "other"]), rec)
    assert not same_scene(changed("centre", lambda c: [[c[0][0] + 10 * SAME_SCENE["centre"],
                                                        *c[0][1:]], *c[1:]]), rec)
    assert not same_scene(changed("masked", lambda m: [m[0] + 0.01, *m[1:]]), rec)
    assert not same_scene(changed("focal", lambda f: [f[0] * 1.01, *f[1:]]), rec)
    assert rec["masked"][-1] > 0.1 and len(rec["mean"]) == len(scene.stems) == 5


def test_train_grow_grows_the_training_masks_only(tmp_path, monkeypatch):
    """--train-grow: the scene the fine-tune trains on has each mask grown by a disc of that
    share of the long side (``grow_mask``), the workspace's masks and the views' flare
    fractions stay as they are, and the stage records it."""
    import gnfr.train
    from pipeline import training_scenes
    from pipeline.training_scenes import grow_mask

    m = np.zeros((40, 60), bool)
    m[18:22, 28:32] = True
    g = grow_mask(m, 0.05)  # radius 3 px
    assert g[m].all() and g.sum() > m.sum()
    assert g[20, 34] and g[20, 25] and not g[20, 36] and not g[13, 30]
    assert grow_mask(m, 0.0) is m and not grow_mask(np.zeros_like(m), 0.05).any()

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=2, ckpt_every=100))
    ws = masked_workspace(tmp_path / "ws")
    before = {s: read_mask(ws, s).copy() for s in view_stems(ws)}
    scenes = []
    real = training_scenes.load_workspace
    monkeypatch.setattr(training_scenes, "load_workspace",
                        lambda root, **kw: scenes.append(real(root, **kw)) or scenes[-1])
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", workers=1,
                       train_grow=0.05), ws)
    plain = real(ws.root, holes_as_flare=True)
    grown, = scenes
    assert bool((grown.masks >= plain.masks).all()) and int(grown.masks.sum()) > int(
        plain.masks.sum())
    assert grown.flare == plain.flare
    assert all(np.array_equal(read_mask(ws, s), before[s]) for s in before)
    assert ws.stage_record("finetune")["params"]["train_grow"] == 0.05


def test_finetune_encoder_bf16_encodes_under_cpu_autocast_only_with_bf16(tmp_path, monkeypatch):
    """--encoder-bf16: with --bf16 the encoder's training forward runs under CPU bf16 autocast
    too (the weights stay fp32) and the setting is recorded; without --bf16 it is recorded off
    and the encoder runs in fp32; a record made before the option existed is up to date."""
    import gnfr.renderer as gr
    import gnfr.train

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=3, ckpt_every=100))
    seen = []
    real_enc = gr.GNFR.encode

    def enc(self, *a, **k):
        if torch.is_grad_enabled():  # training's encoding, not the bank's probe
            seen.append(torch.is_autocast_enabled("cpu"))
        return real_enc(self, *a, **k)

    monkeypatch.setattr(gr.GNFR, "encode", enc)
    monkeypatch.setattr(gr, "native_bf16", lambda: True)
    ws = masked_workspace(tmp_path / "ws")
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", bf16=True,
                       encoder_bf16=True, workers=1), ws)
    assert seen and all(seen)
    assert ws.stage_record("finetune")["params"]["train"]["encoder_bf16"] is True
    assert all(t.dtype == torch.float32 for t in load_file(str(ws.model_file)).values())
    seen.clear()
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", bf16=False,
                       encoder_bf16=True, workers=1), ws)  # trains again, the encoder in fp32
    assert seen and not any(seen)
    assert ws.stage_record("finetune")["params"]["train"]["encoder_bf16"] is False
    rec = ws.stage_record("finetune")
    del rec["params"]["train"]["encoder_bf16"]  # as written before the option existed
    ws.update_manifest("finetune", rec)
    stamp = ws.model_file.stat().st_mtime_ns
    run(FinetuneConfig(preset="quick", init="scratch", device="cpu", bf16=False, workers=1), ws)
    assert ws.model_file.stat().st_mtime_ns == stamp
