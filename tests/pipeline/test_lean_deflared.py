"""`render --lean-deflared`: a novel frame leans to its nearest photo read de-flared, so at
a photo's own camera the video shows that photo's de-flared photo, flare region included."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from pipeline.cameras import load_cameras
from pipeline.errors import UserError
from pipeline.stereo import PosedView
from tests.pipeline.render_ws import HYBRID_BOX, HYBRID_FLARED  # hws: conftest.py


def _view(x: float, value: float, deflared: bool = True) -> PosedView:
    c2w = np.eye(4)
    c2w[0, 3] = x
    img = np.full((4, 6, 3), value, np.float32)
    return PosedView(img, np.eye(3), c2w, np.zeros((4, 6), bool),
                     deflared=img + 0.5 if deflared else None)


def test_the_nearest_photo_and_those_at_its_spot_are_read_deflared_the_rest_as_they_are():
    from pipeline.render.fill import lean_deflared_views

    photos = {"a": _view(0.0, 0.1), "twin": _view(0.01, 0.2), "b": _view(1.0, 0.3),
              "c": _view(2.0, 0.4)}
    out = lean_deflared_views(photos, ["a", "twin", "b", "c"], same_spot=0.05)
    for s in ("a", "twin"):  # the nearest and its twin: de-flared, no flare mask
        assert out[s].image is photos[s].deflared and out[s].valid is None
        assert out[s].c2w is photos[s].c2w
    for s in ("b", "c"):  # farther: as they are
        assert out[s] is photos[s]
    assert photos["a"].valid is not None  # the caller's views are not changed
    alone = lean_deflared_views(photos, ["a", "twin", "b"], same_spot=0.0)
    assert alone["a"].valid is None and alone["twin"] is photos["twin"]
    bare = {"a": _view(0.0, 0.1, deflared=False), "b": _view(1.0, 0.3)}
    assert lean_deflared_views(bare, ["a", "b"], 0.05)["a"] is bare["a"]  # none loaded
    assert lean_deflared_views(photos, [], 0.05) is photos


def _one_frame_path(ws, tmp_path, stem: str):
    from gnfr.paths import PathCamera, path_to_json

    f = load_cameras(ws.cameras_json).by_stem()[stem]
    p = tmp_path / "at_photo.json"
    p.write_text(json.dumps(path_to_json([PathCamera("at", f.K, f.c2w, f.width, f.height)])))
    return p


def test_a_frame_at_a_flared_photo_shows_its_deflared_photo(hws, tmp_path, capsys):
    from pipeline.images import read_image
    from pipeline.render import RenderConfig, run

    run(RenderConfig(path="inputs"), hws)
    path = hws.deflared_path(HYBRID_FLARED)
    keep = path.read_bytes()
    img = cv2.imread(str(path))
    img[HYBRID_BOX] = img[HYBRID_BOX][::-1, ::-1].copy()  # a fill no other photo shows
    cv2.imwrite(str(path), img)
    want = img[..., ::-1].astype(int)  # RGB
    try:
        p = _one_frame_path(hws, tmp_path, HYBRID_FLARED)
        run(RenderConfig(path=str(p), lean_deflared=True), hws)
        on = read_image(hws.render_dir(str(p)) / "at.png").astype(int)
        assert hws.stage_record("render:at_photo")["params"]["lean_deflared"] is True
        inner = (slice(HYBRID_BOX[0].start + 4, HYBRID_BOX[0].stop - 4),
                 slice(HYBRID_BOX[1].start + 4, HYBRID_BOX[1].stop - 4))
        # the de-flared photo's fill (brought by the fill's per-channel gains to the others,
        # here a few levels)
        assert np.abs(on[inner] - want[inner]).mean() <= 5
        assert np.abs(on[inner] - want[inner]).max() <= 12
        run(RenderConfig(path=str(p), lean_deflared=False), hws)  # off: the photos as they are
        off = read_image(hws.render_dir(str(p)) / "at.png").astype(int)
        assert hws.stage_record("render:at_photo")["params"]["lean_deflared"] is False
        assert np.abs(off[inner] - want[inner]).mean() > 20  # the others' view, not the fill
        outside = np.ones(on.shape[:2], bool)
        outside[HYBRID_BOX[0].start - 6:HYBRID_BOX[0].stop + 6,
                HYBRID_BOX[1].start - 6:HYBRID_BOX[1].stop + 6] = False
        # away from the flare both are the photo itself
        assert np.abs(on[outside] - off[outside]).mean() <= 3  # up to the fill's gains
        assert np.abs(on[outside] - want[outside]).mean() <= 5
    finally:
        path.write_bytes(keep)


def test_lean_deflared_needs_the_deflared_photos_and_is_not_for_them(hws, tmp_path, capsys):
    from pipeline.render import RenderConfig, run
    from pipeline.workspace import Workspace

    bare = Workspace.create(tmp_path / "bare", hws.photos_dir)
    from pipeline.render.sources import require_deflared

    with pytest.raises(UserError, match="render --lean-deflared reads the de-flared photos"):
        require_deflared(bare, {}, RenderConfig(lean_deflared=True))
    run(RenderConfig(path="inputs", lean_deflared=True), hws)  # for the frames only: ignored
    assert "--lean-deflared is for the video's frames" in capsys.readouterr().err
    assert "lean_deflared" not in hws.stage_record("render:inputs")["params"]


def test_the_default_leans_where_the_deflared_photos_are_up_to_date(hws, tmp_path, capsys):
    """Not given, the CPU's frames lean to the de-flared photos when those are the finished
    render of today's inputs; after a mask changes they are not, and the frames read the
    photos as they are, with a line saying how to bring them up to date. CUDA has no key
    blend and never leans; the de-flared photos never lean, nor do the frames they take
    as their fill."""
    import shutil
    from dataclasses import replace

    from pipeline.render import RenderConfig, deflared_up_to_date, resolve_lean, run
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_views

    ws = Workspace(shutil.copytree(hws.root, tmp_path / "ws"))
    run(RenderConfig(path="inputs"), ws)
    frames = ws.stage_record("render:inputs_frames")["params"]
    assert frames["lean_deflared"] is False  # the fill's own frames: drawn from the photos
    p = _one_frame_path(ws, tmp_path, HYBRID_FLARED)
    run(RenderConfig(path=str(p)), ws)
    assert ws.stage_record("render:at_photo")["params"]["lean_deflared"] is True
    ckpt = ws.model_file
    views = read_views(ws)
    assert deflared_up_to_date(ws, views, ckpt)
    cfg = RenderConfig(path=str(p), fill="hybrid", key_blend=0.5)
    assert resolve_lean(cfg, ws, views, ckpt, "at_photo", "cpu").lean_deflared is True
    assert resolve_lean(cfg, ws, views, ckpt, "at_photo", "cuda:0").lean_deflared is False
    assert resolve_lean(cfg, ws, views, ckpt, "inputs", "cpu").lean_deflared is False
    assert resolve_lean(replace(cfg, key_blend=0.0), ws, views, ckpt, "at_photo",
                        "cpu").lean_deflared is False
    mask = cv2.imread(str(ws.mask_path(HYBRID_FLARED)), cv2.IMREAD_UNCHANGED)
    mask[0, 0] = 255 - mask[0, 0]  # the masks changed since the de-flared photos
    cv2.imwrite(str(ws.mask_path(HYBRID_FLARED)), mask)
    assert not deflared_up_to_date(ws, views, ckpt)
    capsys.readouterr()
    run(RenderConfig(path=str(p)), ws)
    assert ws.stage_record("render:at_photo")["params"]["lean_deflared"] is False
    err = capsys.readouterr().err
    assert "the de-flared photos are not up to date" in err and "--path inputs" in err

