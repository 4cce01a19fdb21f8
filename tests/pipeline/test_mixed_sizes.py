"""Views of different sizes (a portrait photo among landscape ones) in training: stretched to
the most common size by default; with ``pad`` (``finetune --pad-views``) each kept at its own
size and padded, as the render's source cache keeps them."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import torch

from gnfr.geometry import project
from gnfr.train import QUICK, SourceBank, edge_probabilities, mirrored, sample_batch
from pipeline.cameras import Frame, load_cameras
from pipeline.training_scenes import load_pack, load_workspace, save_pack
from pipeline.ws_files import read_mask, read_view_image, view_stems, write_mask
from tests.fixtures import make_plane_workspace
from workflows.research.turn_views import turn_frame, turn_workspace


def _frame(rng) -> Frame:
    K = np.array([[90.0, 0, 61.3], [0, 85.0, 44.1], [0, 0, 1]])
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    c2w = np.eye(4)
    c2w[:3, :3] = q * np.sign(np.linalg.det(q))
    c2w[:3, 3] = rng.normal(size=3)
    return Frame(name="a.png", stem="a", K=K, width=120, height=90, c2w=c2w, near=0.1,
                 far=9.0, colmap_camera={"model": "PINHOLE", "width": 120, "height": 90,
                                         "params": [90.0, 85.0, 61.3, 44.1]})


def test_a_turned_camera_sees_each_point_where_the_turned_image_has_it():
    """turn_frame: a world point at continuous pixel (u, v) of the view is at (H - v, u) of
    the view turned clockwise (cv2.ROTATE_90_CLOCKWISE), at the same depth; sizes swap."""
    rng = np.random.default_rng(3)
    f = _frame(rng)
    t = turn_frame(f)
    assert (t.width, t.height) == (90, 120)
    assert t.colmap_camera["params"] == [85.0, 90.0, 90 - 44.1, 61.3]
    assert (t.colmap_camera["width"], t.colmap_camera["height"]) == (90, 120)
    pts = torch.from_numpy(f.c2w[:3, :3] @ np.c_[rng.uniform(-1, 1, (50, 2)), np.ones(50)].T
                           * 3 + f.c2w[:3, 3:4]).T.float()
    xy, d = project(pts, torch.tensor(f.K[None]).float(), torch.tensor(f.w2c[None]).float())
    xy2, d2 = project(pts, torch.tensor(t.K[None]).float(), torch.tensor(t.w2c[None]).float())
    assert torch.allclose(d, d2, atol=1e-5)
    assert torch.allclose(xy2[0, :, 0], 90 - xy[0, :, 1], atol=1e-3)
    assert torch.allclose(xy2[0, :, 1], xy[0, :, 0], atol=1e-3)
    assert np.allclose(t.center, f.center)


@pytest.fixture
def plane_pair(tmp_path):
    """(the plane workspace, a copy with views 0 and 3 turned to portrait), with masks."""
    ws = make_plane_workspace(tmp_path / "ws", n_views=5, size=(120, 90))
    for i, s in enumerate(view_stems(ws)):
        m = np.zeros((90, 120), bool)
        m[10:40, 30:40 + 10 * i] = True
        write_mask(ws, s, m)
    stems = view_stems(ws)
    turned = tmp_path / "turned"
    turn_workspace(ws.root, turned, [stems[0], stems[3]])
    return ws, turned, stems


def test_load_workspace_stretches_other_sizes_to_the_most_common_one_by_default(plane_pair,
                                                                             tmp_path):
    """Without ``pad``: every view at the most common size (here landscape, though the first
    view is portrait), intrinsics scaled alike, nothing padded."""
    import cv2

    from pipeline.workspace import Workspace

    ws, turned, stems = plane_pair
    first = tmp_path / "first"  # the first view portrait, the others landscape
    turn_workspace(ws.root, first, [stems[0]])
    for root, turned_stems in ((turned, [stems[0], stems[3]]), (first, [stems[0]])):
        scene = load_workspace(root)
        assert scene.extents is None and tuple(scene.images.shape[-2:]) == (90, 120)
        cams = load_cameras(Workspace(root).cameras_json).by_stem()
        for s in turned_stems:
            i = scene.stems.index(s)
            own = read_view_image(Workspace(root), s)
            want = cv2.resize(own, (120, 90), interpolation=cv2.INTER_AREA)
            assert np.array_equal(scene.images[i].permute(1, 2, 0).numpy(), want)
            K = cams[s].K.copy()
            K[0] *= 120 / 90
            K[1] *= 90 / 120
            assert np.allclose(scene.K[i].numpy(), K)


def test_load_workspace_pads_a_portrait_view_and_does_not_stretch_it(plane_pair):
    """A portrait view among landscape ones keeps its own pixels and intrinsics; views are
    padded (black, marked flare) to the largest height and width; the flare fractions are of
    each view's own pixels; nothing is padded when all views are one size."""
    from pipeline.workspace import Workspace

    ws, turned, stems = plane_pair
    plain = load_workspace(ws.root)
    assert plain.extents is None and tuple(plain.images.shape[-2:]) == (90, 120)
    scene = load_workspace(turned, pad=True)
    assert tuple(scene.images.shape[-2:]) == (120, 120)
    assert scene.extents.tolist() == [[90, 120], [120, 90], [120, 90], [90, 120], [120, 90]]
    tw = Workspace(turned)
    cams = load_cameras(tw.cameras_json).by_stem()
    for i, s in enumerate(stems):
        h, w = scene.size_of(i)
        own = torch.from_numpy(read_view_image(tw, s)).permute(2, 0, 1)
        assert torch.equal(scene.images[i, :, :h, :w], own)
        assert np.allclose(scene.K[i].numpy(), cams[s].K)
        pad = torch.ones(120, 120, dtype=torch.bool)
        pad[:h, :w] = False
        assert int(scene.images[i][:, pad].sum()) == 0
        assert bool((scene.masks[i, 0][pad] == 1).all())
        assert int(pad.sum()) == (0 if (h, w) == (120, 120) else 120 * 120 - h * w)
        assert scene.flare[s] == pytest.approx(float(read_mask(tw, s).mean()))
    assert scene.flare[stems[3]] == pytest.approx(plain.flare[stems[3]])
    assert load_workspace(ws.root, pad=True).extents is None


def _views(bank: SourceBank, ids: torch.Tensor):
    """The bank's views ``ids`` as a training step reads them (features not needed here)."""
    feats = torch.zeros(len(ids), 2, *(s // 4 for s in bank.images.shape[-2:]))
    return bank.views(ids, feats, "cpu")


@pytest.mark.parametrize("full_res_colour", [False, True])
def test_a_padded_source_gives_each_point_the_colour_of_the_unturned_photo(plane_pair,
                                                                        full_res_colour):
    """The same world point sampled from a turned, padded view (training's source bank) and
    from that view unturned gives one colour and one flare flag; a point whose projection
    falls in the padding is outside the view."""
    from gnfr.geometry import pixel_rays
    from gnfr.renderer import gather

    ws, turned, stems = plane_pair
    sa, sb = load_workspace(ws.root), load_workspace(turned, pad=True)
    a = SourceBank.of(sa, 0.5, "cpu", full_res_colour)
    b = SourceBank.of(sb, 0.5, "cpu", full_res_colour)
    ids = torch.tensor([3, 0])
    va, vb = _views(a, ids), _views(b, ids)
    # world points on view 0's own pixel rays (its unturned camera), mid-way in its bounds
    g = torch.Generator().manual_seed(0)
    pix = torch.rand(200, 2, generator=g) * torch.tensor([118.0, 88.0]) + 1.0
    o, d = pixel_rays(sa.K[0].float(), sa.c2w[0].float(), pix)
    pts = (o + d * float(sa.near[0] + sa.far[0]) / 2)[:, None]  # [R, 1, 3]
    ca, valid_a, fa = gather(va, torch.tensor([1]), pts)
    cb, valid_b, fb = gather(vb, torch.tensor([1]), pts)
    assert valid_a.all() and valid_b.all()
    assert float(ca[..., :3].std()) > 0.05  # the plane's texture, not padding
    assert torch.allclose(ca[..., :3], cb[..., :3], atol=1e-5)
    assert torch.equal(fa, fb) and fa.any()
    # a point past the portrait view's right edge lies in its padding: outside it
    assert tuple(sb.size_of(0)) == (120, 90)
    o2, d2 = pixel_rays(sb.K[0].float(), sb.c2w[0].float(), torch.tensor([[93.0, 10.0]]))
    _, valid_pad, _ = gather(vb, torch.tensor([1]), (o2 + d2 * 1.5)[:, None])
    assert not valid_pad.any()


def test_training_never_draws_a_padded_view_s_padding(plane_pair):
    """sample_batch draws target pixels inside the target's own size, uniformly and by
    edges; the edge probabilities cover the view's own pixels."""
    _, turned, _ = plane_pair
    scene = load_workspace(turned, pad=True)
    scene = replace(scene, targets=None)
    gen = torch.Generator().manual_seed(1)
    for edge in (0.0, 0.5):
        cfg = replace(QUICK, rays=256, samples=4, edge_rays=edge, max_flare=1.0)
        for _ in range(12):
            b = sample_batch(scene, cfg, gen)
            h, w = scene.size_of(b.target)
            xy = project(b.rays_o + b.rays_d, scene.K[b.target][None].float(),
                         torch.linalg.inv(scene.c2w[b.target])[None].float())[0][0]
            assert (xy[:, 0] < w).all() and (xy[:, 1] < h).all()
    assert len(edge_probabilities(scene, 0, 0.5)) == 90 * 120


def test_a_padded_scene_s_mirror_flips_each_view_inside_its_own_width(plane_pair):
    """mirrored: a padded view flips inside its own width (padding stays at the right), and
    the mirrored bank gives a mirrored point the colour the scene gives the point."""
    from gnfr.renderer import gather

    _, turned, _ = plane_pair
    scene = load_workspace(turned, pad=True)
    m = mirrored(scene)
    assert torch.equal(m.extents, scene.extents)
    assert torch.equal(m.images[0, :, :, :90], scene.images[0, :, :, :90].flip(-1))
    assert int(m.images[1, :, 90:].sum()) == 0 and int(m.images[0, :, :, 90:].sum()) == 0
    a, b = SourceBank.of(scene, 1.0, "cpu"), SourceBank.of(m, 1.0, "cpu")
    ids = torch.tensor([0, 2])
    va, vb = _views(a, ids), _views(b, ids)
    from gnfr.geometry import pixel_rays

    pix = torch.rand(100, 2, generator=torch.Generator().manual_seed(2)) * torch.tensor(
        [88.0, 118.0]) + 1.0
    o, d = pixel_rays(a.K[0], a.c2w[0], pix)
    pts = (o + d * float(scene.near[0] + scene.far[0]) / 2)[:, None]
    S = torch.tensor([-1.0, 1.0, 1.0])
    ca, _, _ = gather(va, torch.tensor([0]), pts)
    cb, valid, _ = gather(vb, torch.tensor([0]), pts * S)
    assert valid.all() and float(ca[..., :3].std()) > 0.05
    assert torch.allclose(ca[..., :3], cb[..., :3], atol=1e-5)


def test_a_scene_pack_keeps_views_of_different_sizes(plane_pair, tmp_path):
    """save_pack / load_pack: each view at its own size, its pixels as close as the
    unturned scene's pack keeps them (JPEG of a fine random texture), masks exact."""
    ws, turned, _ = plane_pair
    plain = load_workspace(ws.root)
    save_pack(plain, tmp_path / "plain")
    jpeg = (load_pack(tmp_path / "plain").images.float() - plain.images.float()).abs().mean()
    scene = load_workspace(turned, pad=True)
    save_pack(scene, tmp_path / "pack")
    back = load_pack(tmp_path / "pack")
    assert torch.equal(back.extents, scene.extents)
    assert torch.equal(back.masks, scene.masks)
    assert torch.allclose(back.K, scene.K)
    for i in range(len(scene.stems)):
        h, w = scene.size_of(i)
        own = (back.images[i, :, :h, :w].float() - scene.images[i, :, :h, :w].float()).abs()
        assert float(own.mean()) < 1.25 * float(jpeg)
        assert int(back.images[i, :, h:].sum() + back.images[i, :, :, w:].sum()) == 0
    small = load_pack(tmp_path / "pack", max_size=60)
    assert small.extents.tolist()[:2] == [[45, 60], [60, 45]]
    assert torch.allclose(small.K[0], scene.K[0] * torch.tensor([[0.5], [0.5], [1.0]],
                                                                dtype=torch.float64))


def test_finetune_trains_on_a_workspace_with_a_portrait_view(plane_pair, monkeypatch):
    """The fine-tune stage runs on views of two sizes, with the mirror and in two processes,
    padded by default, and its targets include the portrait views; --no-pad-views
    stretches them to the common size."""
    import gnfr.train
    import pipeline.finetune as ft
    from pipeline.workspace import Workspace
    from tests.pipeline.test_finetune import TINY

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=12, ckpt_every=100))
    targets = []
    real = ft.sample_batch

    def spy(scene, cfg, gen):
        b = real(scene, cfg, gen)
        targets.append(scene.size_of(b.target))
        return b

    monkeypatch.setattr(ft, "sample_batch", spy)
    _, turned, _ = plane_pair
    ws = Workspace(turned)
    ft.run(ft.FinetuneConfig(preset="quick", init="scratch", device="cpu", mirror=True,
                             workers=2), ws)
    assert ws.model_file.exists() and len(targets) == 12
    assert (120, 90) in targets and (90, 120) in targets
    assert ws.stage_record("finetune")["params"]["pad_views"] is True
    targets.clear()  # --no-pad-views stretches the portrait views to the common size
    ft.run(ft.FinetuneConfig(preset="quick", init="scratch", device="cpu", pad_views=False),
           ws)
    assert set(targets) == {(90, 120)}


def test_pad_views_on_views_of_one_size_is_recorded_off_and_reruns_nothing(plane_pair,
                                                                         monkeypatch):
    """Where every view has one size padding changes nothing: the stage records it off, so
    a fine-tune finished with the default (padding) is up to date without it, and so is
    one recorded before the option existed."""
    import gnfr.train
    import pipeline.finetune as ft
    from pipeline.workspace import Workspace
    from tests.pipeline.test_finetune import TINY

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=4, ckpt_every=100))
    ws, turned, _ = plane_pair
    assert not ft.mixed_sizes(ws) and ft.mixed_sizes(Workspace(turned))
    ft.run(ft.FinetuneConfig(preset="quick", init="scratch", device="cpu"), ws)
    assert ws.stage_record("finetune")["params"]["pad_views"] is False
    fits = []
    monkeypatch.setattr(ft, "fit", lambda *a, **k: fits.append(1))
    ft.run(ft.FinetuneConfig(preset="quick", init="scratch", device="cpu", pad_views=False),
           ws)
    assert fits == [] and ws.stage_record("finetune")["params"]["pad_views"] is False
    manifest = json.loads(ws.manifest_path.read_text())  # as written before the option
    del manifest["stages"]["finetune"]["params"]["pad_views"]
    ws.manifest_path.write_text(json.dumps(manifest))
    ft.run(ft.FinetuneConfig(preset="quick", init="scratch", device="cpu"), ws)
    assert fits == []


def test_the_fine_tune_s_scene_record_counts_each_view_s_own_pixels(plane_pair):
    """scene_record (what a carried fine-tune is compared by): a padded view's mean colour
    and masked fraction are of its own pixels, the padding (black, marked) left out."""
    from pipeline.finetune import scene_record
    from pipeline.workspace import Workspace

    _, turned, stems = plane_pair
    scene = load_workspace(turned, pad=True)
    rec = scene_record(scene)
    assert rec["size"] == [120, 120]
    tw = Workspace(turned)
    for i, s in enumerate(stems):
        assert rec["masked"][i] == pytest.approx(float(read_mask(tw, s).mean()), abs=1e-6)
        own = read_view_image(tw, s).reshape(-1, 3).mean(0)
        assert np.allclose(rec["mean"][i], own, atol=1e-3)


def test_a_colmap_folder_with_a_portrait_view_loads_padded(plane_pair, tmp_path):
    """load_colmap (pretraining's COLMAP reader) takes views of different sizes as
    load_workspace does: each at its own size and intrinsics, padded."""
    from pipeline.training_scenes import load_colmap
    from pipeline.workspace import Workspace
    from tests.workflows.test_pretrain import _write_colmap_text

    _, turned, _ = plane_pair
    _write_colmap_text(Workspace(turned), tmp_path / "col")
    a, b = load_colmap(tmp_path / "col"), load_workspace(turned, pad=True)
    assert torch.equal(a.extents, b.extents)
    assert torch.equal(a.images, b.images)
    assert torch.allclose(a.K, b.K, atol=1e-6)


@pytest.mark.parametrize("scale,full_res_colour", [(1.0, False), (0.5, True)])
def test_a_view_encoded_apart_has_the_features_it_has_alone(plane_pair, scale,
                                                            full_res_colour):
    """SourceBank(apart=True): every view of a padded scene, portrait or landscape, gives a
    point the features (and colour) that view gives it encoded alone at its own size, also
    when its features come from elsewhere (``views``, as the two-process step makes them);
    encoded in the padded image instead, its features differ."""
    from gnfr.geometry import pixel_rays
    from gnfr.model import GNFR
    from gnfr.renderer import SourceViews, gather
    from tests.pipeline.test_finetune import TINY

    torch.manual_seed(0)
    model = GNFR(TINY.model).eval()
    _, turned, _ = plane_pair
    scene = load_workspace(turned, pad=True)
    apart = SourceBank.of(scene, scale, "cpu", full_res_colour, apart=True)
    together = SourceBank.of(scene, scale, "cpu", full_res_colour)
    ids = torch.tensor([3, 1, 0])
    with torch.no_grad():
        va, vt = apart.encode(model, "cpu", ids), together.encode(model, "cpu", ids)
        vv = apart.views(ids, va.feats, "cpu")
        assert tuple(va.feats.shape[-2:]) == tuple(vt.feats.shape[-2:])
        for j, v in enumerate(ids.tolist()):
            h, w = scene.size_of(v)
            one = replace(scene, images=scene.images[v:v + 1, :, :h, :w].clone(),
                          masks=scene.masks[v:v + 1, :, :h, :w].clone(), K=scene.K[v:v + 1],
                          c2w=scene.c2w[v:v + 1], near=scene.near[v:v + 1],
                          far=scene.far[v:v + 1], stems=[scene.stems[v]], extents=None)
            alone = SourceBank.of(one, scale, "cpu", full_res_colour).encode(model, "cpu")
            assert isinstance(alone, SourceViews) and alone.feat_scale is None
            pix = torch.rand(150, 2, generator=torch.Generator().manual_seed(v)) * torch.tensor(
                [w - 2.0, h - 2.0]) + 1.0
            o, d = pixel_rays(scene.K[v].float(), scene.c2w[v].float(), pix)
            pts = (o + d * float(scene.near[v] + scene.far[v]) / 2)[:, None]
            want, ok, _ = gather(alone, torch.tensor([0]), pts)
            assert ok.all() and float(want[..., 3:].std()) > 1e-3
            for got_views in (va, vv):
                got, ok2, _ = gather(got_views, torch.tensor([j]), pts)
                assert ok2.all()
                assert torch.allclose(got, want, atol=1e-5)
            padded, _, _ = gather(vt, torch.tensor([j]), pts)
            assert torch.allclose(padded[..., :3], want[..., :3], atol=1e-5)
            assert float((padded[..., 3:] - want[..., 3:]).abs().max()) > 1e-3


def test_encode_apart_is_recorded_in_the_model_and_read_by_render(plane_pair, monkeypatch):
    """finetune --encode-apart on views of two sizes records it in the stage and the model,
    and render encodes the sources apart for that model; on views of one size it is
    recorded off (nothing padded, nothing to encode apart)."""
    import gnfr.train
    import pipeline.finetune as ft
    from gnfr.checkpoint import read_metadata
    from gnfr.renderer import SourceViews
    from pipeline.render import RenderConfig
    from pipeline.render import run as render
    from pipeline.select import build_views
    from pipeline.workspace import Workspace, atomic_write_json
    from tests.pipeline.test_finetune import TINY

    monkeypatch.setitem(gnfr.train.PRESETS, "quick", replace(TINY, iters=4, ckpt_every=100))
    plain, turned, _ = plane_pair
    ws = Workspace(turned)
    ft.run(ft.FinetuneConfig(preset="quick", init="scratch", device="cpu",
                             encode_apart=True), ws)
    assert ws.stage_record("finetune")["params"]["train"]["encode_apart"] is True
    assert read_metadata(ws.model_file)[1].get("encode_apart") is True
    seen = []
    real = SourceViews.encode

    def spy(*a, **k):
        seen.append((k.get("apart"), k.get("extents") is not None))
        return real(*a, **k)

    monkeypatch.setattr(SourceViews, "encode", spy)
    cams = load_cameras(ws.cameras_json)  # views.json as select writes it
    frac = {s: float(read_mask(ws, s).mean()) for s in cams.stems}
    atomic_write_json(ws.views_json, build_views(cams.stems, cams.centers(), frac, 0.1))
    render(RenderConfig(path="inputs", device="cpu", workers=1), ws)
    assert seen and all(s == (True, True) for s in seen)
    ft.run(ft.FinetuneConfig(preset="quick", init="scratch", device="cpu",
                             encode_apart=True), plain)
    assert plain.stage_record("finetune")["params"]["train"]["encode_apart"] is False
    assert "encode_apart" not in read_metadata(plain.model_file)[1]
