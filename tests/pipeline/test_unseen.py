"""`render --unseen-below`: a novel frame's pixels no source sees, drawn from around them."""

from __future__ import annotations

import json

import cv2
import numpy as np

from pipeline.cameras import load_cameras
from pipeline.render.unseen import fill_unseen


def _frame(dtype=np.uint8):
    top = np.iinfo(dtype).max
    img = np.zeros((40, 60, 3), dtype)
    img[...] = (np.array([0.8, 0.6, 0.3]) * top).astype(dtype)  # sky
    img[:8] = (np.array([0.1, 0.1, 0.1]) * top).astype(dtype)  # a dark smear along the top
    seen = np.ones((40, 60), np.float32)
    seen[:8] = 0.0
    seen[8:10] = 0.3  # partly seen: blended
    return img, seen


def test_unseen_pixels_are_drawn_from_around_them_and_seen_ones_kept():
    for dtype in (np.uint8, np.uint16):
        img, seen = _frame(dtype)
        out = fill_unseen(img, seen, 0.5)
        assert out.dtype == dtype and out.shape == img.shape
        assert np.array_equal(out[10:], img[10:])  # seen at or above 0.5: untouched
        sky = img[20, 30].astype(float)
        # the smear now carries the sky around it (within 2 % of the range)
        assert np.abs(out[:8].astype(float) - sky).max() < 0.02 * np.iinfo(dtype).max
        # partly seen rows take 1 - 0.3 / 0.5 = 40 % of the drawn colour
        w = 1 - 0.3 / 0.5
        assert np.allclose(out[8:10].astype(float), img[8:10] * (1 - w) + sky * w,
                           atol=0.02 * np.iinfo(dtype).max)
        assert np.array_equal(fill_unseen(img, seen, 0.0), img)  # off
        assert np.array_equal(fill_unseen(img, np.ones_like(seen), 0.5), img)  # all seen
        assert np.array_equal(fill_unseen(img, np.zeros_like(seen), 0.5), img)  # none: as is


def _turned(c2w: np.ndarray, degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    R = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    out = np.array(c2w, float).copy()
    out[:3, :3] = out[:3, :3] @ R
    return out


def test_a_frame_turned_past_the_sources_changes_only_where_they_do_not_see(rws, tmp_path):
    """A path camera at the first photo's spot turned 35 degrees: part of its frame lies
    past every source. At the default (--unseen-below 0.5) only the pixels whose rays are under half
    seen change, the seen ones are those of `--unseen-below 0` to the bit, and the stage
    re-renders when the option changes."""
    import torch

    from gnfr.paths import PathCamera, path_to_json
    from pipeline.render import RenderConfig, run
    from pipeline.render.sources import encode_sources, find_checkpoint, load_model
    from pipeline.render.unseen import seen_map

    cams = load_cameras(rws.cameras_json)
    f0 = cams.frames[0]
    K = np.array([[24.0, 0, 16], [0, 24.0, 12], [0, 0, 1]])
    cam = PathCamera("turned", K, _turned(f0.c2w, 35.0), 32, 24)
    p = tmp_path / "turned.json"
    p.write_text(json.dumps(path_to_json([cam])))
    run(RenderConfig(path=str(p), unseen_below=0.0), rws)
    frame = rws.renders / "turned" / "turned.png"
    plain = cv2.imread(str(frame))
    rec = json.loads((rws.renders / "turned" / "cameras.json").read_text())["frames"][0]
    run(RenderConfig(path=str(p)), rws)  # the default, 0.5
    filled = cv2.imread(str(frame))

    model = load_model(find_checkpoint(rws, None), "cpu")
    src, index = encode_sources(model, rws, cams, rec["sources"], "cpu")
    ids = torch.tensor([index[s] for s in rec["sources"]])
    seen = seen_map(src, ids, cam, rec["near"], rec["far"], 32)
    assert seen.shape == (24, 32)
    assert (seen < 0.5).any() and (seen >= 0.5).any()  # the turn leaves part unseen
    assert np.array_equal(filled[seen >= 0.5], plain[seen >= 0.5])
    assert not np.array_equal(filled[seen < 0.5], plain[seen < 0.5])
