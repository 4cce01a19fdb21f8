"""`render --source-grow`: novel frames' source photos with their flare masks grown."""

from __future__ import annotations

import json

import numpy as np

from pipeline.cameras import load_cameras
from tests.pipeline.render_ws import FLARED  # rws: the posed workspace (conftest.py)


def test_grow_mask_grows_by_a_share_of_the_long_side():
    from pipeline.ws_files import grow_mask

    m = np.zeros((50, 100), bool)
    m[25, 50] = True
    assert grow_mask(m, 0.0) is m
    g = grow_mask(m, 0.05)  # 5 pixels of the 100-pixel side
    assert g[25, 45] and g[25, 55] and g[20, 50] and g[30, 50]
    assert not g[25, 44] and not g[25, 56] and not g[19, 50]
    assert not g[21, 46]  # a disc, not a square
    assert grow_mask(m, 0.001) is m  # under half a pixel: unchanged (as --train-grow)


def test_novel_frames_sources_and_photo_fill_read_grown_masks(rws, tmp_path, capsys):
    import torch

    from gnfr.paths import PathCamera, path_to_json
    from pipeline.render import RenderConfig, run
    from pipeline.render.fill import photo_views
    from pipeline.render.jobs import FrameJob
    from pipeline.render.sources import encode_sources, find_checkpoint, load_model
    from pipeline.ws_files import grow_mask, read_mask

    cams = load_cameras(rws.cameras_json)
    with torch.inference_mode():
        model = load_model(find_checkpoint(rws, None), "cpu")
        plain, index = encode_sources(model, rws, cams, cams.stems, "cpu")
        grown, _ = encode_sources(model, rws, cams, cams.stems, "cpu", grow=0.05)
    want = grow_mask(read_mask(rws, FLARED), 0.05)
    got = grown.masks[index[FLARED], 0].numpy() > 0.5
    assert np.array_equal(got, want) and got.sum() > plain.masks[index[FLARED], 0].sum()
    for s in cams.stems:  # the images are the photos either way
        assert torch.equal(grown.images[index[s]], plain.images[index[s]])

    job = FrameJob(tmp_path / "x.png", list(cams.stems), 0.1, 10.0, cams.frames[0])
    cfg = RenderConfig(source_grow=0.05, depth_min_blob=0.0)
    views = photo_views(rws, cams, [job], cfg)
    assert np.array_equal(~views[FLARED].valid, want)
    base = photo_views(rws, cams, [job], RenderConfig(depth_min_blob=0.0))
    assert np.array_equal(~base[FLARED].valid, read_mask(rws, FLARED))

    f0 = cams.frames[0]
    p = tmp_path / "one.json"
    p.write_text(json.dumps(path_to_json([PathCamera("one", f0.K, f0.c2w, f0.width,
                                                     f0.height)])))
    run(RenderConfig(path=str(p), source_grow=0.05), rws)
    assert rws.stage_record("render:one")["params"]["source_grow"] == 0.05
    capsys.readouterr()
    run(RenderConfig(path="inputs", source_grow=0.05), rws)  # for the frames only: ignored
    assert "--source-grow is for the video's frames" in capsys.readouterr().err
    assert "source_grow" not in rws.stage_record("render:inputs")["params"]
