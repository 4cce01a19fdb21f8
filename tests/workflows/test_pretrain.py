"""Pretraining: scene readers (LLFF, COLMAP text and binary), held-out scenes, torchrun."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import torch

from gnfr.checkpoint import load_model
from pipeline.cameras import load_cameras
from pipeline.errors import UserError
from pipeline.training_scenes import load_colmap, load_llff, load_workspace, qvec_to_rotmat
from tests.conftest import REPO
from tests.fixtures import make_temple_workspace
from workflows.research.pretrain import find_scenes


def _rotmat_to_qvec(R):
    w = np.sqrt(max(1e-12, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    return np.array([w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w),
                     (R[1, 0] - R[0, 1]) / (4 * w)])


def _write_colmap_text(ws, folder):
    """A COLMAP text model + images/ of the temple workspace (points from the near/far)."""
    cams = load_cameras(ws.cameras_json)
    (folder / "sparse" / "0").mkdir(parents=True)
    (folder / "images").mkdir()
    lines_c, lines_i = [], []
    pts = np.random.default_rng(0).uniform(-0.15, 0.15, (50, 3))
    for i, f in enumerate(cams.frames, 1):
        (folder / "images" / f"{f.stem}.png").write_bytes((ws.images / f"{f.stem}.png")
                                                          .read_bytes())
        K = f.K
        lines_c.append(f"{i} PINHOLE {f.width} {f.height} {K[0, 0]} {K[1, 1]} {K[0, 2]} "
                       f"{K[1, 2]}")
        w2c = np.linalg.inv(f.c2w)
        q, t = _rotmat_to_qvec(w2c[:3, :3]), w2c[:3, 3]
        lines_i.append(f"{i} {' '.join(map(str, q))} {' '.join(map(str, t))} {i} {f.stem}.png")
        lines_i.append(" ".join(f"1.0 2.0 {j + 1}" for j in range(len(pts))))
    sp = folder / "sparse" / "0"
    (sp / "cameras.txt").write_text("\n".join(lines_c) + "\n")
    (sp / "images.txt").write_text("\n".join(lines_i) + "\n")
    ids = range(1, len(cams.frames) + 1)
    (sp / "points3D.txt").write_text("".join(
        f"{j + 1} {p[0]} {p[1]} {p[2]} 1 2 3 0.5 {' '.join(f'{i} {j}' for i in ids)}\n"
        for j, p in enumerate(pts)))
    return cams


def test_colmap_text_and_binary_readers_recover_cameras(tmp_path):
    ws = make_temple_workspace(tmp_path / "ws", n_views=4, scale=0.2)
    cams = _write_colmap_text(ws, tmp_path / "col")
    a = load_colmap(tmp_path / "col")
    pycolmap = pytest.importorskip("pycolmap")
    rec = pycolmap.Reconstruction(str(tmp_path / "col" / "sparse" / "0"))
    (tmp_path / "bin" / "sparse").mkdir(parents=True)
    rec.write_binary(str(tmp_path / "bin" / "sparse"))
    (tmp_path / "bin" / "images").symlink_to(tmp_path / "col" / "images")
    b = load_colmap(tmp_path / "bin")
    for sc in (a, b):
        assert sc.stems == cams.stems and sc.images.shape[0] == 4
        assert torch.allclose(sc.K[0], torch.tensor(cams.frames[0].K), atol=1e-6)
        # rotations are kept; centres are recentred and scaled into the unit sphere
        for f, c2w in zip(cams.frames, sc.c2w, strict=True):
            assert np.allclose(c2w[:3, :3].numpy(), f.c2w[:3, :3], atol=1e-6)
        assert float(sc.c2w[:, :3, 3].norm(dim=1).max()) == pytest.approx(1.0)
        assert bool((sc.near < sc.far).all()) and bool((sc.near > 0).all())
    assert torch.allclose(a.c2w, b.c2w, atol=1e-6) and torch.allclose(a.near, b.near)
    assert np.allclose(qvec_to_rotmat(_rotmat_to_qvec(cams.frames[1].c2w[:3, :3])),
                       cams.frames[1].c2w[:3, :3], atol=1e-8)


def test_llff_poses_convert_to_opencv(tmp_path):
    ws = make_temple_workspace(tmp_path / "ws", n_views=4, scale=0.2)
    ref = load_workspace(ws.root)
    cams = load_cameras(ws.cameras_json)
    rows = []
    for f in cams.frames:
        R, c = f.c2w[:3, :3], f.c2w[:3, 3]
        llff = np.stack([R[:, 1], R[:, 0], -R[:, 2], c,
                         [f.height, f.width, f.K[0, 0]]], 1)  # down, right, back, t, hwf
        rows.append(np.concatenate([llff.reshape(-1), [f.near, f.far]]))
    d = tmp_path / "llff"
    (d / "images").mkdir(parents=True)
    np.save(d / "poses_bounds.npy", np.array(rows))
    for f in cams.frames:
        (d / "images" / f"{f.stem}.png").write_bytes((ws.images / f"{f.stem}.png").read_bytes())
    sc = load_llff(d)
    assert torch.allclose(sc.c2w[:, :3, :3], ref.c2w[:, :3, :3], atol=1e-9)
    # same scene up to a similarity: relative centre distances agree after scaling
    dref = torch.cdist(ref.c2w[:, :3, 3], ref.c2w[:, :3, 3])
    dl = torch.cdist(sc.c2w[:, :3, 3], sc.c2w[:, :3, 3])
    s = dl.max() / dref.max()
    assert torch.allclose(dl, dref * s, atol=1e-6)
    assert torch.allclose(sc.near, ref.near * 0.9 * s, atol=1e-6)


def test_find_scenes_leaves_out_heldout(tmp_path):
    make_temple_workspace(tmp_path / "all" / "kermit", n_views=3, scale=0.1)
    make_temple_workspace(tmp_path / "all" / "temple", n_views=3, scale=0.1)
    assert [p.name for p in find_scenes([tmp_path / "all"])] == ["temple"]
    with pytest.raises(UserError):
        find_scenes([tmp_path / "all" / "kermit"])


def test_torchrun_two_process_gloo_pretrain(tmp_path):
    make_temple_workspace(tmp_path / "scenes" / "temple", n_views=5, scale=0.15)
    out = tmp_path / "out"
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(REPO))
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone",
           "--nproc_per_node", "2", "-m", "workflows.research.pretrain", str(tmp_path / "scenes"),
           "--out", str(out), "--preset", "tiny", "--iters", "6", "--no-flare",
           "--device", "cpu"]
    res = subprocess.run(cmd, env=env, cwd=REPO, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr[-3000:]
    model = load_model(out / "gnfr.safetensors")
    assert model.config.width == 16
    state = torch.load(out / "train_state.pt", weights_only=True)
    assert state["step"] == 6
    # resuming a finished run (in-process, single rank) does nothing more and keeps the step
    from workflows.research.pretrain import PretrainConfig, run

    stamp = (out / "gnfr.safetensors").stat().st_mtime_ns
    run(PretrainConfig(scenes=[tmp_path / "scenes"], out=out, preset="tiny", iters=6,
                       flare=False, device="cpu"))
    assert torch.load(out / "train_state.pt", weights_only=True)["step"] == 6
    assert (out / "gnfr.safetensors").stat().st_mtime_ns == stamp


# --------------------------------------------------------------------------- step counts
@pytest.fixture(scope="module")
def pretrain_scenes(tmp_path_factory):
    root = tmp_path_factory.mktemp("pretrain_scenes")
    make_temple_workspace(root / "temple", n_views=5, scale=0.15)
    return root


@pytest.fixture
def steps_taken(monkeypatch):
    """The step argument of every train_step the training loop (gnfr.fit) makes."""
    import gnfr.fit

    taken, real = [], gnfr.fit.train_step

    def counting(model, opt, batch, *args):
        taken.append(args[3])                        # (bank, cache, cfg, step, ...)
        return real(model, opt, batch, *args)
    monkeypatch.setattr(gnfr.fit, "train_step", counting)
    return taken


def _pretrain_cli(scenes, out, iters: int, *extra: str) -> None:
    from workflows.cli import main

    assert main(["pretrain", str(scenes), "--out", str(out), "--preset", "tiny", "--iters",
                 str(iters), "--no-flare", "--device", "cpu", *extra]) == 0


def _steps_logged(out) -> list[int]:
    import json

    return [json.loads(ln)["step"] for ln in (out / "metrics.jsonl").read_text().splitlines()]


def test_init_from_weights_continues_their_step_count(pretrain_scenes, steps_taken, tmp_path,
                                                      capsys):
    from gnfr.checkpoint import read_metadata
    from workflows.research.pretrain import export_fp16, start_step

    _pretrain_cli(pretrain_scenes, tmp_path / "a", 6)
    assert steps_taken == list(range(6))
    shipped = export_fp16(tmp_path / "a" / "gnfr.safetensors", tmp_path / "shipped.safetensors")
    assert read_metadata(shipped)[1]["step"] == 6
    steps_taken.clear()
    _pretrain_cli(pretrain_scenes, tmp_path / "b", 12, "--init", str(shipped))
    assert steps_taken == list(range(6, 12))             # not 0..11: it went on from step 6
    assert _steps_logged(tmp_path / "b") == [10, 12]
    assert torch.load(tmp_path / "b" / "train_state.pt", weights_only=True)["step"] == 12
    assert read_metadata(tmp_path / "b" / "gnfr.safetensors")[1]["step"] == 12
    # weights of another preset (same architecture) start the count at 0
    other = export_fp16(tmp_path / "a" / "gnfr.safetensors", tmp_path / "other.safetensors",
                        {"preset": "pretrain-quick"})
    from gnfr.train import PRESETS

    assert start_step(PRESETS["tiny"], str(other), "tiny") == 0
    assert start_step(PRESETS["tiny"], str(shipped), "tiny") == 6
    assert start_step(PRESETS["tiny"], "scratch", "tiny") == 0
    # an --iters the weights already reached is refused (nothing would be trained)
    from workflows.cli import main

    assert main(["pretrain", str(pretrain_scenes), "--out", str(tmp_path / "d"), "--preset",
                 "tiny", "--iters", "6", "--device", "cpu", "--init", str(shipped)]) == 2
    assert "give --iters above 6" in capsys.readouterr().err
    assert not (tmp_path / "d" / "gnfr.safetensors").exists()
    steps_taken.clear()
    _pretrain_cli(pretrain_scenes, tmp_path / "c", 3, "--init", str(other))
    assert steps_taken == [0, 1, 2]
    assert read_metadata(tmp_path / "c" / "gnfr.safetensors")[1]["step"] == 3


def test_interrupted_pretrain_resumes_its_step_count(pretrain_scenes, steps_taken, tmp_path):
    from dataclasses import replace

    import gnfr.fit
    import workflows.research.pretrain as wp
    from gnfr.train import PRESETS

    class Killed(Exception):
        pass

    real = gnfr.fit.train_step

    def dies_at_step_5(model, opt, batch, *args):
        if args[3] == 5:                             # (bank, cache, cfg, step, ...)
            raise Killed
        return real(model, opt, batch, *args)
    cfg = replace(PRESETS["tiny"], ckpt_every=2)
    config = wp.PretrainConfig(scenes=[pretrain_scenes], out=tmp_path / "run", preset="tiny",
                               iters=10, flare=False, device="cpu")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(gnfr.fit, "train_step", dies_at_step_5)
        with pytest.raises(Killed):
            wp.run(config, cfg)
    # steps 0..4 ran; the last checkpoint is the one after step index 3 (step count 4)
    assert torch.load(tmp_path / "run" / "train_state.pt", weights_only=True)["step"] == 4
    assert steps_taken == [0, 1, 2, 3, 4]
    wp.run(config, cfg)                                  # rerun in the same folder
    assert steps_taken[5:] == list(range(4, 10))         # continued, not restarted
    assert torch.load(tmp_path / "run" / "train_state.pt", weights_only=True)["step"] == 10
    assert _steps_logged(tmp_path / "run") == [5, 10]   # the killed run's 5 was dropped
    # resumed under other settings (another share of flared views): refused, naming it
    from pipeline.errors import UserError

    with pytest.raises(UserError, match=r"started with --flare-prob 0.5 \(now 0.3\)"):
        wp.run(replace(config, flare_prob=0.3, iters=12), cfg)
    assert steps_taken[-1] == 9
    wp.run(replace(config, iters=12), cfg)               # more steps of the same: resumes
    assert steps_taken[-2:] == [10, 11]


def test_resumes_a_train_state_of_the_existing_format(pretrain_scenes, steps_taken, tmp_path):
    """OUT/ as pretraining has written it (weights + {"step", "optimizer", "rng"}): a run
    in that folder goes on from the step, with the saved optimizer state."""
    from gnfr.checkpoint import save_model
    from gnfr.model import GNFR
    from gnfr.train import PRESETS, make_optimizer

    cfg = PRESETS["tiny"]
    model = GNFR(cfg.model)
    opt = make_optimizer(model, cfg)
    for p in model.parameters():                       # an Adam state to carry over
        p.grad = torch.ones_like(p)
    opt.step()
    out = tmp_path / "out"
    out.mkdir()
    save_model(out / "gnfr.safetensors", model, {"step": 7, "preset": "tiny"})
    gen = torch.Generator().manual_seed(0)
    torch.save({"step": 7, "optimizer": opt.state_dict(),
                "rng": {"gen": gen.get_state(), "torch": torch.get_rng_state()}},
               out / "train_state.pt")
    _pretrain_cli(pretrain_scenes, out, 9)
    assert steps_taken == [7, 8]
    st = torch.load(out / "train_state.pt", weights_only=True)
    assert list(st) == ["step", "optimizer", "rng"] and st["step"] == 9
    assert all(int(s["step"]) == 1 + 2 for s in st["optimizer"]["state"].values())
    assert _steps_logged(out) == [9]


def test_pretrain_options_reach_the_run(pretrain_scenes, tmp_path):
    """--full-res-colour is recorded in the weights (render follows it); off by default."""
    from gnfr.checkpoint import read_metadata

    _pretrain_cli(pretrain_scenes, tmp_path / "f", 4, "--full-res-colour", "--ckpt-every", "2")
    _, meta = read_metadata(tmp_path / "f" / "gnfr.safetensors")
    assert meta["full_res_colour"] is True and meta["step"] == 4
    _pretrain_cli(pretrain_scenes, tmp_path / "p", 2)
    _, meta = read_metadata(tmp_path / "p" / "gnfr.safetensors")
    assert meta["full_res_colour"] is False


def test_pretrain_dropout_reaches_the_transformers(pretrain_scenes, tmp_path, monkeypatch):
    """--dropout sets the transformers' dropout of the model that trains (0 without it)."""
    import workflows.research.pretrain as pt

    seen = []
    real = pt.init_model

    def spy(cfg, device, init):
        model, how = real(cfg, device, init)
        seen.append({m.p for m in model.modules() if isinstance(m, torch.nn.Dropout)})
        return model, how

    monkeypatch.setattr(pt, "init_model", spy)
    _pretrain_cli(pretrain_scenes, tmp_path / "d", 2, "--dropout", "0.1")
    _pretrain_cli(pretrain_scenes, tmp_path / "n", 2)
    assert seen == [{0.1}, {0.0}]


def test_pretrain_random_sources_reach_the_source_draw(pretrain_scenes, tmp_path, monkeypatch):
    """--random-sources makes every training step draw its sources in GNT's random order of
    the pool; without it they are the nearest first."""
    import gnfr.train as gt

    flags = []
    real = gt.train_sources

    def spy(*args, **kwargs):
        flags.append(kwargs["random_pick"])
        return real(*args, **kwargs)

    monkeypatch.setattr(gt, "train_sources", spy)
    _pretrain_cli(pretrain_scenes, tmp_path / "r", 2, "--random-sources")
    n_random = len(flags)
    _pretrain_cli(pretrain_scenes, tmp_path / "n", 2)
    assert n_random >= 2 and set(flags[:n_random]) == {True}
    assert len(flags) > n_random and set(flags[n_random:]) == {False}


def test_lr_restart_schedule_counts_from_the_restart_step():
    """A warm restart: before its step the preset's halving; from it, ``lr_restart`` of the
    starting rates, halved every ``lr_decay_steps`` counted from the restart."""
    from dataclasses import replace

    from gnfr.model import GNFR
    from gnfr.train import PRESETS, make_optimizer, set_learning_rates

    cfg = replace(PRESETS["tiny"], lr_decay_steps=10, lr_restart=0.125, lr_restart_step=45)
    opt = make_optimizer(GNFR(cfg.model), cfg)
    assert set_learning_rates(opt, cfg, 44) == 0.5 ** 4
    assert set_learning_rates(opt, cfg, 45) == 0.125
    assert set_learning_rates(opt, cfg, 54) == 0.125
    assert set_learning_rates(opt, cfg, 55) == 0.0625
    lrs = {g["name"]: g["lr"] for g in opt.param_groups}
    assert lrs == {"encoder": cfg.lr_encoder * 0.0625, "transformer": cfg.lr_transformer * 0.0625}
    assert set_learning_rates(opt, replace(cfg, lr_restart=0.0), 55) == 0.5 ** 5


def test_pretrain_lr_restart_starts_at_the_init_step_and_survives_a_resume(
        pretrain_scenes, steps_taken, tmp_path, capsys, monkeypatch):
    """--lr-restart from weights recorded at step 6: the logged rates are the restart's from
    step 6 on, and a rerun of the same command in the same folder keeps that restart step."""
    import json
    from dataclasses import replace

    import gnfr.train
    from workflows.research.pretrain import export_fp16

    monkeypatch.setitem(gnfr.train.PRESETS, "tiny",
                        replace(gnfr.train.PRESETS["tiny"], lr_decay_steps=4))

    _pretrain_cli(pretrain_scenes, tmp_path / "a", 6)
    shipped = export_fp16(tmp_path / "a" / "gnfr.safetensors", tmp_path / "shipped.safetensors")
    out = tmp_path / "b"
    _pretrain_cli(pretrain_scenes, out, 10, "--init", str(shipped), "--lr-restart", "0.25")
    _pretrain_cli(pretrain_scenes, out, 15, "--init", str(shipped), "--lr-restart", "0.25")
    lines = [json.loads(ln) for ln in (out / "metrics.jsonl").read_text().splitlines()]
    # step indices 9 and 14, the restart at 6 (a restart at the resume's 10 would give 0.125)
    assert [(ln["step"], ln["lr_factor"]) for ln in lines] == [(10, 0.25), (15, 0.0625)]
    _pretrain_cli(pretrain_scenes, tmp_path / "c", 10, "--init", str(shipped))
    plain = [json.loads(ln) for ln in (tmp_path / "c" / "metrics.jsonl").read_text().splitlines()]
    assert [ln["lr_factor"] for ln in plain] == [0.25]  # step index 9: the plain halving
    from gnfr.checkpoint import read_metadata

    meta = read_metadata(out / "gnfr.safetensors")[1]
    assert (meta["lr_restart"], meta["lr_restart_step"], meta["step"]) == (0.25, 6, 15)
    assert "lr_restart" not in read_metadata(tmp_path / "c" / "gnfr.safetensors")[1]
    from workflows.cli import main

    capsys.readouterr()
    assert main(["pretrain", str(pretrain_scenes), "--out", str(tmp_path / "d"), "--preset",
                 "tiny", "--iters", "8", "--device", "cpu", "--lr-restart", "2"]) == 2
    err = capsys.readouterr().err
    assert "--lr-restart" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "d").exists()


def test_mirrored_scene_is_the_same_geometry_seen_in_a_mirror(pretrain_scenes):
    """A world point at pixel (x, y) of a view projects to (W - x, y) of the mirrored view,
    at the same depth; the mirrored images are the flipped ones and the cameras stay proper
    rotations; the views' neighbours carry over."""
    from gnfr.geometry import project
    from gnfr.train import mirrored

    scene = load_workspace(pretrain_scenes / "temple")
    scene.masks = torch.zeros(scene.images.shape[0], 1, *scene.images.shape[-2:], dtype=torch.uint8)
    scene.masks[:, :, :, :3] = 1  # a flare strip on the left edge
    mir = mirrored(scene)
    W = scene.images.shape[-1]
    pts = torch.from_numpy(np.random.default_rng(0).uniform(-0.1, 0.1, (40, 3))).float()
    xy, z = project(pts, scene.K.float(), torch.linalg.inv(scene.c2w.float()))
    xy_m, z_m = project(pts * torch.tensor([-1.0, 1.0, 1.0]), mir.K.float(),
                        torch.linalg.inv(mir.c2w.float()))
    assert (z > 0).all() and torch.allclose(z_m, z, atol=1e-4)
    assert torch.allclose(xy_m[..., 0], W - xy[..., 0], atol=1e-3)
    assert torch.allclose(xy_m[..., 1], xy[..., 1], atol=1e-3)
    assert not torch.allclose(xy_m[..., 0], xy[..., 0], atol=1.0)  # it did move the points
    assert torch.equal(mir.images, scene.images.flip(-1))
    assert mir.masks[..., -3:].all() and not mir.masks[..., :-3].any()
    assert torch.allclose(torch.linalg.det(mir.c2w[:, :3, :3].float()), torch.ones(len(mir.stems)),
                          atol=1e-5)
    assert mir.ranked == scene.ranked and mir.name == "temple~mirror"


def test_pretrain_mirror_doubles_the_scenes_and_is_recorded(pretrain_scenes, tmp_path,
                                                           monkeypatch):
    """--mirror trains on each scene and its mirror image (the draws reach both) and says so
    in the weights' metadata; without it, one scene and no such key."""
    import workflows.research.pretrain as pt
    from gnfr.checkpoint import read_metadata

    names = []
    real = pt.sample_batch

    def spy(scene, *args):
        names.append(scene.name)
        return real(scene, *args)

    monkeypatch.setattr(pt, "sample_batch", spy)
    _pretrain_cli(pretrain_scenes, tmp_path / "m", 24, "--mirror")
    assert set(names) == {"temple", "temple~mirror"}
    assert read_metadata(tmp_path / "m" / "gnfr.safetensors")[1]["pretrain_mirror"] is True
    names.clear()
    _pretrain_cli(pretrain_scenes, tmp_path / "n", 4)
    assert set(names) == {"temple"}
    assert "pretrain_mirror" not in read_metadata(tmp_path / "n" / "gnfr.safetensors")[1]


def test_pretrain_layered_adds_drawn_scenes_and_is_recorded(pretrain_scenes, tmp_path,
                                                           monkeypatch):
    """--layered N adds N layered scenes at the load size (4:3), the steps reach both kinds
    at about --layered-share, and the weights' metadata says so."""
    import workflows.research.pretrain as pt
    from gnfr.checkpoint import read_metadata

    names, shapes = [], {}
    real = pt.sample_batch

    def spy(scene, *args):
        names.append(scene.name)
        shapes[scene.name] = tuple(scene.images.shape[-2:])
        return real(scene, *args)

    monkeypatch.setattr(pt, "sample_batch", spy)
    _pretrain_cli(pretrain_scenes, tmp_path / "l", 40, "--layered", "2", "--layered-share",
                  "0.5", "--max-size", "64")
    layered = [n for n in names if n.startswith("layered")]
    assert set(layered) == {"layered000", "layered001"} and "temple" in names
    assert 8 <= len(layered) <= 32            # 40 draws at one half: far outside is a bug
    assert shapes["layered000"] == (48, 64)
    meta = read_metadata(tmp_path / "l" / "gnfr.safetensors")[1]
    assert meta["pretrain_layered"] == 2 and meta["pretrain_layered_share"] == 0.5


@pytest.mark.parametrize("content", [b"not numpy", None])
def test_a_bad_poses_bounds_file_stops_pretraining_with_one_line(tmp_path, capsys, content):
    """An unreadable or wrongly shaped poses_bounds.npy: one line naming it, exit 2, and no
    output folder made."""
    from workflows.cli import main

    scene = tmp_path / "llff"
    (scene / "images").mkdir(parents=True)
    if content is None:
        np.save(scene / "poses_bounds.npy", np.zeros((3, 12)))
    else:
        (scene / "poses_bounds.npy").write_bytes(content)
    assert main(["pretrain", str(scene), "--out", str(tmp_path / "out"), "--preset", "tiny",
                 "--iters", "2", "--device", "cpu"]) == 2
    err = capsys.readouterr().err
    assert str(scene / "poses_bounds.npy") in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_pretrain_dec_norm_builds_the_normalised_encoder_and_records_it(pretrain_scenes,
                                                                         tmp_path, capsys):
    """--dec-norm trains the encoder with the decoder's InstanceNorm and stores it in the
    weights' config; starting it from weights without it stops with one line."""
    from gnfr.checkpoint import read_metadata

    _pretrain_cli(pretrain_scenes, tmp_path / "n", 2, "--dec-norm")
    cfg, _ = read_metadata(tmp_path / "n" / "gnfr.safetensors")
    assert cfg.dec_norm is True
    _pretrain_cli(pretrain_scenes, tmp_path / "p", 2)
    cfg, _ = read_metadata(tmp_path / "p" / "gnfr.safetensors")
    assert cfg.dec_norm is False
    from workflows.cli import main

    capsys.readouterr()
    assert main(["pretrain", str(pretrain_scenes), "--out", str(tmp_path / "x"), "--preset",
                 "tiny", "--iters", "4", "--no-flare", "--device", "cpu", "--dec-norm",
                 "--init", str(tmp_path / "p" / "gnfr.safetensors")]) == 2
    err = capsys.readouterr().err
    assert "--init" in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()
    # its run folder resumed without the flag: one line, the folder as it was
    before = (tmp_path / "n" / "gnfr.safetensors").read_bytes()
    assert main(["pretrain", str(pretrain_scenes), "--out", str(tmp_path / "n"), "--preset",
                 "tiny", "--iters", "4", "--no-flare", "--device", "cpu"]) == 2
    err = capsys.readouterr().err
    assert "--dec-norm" in err and "Traceback" not in err
    assert (tmp_path / "n" / "gnfr.safetensors").read_bytes() == before
    # a prior with the norm continues (pretrain) and fine-tunes with it, no flag needed
    from gnfr.train import PRESETS
    from pipeline.finetune import init_model

    normed = tmp_path / "n" / "gnfr.safetensors"
    _pretrain_cli(pretrain_scenes, tmp_path / "n2", 4, "--init", str(normed))
    assert read_metadata(tmp_path / "n2" / "gnfr.safetensors")[0].dec_norm is True
    model, how = init_model(PRESETS["tiny"], torch.device("cpu"), str(normed))
    assert model.config.dec_norm is True and str(normed) in how
    assert init_model(PRESETS["tiny"], torch.device("cpu"), "scratch")[0].config.dec_norm is False


def test_pretrain_from_a_file_that_is_not_weights_stops_with_one_line(pretrain_scenes,
                                                                      tmp_path, capsys):
    from workflows.cli import main

    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(b"not weights")
    assert main(["pretrain", str(pretrain_scenes), "--out", str(tmp_path / "x"), "--preset",
                 "tiny", "--iters", "2", "--no-flare", "--device", "cpu", "--init",
                 str(bad)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()


def test_exposure_match_evens_out_workspaces_with_depth_maps(tmp_path):
    """--exposure-match: a workspace with depth maps whose views differ by half a stop each
    is loaded at its common exposure (the gains ``finetune --exposure-match`` finds, applied
    to the photos), a workspace without depth maps as it is; the weights name the scenes
    evened out, and a run without the option names none."""
    import cv2

    from gnfr.checkpoint import read_metadata
    from pipeline import depth
    from pipeline import exposure as ex
    from pipeline.depth import DepthConfig
    from pipeline.finetune import exposure_gains
    from pipeline.ws_files import read_view_image
    from tests.fixtures import make_plane_workspace
    from workflows.research.pretrain import PretrainConfig, load_scenes

    scenes = tmp_path / "scenes"
    ws = make_plane_workspace(scenes / "plane", n_views=5)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    for i, s in enumerate(stems):  # view i: (i - 2) / 2 EV
        img = read_view_image(ws, s, as_float=True)
        out = ex.apply_gain(img, [2.0 ** (0.5 * (i - 2))] * 3)
        cv2.imwrite(str(ws.image_path(s)), (out[..., ::-1] * 255).round().astype(np.uint8))
    depth.run(DepthConfig(), ws)
    make_temple_workspace(scenes / "temple", n_views=5, scale=0.15)  # no depth maps
    config = PretrainConfig(scenes=[scenes], flare=False, exposure_match=True)
    evened: list[str] = []
    loaded = {sc.name: sc for sc in load_scenes(config, evened=evened)}
    assert evened == ["plane"]
    plain = {sc.name: sc for sc in load_scenes(PretrainConfig(scenes=[scenes], flare=False))}
    assert torch.equal(loaded["temple"].images, plain["temple"].images)
    gains = exposure_gains(ws)
    for i, s in enumerate(loaded["plane"].stems):
        want = ex.apply_gain(read_view_image(ws, s), gains[s])
        assert np.abs(loaded["plane"].images[i].permute(1, 2, 0).numpy().astype(int)
                      - want.astype(int)).max() <= 1
    level = [float(v.float().mean()) for v in loaded["plane"].images]
    raw = [float(v.float().mean()) for v in plain["plane"].images]
    assert max(raw) - min(raw) > 3 * (max(level) - min(level))  # two stops become little
    _pretrain_cli(scenes, tmp_path / "e", 2, "--exposure-match")
    assert read_metadata(tmp_path / "e" / "gnfr.safetensors")[1]["pretrain_exposure_match"] \
        == ["plane"]
    _pretrain_cli(scenes, tmp_path / "n", 2)
    assert "pretrain_exposure_match" not in read_metadata(tmp_path / "n" / "gnfr.safetensors")[1]


def test_pretrain_source_flare_reads_flared_twins_and_records_it(pretrain_scenes, tmp_path,
                                                                 monkeypatch):
    """--source-flare 1 --flare-flag: every step reads its sources from one of its scene's
    flared twins (their masks hold the twin's flare), the weights
    record the share and carry the flag in their config; without the options no twin is
    drawn, the steps read the scene and the weights have neither."""
    import json

    import workflows.research.pretrain as pt
    from gnfr.checkpoint import read_metadata
    from pipeline.source_flare import TWINS

    banks = []
    real = pt.source_twins

    def spy(model, scenes, config, train_cfg, device):
        out = real(model, scenes, config, train_cfg, device)
        banks.append(out)
        return out

    monkeypatch.setattr(pt, "source_twins", spy)
    _pretrain_cli(pretrain_scenes, tmp_path / "t", 3, "--source-flare", "1", "--flare-flag",
                  "--ckpt-every", "1")
    assert len(banks[0]) == 1  # one scene
    twins = banks[0][0]
    assert len(twins) == TWINS
    assert all(bank.masks is not None and bool(bank.masks.any()) for bank, _ in twins)
    lines = [json.loads(x) for x in (tmp_path / "t" / "metrics.jsonl").read_text().splitlines()]
    assert lines and all("twin" in r for r in lines)
    cfg, meta = read_metadata(tmp_path / "t" / "gnfr.safetensors")
    assert meta["pretrain_source_flare"] == 1.0 and cfg.flare_flag
    _pretrain_cli(pretrain_scenes, tmp_path / "n", 2, "--ckpt-every", "1")
    assert banks[1] == []
    lines = [json.loads(x) for x in (tmp_path / "n" / "metrics.jsonl").read_text().splitlines()]
    assert lines and not any("twin" in r for r in lines)
    cfg, meta = read_metadata(tmp_path / "n" / "gnfr.safetensors")
    assert "pretrain_source_flare" not in meta and not cfg.flare_flag


def test_pretrain_options_land_on_the_training_config_and_nothing_else_moves():
    """``train_config``: each option that shapes the training sets its one field of the
    preset (the transformers' dropout, the decoder's norm and the flare flag on the model);
    with none given only the seed differs from the preset."""
    from dataclasses import asdict, replace

    from gnfr.train import PRESETS
    from workflows.research.pretrain import PretrainConfig, train_config

    base = PRESETS["tiny"]
    plain = train_config(PretrainConfig(preset="tiny", seed=base.seed + 3))
    assert asdict(plain) == {**asdict(base), "seed": base.seed + 3}
    cfg = train_config(PretrainConfig(preset="tiny", iters=7, ckpt_every=3, dropout=0.1,
                                      dec_norm=True, random_sources=True, flare_flag=True,
                                      full_res_colour=True, seed=5))
    assert (cfg.iters, cfg.ckpt_every, cfg.seed) == (7, 3, 5)
    assert cfg.full_res_colour and cfg.random_sources
    assert (cfg.model.dropout, cfg.model.dec_norm, cfg.model.flare_flag) == (0.1, True, True)
    assert asdict(replace(cfg, iters=base.iters, ckpt_every=base.ckpt_every, seed=base.seed,
                          full_res_colour=base.full_res_colour,
                          random_sources=base.random_sources, model=base.model)) == asdict(base)
    assert asdict(replace(cfg.model, dropout=base.model.dropout, dec_norm=base.model.dec_norm,
                          flare_flag=base.model.flare_flag)) == asdict(base.model)
    # --preset is overridden entirely by an explicit TrainConfig
    other = replace(PRESETS["quick"], iters=11)
    assert train_config(PretrainConfig(preset="tiny", seed=2), other).iters == 11
