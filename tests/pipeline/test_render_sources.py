"""Render stage: which photos a frame or a de-flared photo takes as sources: nearest and least
flared, the equal-below line, the nearest count, and changes of sources faded or held along a
path.

Split from test_render.py by topic; the workspaces and fixtures are tests/pipeline/render_ws.py
and conftest.py."""

from __future__ import annotations

import json
from dataclasses import replace

import cv2
import numpy as np
import pytest

from pipeline.cameras import load_cameras
from tests.pipeline.render_ws import FLARED, make_render_ws


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

