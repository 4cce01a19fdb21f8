"""Render stage: input views with masks and camera models, novel paths, cache, restart."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

from pipeline.camera_models import CameraModel
from pipeline.cameras import load_cameras, save_cameras
from pipeline.workspace import Workspace, atomic_imwrite, atomic_write_json

TINY = dict(enc_widths=(8, 8, 8), enc_blocks=(1, 1, 1), feat_ch=8, width=16, depth=1,
            heads=2, n_freqs_pts=2, n_freqs_dirs=2)
FLARED = "templeSR0002"
BOX = (slice(10, 22), slice(30, 46))  # rows, cols of the flare square in WS/images geometry


def add_masks_views_model(ws: Workspace, flared: str, box, seed: int) -> None:
    """WS/masks (a flare square ``box`` in view ``flared``, none elsewhere), views.json and
    a tiny random GN-FR checkpoint (``seed``) at WS/model/gnfr.safetensors."""
    from gnfr.checkpoint import save_model
    from gnfr.model import GNFR, GNFRConfig
    from pipeline.select import build_views

    cams = load_cameras(ws.cameras_json)
    frac = {}
    for f in cams.frames:
        m = np.zeros((f.height, f.width), np.uint8)
        if f.stem == flared:
            m[box] = 255
        atomic_imwrite(ws.masks / f"{f.stem}.png", m)
        frac[f.stem] = float((m > 0).mean())
    atomic_write_json(ws.views_json, build_views(cams.stems, cams.centers(), frac, 0.1))
    torch.manual_seed(seed)
    save_model(ws.model_file, GNFR(GNFRConfig(**TINY)),
               {"samples": 4, "eval_views": 3, "source_scale": 0.5, "point_sampler": True})


def make_render_ws(root: Path, n_views: int = 5, seed: int = 0) -> Workspace:
    """A posed temple workspace (160x120) with views.json, masks (one small flare square in
    one view) and a tiny random GN-FR checkpoint at WS/model/gnfr.safetensors."""
    from tests.fixtures import make_temple_workspace

    ws = make_temple_workspace(root, n_views=n_views, scale=0.25)
    add_masks_views_model(ws, FLARED, BOX, seed)
    return ws


@pytest.fixture(scope="module")
def rws(tmp_path_factory):
    return make_render_ws(tmp_path_factory.mktemp("render") / "ws")


class Counter:
    """Wraps a function and counts its calls and the rays it was given."""

    def __init__(self, fn):
        self.fn, self.calls, self.rays = fn, 0, 0

    def __call__(self, *args, **kw):
        self.calls += 1
        self.rays += len(args[3]) if len(args) > 3 else 0
        return self.fn(*args, **kw)


@pytest.fixture
def counters(monkeypatch):
    import gnfr.renderer as R

    rays, enc = Counter(R.render_rays), Counter(R.SourceViews.encode)
    monkeypatch.setattr(R, "render_rays", rays)
    monkeypatch.setattr(R.SourceViews, "encode", enc)
    return rays, enc


def test_inputs_replace_only_the_flare_region(rws, counters):
    from pipeline.render import RenderConfig, blend_weights, flare_mask_in, run

    rays, enc = counters
    outs = run(RenderConfig(path="inputs", flare_layer=0), rws)  # the fill as it is
    assert outs == [rws.deflared]
    cams = load_cameras(rws.cameras_json)
    assert enc.calls == 1  # every source view encoded once, in one cache
    for f in cams.frames:
        got = cv2.imread(str(rws.deflared / f"{f.stem}.png"))
        orig = cv2.imread(str(rws.decoded / f"{f.stem}.png"))
        assert got.shape == orig.shape
        if f.stem != FLARED:
            assert np.array_equal(got, orig)  # no flare: the photo untouched
            continue
        from pipeline.render import decoded_camera

        alpha = blend_weights(flare_mask_in(decoded_camera(f, f.width, f.height), f, rws),
                              RenderConfig().dilate, RenderConfig().feather)
        assert rays.rays == int((alpha > 0.5 / 255).sum())  # only the flare region rendered
        assert alpha[BOX].min() == 1.0
        assert np.array_equal(got[alpha == 0], orig[alpha == 0])
        assert np.abs(got[BOX].astype(int) - orig[BOX]).mean() > 1  # replaced there
    assert rays.calls == 1
    # rerun: the stage is up to date, nothing is rendered or encoded again
    run(RenderConfig(path="inputs", flare_layer=0), rws)
    assert (rays.calls, enc.calls) == (1, 1)


def test_mask_warped_through_the_distortion_model(tmp_path):
    """A flare dot in WS/images (pinhole) lands where the distorted decoded camera sees
    the same ray."""
    from pipeline.render import decoded_camera, flare_mask_in

    ws = Workspace(tmp_path)
    cams_path = tmp_path / "cameras.json"
    from pipeline.cameras import Cameras, Frame

    K = np.array([[150.0, 0, 80], [0, 150.0, 60], [0, 0, 1]])
    cc = {"model": "OPENCV", "width": 200, "height": 150,
          "params": [190.0, 185.0, 101.0, 74.0, -0.25, 0.08, 0.002, -0.001]}
    f = Frame("a.jpg", "a", K, 160, 120, np.eye(4), 0.1, 5.0, cc)
    save_cameras(cams_path, Cameras([f]))
    m = np.zeros((120, 160), np.uint8)
    m[14:19, 20:25] = 255  # a dot near a corner, where distortion is strong
    atomic_imwrite(ws.masks / "a.png", m)
    cam = decoded_camera(f, 200, 150)
    warped = flare_mask_in(cam, f, ws)
    xy = np.linalg.solve(K, np.array([22.5, 16.5, 1.0]))[None, :2]  # dot centre (+0.5)
    u, v = cam.normalized_to_pixel(xy)[0] - 0.5
    ys, xs = np.nonzero(warped)
    assert abs(xs.mean() - u) < 1.0 and abs(ys.mean() - v) < 1.0
    # and it is NOT where a pinhole-only warp would put it
    pin = CameraModel.pinhole(cam.K, 200, 150).normalized_to_pixel(xy)[0] - 0.5
    assert np.hypot(*(pin - [u, v])) > 2.0


def _dies_after(n: int, write_frame):
    """``write_frame`` that writes ``n`` frames, then raises KeyboardInterrupt (a kill)."""
    written = []

    def dying(path, rgb, exif=None):
        if len(written) == n:
            raise KeyboardInterrupt
        write_frame(path, rgb, exif)
        written.append(path)

    return dying


def test_novel_path_resumes_after_a_kill(rws, counters, monkeypatch):
    import pipeline.render as R
    import pipeline.render.engine as E  # where frames are written

    rays, enc = counters
    cfg = R.RenderConfig(path="interpolate", frames=4, size=(16, 12))
    real = E.write_frame
    monkeypatch.setattr(E, "write_frame", _dies_after(2, real))
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


def test_novel_frames_use_nearest_least_flared_sources(rws):
    from pipeline.render import RenderConfig, novel_depth_range, novel_sources

    cams = load_cameras(rws.cameras_json)
    views = json.loads(rws.views_json.read_text())["views"]
    c = cams.frames[2].center + 1e-3
    src = novel_sources(c, cams, views, RenderConfig(n_sources=3, pool=4))
    d = np.linalg.norm(cams.centers() - c, axis=1)
    nearest4 = [cams.frames[i].stem for i in np.argsort(d)[:4]]
    assert FLARED in nearest4 and FLARED not in src  # the flared one is dropped
    assert src == [s for s in nearest4 if s != FLARED]
    near, far = novel_depth_range(c, cams)
    assert near <= cams.frames[2].near and far >= cams.frames[2].far


def _nearest_view_flared(rws):
    """The cameras, views.json's views with only the view nearest to a novel camera beside
    view 2 marked 5 % flared, that camera's centre, and the views nearest first."""
    cams = load_cameras(rws.cameras_json)
    views = json.loads(rws.views_json.read_text())["views"]
    c = cams.frames[2].center + 1e-3
    nearest = [cams.frames[i].stem
               for i in np.argsort(np.linalg.norm(cams.centers() - c, axis=1))]
    views = {s: {**v, "flare_fraction": 0.05 if s == nearest[0] else 0.0}
             for s, v in views.items()}
    return cams, views, c, nearest


def test_sources_equal_below_keeps_a_near_view_under_the_line(rws):
    from pipeline.render import RenderConfig, novel_sources

    cams, views, c, nearest = _nearest_view_flared(rws)
    strict = novel_sources(c, cams, views, RenderConfig(n_sources=3, pool=4, nearest_source=False,
                                                         sources_equal_below=0.0))
    assert strict == [s for s in nearest[1:4]]  # 5 % is more than the tolerance: dropped
    under = novel_sources(c, cams, views, RenderConfig(n_sources=3, pool=4, nearest_source=False,
                                                        sources_equal_below=0.1))
    assert sorted(under) == sorted(nearest[:3])  # under the 10 % line: the nearest three
    assert novel_sources(c, cams, views, RenderConfig(
        n_sources=3, pool=4, nearest_source=False, sources_equal_below=0.04)) == strict


def test_nearest_source_keeps_the_nearest_view_however_flared(rws, monkeypatch):
    """``nearest_source``: the nearest view, 40 % flared, is a source of a novel frame in
    place of the farthest chosen one (nearest first, as many sources); without it that view
    gives way; the default follows NOVEL_NEAREST_SOURCE."""
    from pipeline.render import RenderConfig, novel_sources
    from pipeline.render import config as C

    cams, views, c, nearest = _nearest_view_flared(rws)
    views = {s: {**v, "flare_fraction": 0.4 if s == nearest[0] else 0.0}
             for s, v in views.items()}
    off = novel_sources(c, cams, views, RenderConfig(n_sources=3, pool=4,
                                                      nearest_source=False))
    assert off == nearest[1:4]
    on = novel_sources(c, cams, views, RenderConfig(n_sources=3, pool=4, nearest_source=True))
    assert on == [nearest[0], *nearest[1:3]]
    for flag in (False, True):
        monkeypatch.setattr(C, "NOVEL_NEAREST_SOURCE", flag)
        assert novel_sources(c, cams, views, RenderConfig(n_sources=3, pool=4)) == \
            (on if flag else off)


def test_nearest_count_keeps_the_nearest_views_however_flared(rws):
    """``nearest_count`` 2: the two views nearest a novel camera, both 40 % flared, are its
    sources in place of the two farthest chosen (nearest first, as many sources); 1 keeps
    the nearest alone, as ``nearest_source`` always did; without ``nearest_source`` the
    count does nothing."""
    from pipeline.render import RenderConfig, novel_sources

    cams, views, c, nearest = _nearest_view_flared(rws)
    views = {s: {**v, "flare_fraction": 0.4 if s in nearest[:2] else 0.0}
             for s, v in views.items()}
    clean = [s for s in nearest if s not in nearest[:2]]

    def src(**kw):
        return novel_sources(c, cams, views, RenderConfig(n_sources=3, pool=5, **kw))

    assert src(nearest_source=False, nearest_count=2) == clean[:3]
    assert src(nearest_source=True, nearest_count=1) == [nearest[0], *clean[:2]]
    assert src(nearest_source=True, nearest_count=2) == [*nearest[:2], clean[0]]
    # more kept than there are sources: the nearest of them
    assert novel_sources(c, cams, views, RenderConfig(n_sources=1, pool=5, nearest_source=True,
                                                      nearest_count=2)) == [nearest[0]]
    # kept views already chosen stay where they are, and nothing else moves
    calm = {s: {**v, "flare_fraction": 0.0} for s, v in views.items()}
    assert novel_sources(c, cams, calm, RenderConfig(n_sources=3, pool=5, nearest_source=True,
                                                     nearest_count=2)) == nearest[:3]


def test_sources_equal_below_defaults_novel_frames_and_photos_apart(rws, monkeypatch):
    """Not given, novel frames use NOVEL_SOURCES_EQUAL_BELOW and the de-flared photos 0."""
    from pipeline.render import RenderConfig, input_sources, novel_sources
    from pipeline.render import config as C

    cams, views, c, nearest = _nearest_view_flared(rws)
    cfg = RenderConfig(n_sources=3, pool=4, nearest_source=False)  # the line alone
    for line, want in ((0.0, nearest[1:4]), (0.1, nearest[:3])):
        monkeypatch.setattr(C, "NOVEL_SOURCES_EQUAL_BELOW", line)
        assert cfg.equal_below(novel=True) == line and cfg.equal_below(novel=False) == 0.0
        assert sorted(novel_sources(c, cams, views, cfg)) == sorted(want)
    # the photos ignore the novel frames' line (still 0.1 here): of view 2's sources the
    # nearest, now 5 % flared, gives way to a clean one
    own = cams.frames[2].stem
    pool = [x["stem"] for x in views[own]["sources"]]
    views = {s: {**v, "flare_fraction": 0.05 if s == pool[0] else 0.0}
             for s, v in views.items()}
    photo = input_sources(own, views, RenderConfig(n_sources=len(pool) - 1, pool=20))
    assert photo == pool[1:]
    assert input_sources(own, views, RenderConfig(n_sources=len(pool) - 1, pool=20,
                                                  sources_equal_below=0.1)) == pool[:-1]


def test_render_cli_errors(rws, capsys):
    from workflows.cli import main

    missing = rws.root.parent / "no_such_path.json"
    assert main(["render", str(rws.root), "--path", str(missing)]) == 2
    errors = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and errors[0].startswith("error: --path")
    assert "no such camera path file" in errors[0]

    assert main(["render", str(rws.root), "--path", "nowhere"]) == 2
    assert main(["render", str(rws.root), "--path", "spiral", "--size", "big"]) == 2
    assert main(["render", str(rws.root), "--blend", "soft"]) == 2
    bad = rws.root.parent / "bad.json"
    bad.write_text('{"frames": [{"name": "x"}]}')
    assert main(["render", str(rws.root), "--path", str(bad)]) == 2


def _exif_app1(orientation: int) -> bytes:
    """A minimal big-endian Exif APP1 segment with one IFD0 entry: Orientation."""
    import struct

    tiff = b"MM" + struct.pack(">HI", 42, 8) + struct.pack(">H", 1)
    tiff += struct.pack(">HHIHH", 0x0112, 3, 1, orientation, 0) + struct.pack(">I", 0)
    body = b"Exif\x00\x00" + tiff
    return b"\xff\xe1" + struct.pack(">H", len(body) + 2) + body


def test_exif_kept_with_orientation_reset(tmp_path):
    from pipeline.render import with_exif

    img = np.zeros((20, 40, 3), np.uint8)
    img[:, :10] = 255
    ok, buf = cv2.imencode(".jpg", img)
    src = tmp_path / "src.jpg"
    src.write_bytes(buf[:2].tobytes() + _exif_app1(6) + buf[2:].tobytes())
    assert cv2.imread(str(src)).shape == (40, 20, 3)  # orientation 6: shown rotated
    upright = cv2.imread(str(src))
    ok, enc = cv2.imencode(".jpg", upright)
    out = tmp_path / "out.jpg"
    out.write_bytes(with_exif(enc.tobytes(), src))
    assert b"Exif\x00\x00" in out.read_bytes()
    assert cv2.imread(str(out)).shape == (40, 20, 3)  # not rotated a second time


def test_full_res_blends_into_the_original_photos(rws, counters):
    from pipeline.render import RenderConfig, run

    rays, enc = counters
    outs = run(RenderConfig(path="inputs", full_res=True, flare_layer=0), rws)
    assert rws.deflared_full in outs
    photos = rws.photos_dir
    got = cv2.imread(str(rws.deflared_full_path(FLARED, ".png")))
    orig = cv2.imread(str(photos / f"{FLARED}.png"))
    assert got.shape == orig.shape == (480, 640, 3)  # the original's full resolution
    rows, cols = BOX
    big = (slice(rows.start * 4, rows.stop * 4), slice(cols.start * 4, cols.stop * 4))
    assert np.abs(got[big].astype(int) - orig[big]).mean() > 1  # flare region replaced
    far = np.ones(got.shape[:2], bool)
    far[big[0].start - 40:big[0].stop + 40, big[1].start - 40:big[1].stop + 40] = False
    assert np.array_equal(got[far], orig[far])  # the rest keeps every original pixel
    other = cv2.imread(str(rws.deflared_full_path("templeSR0001", ".png")))
    assert np.array_equal(other, cv2.imread(str(photos / "templeSR0001.png")))
    # only flare pixels were rendered: one decoded-size view (a new setting rerenders
    # WS/deflared too) and the same view at full resolution
    assert rays.calls == 2 and 48 * 64 <= rays.rays < 110 * 130 + 30 * 40


def test_full_res_knows_raw_photos_from_decodes_record(tmp_path):
    """Which file a view came from and whether it is raw come from decode's record; a
    workspace whose record lists neither falls back to cameras.json's name and the suffix
    (raw when it is not one of pipeline.images.PHOTO_EXTS)."""
    from pipeline.cameras import Frame
    from pipeline.render import FrameJob, FullRes, plan_full_res

    photos = tmp_path / "photos"
    photos.mkdir()
    for name in ("a.dng", "b.jpe", "c.jpg"):
        (photos / name).write_bytes(b"x")
    ws = Workspace.create(tmp_path / "ws", photos)
    atomic_imwrite(ws.linear_path("a"), np.zeros((4, 4, 3), np.uint16))
    frames = [Frame(n, n.split(".")[0], np.eye(3), 4, 4, np.eye(4), 0.1, 5.0)
              for n in ("a.dng", "b.jpe", "c.png")]  # cameras.json names c.png, not c.jpg
    jobs = [FrameJob(ws.deflared_path(f.stem), ["s"], 0.1, 5.0, f) for f in frames]

    def planned():
        return {j.camera.stem: (j.out.name, j.full_res) for j in plan_full_res(ws, jobs)}

    guessed = planned()  # no record: cameras.json's names, raw by suffix
    assert guessed["a"] == ("a.tiff", FullRes(ws.linear_path("a"), linear=True))
    assert guessed["b"] == ("b.jpg", FullRes(photos / "b.jpe", linear=False,
                                             exif=photos / "b.jpe"))  # .jpe is a JPEG
    assert "c" not in guessed  # photos/c.png does not exist
    sources = {"a": "a.dng", "b": "b.jpe", "c": "c.jpg"}
    ws.begin_stage("decode", {}, []).finish([ws.decoded], extra={"sources": sources,
                                                                 "raw": ["a"]})
    known = planned()
    assert known["c"] == ("c.jpg", FullRes(photos / "c.jpg", linear=False,
                                           exif=photos / "c.jpg"))
    assert known["a"] == guessed["a"] and known["b"] == guessed["b"]
    assert all(j.out.parent == ws.deflared_full for j in plan_full_res(ws, jobs))
    ws.begin_stage("decode", {}, []).finish([ws.decoded], extra={"sources": sources,
                                                                 "raw": ["a", "b"]})
    assert "b" not in planned()  # raw by the record whatever its suffix: no WS/linear/b.tiff


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2) / 255.0**2
    return float(-10 * np.log10(max(mse, 1e-10)))


@pytest.mark.slow
def test_overfit_scene_reproduces_the_input_views(tmp_path):
    """Train a tiny GN-FR on the scene (gnfr.train, the fine-tuning code), then render at
    input cameras through the render stage (each view's sources exclude itself).

    Within a CPU test budget (120 steps) the tiny model gets about 15.4 dB (10.4 before
    training, 16.1 for the photo's mean colour): this checks that the render stage feeds
    the trained model the way training does, NOT yet that renders reproduce the photos
    in detail (that needs a longer fine-tune; see the report of issue 5)."""
    from dataclasses import replace

    from gnfr.checkpoint import save_model
    from gnfr.model import GNFR, GNFRConfig
    from gnfr.paths import PathCamera, path_to_json
    from gnfr.train import QUICK, SourceBank, make_optimizer, sample_batch, train_step
    from pipeline.render import RenderConfig, run
    from pipeline.training_scenes import load_workspace

    ws = make_render_ws(tmp_path / "ws", n_views=6)
    cams = load_cameras(ws.cameras_json).frames[1:4]
    path = tmp_path / "inputs_small.json"
    pcs = []
    for f in cams:
        K = f.K.copy()
        K[:2] /= 4
        pcs.append(PathCamera(f.stem, K, f.c2w, f.width // 4, f.height // 4))
    path.write_text(json.dumps(path_to_json(pcs)))
    truth = {f.stem: cv2.resize(cv2.imread(str(ws.decoded / f"{f.stem}.png")), (40, 30),
                                interpolation=cv2.INTER_AREA) for f in cams}

    def score() -> float:
        run(RenderConfig(path=str(path), samples=8, n_sources=3, source_scale=0.5), ws,
            force=True)
        return np.mean([_psnr(cv2.imread(str(ws.renders / "inputs_small" / f"{s}.png")), t)
                        for s, t in truth.items()])

    before = score()
    cfg = replace(QUICK, model=GNFRConfig(**TINY), rays=128, samples=8, n_views=(3, 3),
                  eval_views=3, source_scale=0.5, lr_encoder=3e-3, lr_transformer=3e-3)
    torch.manual_seed(0)
    scene = load_workspace(ws.root)
    model = GNFR(cfg.model)
    opt, gen = make_optimizer(model, cfg), torch.Generator().manual_seed(0)
    bank = SourceBank.of(scene, cfg.source_scale, "cpu")
    for step in range(120):
        train_step(model, opt, sample_batch(scene, cfg, gen), bank, None, cfg, step)
    save_model(ws.model_file, model,
               {"samples": 8, "eval_views": 3, "source_scale": 0.5})
    after = score()
    mean_colour = np.mean([_psnr(np.broadcast_to(t.reshape(-1, 3).mean(0), t.shape), t)
                           for t in truth.values()])
    print(f"PSNR before {before:.2f} dB, after {after:.2f} dB, mean colour {mean_colour:.2f}")
    assert after > before + 3.0
    assert after > mean_colour - 1.5


def test_blend_keeps_the_light_the_mask_encloses():
    import numpy as np

    from pipeline.render import blend_weights

    yy, xx = np.mgrid[:100, :100]
    d = np.hypot(yy - 50, xx - 50)
    ring = (d > 4) & (d < 25)  # flare around an unmarked light core of radius 4
    w = blend_weights(ring, dilate=0.05, feather=0.05)
    assert w[50, 50] == 0.0 and w[50, 52] == 0.0  # the light stays the photo's
    assert w[50, 65] == 1.0  # flare is re-rendered
    assert w[50, 78] > 0.0 and w[0, 0] == 0.0  # dilated + feathered outward only


def test_colour_match_undoes_a_gain_and_offset_fitted_on_the_ring():
    from pipeline.render import MATCH_MIN_PIXELS, match_colours

    rng = np.random.default_rng(0)
    photo = rng.uniform(0.1, 0.8, (500, 3)).astype(np.float32)
    gain, offset = np.array([0.8, 1.25, 1.0]), np.array([0.05, -0.03, 0.1])
    rgb = ((photo - offset) / gain).astype(np.float32)  # a fill drifted in colour
    ring = np.zeros(500, bool)
    ring[:300] = True  # fitted here only; the other 200 pixels are the flare region
    fixed = match_colours(rgb, photo, ring)
    assert np.abs(fixed[~ring] - photo[~ring]).max() < 1e-4  # corrected where it was not fit
    assert np.abs(rgb[~ring] - photo[~ring]).max() > 0.05
    # too few ring pixels, or matching off: the render is left as it is
    few = np.zeros(500, bool)
    few[:MATCH_MIN_PIXELS - 1] = True
    assert match_colours(rgb, photo, few) is rgb and match_colours(rgb, photo, None) is rgb
    # an implausible fit (inverted colours) is clipped to the allowed gain range
    inv = match_colours(1.0 - photo, photo, ring)
    assert np.isfinite(inv).all() and (inv >= 0).all()


@pytest.fixture(scope="module")
def hws(tmp_path_factory):
    """A textured-plane workspace (exact cameras) with a fake flare square in one view,
    views.json, a tiny random model, and WS/depth from the depth stage (without the novel
    frames' maps: the tests of the render's options were written against WS/depth)."""
    from pipeline.depth import DepthConfig
    from pipeline.depth import run as depth_run
    from tests.fixtures import make_plane_workspace

    ws = make_plane_workspace(tmp_path_factory.mktemp("hybrid") / "ws")
    add_masks_views_model(ws, HYBRID_FLARED, HYBRID_BOX, 0)
    depth_run(DepthConfig(neighbours=3, frames_sgm=None), ws)
    return ws


HYBRID_FLARED = "plane02"
HYBRID_BOX = (slice(40, 70), slice(60, 100))


def test_hybrid_inputs_fill_the_flare_region_from_the_photos(hws, counters):
    """The fake flare square covers clean pixels the neighbours see: the photos warped by
    depth must put them back far better than the (random) network, which renders fewer
    rays."""
    from pipeline.render import RenderConfig, blend_weights, decoded_camera, flare_mask_in, run

    rays, _ = counters
    run(RenderConfig(path="inputs", fill="hybrid", color_match=False, flare_layer=0), hws)
    f = load_cameras(hws.cameras_json).by_stem()[HYBRID_FLARED]
    got = cv2.imread(str(hws.deflared / f"{HYBRID_FLARED}.png")).astype(int)
    orig = cv2.imread(str(hws.decoded / f"{HYBRID_FLARED}.png")).astype(int)
    hybrid_err = np.abs(got[HYBRID_BOX] - orig[HYBRID_BOX]).mean()
    hybrid_rays = rays.rays
    run(RenderConfig(path="inputs", fill="network", color_match=False, flare_layer=0), hws)
    net = cv2.imread(str(hws.deflared / f"{HYBRID_FLARED}.png")).astype(int)
    net_err = np.abs(net[HYBRID_BOX] - orig[HYBRID_BOX]).mean()
    alpha = blend_weights(flare_mask_in(decoded_camera(f, f.width, f.height), f, hws),
                          RenderConfig().dilate, RenderConfig().feather)
    assert rays.rays - hybrid_rays == int((alpha > 0.5 / 255).sum())  # network: every pixel
    assert hybrid_rays < rays.rays - hybrid_rays
    assert hybrid_err < 0.5 * net_err, (hybrid_err, net_err)


def test_hybrid_novel_frame_at_an_input_camera_reproduces_the_photo(hws, tmp_path):
    from gnfr.paths import PathCamera, path_to_json
    from pipeline.render import RenderConfig, run

    cams = load_cameras(hws.cameras_json)
    f = cams.by_stem()["plane03"]  # a clean view: its own photo is among the sources
    path = tmp_path / "at_input.json"
    atomic_write_json(path, path_to_json([PathCamera("v", f.K, f.c2w, f.width, f.height)]))
    run(RenderConfig(path=str(path), fill="hybrid"), hws)
    got = cv2.imread(str(hws.renders / "at_input" / "v.png")).astype(int)
    orig = cv2.imread(str(hws.images / f"{f.stem}.png")).astype(int)
    assert got.shape == orig.shape  # hybrid frames default to the input size
    inner = (slice(12, -12), slice(12, -12))  # the border only this photo sees: the network
    assert _psnr(got[inner], orig[inner]) > 30


def test_novel_frames_warp_through_the_frames_maps_and_the_inputs_through_ws_depth(hws,
                                                                                  tmp_path):
    """A novel frame at an input camera warps the photos through WS/depth/frames: without
    that folder (the render falls back to WS/depth) it comes out different, both close to
    the photo; the de-flared inputs are WS/depth's to the bit either way; the render
    records which maps it used."""
    import shutil

    from gnfr.paths import PathCamera, path_to_json
    from pipeline.depth import DepthConfig
    from pipeline.depth import run as depth_run
    from pipeline.render import RenderConfig, run
    from pipeline.workspace import Workspace

    ws = Workspace(shutil.copytree(hws.root, tmp_path / "ws", symlinks=True))
    depth_run(DepthConfig(neighbours=3), ws)  # the defaults: WS/depth/frames too
    assert ws.depth_frames.is_dir()
    f = load_cameras(ws.cameras_json).by_stem()["plane03"]
    path = tmp_path / "at_input.json"
    atomic_write_json(path, path_to_json([PathCamera("v", f.K, f.c2w, f.width, f.height)]))
    orig = cv2.imread(str(ws.images / f"{f.stem}.png")).astype(int)
    inner = (slice(12, -12), slice(12, -12))
    inputs = RenderConfig(path="inputs", fill="hybrid", color_match=False, flare_layer=0)
    frames, deflared = {}, {}
    for maps in ("frames", "depth"):
        if maps == "depth":
            shutil.rmtree(ws.depth_frames)
        run(RenderConfig(path=str(path), fill="hybrid"), ws)
        assert ws.stage_record("render:at_input")["params"]["depth_maps"] == maps
        frames[maps] = cv2.imread(str(ws.renders / "at_input" / "v.png")).astype(int)
        assert _psnr(frames[maps][inner], orig[inner]) > 30, maps
        run(inputs, ws, force=True)
        deflared[maps] = cv2.imread(str(ws.deflared / f"{HYBRID_FLARED}.png"))
    assert not np.array_equal(frames["frames"], frames["depth"])
    assert np.array_equal(deflared["frames"], deflared["depth"])


def test_a_depth_stage_of_an_earlier_version_gets_a_hint_for_the_frames_maps(hws, tmp_path,
                                                                               capsys):
    """A novel render on a workspace whose depth stage predates the frames' maps says how to
    make them; none where the stage ran with them off (``--frames-sgm none``)."""
    import shutil

    from pipeline.render import RenderConfig, run
    from pipeline.workspace import Workspace

    path = _path_between(hws, tmp_path)
    ws = Workspace(shutil.copytree(hws.root, tmp_path / "ws", symlinks=True))
    run(RenderConfig(path=str(path), fill="hybrid"), ws)
    assert "--force` writes them" not in capsys.readouterr().err  # switched off: no hint
    manifest = json.loads((ws.root / "manifest.json").read_text())
    del manifest["stages"]["depth"]["params"]["frames_sgm"]  # as an earlier version wrote it
    (ws.root / "manifest.json").write_text(json.dumps(manifest))
    run(RenderConfig(path=str(path), fill="hybrid"), ws, force=True)
    err = " ".join(capsys.readouterr().err.split())
    assert f"deflare-scene depth {ws.root} --force` writes them" in err


def test_depth_guided_samples_stay_in_their_band_and_equal_uniform_on_the_whole_ray():
    from gnfr.geometry import sample_depths
    from pipeline.render import DEPTH_BAND, split_guided

    depth = torch.tensor([1.0, 2.0, 0.0, 4.0])
    known = torch.tensor([True, True, False, True])
    parts = split_guided(4, (depth, known), 8)
    (ks, lo, hi, ns), (us, lo2, hi2, ns2) = parts
    assert ks.tolist() == [0, 1, 3] and us.tolist() == [2] and ns == 8 and lo2 is None
    t = sample_depths(lo, hi, ns, jitter=False)
    d = depth[ks][:, None]
    assert bool(((t >= d / DEPTH_BAND) & (t <= d * DEPTH_BAND)).all())
    assert split_guided(4, (depth, known), 0)[0][0].tolist() == [0, 1, 2, 3]  # 0: off
    # rays whose band is their whole near-far range sample exactly as the uniform render
    d = torch.tensor([1.0, 3.0])
    near, far = d / DEPTH_BAND, d * DEPTH_BAND
    (_, lo, hi, n), _ = split_guided(2, (d, torch.tensor([True, True])), 24)
    assert torch.allclose(sample_depths(lo, hi, n, jitter=False),
                          sample_depths(near, far, 24, jitter=False), rtol=1e-6)


def test_ring_check_turns_down_only_the_region_whose_ring_disagrees():
    from pipeline.render.inputs import RING_TOLERANCE, check_on_ring

    photo = np.full((40, 80, 3), 0.5, np.float32)
    region = np.zeros((40, 80), bool)  # two flare regions, each with its ring (the blend's
    region[8:22, 8:22] = region[8:22, 48:62] = True  # outer band, where the photo is clean)
    inner = np.zeros_like(region)
    inner[10:20, 10:20] = inner[10:20, 50:60] = True
    ring = region & ~inner
    colour = photo.copy()
    colour[:, 40:] += 2 * RING_TOLERANCE  # the right region's photos show another surface
    wgt, rejected = check_on_ring(colour, np.ones((40, 80), np.float32), photo, region, ring)
    assert rejected[8:22, 48:62].all() and rejected.sum() == 14 * 14
    assert (wgt[rejected] == 0).all() and (wgt[~rejected] == 1).all()


@pytest.mark.parametrize("band", [True, False])
def test_band_rejected_decides_the_band_where_the_ring_check_turns_the_photos_down(
        hws, monkeypatch, band):
    """Every region turned down (a tolerance below any error): with the band kept its rays
    sample around the photos' depth as before; without it none does, and the record says
    which."""
    import pipeline.render.engine as engine
    import pipeline.render.inputs as inputs
    from pipeline.render import RenderConfig, run

    seen = []

    def spy(n, guided, depth_samples):
        seen.append(0 if guided is None else int(guided[1].sum()))
        return split(n, guided, depth_samples)

    split = engine.split_guided
    monkeypatch.setattr(engine, "split_guided", spy)
    monkeypatch.setattr(inputs, "RING_TOLERANCE", -1.0)
    run(RenderConfig(path="inputs", fill="hybrid", band_rejected=band), hws, force=True)
    assert len(seen) == 1  # the one flared photo renders rays
    assert (seen[0] > 0) == band, seen
    assert hws.stage_record("render:inputs")["params"]["band_rejected"] is band


def test_band_rejected_on_a_video_says_it_is_for_the_photos(hws, capsys):
    from pipeline.render import RenderConfig, run

    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25,
                     band_rejected=False), hws)
    assert "--no-band-rejected is for the de-flared photos" in capsys.readouterr().err
    assert "band_rejected" not in hws.stage_record("render:interpolate")["params"]


def test_fill_parts_splits_the_true_flare_by_who_fills_it(hws, tmp_path, monkeypatch):
    """benchmarks/fill_parts.py on the plane: the fake flare square (its truth the decoded
    photo, its true mask the square) is filled by the photos and scores high there; with
    every region turned down by the ring check the network fills it all and each of its
    band's rays lies in a turned-down region."""
    import pipeline.render.inputs as inputs
    from pipeline.render import RenderConfig, run
    from tests.conftest import load_benchmark

    run(RenderConfig(path="inputs", fill="hybrid"), hws)
    truth = tmp_path / "truth"
    (truth / "masks_gt").mkdir(parents=True)
    (truth / "clean").symlink_to(hws.decoded)
    img = cv2.imread(str(hws.decoded / f"{HYBRID_FLARED}.png"))
    gt = np.zeros(img.shape[:2], np.uint8)
    gt[HYBRID_BOX] = 255
    cv2.imwrite(str(truth / "masks_gt" / f"{HYBRID_FLARED}.png"), gt)
    fp = load_benchmark("fill_parts")
    rec = fp.fill_parts(hws.root, truth, {"hybrid": hws.deflared})
    row = rec["views"][HYBRID_FLARED]
    assert list(rec["views"]) == [HYBRID_FLARED]
    assert abs(sum(row[f"share_{p}"] for p in fp.PARTS) - 1) < 1e-3
    assert row["share_photos"] > 0.5 and row["photos_hybrid"] > 25
    monkeypatch.setattr(inputs, "RING_TOLERANCE", -1.0)
    down = fp.fill_parts(hws.root, truth, {"hybrid": hws.deflared})
    assert down["views"][HYBRID_FLARED]["share_photos"] == 0
    assert down["rays"]["guided"] > 0
    assert down["rays"]["guided_rejected"] == down["rays"]["guided"]


def test_full_res_colour_samples_sources_at_full_size(rws):
    """--full-res-colour: the encoder sees the sources at source_scale, colours come from
    WS/images at full size; the default follows the checkpoint (trained without it)."""
    from pipeline.render import encode_sources, load_model
    from pipeline.render.sources import find_checkpoint

    cams = load_cameras(rws.cameras_json)
    stems = [f.stem for f in cams.frames][:3]
    model = load_model(find_checkpoint(rws, None), "cpu")
    small, _ = encode_sources(model, rws, cams, stems, "cpu", 0.5)
    full, _ = encode_sources(model, rws, cams, stems, "cpu", 0.5, full_res_colour=True)
    f0 = cams.frames[0]
    assert full.images.shape[-2:] == (f0.height, f0.width)
    assert small.images.shape[-1] == round(f0.width * 0.5)
    # the encoder saw the same half-size views (resized by torch, not OpenCV's uint8 area
    # filter: close, not bit-equal)
    assert full.feats.shape == small.feats.shape
    diff = float((full.feats - small.feats).abs().mean())
    assert diff < 0.1 * float(small.feats.abs().mean()), diff
    assert torch.allclose(full.K[0], torch.tensor(f0.K, dtype=torch.float32))


def test_inputs_path_resumes_after_a_kill(rws, monkeypatch):
    """`render --path inputs` killed after two de-flared photos: a rerun renders only the
    others and leaves the finished ones untouched."""
    import pipeline.render as R
    import pipeline.render.engine as E

    cfg = R.RenderConfig(path="inputs", fill="network")
    for p in rws.deflared.glob("*.png"):  # start from nothing (other tests render inputs)
        p.unlink()
    real = E.write_frame
    monkeypatch.setattr(E, "write_frame", _dies_after(2, real))
    with pytest.raises(KeyboardInterrupt):
        R.run(cfg, rws, force=True)
    done = sorted(rws.deflared.glob("*.png"))
    assert len(done) == 2 and not list(rws.deflared.glob(".*"))
    mtimes = {p: p.stat().st_mtime_ns for p in done}
    again: list[Path] = []
    monkeypatch.setattr(E, "write_frame", lambda path, rgb, exif=None: (
        again.append(path), real(path, rgb, exif)))
    R.run(cfg, rws)
    n = len(load_cameras(rws.cameras_json).frames)
    assert len(list(rws.deflared.glob("*.png"))) == n
    assert len(again) == n - 2 and not set(again) & set(done)  # only the missing photos
    assert all(p.stat().st_mtime_ns == t for p, t in mtimes.items())


def test_render_bf16_runs_the_rays_under_cpu_autocast_and_is_recorded(rws, monkeypatch,
                                                                       capsys):
    """--bf16: GN-FR's forward pass runs under bf16 autocast on the CPU (every chunk), the
    frames stay close to the fp32 frames, and the setting is in the stage's parameters (a
    render without it renders again); without it no pass runs under autocast, and a record
    made before the setting existed is up to date at the fp32 default. On a CPU without native
    bf16 it warns that bf16 is emulated."""
    import gnfr.renderer as gr
    import pipeline.render as R

    seen = []
    real = gr.GNFR.forward

    def spy(self, *a, **k):
        seen.append(torch.is_autocast_enabled("cpu"))
        return real(self, *a, **k)

    monkeypatch.setattr(gr.GNFR, "forward", spy)
    out = rws.renders / "interpolate"
    R.run(R.RenderConfig(path="interpolate", frames=2, size=(20, 15), fill="network"), rws,
          force=True)
    plain = {p.name: cv2.imread(str(p)).astype(float) for p in out.glob("*.png")}
    assert seen and not any(seen)
    assert rws.stage_record("render:interpolate")["params"]["bf16"] is False
    seen.clear()
    monkeypatch.setattr(gr, "native_bf16", lambda: False)
    capsys.readouterr()
    R.run(R.RenderConfig(path="interpolate", frames=2, size=(20, 15), fill="network",
                         bf16=True), rws)  # not forced: the recorded setting differs
    assert "no native bf16" in " ".join(capsys.readouterr().err.split())
    assert seen and all(seen)
    assert rws.stage_record("render:interpolate")["params"]["bf16"] is True
    for name, img in plain.items():
        diff = cv2.imread(str(out / name)).astype(float) - img
        assert 10 * np.log10(255 ** 2 / max((diff ** 2).mean(), 1e-9)) > 30, name
    R.run(R.RenderConfig(path="interpolate", frames=2, size=(20, 15), fill="network",
                         bf16=False), rws)  # renders fp32 again
    rec = rws.stage_record("render:interpolate")
    assert rec["params"]["bf16"] is False
    del rec["params"]["bf16"]  # a record made before the setting existed rendered fp32
    rws.update_manifest("render:interpolate", rec)
    stamps = {p: p.stat().st_mtime_ns for p in out.glob("*.png")}
    seen.clear()
    R.run(R.RenderConfig(path="interpolate", frames=2, size=(20, 15), fill="network"), rws)
    assert not seen and all(p.stat().st_mtime_ns == t for p, t in stamps.items())


def test_render_compile_wraps_the_model_once_and_changes_nothing(rws, monkeypatch):
    """--compile: torch.compile(dynamic=False) is applied once per render, chunks are
    padded to one shape, and the frames equal the uncompiled ones (the setting is not part
    of the stage's parameters: it changes speed, not output)."""
    import pipeline.render as R

    calls = []

    def fake_compile(model, **kw):  # the wiring, without minutes of compiling
        calls.append(kw)
        return model

    cfg = R.RenderConfig(path="interpolate", frames=2, size=(20, 15), chunk=64)
    R.run(cfg, rws, force=True)
    out = rws.renders / "interpolate"
    plain = {p.name: cv2.imread(str(p)) for p in out.glob("*.png")}
    monkeypatch.setattr(torch, "compile", fake_compile)
    R.run(R.RenderConfig(path="interpolate", frames=2, size=(20, 15), chunk=64, compile=True),
          rws, force=True)
    assert calls == [{"dynamic": False}]
    for name, img in plain.items():
        assert np.abs(cv2.imread(str(out / name)).astype(int) - img).max() <= 1
    assert rws.stage_record("render:interpolate")["params"]["compile"] is None


def _path_between(ws, tmp_path) -> Path:
    """A camera path file of one frame halfway between plane01 and plane03."""
    from gnfr.paths import PathCamera, path_to_json

    cams = load_cameras(ws.cameras_json).by_stem()
    a, b = cams["plane01"], cams["plane03"]
    c2w = a.c2w.copy()
    c2w[:3, 3] = 0.5 * (a.c2w[:3, 3] + b.c2w[:3, 3])
    path = tmp_path / "between.json"
    atomic_write_json(path, path_to_json([PathCamera("v", a.K, c2w, a.width, a.height)]))
    return path


@pytest.mark.parametrize("field", ["close_holes", "sharp_holes"])
def test_small_hole_options_give_the_photos_more_of_a_novel_frame(hws, tmp_path, counters,
                                                                  field):
    """A frame between two cameras: with --close-holes (the small holes of the photos'
    agreed region are filled from the photos) or --sharp-holes (they no longer feather the
    photos around them) the network renders fewer rays, and the frame stays as close to the
    plane's texture as without (GN-FR's depth first off: with it GN-FR draws every pixel)."""
    from pipeline.render import RenderConfig, run

    rays, _ = counters
    path = _path_between(hws, tmp_path)
    frames = {}
    for value in (0.0, 0.03):
        before = rays.rays
        run(RenderConfig(path=str(path), fill="hybrid", network_scale=1.0, network_depth="off",
                         **{field: value}), hws, force=True)
        frames[value] = (rays.rays - before,
                         cv2.imread(str(hws.renders / "between" / "v.png")).astype(int))
    assert frames[0.03][0] < frames[0.0][0], (frames[0.03][0], frames[0.0][0])
    inner = (slice(12, -12), slice(12, -12))
    assert _psnr(frames[0.03][1][inner], frames[0.0][1][inner]) > 25


def test_network_vote_takes_single_photos_only_where_the_network_agrees(hws, tmp_path):
    """A frame between two cameras with a strict agreement rule (every photo must agree),
    so GN-FR (random here) draws much of it. With --network-vote at its loosest every pixel
    some photo sees is taken from the photos: the frame approaches the photos' own fill
    (min_support 1); at a tolerance no random network meets, the frame is unchanged."""
    from pipeline.render import RenderConfig, run

    path = _path_between(hws, tmp_path)
    frames = {}
    for key, support, vote in (("photos", 1, 0.0), ("strict", 4, 0.0), ("vote", 4, 1.0),
                               ("tight", 4, 1e-6)):
        run(RenderConfig(path=str(path), fill="hybrid", min_support=support,
                         network_vote=vote, network_scale=0.5), hws, force=True)
        frames[key] = cv2.imread(str(hws.renders / "between" / "v.png")).astype(int)
    inner = (slice(12, -12), slice(12, -12))
    strict = _psnr(frames["strict"][inner], frames["photos"][inner])
    voted = _psnr(frames["vote"][inner], frames["photos"][inner])
    assert voted > strict + 3, (voted, strict)
    assert np.abs(frames["tight"] - frames["strict"]).max() <= 1


def test_depth_min_blob_leaves_islands_out_of_the_depth_the_render_reads(hws):
    """render --depth-min-blob: the photos' depth maps as the render reads them lose their
    islands under the limit (an island planted in one map here), keep everything else, and
    WS/depth itself is not rewritten."""
    from pipeline.render import RenderConfig, photo_views
    from pipeline.render.jobs import FrameJob

    cams = load_cameras(hws.cameras_json)
    stems = cams.stems
    path = hws.depth_path(stems[0])
    with np.load(path) as z:
        saved = {k: z[k] for k in z.files}
    d = saved["depth"].astype(np.float32).copy()
    f = cams.by_stem()[stems[0]]
    d[:8, :8] = 0
    d[2:5, 2:5] = f.near * 1.01  # a 9-pixel island near the near bound, cut off by the gap
    np.savez(path, **{**saved, "depth": d})
    try:
        before = path.read_bytes()
        job = FrameJob(out=hws.root / "x.png", sources=list(stems), near=f.near, far=f.far,
                       camera=f)
        plain = photo_views(hws, cams, [job], RenderConfig(photo_sources=len(stems)))
        clean = photo_views(hws, cams, [job], RenderConfig(photo_sources=len(stems),
                                                          depth_min_blob=0.001))
        assert (plain[stems[0]].depth[2:5, 2:5] > 0).all()
        assert (clean[stems[0]].depth[2:5, 2:5] == 0).all()
        big = plain[stems[0]].depth > 0
        big[:8, :8] = False
        assert (clean[stems[0]].depth[big] > 0).mean() > 0.95
        assert path.read_bytes() == before
    finally:
        np.savez(path, **saved)


def test_depth_min_blob_defaults_by_path(hws):
    """Unset, the de-flared photos (`--path inputs`) read the depth maps without their
    islands (INPUTS_MIN_BLOB) and novel paths keep every island; given, it is used as is."""
    from pipeline.render import RenderConfig, run
    from pipeline.render.config import INPUTS_MIN_BLOB, NOVEL_SOURCES_EQUAL_BELOW

    run(RenderConfig(path="inputs", fill="hybrid"), hws)
    assert hws.stage_record("render:inputs")["params"]["depth_min_blob"] == INPUTS_MIN_BLOB
    run(RenderConfig(path="inputs", fill="hybrid", depth_min_blob=0.0), hws)
    assert hws.stage_record("render:inputs")["params"]["depth_min_blob"] == 0.0
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25), hws)
    assert hws.stage_record("render:interpolate")["params"]["depth_min_blob"] == 0.0
    # the novel frames' source line is recorded as used (a record of the old line is not
    # up to date); the photos' stays unset (always 0 there)
    assert hws.stage_record("render:interpolate")["params"]["sources_equal_below"] == \
        NOVEL_SOURCES_EQUAL_BELOW
    assert hws.stage_record("render:inputs")["params"]["sources_equal_below"] is None
    from pipeline.render.config import NOVEL_NEAREST_SOURCE
    assert hws.stage_record("render:interpolate")["params"]["nearest_source"] is \
        NOVEL_NEAREST_SOURCE
    assert hws.stage_record("render:inputs")["params"]["nearest_source"] is None
    # the count is the novel frames' (recorded there); the photos never take themselves
    assert hws.stage_record("render:interpolate")["params"]["nearest_count"] == \
        RenderConfig().nearest_n()
    assert "nearest_count" not in hws.stage_record("render:inputs")["params"]


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


def test_fill_defaults_recorded_as_used_and_older_photos_stay_up_to_date(hws):
    """The novel frames record the CPU fill they used (NOVEL_CPU_FILL); the de-flared photos
    record no network scale (they do not use one), and a record written before the
    forty-fifth session (network_scale 0.25 there) is still up to date, while a novel
    path's old record (1-pixel agreement, depth maps only) is not."""
    from pipeline.render import RenderConfig, run
    from pipeline.render.config import NOVEL_CPU_FILL

    run(RenderConfig(path="inputs", fill="hybrid"), hws)
    rec = hws.stage_record("render:inputs")
    assert "network_scale" not in rec["params"]
    assert (rec["params"]["agree_window"], rec["params"]["network_depth"]) == (1, "off")
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25), hws)
    nov = hws.stage_record("render:interpolate")["params"]
    assert (nov["network_scale"], nov["agree_window"], nov["network_depth"],
            nov["key_blend"], nov["novel_agree"]) == (NOVEL_CPU_FILL["network_scale"], 3,
                                                      "holes", 0.5, 0.12)
    assert (rec["params"]["key_blend"], rec["params"]["novel_agree"]) == (0.0, 0.08)
    for name, old in (("render:inputs", {"network_scale": 0.25}),
                      ("render:interpolate", {"network_scale": 0.25, "agree_window": 1,
                                              "network_depth": "off"})):
        r = hws.stage_record(name)
        # records from before the forty-ninth and fiftieth sessions' options hold none
        kept = {k: v for k, v in r["params"].items()
                if k not in ("key_blend", "nearest_source", "key_occlusion",
                              "key_power", "novel_agree")}
        hws.update_manifest(name, {**r, "params": {**kept, **old}})
    photos = sorted((hws.deflared).iterdir())
    stamps = [f.stat().st_mtime_ns for f in photos]
    run(RenderConfig(path="inputs", fill="hybrid"), hws)  # up to date: nothing rewritten
    assert [f.stat().st_mtime_ns for f in photos] == stamps
    assert hws.stage_record("render:inputs")["params"].get("network_scale") == 0.25
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25), hws)
    assert hws.stage_record("render:interpolate")["params"]["agree_window"] == 3
    # a video of the forty-ninth session (its options, no agreement tolerance recorded)
    # renders again at the fiftieth's looser agreement
    r = hws.stage_record("render:interpolate")
    hws.update_manifest("render:interpolate", {**r, "params": {
        k: v for k, v in r["params"].items() if k != "novel_agree"}})
    frames = sorted(hws.render_dir("interpolate").glob("*.png"))
    stamps = [f.stat().st_mtime_ns for f in frames]
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25), hws)
    assert [f.stat().st_mtime_ns for f in frames] != stamps
    assert hws.stage_record("render:interpolate")["params"]["novel_agree"] == 0.12


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


def test_the_pace_line_says_how_fast_the_video_moves_and_how_to_calm_it(hws, capsys):
    """Rendering the interpolate path says how far the scene moves a frame and a second; over
    CALM_PACE a second it names the ``--seconds`` that brings the pace under it."""
    import re
    from dataclasses import replace

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


def test_key_occlusion_without_a_key_blend_says_it_does_nothing(hws, capsys):
    """``--key-occlusion`` and ``--key-power`` only shape the key blend: asked where there is
    none (the de-flared photos, or ``--key-blend 0``) the render says so in one line; with
    the blend they are recorded."""
    from pipeline.render import RenderConfig, run

    run(RenderConfig(path="inputs", fill="hybrid", key_occlusion=True, novel_agree=0.2), hws)
    err = capsys.readouterr().err
    assert "--key-occlusion does nothing without the key blend" in err
    assert "the de-flared photos have none" in err
    assert "--novel-agree is for the video's frames" in err  # and not recorded as used:
    assert hws.stage_record("render:inputs")["params"]["novel_agree"] == 0.08
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25, key_blend=0.0,
                     key_occlusion=True), hws)
    assert "(--key-blend 0)" in capsys.readouterr().err
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25, key_blend=0.0,
                     key_occlusion=True, key_power=2.0), hws)
    assert "--key-occlusion and --key-power 2 do nothing" in capsys.readouterr().err
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25,
                     key_occlusion=True, key_power=2.0), hws)
    err = capsys.readouterr().err
    assert "nothing without" not in err
    params = hws.stage_record("render:interpolate")["params"]
    assert params["key_occlusion"] is True and params["key_power"] == 2.0


def test_depth_samples_default_novel_frames_on_the_cpu_sample_the_whole_ray():
    """Hybrid novel frames on the CPU sample GN-FR's rays along the whole ray (the rule in
    docs/history/fill.md); the de-flared photos and CUDA keep the band of a third of the
    samples; an explicit value and the network fill are as asked."""
    from pipeline.render import RenderConfig, depth_samples

    cfg = RenderConfig()
    assert depth_samples(cfg, "cpu", 24, novel=True) == 0
    assert depth_samples(cfg, "cpu", 24, novel=False) == 8
    assert depth_samples(cfg, "cuda", 24, novel=True) == 8
    assert depth_samples(cfg, "cpu", 6, novel=False) == 4
    assert depth_samples(RenderConfig(depth_samples=5), "cpu", 24, novel=True) == 5
    assert depth_samples(RenderConfig(fill="network"), "cpu", 24, novel=False) == 0


def test_novel_frames_on_the_cpu_fill_as_the_forty_fifth_rule_chose():
    """Novel frames on the CPU: GN-FR's share at NOVEL_CPU_FILL's scale, its own depth in the
    holes, a 3x3 agreement (the rule in docs/history/fill.md); the de-flared photos keep a
    1-pixel agreement and the depth maps' depth (no network scale: GN-FR renders them at their
    size), CUDA its full-size share with them too; what the user gives is kept."""
    from pipeline.render import RenderConfig, resolve_fill
    from pipeline.render.config import NOVEL_CPU_FILL

    cfg = RenderConfig()
    got = resolve_fill(cfg, "cpu", novel=True)
    assert (got.agree_window, got.network_depth) == (3, "holes")
    assert got.network_scale == NOVEL_CPU_FILL["network_scale"] == 0.35  # w3d35 of the rule
    assert got.key_blend == NOVEL_CPU_FILL["key_blend"] == 0.5  # nkb50 of the 49th rule
    assert got.novel_agree == NOVEL_CPU_FILL["novel_agree"] == 0.12  # ag12 of the 50th rule
    for device, novel in (("cpu", False), ("cuda", True), ("cuda", False)):
        got = resolve_fill(cfg, device, novel)
        assert (got.agree_window, got.network_depth) == (1, "off"), (device, novel)
        assert got.key_blend == 0.0, (device, novel)
        assert got.novel_agree == 0.08, (device, novel)
        assert got.network_scale == (1.0 if novel else None), (device, novel)
    mine = RenderConfig(agree_window=5, network_depth="off", network_scale=0.25)
    got = resolve_fill(mine, "cpu", novel=True)
    assert (got.agree_window, got.network_depth, got.network_scale) == (5, "off", 0.25)
    assert resolve_fill(RenderConfig(network_depth="all"), "cuda", True).network_depth == "all"
    net = resolve_fill(RenderConfig(fill="network"), "cpu", novel=True)  # nothing to fill
    assert (net.agree_window, net.network_depth) == (1, "off")
    assert net.network_scale == NOVEL_CPU_FILL["network_scale"]  # what its records hold


@pytest.mark.parametrize("mode", ["holes", "all"])
def test_network_depth_renders_every_low_res_pixel_and_warps_through_its_depth(
        hws, tmp_path, monkeypatch, mode):
    """--network-depth: GN-FR renders every pixel of the frame at --network-scale with its
    depth, and the photos are warped through that depth, upsampled (``all``: in place of the
    depth maps; ``holes``: beside them). The frame is written at its size."""
    import gnfr.renderer
    import pipeline.render.novel as novel
    from pipeline.render import RenderConfig, run

    seen: dict = {}
    real_rays, real_fill = gnfr.renderer.render_rays, novel.fill_from_photos

    def rays(*a, **k):
        out = real_rays(*a, **k)
        seen["rays"], seen["with_depth"] = len(a[3]), k.get("with_depth")
        seen["depth"] = out["depth"].numpy()
        return out

    def fill(*a, **k):
        seen["prior"], seen["only"] = k.get("prior_depth"), k.get("prior_only")
        return real_fill(*a, **k)

    monkeypatch.setattr(gnfr.renderer, "render_rays", rays)
    monkeypatch.setattr(novel, "fill_from_photos", fill)
    path = _path_between(hws, tmp_path)
    run(RenderConfig(path=str(path), fill="hybrid", network_scale=0.25, network_depth=mode),
        hws, force=True)
    frame = cv2.imread(str(hws.renders / "between" / "v.png"))
    H, W = frame.shape[:2]
    h, w = round(H * 0.25), round(W * 0.25)
    assert seen["with_depth"] and seen["rays"] == h * w
    low = seen["depth"].reshape(h, w).astype(np.float32)
    assert np.allclose(seen["prior"], cv2.resize(low, (W, H), interpolation=cv2.INTER_LINEAR))
    assert seen["only"] is (mode == "all")


def test_a_missing_mask_fails_before_the_deflared_photos_are_cleared(tmp_path, capsys):
    """render --path inputs whose inputs changed (one view's mask deleted): one error line
    naming the mask and what to run, and the earlier de-flared photos are still there (the
    stage used to clear WS/deflared first and fail on the missing mask after)."""
    from pipeline.workspace import digest_paths
    from workflows.cli import main

    ws = make_render_ws(tmp_path / "ws", n_views=3)
    assert main(["render", str(ws.root), "--path", "inputs"]) == 0
    before = digest_paths([ws.deflared])
    assert len(list(ws.deflared.glob("*.png"))) == 3
    gone = sorted(ws.masks.glob("*.png"))[0]
    gone.unlink()
    capsys.readouterr()
    assert main(["render", str(ws.root), "--path", "inputs"]) == 2
    errors = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and f"{gone} is missing" in errors[0]
    assert digest_paths([ws.deflared]) == before


def test_frame_workers_one_process_per_thread_on_the_cpu_only(monkeypatch):
    """The render's processes: one per torch thread on the CPU when not asked, at most one per
    MIN_FRAMES_PER_WORKER frames; what the user asks; this process alone on CUDA, with
    ``compile`` and (the test suite's setting) with AUTO_WORKERS off."""
    import torch

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


def _frame_job(tmp_path, name, x, sources):
    from gnfr.paths import PathCamera
    from pipeline.render import FrameJob

    c2w = np.eye(4)
    c2w[0, 3] = x
    K = np.array([[50.0, 0, 16], [0, 50.0, 12], [0, 0, 1]])
    return FrameJob(tmp_path / f"{name}.png", list(sources), 1.0, 5.0,
                    PathCamera(name, K, c2w, 32, 24))


def _line_cameras(xs):
    from pipeline.cameras import Cameras, Frame

    K = np.array([[50.0, 0, 16], [0, 50.0, 12], [0, 0, 1]])
    frames = []
    for i, x in enumerate(xs):
        c2w = np.eye(4)
        c2w[0, 3] = x
        frames.append(Frame(f"p{i}", f"p{i}", K, 32, 24, c2w, 1.0, 5.0))
    return Cameras(frames)


def test_fade_sources_spreads_a_change_of_sources_over_the_frames_around_it(tmp_path):
    """``plan.fade_sources``: frames 0-5 with sources {p0, p1} then frames 6-9 with {p1, p2}:
    at radius 1 frames 5 and 6 each take a third of the other's choice, at radius 2 frames
    4-7 take a fifth or two; the rest render as before. A step longer than FADE_STEP of the
    photos' spacing (a cut) is never faded across; the fill's first photos are the frame's
    ``k`` photos nearest the frame that chose them."""
    from pipeline.render.plan import FADE_STEP, fade_sources, fill_first, photo_spacing

    cams = _line_cameras([0.0, 1.0, 2.0])
    assert photo_spacing(cams) == pytest.approx(1.0)
    jobs = [_frame_job(tmp_path, f"{i:05d}", 0.2 * i, ["p0", "p1"] if i < 6 else ["p1", "p2"])
            for i in range(10)]
    faded = fade_sources(jobs, cams, 1, k=2)
    shares = {i: [(f.sources, round(f.weight, 4)) for f in j.fades] for i, j in enumerate(faded)
              if j.fades}
    assert shares == {5: [(("p1", "p2"), 0.3333)], 6: [(("p0", "p1"), 0.3333)]}
    assert faded[5].fades[0].fill_first == fill_first(jobs[6], cams, 2) == ("p1", "p2")
    assert faded[6].fades[0].fill_first == ("p1", "p0")  # frame 5 sits on p1's camera
    assert faded[5].all_sources == ["p0", "p1", "p2"]
    # the fill's first photo alone (k=1) also changes where the nearest photo does (x=0.5)
    near = {i for i, j in enumerate(fade_sources(jobs, cams, 1, k=1)) if j.fades}
    assert near == {2, 3, 5, 6, 7, 8}
    wide = fade_sources(jobs, cams, 2, k=2)
    shares = {i: [round(f.weight, 4) for f in j.fades] for i, j in enumerate(wide) if j.fades}
    assert shares == {4: [0.2], 5: [0.4], 6: [0.4], 7: [0.2]}
    # a cut: frame 6 far along the line, beyond FADE_STEP spacings from frame 5
    cut = [_frame_job(tmp_path, f"c{i}", 0.2 * i + (FADE_STEP + 0.5) * (i >= 6), j.sources)
           for i, j in enumerate(jobs)]
    assert not any(j.fades for j in fade_sources(cut, cams, 2, k=2))
    assert fade_sources(jobs, cams, 0, k=1) == jobs


def test_fade_steps_back_on_a_dense_path(tmp_path, capsys):
    """``plan.fade_or_not`` (``RenderConfig.fade_limit``): a path whose fades would render
    more than the limit's images a frame renders without them, saying so in one line; at
    or under the limit, or with the limit 0, the fades stay."""
    from pipeline.render.jobs import SourceSet
    from pipeline.render.plan import fade_or_not

    one = SourceSet(("p1", "p2"), ("p1",), 1 / 3)
    jobs = [_frame_job(tmp_path, f"{i:05d}", 0.2 * i, ["p0", "p1"]) for i in range(4)]
    jobs = [replace(j, fades=(one,) * n) for j, n in zip(jobs, (1, 2, 2, 1), strict=True)]
    assert fade_or_not(jobs, 3.0) == jobs and fade_or_not(jobs, 0.0) == jobs
    plain = fade_or_not(jobs, 1.5)  # 2.5 images a frame
    assert all(j.fades == () for j in plain) and [j.sources for j in plain] == [
        j.sources for j in jobs]
    out = capsys.readouterr()
    line = (out.out + out.err).strip()
    assert "\n" not in line and "2.50 images a frame" in line and "fade_limit=0" in line


def test_fade_cut_follows_the_paths_own_steps(tmp_path):
    """``fade_sources(..., cut=C)`` (``RenderConfig.fade_cut``): a path that steps two photo
    spacings at every frame (a densely photographed object, a short path) is faded across
    its changes of sources when C times its median step is longer than the step; a step
    much longer than the path's usual one stays a cut; with C=0 the photos' spacing alone
    decides (every step over ``FADE_STEP`` spacings is a cut)."""
    from pipeline.render.plan import FADE_STEP, fade_sources

    cams = _line_cameras([float(x) for x in range(20)])
    assert FADE_STEP < 2.0
    srcs = [["p0", "p1"], ["p1", "p2"], ["p2", "p3"], ["p3", "p4"]]
    xs = [0.0, 2.0, 4.0, 6.0]
    jobs = [_frame_job(tmp_path, f"{i:05d}", x, s)
            for i, (x, s) in enumerate(zip(xs, srcs, strict=True))]
    assert not any(j.fades for j in fade_sources(jobs, cams, 1, k=2))
    assert not any(j.fades for j in fade_sources(jobs, cams, 1, k=2, cut=0.9))
    faded = fade_sources(jobs, cams, 1, k=2, cut=3.0)
    assert [len(j.fades) for j in faded] == [1, 2, 2, 1]
    # frame 3 jumps 12 spacings (six median steps): a cut at C=3, joined at C=7
    far = [*jobs[:3], _frame_job(tmp_path, "00003", 16.0, ["p15", "p16"])]
    assert [len(j.fades) for j in fade_sources(far, cams, 1, k=2, cut=3.0)] == [1, 2, 1, 0]
    assert [len(j.fades) for j in fade_sources(far, cams, 1, k=2, cut=7.0)] == [1, 2, 2, 1]


def test_a_faded_frame_is_the_weighted_mean_of_its_renders(tmp_path, monkeypatch):
    """``engine.render_jobs``: a job with fades renders its camera once per source set (the
    fade's sources and fill's first photos passed on) and writes the weighted mean."""
    from pipeline.render import RenderConfig, engine
    from pipeline.render.jobs import SourceSet

    seen, written = [], {}

    def fake_render(model, src, index, job, *a, **k):
        seen.append((tuple(job.sources), job.fill_first, job.fades))
        return np.full((2, 2, 3), 30 if job.sources == ["p0", "p1"] else 90, np.uint8)

    monkeypatch.setattr(engine, "render_image", fake_render)
    monkeypatch.setattr(engine, "write_frame",
                        lambda out, img, exif=None: written.__setitem__(out.name, img))
    plain = _frame_job(tmp_path, "a", 0.0, ["p0", "p1"])
    fade = SourceSet(("p1", "p2"), ("p1",), 1 / 3)
    faded = _frame_job(tmp_path, "b", 0.0, ["p0", "p1"])
    faded.fades = (fade,)
    engine.render_jobs(None, None, {}, [plain, faded], {}, RenderConfig(), None, quiet=True)
    assert (written["a.png"] == 30).all() and (written["b.png"] == 50).all()
    assert seen == [(("p0", "p1"), None, ()), (("p0", "p1"), None, (fade,)),
                    (("p1", "p2"), ("p1",), ())]


def test_source_fade_renders_only_the_frames_near_a_change(hws):
    """``--source-fade 1`` (the default; ``fade_limit`` 0, never stepping back) on the plane's
    tour against 0: the frames with no change of sources in reach come out as without it, to
    the bit; the frames beside a change differ; the path's cameras.json names the fades; the
    render records the options for paths only."""
    from pipeline.render import RenderConfig, run

    out = hws.renders / "interpolate"
    cfg = RenderConfig(path="interpolate", fill="hybrid", frames=12, scale=0.25, n_sources=2,
                       workers=1, source_fade=0, fade_limit=0)  # 1.67 images a frame here
    run(cfg, hws)
    before = {p.name: cv2.imread(str(p)) for p in sorted(out.glob("*.png"))}
    run(RenderConfig(**{**cfg.__dict__, "source_fade": 1}), hws)
    frames = json.loads((out / "cameras.json").read_text())["frames"]
    faded = {f"{f['name']}.png" for f in frames if f.get("fades")}
    assert faded and len(faded) < len(frames)
    for name, img in before.items():
        now = cv2.imread(str(out / name))
        assert (now == img).all() == (name not in faded), name
    assert hws.stage_record("render:interpolate")["params"]["source_fade"] == 1
    run(RenderConfig(path="inputs", fill="hybrid", source_fade=1), hws)
    params = hws.stage_record("render:inputs")["params"]
    assert "source_fade" not in params and "fade_limit" not in params


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


def test_hold_sources_keeps_a_choice_while_it_stays_near(tmp_path):
    """``plan.hold_sources``: photos on a line, frames walking along it with the two nearest
    as sources. Held by one, the choice changes less often; every frame's sources are still
    among the three it would choose, the photo nearest it is among its sources and first in
    its fill, and 0 leaves the jobs as they are."""
    from pipeline.render import RenderConfig, novel_sources
    from pipeline.render.plan import fill_first, hold_sources
    from pipeline.ws_files import ViewsFile

    cams = _line_cameras([0.0, 1.0, 2.0, 3.0, 4.0])
    views = ViewsFile.from_json({"max_flare": 0.1, "views": {
        f"p{i}": {"flare_fraction": 0.0, "target": True} for i in range(5)}})
    cfg = RenderConfig(n_sources=2, photo_sources=1)
    jobs = []
    for i in range(41):
        job = _frame_job(tmp_path, f"{i:05d}", 0.1 * i + 0.03, [])
        job.sources = novel_sources(job.camera.c2w[:3, 3], cams, views, cfg)
        jobs.append(job)

    def changes(js):
        keys = [(frozenset(j.sources), fill_first(j, cams, 1)) for j in js]
        return sum(a != b for a, b in zip(keys, keys[1:], strict=False))

    held = hold_sources(jobs, cams, views, cfg, 1)
    assert changes(held) < changes(jobs)
    wider = RenderConfig(n_sources=3, photo_sources=1)
    for job in held:
        c = job.camera.c2w[:3, 3]
        nearest = min(cams.stems, key=lambda s: abs(cams.by_stem()[s].center[0] - c[0]))
        assert set(job.sources) <= set(novel_sources(c, cams, views, wider))
        assert nearest in job.sources and fill_first(job, cams, 1) == (nearest,)
    assert any(j.fill_first is not None for j in held)
    assert hold_sources(jobs, cams, views, cfg, 0) == jobs


def test_photo_views_load_the_photos_a_held_or_faded_fill_takes_first(hws, tmp_path):
    """``photo_views`` loads a job's own ``fill_first`` and its fades' too, even where they
    lie past the first ``photo_sources`` of the job's sources."""
    from pipeline.render import RenderConfig, photo_views
    from pipeline.render.jobs import SourceSet

    stems = load_cameras(hws.cameras_json).stems
    cfg = RenderConfig(photo_sources=1)
    held = _frame_job(tmp_path, "a", 0.0, stems[:3])
    held.fill_first = (stems[2],)
    faded = _frame_job(tmp_path, "b", 0.0, stems[:1])
    faded.fades = (SourceSet(tuple(stems[3:5]), (stems[4],), 0.5),)
    got = photo_views(hws, load_cameras(hws.cameras_json), [held, faded], cfg)
    assert set(got) == {stems[0], stems[2], stems[3], stems[4]}


def test_flare_fallback_is_the_model_s_unless_render_is_told_and_is_recorded(tmp_path,
                                                                           monkeypatch):
    """The de-flared photos' rays fall back to the model's recorded ``flare_fallback``
    (``valid`` for a model without one), ``--flare-fallback`` overrides it and is in the
    stage's parameters (a change renders again), and a record made before the setting
    existed is up to date at ``valid``."""
    import gnfr.renderer as gr
    import pipeline.render as R
    from gnfr.checkpoint import save_model

    seen = []
    real = gr.attention_mask

    def spy(valid, flared, rgb=None, fallback="valid"):
        seen.append(fallback)
        return real(valid, flared, rgb, fallback)

    monkeypatch.setattr(gr, "attention_mask", spy)
    ws = make_render_ws(tmp_path / "ws")
    R.run(R.RenderConfig(path="inputs", fill="network"), ws)
    assert seen and set(seen) == {"valid"}
    assert ws.stage_record("render:inputs")["params"]["flare_fallback"] == "valid"
    seen.clear()
    R.run(R.RenderConfig(path="inputs", fill="network", flare_fallback="darkest"), ws)
    assert seen and set(seen) == {"darkest"}
    rec = ws.stage_record("render:inputs")
    assert rec["params"]["flare_fallback"] == "darkest"
    seen.clear()
    R.run(R.RenderConfig(path="inputs", fill="network", flare_fallback="valid"), ws)
    rec = ws.stage_record("render:inputs")
    del rec["params"]["flare_fallback"]  # made before the setting existed
    ws.update_manifest("render:inputs", rec)
    seen.clear()
    R.run(R.RenderConfig(path="inputs", fill="network"), ws)
    assert not seen  # up to date
    model, meta = _model_and_meta(ws.model_file)
    save_model(ws.model_file, model, {**meta, "flare_fallback": "darkest"})
    R.run(R.RenderConfig(path="inputs", fill="network"), ws)  # a new model: rendered again
    assert seen and set(seen) == {"darkest"}


def _model_and_meta(path):
    """The GN-FR model saved at ``path`` and its metadata."""
    from gnfr.checkpoint import load_weights, read_metadata
    from gnfr.model import GNFR

    cfg, meta = read_metadata(path)
    model = GNFR(cfg)
    load_weights(model, path)
    return model, meta


def test_de_flared_photos_default_to_more_sources_than_novel_frames(tmp_path):
    """Without --n-sources the de-flared photos take at least ``INPUTS_SOURCES`` sources
    (the model's count when larger), novel frames the model's ``eval_views`` (10 without
    one); --n-sources sets both. The photos' render records the count it used."""
    import pipeline.render as R
    from pipeline.render.config import INPUTS_SOURCES

    assert INPUTS_SOURCES == 12
    cfg = R.RenderConfig()
    assert cfg.path == "inputs" and cfg.source_count(6) == 12 and cfg.source_count(16) == 16
    assert cfg.source_count(None) == 12
    novel = R.RenderConfig(path="interpolate")
    assert novel.source_count(6) == 6 and novel.source_count(None) == 10
    assert R.RenderConfig(n_sources=4).source_count(6) == 4
    assert R.RenderConfig(path="spiral", n_sources=4).source_count(6) == 4
    ws = make_render_ws(tmp_path / "ws")  # its model's eval_views: 3; 4 other views
    R.run(R.RenderConfig(fill="network"), ws)
    assert ws.stage_record("render:inputs")["params"]["n_sources"] == 12
    views = json.loads(ws.views_json.read_text())["views"]
    assert len(R.input_sources(FLARED, views, R.RenderConfig(n_sources=12))) == 4  # all
    R.run(R.RenderConfig(path="interpolate", frames=2, size=(20, 15), fill="network"), ws)
    assert ws.stage_record("render:interpolate")["params"]["n_sources"] == 3


def test_key_spot_scales_with_the_cameras_and_renders(hws):
    """``key_spot``: each novel job's ``same_spot`` is the option times the median distance
    between the cameras (0 when off); a video renders with it and records it."""
    from pipeline.render import RenderConfig, plan_jobs, run
    from pipeline.render.plan import median_camera_distance
    from pipeline.ws_files import read_cameras, read_views

    cams = read_cameras(hws)
    c = cams.centers()
    pairs = [np.linalg.norm(c[i] - c[j]) for i in range(len(c)) for j in range(i + 1, len(c))]
    assert median_camera_distance(cams) == pytest.approx(float(np.median(pairs)))
    cfg = RenderConfig(path="interpolate", frames=3, size=(40, 30), n_sources=3)
    for spot in (0.0, 0.2):
        _, _, jobs = plan_jobs(replace(cfg, key_spot=spot), hws, cams, read_views(hws), "cpu")
        assert {j.same_spot for j in jobs} == {spot * median_camera_distance(cams)}
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25, key_spot=0.2),
        hws)
    assert hws.stage_record("render:interpolate")["params"]["key_spot"] == 0.2
    assert len(list(hws.render_dir("interpolate").glob("*.png"))) == 2
    # the default: NOVEL_CPU_FILL's on the CPU for hybrid novel frames, 0 on CUDA, for the
    # network alone and for the de-flared photos
    from pipeline.render.config import NOVEL_CPU_FILL
    from pipeline.render.plan import resolve_fill

    assert NOVEL_CPU_FILL["key_spot"] == 0.1
    hybrid = RenderConfig(path="interpolate", fill="hybrid")
    assert resolve_fill(hybrid, "cpu", novel=True).key_spot == 0.1
    assert resolve_fill(hybrid, "cuda", novel=True).key_spot == 0.0
    assert resolve_fill(replace(hybrid, fill="network"), "cpu", novel=True).key_spot == 0.0
    assert resolve_fill(hybrid, "cpu", novel=False).key_spot == 0.0
    _, _, jobs = plan_jobs(replace(cfg, fill="network"), hws, cams, read_views(hws), "cpu")
    assert {j.same_spot for j in jobs} == {0.0}
    _, _, jobs = plan_jobs(cfg, hws, cams, read_views(hws), "cpu")  # hybrid, the default
    assert {j.same_spot for j in jobs} == {0.1 * median_camera_distance(cams)}
    # a video recorded before the option (no key_spot) is not up to date at the default
    rec = hws.stage_record("render:interpolate")
    hws.update_manifest("render:interpolate", {**rec, "params": {
        k: v for k, v in rec["params"].items() if k != "key_spot"}})
    frames = sorted(hws.render_dir("interpolate").glob("*.png"))
    stamps = [f.stat().st_mtime_ns for f in frames]
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25, key_spot=0.0),
        hws)  # the old record is what --key-spot 0 renders
    assert [f.stat().st_mtime_ns for f in frames] == stamps
    run(RenderConfig(path="interpolate", fill="hybrid", frames=2, scale=0.25), hws)
    assert hws.stage_record("render:interpolate")["params"]["key_spot"] == 0.1
    assert [f.stat().st_mtime_ns for f in frames] != stamps


def test_the_render_record_holds_each_paths_own_settings():
    """record_params: the de-flared photos record no path setting (pace, tour, cross-fade,
    nearest views, exposure glide, network scale), the video no ring check, only the
    interpolate path its pace and tour; the model's training settings fill what the config
    leaves; record_defaults gives the older records' meaning for each path's own settings."""
    from dataclasses import asdict

    from pipeline.render import record_defaults, record_params
    from pipeline.render.config import RenderConfig

    cfg = RenderConfig()
    meta = {"source_scale": 0.25, "point_sampler": False}
    rec = {key: record_params(cfg, meta, key, "cpu", 32, False)
           for key in ("inputs", "interpolate", "spiral")}
    video_only = {"pace", "tour", "nearest_count", "source_fade", "fade_cut", "fade_limit",
                  "source_hold", "path_exposure", "from_deflared", "source_grow",
                  "network_scale"}
    assert not video_only & rec["inputs"].keys()
    assert video_only <= rec["interpolate"].keys()
    assert video_only - {"pace", "tour"} <= rec["spiral"].keys()
    assert not {"pace", "tour"} & rec["spiral"].keys()
    assert "band_rejected" in rec["inputs"] and "band_rejected" not in rec["spiral"]
    for r in rec.values():
        assert r["device"] is None and r["samples"] == 32
        assert r["source_scale"] == 0.25 and r["point_sampler"] is False
        assert r["depth_maps"] == "depth"
        assert set(r) - set(asdict(cfg)) <= {"point_sampler", "encode_apart", "depth_maps"}
    assert record_params(cfg, meta, "spiral", "cpu", 32, True)["depth_maps"] == "frames"
    old_inputs, old_video = record_defaults("inputs", "cpu"), record_defaults("spiral", "cpu")
    assert old_inputs["network_scale"] == 0.25  # the novel frames' CPU default of then
    assert record_defaults("inputs", "cuda")["network_scale"] == 1.0
    assert old_video["source_fade"] == 0 and old_video["pace"] == "travel"
    assert old_inputs["source_fade"] == cfg.source_fade  # no record of it: today's default
