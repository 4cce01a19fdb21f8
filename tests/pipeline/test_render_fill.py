"""Render stage: the hybrid fill: photos warped by depth where they agree, GN-FR's render
elsewhere; the depth the render reads, the ring check and band, small holes, the network vote,
the frames at the photos' cameras.

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
from pipeline.workspace import Workspace, atomic_write_json
from tests.pipeline.render_ws import HYBRID_BOX, HYBRID_FLARED, path_between, psnr


def test_hybrid_inputs_fill_the_flare_region_from_the_photos(hws, counters):
    """The fake flare square covers clean pixels the neighbours see: the photos warped by
    depth must put them back far better than the (random) network, which renders fewer
    rays."""
    from pipeline.render import RenderConfig, blend_weights, decoded_camera, flare_mask_in, run

    rays, _ = counters
    run(RenderConfig(path="inputs", fill="hybrid", inputs_fill="photos", color_match=False,
                     flare_layer=0), hws)
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
    assert psnr(got[inner], orig[inner]) > 30


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

    ws = Workspace(shutil.copytree(hws.root, tmp_path / "ws", symlinks=True))
    depth_run(DepthConfig(neighbours=3), ws)  # the defaults: WS/depth/frames too
    assert ws.depth_frames.is_dir()
    f = load_cameras(ws.cameras_json).by_stem()["plane03"]
    path = tmp_path / "at_input.json"
    atomic_write_json(path, path_to_json([PathCamera("v", f.K, f.c2w, f.width, f.height)]))
    orig = cv2.imread(str(ws.images / f"{f.stem}.png")).astype(int)
    inner = (slice(12, -12), slice(12, -12))
    inputs = RenderConfig(path="inputs", fill="hybrid", inputs_fill="photos", color_match=False,
                          flare_layer=0)
    frames, deflared = {}, {}
    for maps in ("frames", "depth"):
        if maps == "depth":
            shutil.rmtree(ws.depth_frames)
        run(RenderConfig(path=str(path), fill="hybrid"), ws)
        assert ws.stage_record("render:at_input")["params"]["depth_maps"] == maps
        frames[maps] = cv2.imread(str(ws.renders / "at_input" / "v.png")).astype(int)
        assert psnr(frames[maps][inner], orig[inner]) > 30, maps
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

    path = path_between(hws, tmp_path)
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
    run(RenderConfig(path="inputs", fill="hybrid", inputs_fill="photos", band_rejected=band), hws,
        force=True)
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

    run(RenderConfig(path="inputs", fill="hybrid", inputs_fill="photos"), hws)
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


@pytest.mark.parametrize("field", ["close_holes", "sharp_holes"])
def test_small_hole_options_give_the_photos_more_of_a_novel_frame(hws, tmp_path, counters,
                                                                  field):
    """A frame between two cameras: with --close-holes (the small holes of the photos'
    agreed region are filled from the photos) or --sharp-holes (they no longer feather the
    photos around them) the network renders fewer rays, and the frame stays as close to the
    plane's texture as without (GN-FR's depth first off: with it GN-FR draws every pixel)."""
    from pipeline.render import RenderConfig, run

    rays, _ = counters
    path = path_between(hws, tmp_path)
    frames = {}
    for value in (0.0, 0.03):
        before = rays.rays
        run(RenderConfig(path=str(path), fill="hybrid", network_scale=1.0, network_depth="off",
                         **{field: value}), hws, force=True)
        frames[value] = (rays.rays - before,
                         cv2.imread(str(hws.renders / "between" / "v.png")).astype(int))
    assert frames[0.03][0] < frames[0.0][0], (frames[0.03][0], frames[0.0][0])
    inner = (slice(12, -12), slice(12, -12))
    assert psnr(frames[0.03][1][inner], frames[0.0][1][inner]) > 25


def test_network_vote_takes_single_photos_only_where_the_network_agrees(hws, tmp_path):
    """A frame between two cameras with a strict agreement rule (every photo must agree),
    so GN-FR (random here) draws much of it. With --network-vote at its loosest every pixel
    some photo sees is taken from the photos: the frame approaches the photos' own fill
    (min_support 1); at a tolerance no random network meets, the frame is unchanged."""
    from pipeline.render import RenderConfig, run

    path = path_between(hws, tmp_path)
    frames = {}
    for key, support, vote in (("photos", 1, 0.0), ("strict", 4, 0.0), ("vote", 4, 1.0),
                               ("tight", 4, 1e-6)):
        run(RenderConfig(path=str(path), fill="hybrid", min_support=support,
                         network_vote=vote, network_scale=0.5), hws, force=True)
        frames[key] = cv2.imread(str(hws.renders / "between" / "v.png")).astype(int)
    inner = (slice(12, -12), slice(12, -12))
    strict = psnr(frames["strict"][inner], frames["photos"][inner])
    voted = psnr(frames["vote"][inner], frames["photos"][inner])
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

    run(RenderConfig(path="inputs", fill="hybrid", inputs_fill="photos"), hws)
    assert hws.stage_record("render:inputs")["params"]["depth_min_blob"] == INPUTS_MIN_BLOB
    run(RenderConfig(path="inputs", fill="hybrid", inputs_fill="photos", depth_min_blob=0.0), hws)
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


def test_key_occlusion_without_a_key_blend_says_it_does_nothing(hws, capsys):
    """``--key-occlusion`` and ``--key-power`` only shape the key blend: asked where there is
    none (the de-flared photos, or ``--key-blend 0``) the render says so in one line; with
    the blend they are recorded."""
    from pipeline.render import RenderConfig, run

    run(RenderConfig(path="inputs", fill="hybrid", inputs_fill="photos", key_occlusion=True,
                     novel_agree=0.2), hws)
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
    path = path_between(hws, tmp_path)
    run(RenderConfig(path=str(path), fill="hybrid", network_scale=0.25, network_depth=mode),
        hws, force=True)
    frame = cv2.imread(str(hws.renders / "between" / "v.png"))
    H, W = frame.shape[:2]
    h, w = round(H * 0.25), round(W * 0.25)
    assert seen["with_depth"] and seen["rays"] == h * w
    low = seen["depth"].reshape(h, w).astype(np.float32)
    assert np.allclose(seen["prior"], cv2.resize(low, (W, H), interpolation=cv2.INTER_LINEAR))
    assert seen["only"] is (mode == "all")


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

