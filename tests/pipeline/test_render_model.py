"""Render stage: how the render runs the model and what it records: full-size colours, CPU bf16,
torch.compile, the flare fallback, the fill's defaults and each path's record.

Split from test_render.py by topic; the workspaces and fixtures are tests/pipeline/render_ws.py
and conftest.py."""

from __future__ import annotations

import cv2
import numpy as np
import torch

from pipeline.cameras import load_cameras
from tests.pipeline.render_ws import make_render_ws


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


def _model_and_meta(path):
    """The GN-FR model saved at ``path`` and its metadata."""
    from gnfr.checkpoint import load_weights, read_metadata
    from gnfr.model import GNFR

    cfg, meta = read_metadata(path)
    model = GNFR(cfg)
    load_weights(model, path)
    return model, meta


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
    video_only = {"pace", "tour", "zoom", "nearest_count", "source_fade", "fade_cut", "fade_limit",
                  "source_hold", "path_exposure", "from_deflared", "source_grow",
                  "network_scale"}
    assert not video_only & rec["inputs"].keys()
    assert video_only <= rec["interpolate"].keys()
    assert video_only - {"pace", "tour", "zoom"} <= rec["spiral"].keys()
    assert not {"pace", "tour", "zoom"} & rec["spiral"].keys()
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
    assert old_video["zoom"] == "fixed"
    assert old_inputs["source_fade"] == cfg.source_fade  # no record of it: today's default

