"""Render stage: camera paths and the video's frames: resume after a kill, JSON paths, the pace and
exposure along a path, and the frame worker processes.

Split from test_render.py by topic; the workspaces and fixtures are tests/pipeline/render_ws.py
and conftest.py."""

from __future__ import annotations

import json
from dataclasses import replace

import cv2
import numpy as np
import pytest
import torch

from pipeline.cameras import load_cameras
from tests.pipeline.render_ws import dies_after


def test_novel_path_resumes_after_a_kill(rws, counters, monkeypatch):
    import pipeline.render as R
    import pipeline.render.engine as E  # where frames are written

    rays, enc = counters
    cfg = R.RenderConfig(path="interpolate", frames=4, size=(16, 12))
    real = E.write_frame
    monkeypatch.setattr(E, "write_frame", dies_after(2, real))
    with pytest.raises(KeyboardInterrupt):
        R.run(cfg, rws)
    out = rws.renders / "interpolate"
    assert sorted(p.name for p in out.glob("*.png")) == ["00000.png", "00001.png"]
    assert not list(out.glob(".*"))  # no half-written temporary left behind
    mtimes = {p: p.stat().st_mtime_ns for p in out.glob("*.png")}
    monkeypatch.setattr(E, "write_frame", real)
    rays.calls = 0
    R.run(cfg, rws)
    assert rays.calls == 2  # only the two missing frames were rendered
    assert sorted(p.name for p in out.glob("*.png")) == [f"{i:05d}.png" for i in range(4)]
    assert all(p.stat().st_mtime_ns == t for p, t in mtimes.items())
    assert cv2.imread(str(out / "00003.png")).shape == (12, 16, 3)
    cams = json.loads((out / "cameras.json").read_text())["frames"]
    assert len(cams) == 4 and all(len(c["sources"]) == 3 for c in cams)
    # a different setting is not a resume: stale frames are replaced, not mixed in
    R.run(R.RenderConfig(path="interpolate", frames=3, size=(16, 12)), rws)
    assert len(list(out.glob("*.png"))) == 3


def test_json_paths_project_and_nerfstudio(rws, tmp_path, counters):
    from gnfr.paths import PathCamera, path_to_json, path_to_nerfstudio
    from pipeline.render import RenderConfig, run

    rays, enc = counters
    cams = load_cameras(rws.cameras_json)
    f0, f1 = cams.frames[0], cams.frames[1]
    K = np.array([[20.0, 0, 10], [0, 20.0, 7.5], [0, 0, 1]])
    own = [PathCamera("left", K, f0.c2w, 20, 15), PathCamera("right", K, f1.c2w, 20, 15)]
    p = tmp_path / "mypath.json"
    p.write_text(json.dumps(path_to_json(own)))
    run(RenderConfig(path=str(p)), rws)
    out = rws.renders / "mypath"
    assert sorted(x.name for x in out.glob("*.png")) == ["left.png", "right.png"]
    assert cv2.imread(str(out / "left.png")).shape == (15, 20, 3)
    assert enc.calls == 1 and rays.calls == 2
    ns = tmp_path / "ns_path.json"
    ns.write_text(json.dumps(path_to_nerfstudio(own)))
    run(RenderConfig(path=str(ns)), rws)
    back = json.loads((rws.renders / "ns_path" / "cameras.json").read_text())["frames"]
    assert np.allclose(back[1]["c2w"], f1.c2w) and np.allclose(back[0]["K"], K)


def test_a_video_recorded_before_the_nearest_count_renders_again_at_two(hws):
    """A video recorded before ``nearest_count`` (one nearest view kept) is not up to date
    under the default of two (NOVEL_NEAREST_COUNT); asked for one, it is."""
    from pipeline.render import RenderConfig, run
    from pipeline.render.config import NOVEL_NEAREST_COUNT

    assert NOVEL_NEAREST_COUNT == 2 == RenderConfig().nearest_n()
    one = RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25,
                       nearest_count=1)
    run(one, hws)
    rec = hws.stage_record("render:interpolate")
    assert rec["params"]["nearest_count"] == 1
    hws.update_manifest("render:interpolate", {**rec, "params": {
        k: v for k, v in rec["params"].items() if k != "nearest_count"}})
    frames = sorted(hws.render_dir("interpolate").glob("*.png"))
    stamps = [f.stat().st_mtime_ns for f in frames]
    run(one, hws)  # the old record is what --nearest-count 1 renders
    assert [f.stat().st_mtime_ns for f in frames] == stamps
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25), hws)
    assert [f.stat().st_mtime_ns for f in frames] != stamps
    assert hws.stage_record("render:interpolate")["params"]["nearest_count"] == 2


def test_the_video_is_paced_on_the_depth_maps_points_and_older_videos_render_again(hws):
    """The interpolate path is paced on the image motion of the depth maps' points
    (``plan.scene_points``; the photos' bounds without depth maps) and records it; a video
    recorded before (no pace) renders again, on the new path."""
    from gnfr import paths
    from pipeline.render import RenderConfig, novel_path, run
    from pipeline.render.plan import PACE_POINTS, scene_points

    cams = load_cameras(hws.cameras_json)
    pts = scene_points(hws, cams)
    assert pts is not None and 0 < len(pts) <= PACE_POINTS
    cfg = RenderConfig(path="interpolate", fill="hybrid", frames=6, scale=0.25)
    on_points = np.stack([p.c2w for p in novel_path(cfg, cams, "cpu", pts)[0]])
    on_bounds = np.stack([p.c2w for p in novel_path(cfg, cams, "cpu")[0]])
    c2ws = np.stack([f.c2w for f in cams.frames])
    by_travel = paths.interpolate_path(c2ws, 6, closed=paths.is_surrounding(c2ws),
                                       up=paths.world_up(c2ws))
    assert np.abs(on_points - by_travel).max() > 1e-3  # the pace moves the frames
    assert np.abs(on_points - on_bounds).max() > 1e-6  # and the points are what it reads
    run(cfg, hws)
    rec = hws.stage_record("render:interpolate")
    assert rec["params"]["pace"] == "image"
    got = json.loads((hws.render_dir("interpolate") / "cameras.json").read_text())
    assert np.allclose([f["c2w"] for f in got["frames"]], on_points)
    hws.update_manifest("render:interpolate", {**rec, "params": {
        k: v for k, v in rec["params"].items() if k != "pace"}})
    frames = sorted(hws.render_dir("interpolate").glob("*.png"))
    stamps = [f.stat().st_mtime_ns for f in frames]
    run(cfg, hws)
    assert [f.stat().st_mtime_ns for f in frames] != stamps
    # --pace travel: the path before the pace, under which such an old video is up to date
    travel = RenderConfig(path="interpolate", fill="hybrid", frames=6, scale=0.25,
                          pace="travel")
    assert np.allclose([p.c2w for p in novel_path(travel, cams, "cpu", pts)[0]], by_travel)
    run(travel, hws)
    rec = hws.stage_record("render:interpolate")
    assert rec["params"]["pace"] == "travel"
    hws.update_manifest("render:interpolate", {**rec, "params": {
        k: v for k, v in rec["params"].items() if k != "pace"}})
    stamps = [f.stat().st_mtime_ns for f in frames]
    run(travel, hws)
    assert [f.stat().st_mtime_ns for f in frames] == stamps
    run(RenderConfig(path="inputs", fill="hybrid"), hws)  # only the interpolate path paces
    assert "pace" not in hws.stage_record("render:inputs")["params"]


def zoom_capture(cams, focal_times):
    """``cams`` with each photo's focal lengths times ``focal_times`` (a mixed-zoom capture)."""
    frames = []
    for f, z in zip(cams.frames, focal_times, strict=True):
        K = np.asarray(f.K, float).copy()
        K[0, 0] *= z
        K[1, 1] *= z
        frames.append(replace(f, K=K))
    return replace(cams, frames=frames)


def test_the_interpolate_path_zooms_to_each_photos_field_of_view(hws):
    """A capture at several zooms: the frame at a photo has its field of view along the
    long side, the frames between lie between, and ``--zoom fixed`` keeps the reference
    photo's; a capture at one zoom (within ZOOM_SPREAD) keeps one K for every frame and
    records ``fixed``, so its older videos stay up to date."""
    from pipeline.render import RenderConfig, novel_path, run
    from pipeline.render.plan import ZOOM_SPREAD, photo_zoom, reference_frame, resolve_zoom

    cams = load_cameras(hws.cameras_json)
    n = len(cams.frames)
    times = np.geomspace(1.0, 2.5, n)
    mixed = zoom_capture(cams, times)
    cfg = RenderConfig(path="interpolate", frames=4 * n + 1, scale=0.25, pace="travel")
    assert np.allclose(photo_zoom(mixed), times / times[cams.frames.index(
        reference_frame(cams))])
    pcs = novel_path(cfg, mixed, "cpu")[0]
    base = novel_path(replace(cfg, zoom="fixed"), mixed, "cpu")[0]
    assert all(np.array_equal(p.K, base[0].K) for p in base)
    # the path starts at a photo's camera: the frame there has its field of view
    first = min(mixed.frames, key=lambda f: np.linalg.norm(f.c2w[:3, 3] - pcs[0].c2w[:3, 3]))
    assert np.linalg.norm(first.c2w[:3, 3] - pcs[0].c2w[:3, 3]) < 1e-9
    assert pcs[0].K[0][0] / max(pcs[0].width, pcs[0].height) == pytest.approx(
        first.K[0][0] / max(first.width, first.height))
    zooms = np.array([p.K[0][0] for p in pcs]) / base[0].K[0][0]
    rel = photo_zoom(mixed)
    assert rel.min() - 1e-9 <= zooms.min() and zooms.max() <= rel.max() + 1e-9
    assert len(np.unique(zooms.round(9))) > n  # glides between the photos' zooms
    assert all(np.allclose(p.K[:, 2], base[0].K[:, 2]) for p in pcs)  # centre kept
    assert resolve_zoom(cfg, mixed).zoom == "photos"
    from pipeline.render.plan import zoom_line

    assert "the long side 1.00 to 2.50 times the reference" in zoom_line(cfg, mixed)
    assert zoom_line(replace(cfg, zoom="fixed"), mixed) is None
    assert zoom_line(cfg, cams) is None  # one zoom: nothing to say
    assert resolve_zoom(replace(cfg, path="spiral"), mixed).zoom == "fixed"
    # one zoom, with the small spread a refined focal length has: one K, recorded fixed
    near_one = zoom_capture(cams, np.linspace(1.0, ZOOM_SPREAD - 0.01, n))
    assert resolve_zoom(cfg, near_one).zoom == "fixed"
    one = novel_path(cfg, near_one, "cpu")[0]
    assert all(np.array_equal(p.K, one[0].K) for p in one)
    assert resolve_zoom(cfg, zoom_capture(cams, np.linspace(1.0, ZOOM_SPREAD + 0.01, n))
                        ).zoom == "photos"
    small = RenderConfig(path="interpolate", frames=3, size=(16, 12))
    run(small, hws)
    rec = hws.stage_record("render:interpolate")
    assert rec["params"]["zoom"] == "fixed"
    frames = sorted(hws.render_dir("interpolate").glob("*.png"))
    stamps = [f.stat().st_mtime_ns for f in frames]
    hws.update_manifest("render:interpolate", {**rec, "params": {  # a record from before
        k: v for k, v in rec["params"].items() if k != "zoom"}})
    run(small, hws)
    assert [f.stat().st_mtime_ns for f in frames] == stamps  # still up to date


def test_the_pace_line_says_how_fast_the_video_moves_and_how_to_calm_it(hws, capsys):
    """Rendering the interpolate path says how far the scene moves a frame and a second; over
    CALM_PACE a second it names the ``--seconds`` that brings the pace under it."""
    import re

    from pipeline.render import RenderConfig, novel_path
    from pipeline.render.plan import CALM_PACE, pace_line, plan_jobs, scene_points
    from pipeline.ws_files import read_views

    cams = load_cameras(hws.cameras_json)
    pts = scene_points(hws, cams)
    # the fixture's tour is short: 6 frames in a twentieth of a second make it fast
    cfg = RenderConfig(path="interpolate", fill="hybrid", seconds=0.05, fps=120.0, scale=0.25)
    line = pace_line(cfg, cams, novel_path(cfg, cams, "cpu", pts)[0], pts)
    m = re.search(r"about ([\d.]+)% of the frame's width a frame, (\d+)% a second at 120 fps; "
                  r"for a calmer video: --seconds (\d+)", line)
    assert m and int(m.group(2)) > 100 * CALM_PACE, line
    calm = replace(cfg, seconds=int(m.group(3)))
    line = pace_line(calm, cams, novel_path(calm, cams, "cpu", pts)[0], pts)
    assert "a second at 120 fps" in line and "calmer" not in line
    fixed = replace(cfg, frames=6)  # a frame count given: the video's rate is not known
    assert "a second" not in pace_line(fixed, cams, novel_path(fixed, cams, "cpu", pts)[0], pts)
    plan_jobs(replace(cfg, n_sources=4), hws, cams, read_views(hws), "cpu")
    assert "render interpolate: the scene moves about" in capsys.readouterr().err


def test_path_exposure_glides_and_is_recorded(hws, monkeypatch):
    """``--path-exposure`` (1 by default): with a model whose views' gains differ by two
    stops, each novel frame's gain (cameras.json's ``exposure``) is its nearest photos'
    median smoothed along the path, the frames render at it (other pixels than at 0) and the
    render records the option for paths only; at 0 no frame holds an exposure."""
    import pipeline.render as render_pkg
    from pipeline.render import RenderConfig, run

    stems = sorted(p.stem for p in hws.images.glob("*.png"))
    gains = {s: [2.0 ** (i / (len(stems) - 1) * 2 - 1)] * 3 for i, s in enumerate(stems)}
    meta = render_pkg.train_meta
    monkeypatch.setattr(render_pkg, "train_meta", lambda ckpt: {**meta(ckpt),
                                                                "exposure_gains": gains})
    out = hws.renders / "interpolate"
    cfg = RenderConfig(path="interpolate", fill="hybrid", frames=8, scale=0.25, n_sources=2,
                       workers=1, source_fade=0, path_exposure=0.0)
    run(cfg, hws)
    frames = json.loads((out / "cameras.json").read_text())["frames"]
    assert not any("exposure" in f for f in frames)
    before = {p.name: cv2.imread(str(p)) for p in sorted(out.glob("*.png"))}
    run(RenderConfig(**{**cfg.__dict__, "path_exposure": RenderConfig().path_exposure}), hws)
    assert hws.stage_record("render:interpolate")["params"]["path_exposure"] == 1.0
    frames = json.loads((out / "cameras.json").read_text())["frames"]
    ev = np.log2([f["exposure"][0] for f in frames])
    assert np.ptp(ev) > 0.1 and np.all(np.abs(ev) < 1.0)
    assert any(not (cv2.imread(str(out / n)) == img).all() for n, img in before.items())
    run(RenderConfig(path="inputs", fill="hybrid", path_exposure=1.0), hws)
    assert "path_exposure" not in hws.stage_record("render:inputs")["params"]


def test_frame_workers_one_process_per_thread_on_the_cpu_only(monkeypatch):
    """The render's processes: one per torch thread on the CPU when not asked, at most one per
    MIN_FRAMES_PER_WORKER frames; what the user asks; this process alone on CUDA, with
    ``compile`` and (the test suite's setting) with AUTO_WORKERS off."""

    import pipeline.render.workers as W
    from pipeline.render import RenderConfig, frame_workers

    assert W.MIN_FRAMES_PER_WORKER == 2
    monkeypatch.setattr(W, "AUTO_WORKERS", True)
    monkeypatch.setattr(torch, "get_num_threads", lambda: 2)
    cfg = RenderConfig()
    assert frame_workers(cfg, "cpu", 48) == 2
    assert frame_workers(cfg, "cpu", 3) == 1  # 3 frames: a second process would not pay
    assert frame_workers(cfg, "cuda", 48) == frame_workers(cfg, "cuda:1", 48) == 1
    assert frame_workers(RenderConfig(compile=True), "cpu", 48) == 1
    assert frame_workers(RenderConfig(workers=3), "cpu", 48) == 3
    assert frame_workers(RenderConfig(workers=3), "cpu", 4) == 2
    assert frame_workers(RenderConfig(workers=1), "cpu", 48) == 1
    monkeypatch.setattr(W, "AUTO_WORKERS", False)
    assert frame_workers(cfg, "cpu", 48) == 1
    assert frame_workers(RenderConfig(workers=2), "cpu", 48) == 2


def test_two_worker_processes_render_the_frames_one_process_does(hws, one_torch_thread,
                                                                  monkeypatch):
    """A hybrid video rendered by two spawned one-thread processes: the same frames, byte for
    byte, as this process with one thread renders; the stage's record does not hold the
    workers (a speed setting: a render made with other workers is up to date)."""
    import pipeline.render as R
    from pipeline.render import RenderConfig, run

    cfg = RenderConfig(path="interpolate", frames=4, size=(40, 30))
    out = hws.renders / "interpolate"
    run(cfg, hws, force=True)
    here = {p.name: p.read_bytes() for p in sorted(out.glob("*.png"))}
    assert len(here) == 4

    def not_here(*a, **k):
        raise AssertionError("rendered in the test's process, not in the workers")

    monkeypatch.setattr(R, "render_here", not_here)  # the spawned workers do not see this
    run(RenderConfig(path="interpolate", frames=4, size=(40, 30), workers=2), hws, force=True)
    there = {p.name: p.read_bytes() for p in sorted(out.glob("*.png"))}
    assert there == here
    rec = hws.stage_record("render:interpolate")
    assert rec["params"]["workers"] is None
    mtimes = {p: p.stat().st_mtime_ns for p in out.glob("*.png")}
    run(RenderConfig(path="interpolate", frames=4, size=(40, 30), workers=1), hws)
    assert {p: p.stat().st_mtime_ns for p in out.glob("*.png")} == mtimes  # up to date


def _dies_silently(setup, jobs, index, results):
    """A render worker killed before it reports (spawned processes import it from here)."""
    import os

    os._exit(9 if index == 1 else 0)


def test_a_worker_that_dies_without_a_word_is_a_one_line_error(hws):
    """A frame process that ends without reporting (the system killed it for memory) stops
    the render with a one-line UserError that says how to go on, instead of a wait that never
    ends; no process is left running."""
    import multiprocessing as mp

    from pipeline.errors import UserError
    from pipeline.render import RenderConfig, RenderSetup, plan_jobs, render_in_workers
    from pipeline.ws_files import read_cameras, read_views

    cfg = RenderConfig(path="interpolate", frames=4, size=(40, 30), n_sources=3)
    _, _, jobs = plan_jobs(cfg, hws, read_cameras(hws), read_views(hws), "cpu")
    setup = RenderSetup(hws, hws.root, cfg, {}, "cpu", [], None)
    with pytest.raises(UserError, match=r"exit code \d+.*render\.workers=1"):
        render_in_workers(setup, jobs, 2, target=_dies_silently)
    assert not mp.active_children()


def _sleeps(setup, jobs, index, results):
    """A render worker that takes its time (spawned processes import it from here)."""
    import time

    time.sleep(60)


def test_an_interrupt_stops_every_worker(hws, monkeypatch):
    """Ctrl-C while the workers render (here: raised by the parent's progress bar) reaches
    the stage as the KeyboardInterrupt it is, and no worker is left running."""
    import multiprocessing as mp
    import time

    import pipeline.render.workers as W
    from pipeline.render import RenderConfig, RenderSetup, plan_jobs, render_in_workers
    from pipeline.ws_files import read_cameras, read_views

    class Interrupted:
        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def add_task(self, *a, **k):
            raise KeyboardInterrupt

    monkeypatch.setattr(W, "make_progress", lambda *a, **k: Interrupted())
    cfg = RenderConfig(path="interpolate", frames=4, size=(40, 30), n_sources=3)
    _, _, jobs = plan_jobs(cfg, hws, read_cameras(hws), read_views(hws), "cpu")
    setup = RenderSetup(hws, hws.root, cfg, {}, "cpu", [], None)
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        render_in_workers(setup, jobs, 2, target=_sleeps)
    assert not mp.active_children() and time.monotonic() - t0 < 30


def test_a_worker_error_is_raised_in_the_stage(hws, tmp_path):
    """A worker that fails (here: an unreadable checkpoint) stops the render with its error,
    the one-line UserError a single process gives."""
    from pipeline.errors import UserError
    from pipeline.render import RenderConfig, RenderSetup, plan_jobs, render_in_workers
    from pipeline.ws_files import read_cameras, read_views

    bad = tmp_path / "broken.safetensors"
    bad.write_bytes(b"not a checkpoint")
    cfg = RenderConfig(path="interpolate", frames=4, size=(40, 30), fill="network", n_sources=3)
    _, _, jobs = plan_jobs(cfg, hws, read_cameras(hws), read_views(hws), "cpu")
    setup = RenderSetup(hws, bad, cfg, {}, "cpu", sorted({s for j in jobs for s in j.sources}),
                        None)
    with pytest.raises(UserError, match="broken.safetensors"):
        render_in_workers(setup, jobs, 2)

