"""`render --from-deflared`: novel frames' GN-FR sources read the flare regions of the
photos from the de-flared photos."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from pipeline.cameras import load_cameras
from pipeline.errors import UserError
from tests.pipeline.render_ws import BOX, FLARED  # rws: the posed workspace (conftest.py)


def _deflared(ws):
    from pipeline.render import RenderConfig, run

    run(RenderConfig(path="inputs"), ws)


def test_a_view_takes_its_flare_region_from_its_deflared_photo_and_keeps_the_rest(rws):
    from pipeline.images import read_image
    from pipeline.render import blend_weights
    from pipeline.render.sources import with_deflared
    from pipeline.ws_files import read_mask, read_view_image

    _deflared(rws)
    frame = load_cameras(rws.cameras_json).by_stem()[FLARED]
    img = read_view_image(rws, FLARED)
    fill = read_image(rws.deflared_path(FLARED))
    out = with_deflared(rws, frame, img, 0.0, 0.01)
    assert out.dtype == np.uint8 and out.shape == img.shape
    alpha = blend_weights(read_mask(rws, FLARED), 0.0, 0.01)
    assert np.array_equal(out[alpha == 0], img[alpha == 0])  # the photo's own pixels
    assert fill.shape == img.shape  # the fixture's decoded photos are pinhole, same size
    inside = alpha == 1
    assert inside[BOX].all()
    # the flare square is the de-flared photo's fill (warped through an identity map)
    assert np.abs(out[inside].astype(int) - fill[inside].astype(int)).max() <= 1
    assert not np.array_equal(out[BOX], img[BOX])  # not the photo's (flared) pixels
    # between them the weights blend the two
    ring = (alpha > 0.2) & (alpha < 0.8)
    assert ring.any()
    want = alpha[ring][:, None] * fill[ring] + (1 - alpha[ring][:, None]) * img[ring]
    assert np.abs(out[ring] - want).max() <= 1.0


def test_novel_frames_encode_the_deflared_flare_regions_and_record_it(rws, tmp_path, capsys):
    import torch

    from gnfr.paths import PathCamera, path_to_json
    from pipeline.render import RenderConfig, run
    from pipeline.render.sources import (
        encode_sources,
        find_checkpoint,
        load_model,
        require_deflared,
        with_deflared,
    )
    from pipeline.ws_files import read_views

    _deflared(rws)
    cams = load_cameras(rws.cameras_json)
    stems = cams.stems
    blend = require_deflared(rws, read_views(rws))
    assert blend == (0.0, 0.01)  # the de-flared photos' own blend, from their record
    with torch.inference_mode():
        model = load_model(find_checkpoint(rws, None), "cpu")
        plain, index = encode_sources(model, rws, cams, stems, "cpu")
        src, _ = encode_sources(model, rws, cams, stems, "cpu", deflared=blend)
    by = cams.by_stem()
    from pipeline.ws_files import read_view_image

    for s in stems:
        i = index[s]
        want = with_deflared(rws, by[s], read_view_image(rws, s), *blend)
        got = (src.images[i].permute(1, 2, 0).numpy() * 255).round().astype(int)
        assert np.abs(got - want.astype(int)).max() <= 1, s
        assert torch.equal(src.masks[i], plain.masks[i]), s  # the flare masks kept
        same = torch.equal(src.images[i], plain.images[i])
        assert same == (s != FLARED), s  # only the flared view reads its de-flared photo
    assert not torch.equal(src.feats[index[FLARED]], plain.feats[index[FLARED]])

    f0 = cams.frames[0]
    p = tmp_path / "one.json"
    p.write_text(json.dumps(path_to_json([PathCamera("one", f0.K, f0.c2w, f0.width,
                                                     f0.height)])))
    on = RenderConfig(path=str(p), from_deflared=True)
    run(on, rws)
    assert rws.stage_record("render:one")["params"]["from_deflared"] is True
    capsys.readouterr()
    run(on, rws)
    assert "render one: up to date" in capsys.readouterr().err
    # the de-flared photos are an input: changed, the frames render again
    path = rws.deflared_path(FLARED)
    img = cv2.imread(str(path))
    img[BOX] = 255 - img[BOX]
    cv2.imwrite(str(path), img)
    run(on, rws)
    assert "up to date" not in capsys.readouterr().err
    run(RenderConfig(path="inputs"), rws, force=True)  # the fixture's photos back
    run(RenderConfig(path=str(p)), rws)  # off: renders again, recorded off
    assert rws.stage_record("render:one")["params"]["from_deflared"] is False


def test_from_deflared_needs_the_deflared_photos_and_is_not_for_them(rws, tmp_path, capsys):
    import shutil

    from pipeline.render import RenderConfig, run
    from pipeline.render.sources import require_deflared
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_views

    bare = Workspace.create(tmp_path / "bare", rws.photos_dir)
    with pytest.raises(UserError, match="not rendered: run `deflare-scene render"):
        require_deflared(bare, {})
    _deflared(rws)
    path = rws.deflared_path(FLARED)
    keep = tmp_path / "keep.png"
    shutil.move(path, keep)
    try:
        with pytest.raises(UserError, match=f"{FLARED}.png is missing"):
            require_deflared(rws, read_views(rws))
    finally:
        shutil.move(keep, path)
    run(RenderConfig(path="inputs", from_deflared=True), rws)  # for the frames only: ignored
    assert "--from-deflared is for the video's frames" in capsys.readouterr().err
    assert "from_deflared" not in rws.stage_record("render:inputs")["params"]
