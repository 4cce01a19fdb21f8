"""gnfr.fit, the training loop: steps and metric lines, interrupt and resume, file names."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace

import pytest
import torch
from safetensors.torch import load_file

from gnfr.checkpoint import load_model, read_metadata
from gnfr.fit import (
    METRICS_FILE,
    MODEL_FILE,
    STATE_FILE,
    StepInput,
    Trainer,
    checkpoint_files,
    has_checkpoint,
    last_record,
    render_meta,
)
from gnfr.model import GNFR
from gnfr.train import TINY, Scene, SourceBank, make_optimizer, prepare_sources, sample_batch

CFG = replace(TINY, iters=6, rays=16, samples=6, log_every=1, ckpt_every=2,
              model=replace(TINY.model, dropout=0.1))


def tiny_scene(n: int = 5, W: int = 64, H: int = 48) -> Scene:
    """Views on a short arc with smooth random textures, flare in the top-left of every
    third view."""
    g = torch.Generator().manual_seed(0)
    base = torch.rand(n, 3, H // 4, W // 4, generator=g)
    imgs = (torch.nn.functional.interpolate(base, size=(H, W), mode="bilinear") * 255)
    K = torch.tensor([[0.8 * W, 0, W / 2], [0, 0.8 * W, H / 2], [0, 0, 1]],
                     dtype=torch.float64).expand(n, 3, 3)
    c2w = torch.eye(4, dtype=torch.float64).repeat(n, 1, 1)
    ang = torch.linspace(-0.3, 0.3, n, dtype=torch.float64)
    c2w[:, 0, 3], c2w[:, 2, 3] = ang.sin() * 3, -ang.cos() * 3
    stems = [f"v{i}" for i in range(n)]
    ranked = {s: [t for t in sorted(stems, key=lambda t: abs(int(t[1:]) - i)) if t != s]
              for i, s in enumerate(stems)}
    masks = torch.zeros(n, 1, H, W, dtype=torch.uint8)
    masks[::3, :, : H // 4, : W // 4] = 1
    return Scene(stems, imgs.to(torch.uint8), K, c2w, torch.full((n,), 1.5, dtype=torch.float64),
                 torch.full((n,), 4.5, dtype=torch.float64), masks,
                 {s: float(masks[i].float().mean()) for i, s in enumerate(stems)}, ranked,
                 name="tiny")


@pytest.fixture(scope="module")
def scene() -> Scene:
    return tiny_scene()


def new_trainer(cfg=CFG) -> Trainer:
    torch.manual_seed(cfg.seed)
    return Trainer(GNFR(cfg.model), cfg)


def run(trainer: Trainer, scene: Scene, out, stop_at: int | None = None, **kw) -> dict:
    """``trainer.run`` on ``scene``; ``stop_at``: the draw of that step raises (a kill)."""
    bank, cache = prepare_sources(trainer.model, scene, trainer.cfg, "cpu")

    def draw(gen):
        if stop_at is not None and trainer.step == stop_at:
            raise KeyboardInterrupt
        return StepInput(sample_batch(scene, trainer.cfg, gen), bank, cache,
                         fields={"scene": scene.name})

    return trainer.run(draw, out=out, meta=lambda step, _: render_meta(trainer.cfg, "t", step),
                       state=lambda step, sec: {"seconds": sec}, **kw)


def lines(out) -> list[dict]:
    return [json.loads(ln) for ln in (out / METRICS_FILE).read_text().splitlines()]


def test_runs_its_steps_logs_and_checkpoints(scene, tmp_path):
    cfg = replace(CFG, log_every=2, ckpt_every=4, iters=5)
    tr = new_trainer(cfg)
    seen, reports = [], []
    stats = run(tr, scene, tmp_path, after_step=lambda inp, r: seen.append(inp.batch.target),
                report=lambda step, it_s, line: reports.append((step, line is not None)))
    assert tr.step == 5 and stats["steps"] == 5 and len(seen) == 5
    assert reports == [(1, False), (2, True), (3, False), (4, True), (5, True)]
    m = lines(tmp_path)
    assert [r["step"] for r in m] == [2, 4, 5]                     # every 2 and the last
    assert list(m[0]) == ["step", "loss", "psnr", "all_flared", "lr_factor", "it_s"]
    assert all(r["lr_factor"] == 1.0 and r["loss"] > 0 for r in m)
    st = torch.load(tmp_path / STATE_FILE, weights_only=True)
    assert st["step"] == 5 and set(st) == {"step", "optimizer", "rng", "seconds"}
    assert read_metadata(tmp_path / MODEL_FILE)[1]["step"] == 5
    # a finished run trains no further and writes nothing more
    stamp = (tmp_path / MODEL_FILE).stat().st_mtime_ns
    assert run(tr, scene, tmp_path)["steps"] == 5
    assert (tmp_path / MODEL_FILE).stat().st_mtime_ns == stamp and len(lines(tmp_path)) == 3


def test_last_record_and_writer_false(scene, tmp_path):
    tr = new_trainer(replace(CFG, iters=2))
    run(tr, scene, tmp_path / "rank1", writer=False)               # a DDP rank other than 0
    assert tr.step == 2 and not (tmp_path / "rank1").exists()
    run(new_trainer(replace(CFG, iters=2)), scene, tmp_path / "rank0", record=last_record)
    m = lines(tmp_path / "rank0")
    assert [r["step"] for r in m] == [1, 2]
    assert list(m[0]) == ["step", "scene", "loss", "psnr", "all_flared", "lr_factor", "it_s"]
    assert m[0]["scene"] == "tiny"


def test_interrupted_run_resumes_step_count_optimizer_and_rng(scene, tmp_path):
    straight = new_trainer()
    run(straight, scene, tmp_path / "straight")
    killed = new_trainer()
    with pytest.raises(KeyboardInterrupt):
        run(killed, scene, tmp_path / "split", stop_at=5)           # steps 1..5 ran
    assert killed.step == 5 and len(lines(tmp_path / "split")) == 5
    saved = torch.load(tmp_path / "split" / STATE_FILE, weights_only=True)
    assert saved["step"] == 4                                       # the last checkpoint
    shutil.copytree(tmp_path / "split", tmp_path / "copy")
    resumed = new_trainer()
    resumed.restore(tmp_path / "split")
    assert resumed.step == 4 and resumed.seconds == saved["seconds"] > 0
    opt_state = resumed.opt.state_dict()["state"]
    assert opt_state and all(int(s["step"]) == 4 for s in opt_state.values())
    assert all(torch.equal(a["exp_avg"], b["exp_avg"])
               for a, b in zip(opt_state.values(), saved["optimizer"]["state"].values(),
                               strict=True))
    stats = run(resumed, scene, tmp_path / "split")
    assert stats["steps"] == 6 and resumed.seconds >= saved["seconds"]
    a = load_file(str(tmp_path / "straight" / MODEL_FILE))
    b = load_file(str(tmp_path / "split" / MODEL_FILE))
    assert all(torch.equal(a[k], b[k]) for k in a)                  # bitwise the same run
    strip = [{k: v for k, v in r.items() if k != "it_s"} for r in lines(tmp_path / "straight")]
    assert [{k: v for k, v in r.items() if k != "it_s"} for r in lines(tmp_path / "split")] \
        == strip                                                    # the killed 5 replaced
    # control: the same resume with a fresh optimizer ends elsewhere
    fresh = new_trainer()
    fresh.restore(tmp_path / "copy")
    fresh.opt = make_optimizer(fresh.model, CFG)
    run(fresh, scene, tmp_path / "copy")
    c = load_file(str(tmp_path / "copy" / MODEL_FILE))
    assert fresh.step == 6 and not all(torch.equal(a[k], c[k]) for k in a)


def test_a_checkpoint_also_after_ckpt_seconds(scene, tmp_path):
    """Besides every ``ckpt_every`` steps, a checkpoint once ``ckpt_seconds`` have passed
    since the last: a run stopped by a time limit keeps its work; 0 turns it off."""
    for seconds, saved in ((1e-6, 3), (0.0, None), (1e9, None)):
        out = tmp_path / f"s{seconds}"
        tr = new_trainer(replace(CFG, ckpt_every=100, ckpt_seconds=seconds))
        with pytest.raises(KeyboardInterrupt):
            run(tr, scene, out, stop_at=3)                          # steps 1..3 ran
        if saved is None:
            assert not (out / STATE_FILE).exists(), seconds
        else:
            assert torch.load(out / STATE_FILE, weights_only=True)["step"] == saved
            assert read_metadata(out / MODEL_FILE)[1]["step"] == saved


def test_checkpoint_file_names_and_contents(scene, tmp_path):
    assert checkpoint_files(tmp_path) == (tmp_path / "gnfr.safetensors",
                                          tmp_path / "train_state.pt")
    assert (MODEL_FILE, STATE_FILE, METRICS_FILE) == ("gnfr.safetensors", "train_state.pt",
                                                      "metrics.jsonl")
    assert not has_checkpoint(tmp_path)
    tr = new_trainer()
    bank, _ = prepare_sources(tr.model, scene, CFG, "cpu")
    tr.train_one(StepInput(sample_batch(scene, CFG, tr.gen), bank))
    tr.save(tmp_path, {"step": tr.step, "note": "x"}, {"unseen": torch.ones(2)})
    assert has_checkpoint(tmp_path)
    st = torch.load(tmp_path / "train_state.pt", weights_only=True)
    assert list(st) == ["step", "optimizer", "rng", "unseen"] and st["step"] == 1
    assert set(st["rng"]) >= {"gen", "torch"}
    assert read_metadata(tmp_path / "gnfr.safetensors")[1] == {"step": 1, "note": "x"}
    assert load_model(tmp_path / "gnfr.safetensors").config == CFG.model
    (tmp_path / "train_state.pt").unlink()
    assert not has_checkpoint(tmp_path)                             # both files, or none


def test_source_bank_fields(scene):
    bank = SourceBank.of(scene, 0.5, "cpu")
    assert bank.images.shape == (5, 3, 24, 32) and bank.images.dtype == torch.float32
    assert bank.K.shape == (5, 3, 3) and bank.c2w.dtype == torch.float32
    assert bank.masks.shape == (5, 1, 24, 32)
    assert float(bank.K[0, 0, 2]) == pytest.approx(16.0)             # K rows scale with size
    model = GNFR(CFG.model).eval()
    assert bank.encode(model, "cpu", torch.tensor([1, 3])).images.shape[0] == 2
    assert bank.encode(model, "cpu").feats.shape[0] == 5


def test_full_res_colour_bank_keeps_full_images_and_encodes_at_source_scale(scene):
    small = SourceBank.of(scene, 0.5, "cpu")
    full = SourceBank.of(scene, 0.5, "cpu", full_res_colour=True)
    assert full.images.shape[-2:] == scene.images.shape[-2:]
    assert small.images.shape[-1] == round(scene.images.shape[-1] * 0.5)
    assert torch.allclose(full.K, scene.K.float()) and full.feature_scale == 0.5
    torch.manual_seed(0)
    model = GNFR(CFG.model).eval()
    a, b = full.encode(model, "cpu"), small.encode(model, "cpu")
    assert torch.allclose(a.feats, b.feats, atol=1e-5)  # the encoder saw the same images
    assert a.images.shape[-2:] == scene.images.shape[-2:]


def test_full_res_colour_bank_filters_the_encoder_input_once(scene):
    """The bank keeps the encoder's area-filtered copies (made once), and encoding through
    them gives the features the per-step filtering of the full-size views gives."""
    from gnfr.renderer import SourceViews

    full = SourceBank.of(scene, 0.5, "cpu", full_res_colour=True)
    assert full.enc_images is not None
    assert full.enc_images.shape[-1] == round(scene.images.shape[-1] * 0.5)
    assert SourceBank.of(scene, 0.5, "cpu").enc_images is None
    torch.manual_seed(0)
    model = GNFR(CFG.model).eval()
    ids = torch.tensor([2, 0])
    cached = full.encode(model, "cpu", ids)
    fresh = SourceViews.encode(model, full.images[ids], full.K[ids], full.c2w[ids],
                               None if full.masks is None else full.masks[ids], "cpu",
                               feature_scale=0.5)
    assert torch.equal(cached.feats, fresh.feats)
    # the bank is shared, not copied: the views are its rows
    assert cached.images.data_ptr() == full.images.data_ptr()
    assert torch.equal(cached.images[cached.rows], fresh.images)


def test_gather_from_a_shared_bank_equals_gather_from_stacked_views(scene):
    """Sampling the chosen views as rows of the whole bank (no per-step copy) gives exactly
    the colours, features, validity and flare of sampling them stacked."""
    from dataclasses import replace

    from gnfr.renderer import SourceViews, gather

    full = SourceBank.of(scene, 0.5, "cpu", full_res_colour=True)
    full = replace(full, masks=(torch.rand(full.images.shape[0], 1, *full.images.shape[-2:],
                                           generator=torch.Generator().manual_seed(3))
                                > 0.7).float())
    torch.manual_seed(0)
    model = GNFR(CFG.model).eval()
    ids = torch.tensor([2, 0, 1])
    shared = full.encode(model, "cpu", ids)
    stacked = SourceViews.encode(model, full.images[ids], full.K[ids], full.c2w[ids],
                                 full.masks[ids], "cpu", feature_scale=0.5)
    c = full.c2w[1, :3, 3]
    points = c + torch.randn(64, 8, 3, generator=torch.Generator().manual_seed(4))
    src_ids = torch.tensor([1, 2, 0])
    a, b = gather(shared, src_ids, points), gather(stacked, src_ids, points)
    for x, y in zip(a, b, strict=True):
        assert torch.equal(x, y)
    assert bool(a[1].any()) and bool(a[2].any())  # points fall inside views and on flare


def test_edge_rays_draw_more_on_edges_and_weigh_each_ray_back(scene):
    """``edge_rays``: pixels drawn in proportion to (share) the target's gradient magnitude,
    the rest uniform; the probabilities sum to one; with share 0 nothing changes (no weights,
    the same draw); the weighted loss estimates the plain mean over the image."""
    from gnfr.losses import masked_mse
    from gnfr.train import edge_probabilities

    img = scene.images.clone()
    img[0] = 100
    img[0, :, :, 40:] = 200  # one vertical edge at x = 40
    edged = replace(scene, images=img)
    q = edge_probabilities(edged, 0, 0.5).reshape(48, 64)
    assert abs(float(q.sum()) - 1) < 1e-5
    assert float(q[:, 39:41].mean()) > 10 * float(q[:, :30].mean())
    assert torch.allclose(q[:, :30], torch.full_like(q[:, :30], 0.5 / (48 * 64)))
    plain = sample_batch(scene, CFG, torch.Generator().manual_seed(3))
    assert plain.weight is None
    again = sample_batch(scene, replace(CFG, edge_rays=0.0), torch.Generator().manual_seed(3))
    assert torch.equal(plain.rgb, again.rgb) and torch.equal(plain.rays_d, again.rays_d)
    b = sample_batch(edged, replace(CFG, edge_rays=0.5, rays=4096),
                     torch.Generator().manual_seed(3))
    assert b.weight is not None and b.weight.shape == (4096,)
    err_map = (torch.arange(64) >= 40).float().expand(48, 64).reshape(-1)  # mean 24 / 64
    g = torch.Generator().manual_seed(4)
    idx = torch.multinomial(q.reshape(-1), 20000, replacement=True, generator=g)
    w = 1.0 / (q.reshape(-1)[idx] * 48 * 64)
    pred = err_map[idx].sqrt()[:, None].expand(-1, 3)
    est = masked_mse(pred, torch.zeros_like(pred), None, w)
    assert abs(float(est) - 24 / 64) < 0.02
    biased = masked_mse(pred, torch.zeros_like(pred), None)  # unweighted: the edges' mean
    assert float(biased) > 24 / 64 + 0.05
    assert torch.allclose(masked_mse(pred, torch.zeros_like(pred), None, torch.ones(20000)),
                          masked_mse(pred, torch.zeros_like(pred), None))


def test_logged_psnr_under_edge_rays_is_the_weighted_estimate(scene):
    """With ``edge_rays`` the step's psnr is over the drawn rays weighted back (the image's
    mean error, as the loss), not their plain mean, which the edges bias low; without the
    loss mask it still leaves the flare pixels out."""
    from gnfr.losses import masked_mse, mse_to_psnr
    from gnfr.renderer import forward_rays
    from gnfr.train import batch_sources, compute_loss

    cfg = replace(CFG, edge_rays=0.5, rays=256, mask_loss=False)
    torch.manual_seed(0)
    model = GNFR(cfg.model).eval()
    bank, cache = prepare_sources(model, scene, cfg, "cpu")
    batch = sample_batch(scene, cfg, torch.Generator().manual_seed(5))
    assert batch.weight is not None and batch.flare is not None
    with torch.no_grad():
        src, ids = batch_sources(model, batch, bank, cache, "cpu")
        _, info = compute_loss(model, batch, src, ids, cfg)
        torch.manual_seed(0)
        rgb = forward_rays(model, src, ids, batch.rays_o, batch.rays_d, batch.t,
                           cfg.point_sampler, cfg.reference)["rgb"]
    weighted = mse_to_psnr(masked_mse(rgb, batch.rgb, batch.flare, batch.weight))
    plain = mse_to_psnr(masked_mse(rgb, batch.rgb, batch.flare))
    assert abs(weighted - plain) > 1e-3  # the two differ on this batch
    assert abs(info["psnr"] - weighted) < 1e-4
