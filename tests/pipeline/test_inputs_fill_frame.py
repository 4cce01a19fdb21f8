"""`render --inputs-fill frame`: the de-flared photos take their fill from the video's frame
drawn at each flared photo's own camera."""

from __future__ import annotations

import json

import cv2
import numpy as np

from tests.pipeline.render_ws import HYBRID_BOX, HYBRID_FLARED  # hws: conftest.py


def test_the_deflared_photo_takes_the_frame_at_its_camera_as_its_fill(hws, capsys):
    from pipeline.images import read_image
    from pipeline.render import RenderConfig, run
    from pipeline.render.config import INPUTS_FRAMES

    cfg = RenderConfig(path="inputs", inputs_fill="frame", flare_layer=0.0)
    run(cfg, hws)
    err = capsys.readouterr().err
    assert "the video's frames at the 1 flared photos' cameras first" in err
    frames = hws.renders / INPUTS_FRAMES
    assert sorted(p.name for p in frames.glob("*.png")) == [f"{HYBRID_FLARED}.png"]
    path = json.loads((hws.renders / f"{INPUTS_FRAMES}.json").read_text())
    assert [f["name"] for f in path["frames"]] == [HYBRID_FLARED]
    assert hws.stage_record("render:inputs")["params"]["inputs_fill"] == "frame"
    assert "inputs_fill" not in hws.stage_record(f"render:{INPUTS_FRAMES}")["params"]
    # a frame no photo fill would draw: the de-flared photo shows it inside the flare
    frame_file = frames / f"{HYBRID_FLARED}.png"
    img = cv2.imread(str(frame_file))
    img[HYBRID_BOX] = img[HYBRID_BOX][::-1, ::-1].copy()
    cv2.imwrite(str(frame_file), img)
    run(cfg, hws)  # the frames are an input of the de-flared photos: they render again
    assert "render:inputs: running again" in capsys.readouterr().err
    out = read_image(hws.deflared_path(HYBRID_FLARED)).astype(int)
    want = img[..., ::-1].astype(int)
    inner = (slice(HYBRID_BOX[0].start + 4, HYBRID_BOX[0].stop - 4),
             slice(HYBRID_BOX[1].start + 4, HYBRID_BOX[1].stop - 4))
    assert np.abs(out[inner] - want[inner]).mean() <= 4  # up to the ring's colour match
    run(RenderConfig(path="inputs", inputs_fill="photos", flare_layer=0.0), hws)  # as before
    assert hws.stage_record("render:inputs")["params"]["inputs_fill"] == "photos"
    plain = read_image(hws.deflared_path(HYBRID_FLARED)).astype(int)
    assert np.abs(plain[inner] - want[inner]).mean() > 20


def test_the_frame_fill_is_the_cpu_default_where_there_is_a_photo_fill(hws, rws):
    from pipeline.render import RenderConfig, record_defaults, resolve_inputs_fill, run

    assert resolve_inputs_fill(RenderConfig(), "cpu", True) == "frame"
    assert resolve_inputs_fill(RenderConfig(), "cuda", True) == "photos"  # not measured
    assert resolve_inputs_fill(RenderConfig(inputs_fill="photos"), "cpu", True) == "photos"
    assert resolve_inputs_fill(RenderConfig(inputs_fill="frame"), "cpu", False) == "photos"
    assert record_defaults("inputs", "cpu")["inputs_fill"] == "photos"  # older records
    run(RenderConfig(path="inputs"), hws, force=True)
    assert hws.stage_record("render:inputs")["params"]["inputs_fill"] == "frame"
    run(RenderConfig(path="inputs"), rws, force=True)  # no depth maps: GN-FR draws it all
    assert rws.stage_record("render:inputs")["params"]["inputs_fill"] == "photos"
