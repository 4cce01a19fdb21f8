"""The views' exposures evened out (pipeline/exposure.py): gains from the depth maps, the
fine-tune that trains at them and the render that reads them back."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pipeline import exposure as ex
from pipeline.cameras import Cameras, Frame
from pipeline.stereo import PosedView
from tests.fixtures import make_plane_workspace, plane_views

W, H = 160, 120
K = np.array([[150.0, 0, W / 2], [0, 150.0, H / 2], [0, 0, 1]])


def test_apply_gain_is_a_gain_in_linear_light_and_round_trips():
    rng = np.random.default_rng(0)
    srgb = rng.uniform(0.05, 0.6, (50, 3)).astype(np.float32)
    lin = ex.srgb_to_lin(srgb)
    out = ex.apply_gain(srgb, [2.0, 1.0, 0.5])
    np.testing.assert_allclose(ex.srgb_to_lin(out), lin * [2.0, 1.0, 0.5], rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(ex.apply_gain(out, [0.5, 1.0, 2.0]), srgb, atol=1e-5)
    u8 = (srgb * 255).round().astype(np.uint8)
    assert ex.apply_gain(u8, [1.0, 1.0, 1.0]).tolist() == u8.tolist()
    assert ex.apply_gain(np.full((1, 3), 0.9, np.float32), [4.0] * 3).max() == pytest.approx(1.0)


def test_solve_gains_recovers_exposures_from_pair_differences():
    stems = ["a", "b", "c", "d"]
    e = {"a": 0.3, "b": -0.2, "c": 0.5, "d": 9.0}  # d is never compared: gain 1
    pairs = [("a", "b"), ("b", "c"), ("a", "c"), ("c", "a")]
    diffs = [(x, y, np.full(3, e[y] - e[x])) for x, y in pairs]
    g = ex.solve_gains(stems, diffs)
    mean = np.mean([e[s] for s in "abc"])
    for s in "abc":
        np.testing.assert_allclose(g[s], np.exp(-(e[s] - mean)), rtol=1e-9)
    assert g["d"].tolist() == [1.0, 1.0, 1.0]
    assert ex.solve_gains(stems, [])["a"].tolist() == [1.0, 1.0, 1.0]


def test_gains_from_depth_warps_undo_each_views_exposure():
    """Four photos of a textured plane, each exposed differently (a stop apart at most, one
    channel shifted as a white balance would): the gains bring them back to one exposure,
    to a hundredth of a stop."""
    rng = np.random.default_rng(4)
    centers = [[x, 0.0, -3.0] for x in (-0.3, -0.1, 0.1, 0.3)]
    images, c2ws, depths = plane_views(rng, centers, K, (W, H))
    ev = np.array([[0.4, 0.4, 0.4], [-0.5, -0.5, -0.5], [0.0, 0.0, 0.3], [0.5, 0.5, 0.5]])
    views, frames = {}, []
    for i, (img, c2w, d) in enumerate(zip(images, c2ws, depths, strict=True)):
        shown = ex.lin_to_srgb(ex.srgb_to_lin(0.1 + 0.6 * img) * 2.0 ** ev[i])
        s = f"v{i}"
        views[s] = PosedView(shown.astype(np.float32), K.copy(), c2w, None,
                             d.astype(np.float32))
        frames.append(Frame(s, s, K, W, H, c2w, 1.0, 6.0))
    cams = Cameras(frames)
    g = ex.solve_gains(cams.stems, ex.pair_differences(views, cams, neighbours=3))
    got = np.stack([np.log2(g[f"v{i}"]) for i in range(4)])
    np.testing.assert_allclose(got, -(ev - ev.mean(0)), atol=0.01)
    assert ex.spread_ev(g) == pytest.approx(np.ptp((ev - ev.mean(0)).mean(1)), abs=0.01)


def test_a_curve_is_a_gain_at_mid_grey_and_a_slope_about_it_and_inverts():
    rng = np.random.default_rng(1)
    srgb = rng.uniform(0.05, 0.8, (60, 3)).astype(np.float32)
    lin = ex.srgb_to_lin(srgb)
    curve = [1.5, 1.0, 0.8, 1.2]
    out = ex.apply_gain(srgb, curve)
    want = np.clip(ex.PIVOT * np.array(curve[:3]) * (lin / ex.PIVOT) ** 1.2, 0, 1)
    np.testing.assert_allclose(ex.srgb_to_lin(out), want, rtol=1e-4, atol=1e-6)
    keep = want.max(-1) < 1.0  # clipped colours cannot come back
    np.testing.assert_allclose(ex.apply_gain(out, ex.inverse(curve))[keep], srgb[keep],
                               atol=1e-4)
    np.testing.assert_allclose(ex.apply_gain(srgb, [2.0, 1.0, 0.5, 1.0]),
                               ex.apply_gain(srgb, [2.0, 1.0, 0.5]), atol=1e-6)
    np.testing.assert_allclose(ex.inverse([2.0, 1.0, 0.5]), [0.5, 1.0, 2.0])


def toned_plane(curves):
    """Four views of a textured plane, view i's linear colours PIVOT * g * (x / PIVOT) ** s
    of the scene's x for its curve (g, s): (views, cameras)."""
    rng = np.random.default_rng(5)
    centers = [[x, 0.0, -3.0] for x in (-0.3, -0.1, 0.1, 0.3)]
    images, c2ws, depths = plane_views(rng, centers, K, (W, H))
    views, frames = {}, []
    for i, (img, c2w, d) in enumerate(zip(images, c2ws, depths, strict=True)):
        shown = ex.apply_gain((0.05 + 0.8 * img).astype(np.float32), curves[i])
        s = f"v{i}"
        views[s] = PosedView(shown, K.copy(), c2w, None, d.astype(np.float32))
        frames.append(Frame(s, s, K, W, H, c2w, 1.0, 6.0))
    return views, Cameras(frames)


def test_curves_even_out_a_tone_curve_one_gain_cannot():
    """Views whose tone differs in slope as well as exposure (a stop apart in the shadows,
    less in the highlights): the curves found are the truth's inverses (up to the common
    exposure they are normalised to) and even the views out as well as those do, where one
    gain per view leaves the pairs' brightness bins several times further apart."""
    truth = [[1.0, 1.0, 1.0, 1.0], [1.4, 1.4, 1.4, 0.85], [0.8, 0.8, 1.0, 1.15],
             [1.2, 1.2, 1.2, 1.1]]
    views, cams = toned_plane(truth)
    curves = ex.solve_curves(cams.stems, ex.pair_bins(views, cams, neighbours=3))
    gains = ex.solve_gains(cams.stems, ex.pair_differences(views, cams, neighbours=3))
    undo = np.stack([ex.inverse(t) for t in truth])  # level -> log g + s * level
    beta = 1.0 / undo[:, 3].mean()
    want_log_g = beta * (np.log(undo[:, :3]) - np.log(undo[:, :3]).mean(0))
    got = np.stack([curves[f"v{i}"] for i in range(4)])
    np.testing.assert_allclose(got[:, 3], beta * undo[:, 3], atol=0.03)
    np.testing.assert_allclose(np.log(got[:, :3]), want_log_g, atol=0.03)
    assert got[:, 3].mean() == pytest.approx(1.0, abs=1e-3)

    def worst(fix):  # the pairs' largest brightness-bin difference after ``fix`` (stops)
        evened = {s: replace(v, image=ex.apply_gain(v.image, fix[s])) for s, v in views.items()}
        return max(float(np.abs(lb - la).max()) / np.log(2)
                   for _, _, la, lb in ex.pair_bins(evened, cams, 3))

    best = worst({f"v{i}": undo[i] for i in range(4)})  # what resampling leaves
    assert worst(curves) < best + 0.05
    assert worst(gains) > 3 * best
    assert ex.solve_curves(cams.stems, [])["v0"].tolist() == [1.0, 1.0, 1.0, 1.0]


def test_exposure_match_trains_at_the_gains_and_render_reads_them(tmp_path, monkeypatch):
    """finetune --exposure-match on a plane whose views differ in exposure: the fine-tune's
    views are brought to the gains the depth maps give, the checkpoint records them, and
    render reads them (the de-flared photos are written)."""
    import cv2
    import torch

    import gnfr.train
    import pipeline.finetune as ft
    from pipeline import depth, render
    from pipeline.depth import DepthConfig
    from pipeline.render.sources import train_meta
    from pipeline.ws_files import read_view_image

    ws = make_plane_workspace(tmp_path / "ws", n_views=5)
    for i, s in enumerate(sorted(p.stem for p in ws.images.glob("*.png"))):  # +-0.5 EV
        img = read_view_image(ws, s, as_float=True)
        out = ex.apply_gain(img, [2.0 ** (0.25 * (i - 2))] * 3)
        cv2.imwrite(str(ws.image_path(s)), (out[..., ::-1] * 255).round().astype(np.uint8))
    from pipeline.ws_files import make_views, read_cameras, write_mask, write_views

    cams = read_cameras(ws)
    for s in cams.stems:  # no flare: empty masks, every view a target
        write_mask(ws, s, np.zeros((cams.by_stem()[s].height, cams.by_stem()[s].width), bool))
    write_views(ws, make_views(cams.stems, cams.centers(), dict.fromkeys(cams.stems, 0.0), 0.1))
    depth.run(DepthConfig(), ws)
    seen = {}
    from pipeline import training_scenes

    load = training_scenes.load_workspace

    def spy(root, **kw):
        seen.update(kw)
        return load(root, **kw)

    monkeypatch.setattr(training_scenes, "load_workspace", spy)
    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(gnfr.train.PRESETS["tiny"],
                                                             iters=2, ckpt_every=100))
    ft.run(ft.FinetuneConfig(preset="quick", init="scratch", device="cpu",
                             exposure_match=True), ws)
    gains = train_meta(ws.model_file)["exposure_gains"]
    assert seen["gains"] is not None and set(gains) == set(seen["gains"])
    ev = [float(np.mean(np.log2(gains[s]))) for s in sorted(gains)]
    assert np.all(np.diff(ev) < 0)  # each view a quarter stop brighter: a smaller gain
    assert ev[0] - ev[-1] == pytest.approx(1.0, abs=0.1)
    torch.manual_seed(0)
    render.run(render.RenderConfig(path="inputs", device="cpu", fill="network"), ws)
    assert len(list(ws.deflared.glob("*.png"))) == 5
    # --exposure-reference darkest: the same ratios, every gain at most 1; render reads them
    ft.run(ft.FinetuneConfig(preset="quick", init="scratch", device="cpu",
                             exposure_match=True, exposure_reference="darkest"), ws)
    dark = train_meta(ws.model_file)["exposure_gains"]
    assert max(max(g) for g in dark.values()) == pytest.approx(1.0, abs=1e-4)
    ratio = {s: np.array(dark[s]) / np.array(gains[s]) for s in gains}
    for s in gains:
        np.testing.assert_allclose(ratio[s], ratio[sorted(gains)[0]], rtol=1e-3)
    assert ws.stage_record("finetune")["params"]["exposure_reference"] == "darkest"
    render.run(render.RenderConfig(path="inputs", device="cpu", fill="network"), ws)
    assert len(list(ws.deflared.glob("*.png"))) == 5


def test_exposure_back_is_the_view_own_or_the_sources_median():
    from pipeline.render.engine import exposure_back
    from pipeline.render.jobs import FrameJob

    gains = {"a": [2.0, 2.0, 2.0], "b": [0.5, 1.0, 1.0], "c": [1.0, 1.0, 4.0]}
    frame = Frame("a.jpg", "a", K, W, H, np.eye(4), 1.0, 6.0)
    job = FrameJob(None, ["b", "c"], 1.0, 6.0, frame)
    np.testing.assert_allclose(exposure_back(job, gains), [0.5, 0.5, 0.5])
    novel = FrameJob(None, ["a", "b", "c"], 1.0, 6.0, object())
    np.testing.assert_allclose(exposure_back(novel, gains), [1.0, 1.0, 0.5])
    np.testing.assert_allclose(exposure_back(FrameJob(None, ["x"], 1.0, 6.0, object()), gains),
                               [1.0, 1.0, 1.0])
    curves = {"a": [2.0, 2.0, 2.0, 0.5], "b": [1.0, 1.0, 1.0, 1.0]}
    np.testing.assert_allclose(exposure_back(job, curves), [0.25, 0.25, 0.25, 2.0])
    srgb = np.array([[0.2, 0.4, 0.6]], np.float32)
    back = ex.apply_gain(ex.apply_gain(srgb, curves["a"]), exposure_back(job, curves))
    np.testing.assert_allclose(back, srgb, atol=1e-5)


@pytest.mark.parametrize("field,value", [("exposure_model", "camera-curve"),
                                         ("exposure_reference", "darkest")])
def test_an_exposure_option_without_exposure_match_is_one_line_naming_both(tmp_path, field,
                                                                           value):
    import pipeline.finetune as ft
    from pipeline.errors import UserError

    ws = make_plane_workspace(tmp_path / "ws", n_views=3)
    option = "--" + field.replace("_", "-")
    with pytest.raises(UserError, match=rf"^{option} {value}: .*--no-exposure-match") as e:
        ft.run(ft.FinetuneConfig(exposure_match=False, **{field: value}), ws)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("c", [0.2, -0.25, 0.0])
def test_the_camera_curve_is_monotone_and_inverts_beyond_its_knee(c):
    level = np.linspace(-6.0, 4.0, 401)
    u = ex.to_radiance(level, c)
    assert np.all(np.diff(u) > 0)
    np.testing.assert_allclose(ex.from_radiance(u, c), level, atol=1e-9)
    near = np.abs(level) < 0.5  # about mid grey it is l + c l^2
    np.testing.assert_allclose(u[near], level[near] + c * level[near] ** 2, atol=1e-12)


def test_a_camera_transform_inverts_and_the_camera_curve_is_found_from_the_bins():
    """Four views of one camera (one tone curve, c = 0.15) at exposures up to 1.3 stops
    apart, one channel's white balance off: the camera curve's fit finds c and gains that
    undo each exposure (up to the common one), evening the views out as well as the truth
    does; a camera transform and its inverse round-trip."""
    rng = np.random.default_rng(2)
    srgb = rng.uniform(0.05, 0.8, (60, 3)).astype(np.float32)
    t = [1.6, 1.2, 0.9, 1.1, 0.15]
    np.testing.assert_allclose(ex.apply_gain(ex.apply_gain(srgb, t), ex.inverse(t)), srgb,
                               atol=1e-4)
    np.testing.assert_allclose(ex.apply_gain(srgb, [2.0, 1.0, 0.5, 1.0, 0.0]),
                               ex.apply_gain(srgb, [2.0, 1.0, 0.5]), atol=1e-5)
    c = 0.15
    k = np.array([[1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [0.8, 0.8, 1.0], [1.6, 1.6, 1.6]])
    truth = [np.append(k[i], [1.0, c]) for i in range(4)]
    views, cams = toned_plane(truth)
    got = ex.solve_camera_curve(cams.stems, ex.pair_bins(views, cams, neighbours=3))
    assert got["v0"][4] == pytest.approx(c, abs=0.03)
    want = -(np.log(k) - np.log(k).mean(0))
    np.testing.assert_allclose(np.log([got[f"v{i}"][:3] for i in range(4)]), want, atol=0.04)

    def worst(fix):
        evened = {s: replace(v, image=ex.apply_gain(v.image, fix[s])) for s, v in views.items()}
        return max(float(np.abs(lb - la).max()) / np.log(2)
                   for _, _, la, lb in ex.pair_bins(evened, cams, 3))

    best = worst({f"v{i}": ex.inverse(truth[i]) for i in range(4)})
    gains = ex.solve_gains(cams.stems, ex.pair_differences(views, cams, neighbours=3))
    assert worst(got) < best + 0.05
    assert worst(gains) > 2 * best
    assert ex.solve_camera_curve(cams.stems, [])["v1"].tolist() == [1.0, 1.0, 1.0, 1.0, 0.0]


def test_corrected_level_is_what_apply_gain_does_in_log_terms():
    rng = np.random.default_rng(3)
    srgb = rng.uniform(0.05, 0.5, (40, 3)).astype(np.float32)
    level = np.log(ex.srgb_to_lin(srgb).astype(np.float64) / ex.PIVOT)
    for t in ([1.3, 1.0, 0.8], [1.2, 0.9, 1.1, 1.1], [1.2, 0.9, 1.1, 1.0, 0.12]):
        got = np.log(ex.srgb_to_lin(ex.apply_gain(srgb, t)) / ex.PIVOT)
        want = ex.corrected_level(t, level)
        if len(t) == 5:
            want = ex.from_radiance(want, t[4])
        np.testing.assert_allclose(got, want, atol=1e-4)


def test_path_gain_glides_between_the_photos_gains():
    """Photos on a line at x = 0, 1, 2 with gains 0.5, 1, 2: a camera on a photo with a small
    reach takes that photo's gain, with a wide one the gains' geometric mean; along the line
    the gain rises steadily, without a jump. Curves average their slopes."""
    centres = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    gains = [[0.5] * 3, [1.0] * 3, [2.0] * 3]
    np.testing.assert_allclose(ex.path_gain([0, 0, 0], centres, gains, 0.05), [0.5] * 3)
    np.testing.assert_allclose(ex.path_gain([0, 0, 0], centres, gains, 1e4), [1.0] * 3,
                               rtol=1e-6)
    xs = np.linspace(0, 2, 81)
    g = np.array([ex.path_gain([x, 0, 0], centres, gains, 0.7)[0] for x in xs])
    assert np.all(np.diff(g) > 0) and np.abs(np.diff(np.log2(g))).max() < 0.05
    assert ex.path_gain([50.0, 0, 0], centres, gains, 0.7)[0] == pytest.approx(2.0)  # far
    curves = [[1.0, 1.0, 1.0, 0.8], [4.0, 4.0, 4.0, 1.2]]
    np.testing.assert_allclose(ex.mean_gain(curves, [1, 1]), [2.0, 2.0, 2.0, 1.0])


def test_between_takes_a_photo_to_a_frames_exposure():
    """``between``: a photo's colours at its gain brought to another exposure: for plain
    gains one product, for curves the one applied and the other undone; to its own gain,
    unchanged."""
    srgb = np.array([[0.2, 0.4, 0.6]], np.float32)
    np.testing.assert_allclose(ex.between(srgb, [2.0] * 3, [0.5] * 3),
                               ex.apply_gain(srgb, [4.0] * 3), atol=1e-6)
    curve, gain = [1.5, 1.5, 1.5, 0.9], [0.8, 1.0, 1.2]
    np.testing.assert_allclose(ex.between(srgb, curve, gain),
                               ex.apply_gain(ex.apply_gain(srgb, curve), ex.inverse(gain)),
                               atol=1e-6)
    np.testing.assert_allclose(ex.between(srgb, curve, curve), srgb, atol=1e-5)


def test_the_fill_at_a_frames_exposure_does_not_follow_its_photos(tmp_path):
    """Four photos of a plane a stop apart in exposure, the model's gains known. A novel
    frame's photo fill from the two darkest and from the two brightest: matched to their own
    median (no ``exposure``) the two fills differ by about a stop; brought to the frame's
    exposure (``FrameJob.exposure``, common here) both are the plane at that exposure."""
    from pipeline.render.config import RenderConfig
    from pipeline.render.fill import fill_from_photos
    from pipeline.render.jobs import FrameJob
    from pipeline.render.plan import resolve_fill

    rng = np.random.default_rng(5)
    centers = [[x, 0.0, -3.0] for x in (-0.3, -0.1, 0.0, 0.1, 0.3)]
    images, c2ws, depths = plane_views(rng, centers, K, (W, H))
    ev = {"v0": -0.5, "v1": -0.5, "v3": 0.5, "v4": 0.5}  # v2 is the novel camera
    truth = 0.1 + 0.6 * images[2]
    photos, gains = {}, {}
    for i, s in enumerate(("v0", "v1", "v2", "v3", "v4")):
        if s in ev:
            shown = ex.lin_to_srgb(ex.srgb_to_lin(0.1 + 0.6 * images[i]) * 2.0 ** ev[s])
            photos[s] = PosedView(shown.astype(np.float32), K.copy(), c2ws[i], None,
                                  depths[i].astype(np.float32))
            gains[s] = np.full(3, 2.0 ** -ev[s])
    cfg = resolve_fill(RenderConfig(key_blend=0.0, photo_fallback=0), "cpu", True)

    def fill(stems, exposure):
        job = FrameJob(None, stems, 2.0, 5.0, None, exposure=exposure,
                       photo_gains=gains if exposure else None)
        f = fill_from_photos(K, c2ws[2], (W, H), job, photos, cfg, novel=True)
        ok = f.weight >= 1
        assert ok.mean() > 0.5
        return float(np.mean(ex.srgb_to_lin(f.colour[ok]) / ex.srgb_to_lin(truth[ok])))

    dark, bright = fill(["v0", "v1"], None), fill(["v3", "v4"], None)
    assert bright / dark == pytest.approx(2.0, rel=0.1)  # a stop apart
    for stems in (["v0", "v1"], ["v3", "v4"]):
        assert fill(stems, (1.0, 1.0, 1.0)) == pytest.approx(1.0, rel=0.03)
    assert fill(["v0", "v1"], (0.5, 0.5, 0.5)) == pytest.approx(2.0, rel=0.06)


def test_exposure_along_the_path_smooths_the_frames_own(tmp_path):
    """``plan.exposure_along_path``: frames whose fill's first photos' median gain jumps
    from 0.5 to 2 half way along the path get that median averaged over the frames near them
    (``path_gain`` at ``reach`` photo spacings): the exposure rises over several frames,
    without a jump, and far from the change it stays near each frame's own; the photos'
    gains go with it for the fill. A frame's own is its nearest photos', not all its
    sources'. Unchanged at reach 0 or without gains; ``exposure_back`` then undoes the
    frame's gain."""
    from pipeline.render.engine import exposure_back
    from pipeline.render.jobs import FrameJob
    from pipeline.render.plan import exposure_along_path, photo_spacing

    frames = [Frame(s, s, K, W, H, _at([x, 0.0, 0.0]), 1.0, 6.0)
              for s, x in (("a", 0.0), ("b", 1.0), ("c", 2.0), ("d", 3.0))]
    cams = Cameras(frames)
    gains = {"a": [0.5] * 3, "b": [0.5] * 3, "c": [2.0] * 3, "d": [2.0] * 3}
    xs = np.linspace(0.0, 3.0, 31)

    def pc(x):
        return type("PC", (), {"c2w": _at([x, 0.0, 0.0])})

    jobs = [FrameJob(None, ["a", "b"] if x < 1.5 else ["c", "d"], 1.0, 6.0, pc(x)) for x in xs]
    assert exposure_along_path(jobs, cams, gains, 0.0, 2) == jobs
    assert exposure_along_path(jobs, cams, None, 1.0, 2) == jobs
    assert photo_spacing(cams) == pytest.approx(1.0)
    got = exposure_along_path(jobs, cams, gains, 0.3, 2)
    ev = np.log2([j.exposure[0] for j in got])
    own = np.log2([0.5 if x < 1.5 else 2.0 for x in xs])
    assert np.all(np.diff(ev) > 0) and np.abs(np.diff(ev)).max() < 0.5  # a 2-stop jump spread
    assert np.abs(ev - own)[(xs < 0.5) | (xs > 2.5)].max() < 0.05
    assert all(set(j.photo_gains) == set(gains) for j in got)
    for job in got:
        np.testing.assert_allclose(exposure_back(job, gains), 1.0 / np.asarray(job.exposure))
    wide = [FrameJob(None, ["a", "b", "c", "d"], 1.0, 6.0, pc(0.0))]  # a, b nearest
    np.testing.assert_allclose(exposure_along_path(wide, cams, gains, 1.0, 2)[0].exposure,
                               [0.5] * 3)
    np.testing.assert_allclose(exposure_along_path(wide, cams, gains, 1.0, 4)[0].exposure,
                               [1.25] * 3)
    without = [FrameJob(None, ["x"], 1.0, 6.0, pc(0.0))]  # no source with a gain
    assert exposure_along_path(without, cams, gains, 1.0, 2) == without


def _at(centre) -> np.ndarray:
    c2w = np.eye(4)
    c2w[:3, 3] = centre
    return c2w


def test_the_round_trip_benchmark_counts_what_a_transform_clips():
    """benchmarks/exposure_roundtrip.py: a gain that lifts a bright pixel past white clips it
    (counted, and it does not come back), one that darkens comes back within a level; a
    curve with a slope over 1 clips highlights the same gain at mid grey leaves."""
    from tests.conftest import load_benchmark

    rt = load_benchmark("exposure_roundtrip")
    img = np.full((4, 4, 3), 100, np.uint8)
    img[0] = 230  # a bright row: a quarter of the pixels
    region = np.zeros((4, 4), bool)
    region[:2] = True  # half of the region bright
    up = rt.view_row(img, region, [2.0, 2.0, 2.0])
    assert up["clipped"] == 0.25 and up["clipped_flare"] == 0.5
    back, clipped = rt.round_trip(img, [2.0, 2.0, 2.0])
    assert clipped[0].all() and not clipped[1:].any() and (back[0] < 230).all()
    assert np.abs(back[1:].astype(int) - 100).max() <= 1
    down = rt.view_row(img, region, [0.5, 0.5, 0.5])
    assert down["clipped"] == 0.0 and down["psnr"] > 40 > up["psnr"]
    flat, steep = (rt.view_row(img, region, [1.0, 1.0, 1.0, s]) for s in (1.0, 1.33))
    assert flat["clipped"] == 0.0 and steep["clipped"] == 0.25


def test_the_round_trip_benchmark_splits_the_flare_region_by_what_the_photos_reach(tmp_path):
    """benchmarks/exposure_roundtrip.py --deflared: on four views of a plane with exact depth,
    a de-flared region 20 levels too bright scores as that offset (all of its error a mean
    offset), reached by the neighbours when they are unflared there and drawn when their
    masks cover it; left as photographed where no mask marks it, blended where one does."""
    import cv2

    from pipeline.cameras import load_cameras
    from pipeline.ws_files import read_view_image, write_depth, write_mask
    from tests.conftest import load_benchmark

    rt = load_benchmark("exposure_roundtrip")
    ws = make_plane_workspace(tmp_path / "ws", n_views=4)
    cams = load_cameras(ws.cameras_json)
    ang = np.linspace(-0.25, 0.25, 4)  # make_plane_workspace's cameras, for their depths
    centers = [[3.0 * np.sin(a), 0.1 * np.cos(3 * a), -3.0 * np.cos(a)] for a in ang]
    Kw = np.array([[1.0 * W, 0, W / 2], [0, 1.0 * W, H / 2], [0, 0, 1]])
    _, _, depths = plane_views(np.random.default_rng(0), centers, Kw, (W, H))
    synth = tmp_path / "synth"
    for d in ("clean", "masks_gt"):
        (synth / d).mkdir(parents=True)
    ws.deflared.mkdir()
    region = np.zeros((H, W), bool)
    region[45:75, 65:95] = True
    scale = cams.colmap_to_world[0, 0]
    for f, d in zip(cams.frames, depths, strict=True):
        img = read_view_image(ws, f.stem)
        write_depth(ws.depth_path(f.stem), d * scale, np.ones_like(d))
        cv2.imwrite(str(synth / "masks_gt" / f"{f.stem}.png"), region.astype(np.uint8) * 255)
        out = img.astype(np.int16)
        out[region] = np.minimum(out[region], 235) + 20  # 20 levels brighter, none clipped
        img[region] = np.minimum(img[region], 235)
        cv2.imwrite(str(synth / "clean" / f"{f.stem}.png"), img[..., ::-1])
        cv2.imwrite(str(ws.deflared / f"{f.stem}.png"),
                    np.clip(out, 0, 255).astype(np.uint8)[..., ::-1])
    rows = {}
    for name, marked in (("open", np.zeros_like(region)), ("masked", region)):
        for f in cams.frames:
            write_mask(ws, f.stem, marked)
        rows[name] = rt.split_rows(synth, ws, 3)
    open_rows, masked_rows = rows["open"], rows["masked"]
    for r in open_rows.values():
        assert r["share_reached"] > 0.9
        assert r["psnr_reached"] == pytest.approx(-20 * np.log10(20 / 255), abs=0.05)
        assert r["bias_share_reached"] > 0.99
        np.testing.assert_allclose(r["bias_reached"], [20 / 255] * 3, atol=2e-3)
    assert all(r["share_reached"] < 0.3 and r["bias_share_drawn"] > 0.99
               for r in masked_rows.values())
    for r in open_rows.values():  # no mask: the render leaves the whole region as it was
        assert r["share_left"] == 1.0 and "psnr_blended" not in r
        np.testing.assert_allclose(r["bias_left"], [20 / 255] * 3, atol=2e-3)
    for r in masked_rows.values():  # the truth as the fill: nearly the truth comes out
        assert r["share_left"] == 0.0 and "psnr_left" not in r
        np.testing.assert_allclose(r["bias_blended"], [20 / 255] * 3, atol=2e-3)
        assert r["psnr_perfect_fill"] > 30 > r["psnr_region"]
        assert np.abs(r["bias_perfect_fill"]).max() < 2 / 255


def test_darkest_reference_scales_every_gain_to_at_most_one():
    """``darkest_reference``: the largest channel factor of any view becomes 1, every ratio
    between views (and a curve's slope) is kept, nothing is brightened any more."""
    gains = {"a": np.array([1.76, 1.6, 1.5]), "b": np.array([0.8, 0.9, 1.0]),
             "c": np.array([1.0, 1.1, 1.2, 0.9])}
    dark = ex.darkest_reference(gains)
    assert max(float(np.max(g[:3])) for g in dark.values()) == pytest.approx(1.0)
    for s in gains:
        np.testing.assert_allclose(dark[s][:3], gains[s][:3] / 1.76)
    assert dark["c"][3] == pytest.approx(0.9) and gains["a"][0] == 1.76  # the input kept
    img = (np.linspace(0, 1, 30, dtype=np.float32).reshape(10, 3))
    assert float(ex.apply_gain(img, dark["a"]).max()) <= 1.0
    assert np.all(ex.apply_gain(img, dark["a"]) <= img + 1e-6)
    assert ex.darkest_reference({}) == {}

