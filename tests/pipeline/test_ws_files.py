"""The workspace contract's typed readers and writers (pipeline/ws_files.py, workspace.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline.cameras import Cameras, Frame, normalising_scale
from pipeline.errors import UserError
from pipeline.workspace import MODEL_FILE, Workspace, atomic_imwrite, atomic_write_json
from pipeline.ws_files import (
    MASK_THRESHOLD,
    FlareEntry,
    FlareFile,
    ViewsFile,
    make_views,
    read_cameras,
    read_depth,
    read_flare,
    read_mask,
    read_masks,
    read_view_image,
    read_views,
    view_stems,
    write_cameras,
    write_depth,
    write_flare,
    write_mask,
    write_views,
)

STEMS = ["a", "b", "c", "d"]


def tiny_ws(tmp_path, size=(16, 12)) -> Workspace:
    """A posed workspace of 4 random 16x12 views on a line (pose recorded as done)."""
    photos = tmp_path / "photos"
    photos.mkdir()
    ws = Workspace.create(tmp_path / "ws", photos)
    W, H = size
    K = np.array([[W, 0, W / 2], [0, W, H / 2], [0, 0, 1.0]])
    rng = np.random.default_rng(0)
    frames = []
    for i, s in enumerate(STEMS):
        atomic_imwrite(ws.image_path(s), rng.integers(0, 256, (H, W, 3), dtype=np.uint8))
        c2w = np.eye(4)
        c2w[0, 3] = 0.1 * i * i  # a, b, c, d ever farther apart
        frames.append(Frame(f"{s}.jpg", s, K, W, H, c2w, 0.5, 3.0,
                            {"model": "PINHOLE", "width": W, "height": H,
                             "params": [W, W, W / 2, H / 2]}))
    write_cameras(ws, Cameras(frames))
    ws.record_stage("pose", {"fixture": "tiny"}, [ws.images, ws.cameras_json])
    return ws


def one_line_naming(err: pytest.ExceptionInfo, path) -> None:
    msg = str(err.value)
    assert str(path) in msg and "\n" not in msg, msg


# --------------------------------------------------------------------------- paths, manifest
def test_every_ws_path_is_a_property(tmp_path):
    ws = tiny_ws(tmp_path)
    r = ws.root
    assert ws.model_file == r / "model" / MODEL_FILE == r / "model" / "gnfr.safetensors"
    assert ws.mask_path("a") == r / "masks" / "a.png"
    assert ws.depth_path("a") == r / "depth" / "a.npz"
    assert ws.image_path("a") == r / "images" / "a.png"
    assert ws.decoded_path("a") == r / "decoded" / "a.png"
    assert ws.linear_path("a") == r / "linear" / "a.tiff"
    assert ws.render_dir("/some/where/path.json") == r / "renders" / "path"
    assert ws.video == r / "photos.mp4" and ws.compare_sheet == r / "photos_compare.jpg"
    assert ws.deflared_full_path("a", ".jpg") == r / "deflared_full" / "a.jpg"
    assert ws.masks_nerfstudio_path("a") == r / "masks_nerfstudio" / "a.png"


def test_model_file_names_agree_across_layers(tmp_path):
    """WS/model is a gnfr run folder: pipeline.workspace names its files for the pipeline
    layer, gnfr.fit for the gnfr layer (which cannot import pipeline); they must agree."""
    from gnfr import fit
    from pipeline import workspace

    ws = tiny_ws(tmp_path)
    assert (fit.MODEL_FILE, fit.STATE_FILE, fit.METRICS_FILE) == (
        workspace.MODEL_FILE, workspace.TRAIN_STATE_FILE, workspace.METRICS_FILE)
    assert fit.checkpoint_files(ws.model) == (ws.model_file, ws.train_state)
    assert ws.metrics_jsonl == ws.model / fit.METRICS_FILE
    assert MODEL_FILE == "gnfr.safetensors"


def test_record_stage_is_a_complete_stage_record(tmp_path):
    ws = tiny_ws(tmp_path)
    rec = ws.stage_record("pose")
    assert rec["status"] == "complete" and rec["params"] == {"fixture": "tiny"}
    assert rec["outputs"] == ["cameras.json", "images"]
    assert {"inputs_digest", "versions", "started", "seconds"} <= set(rec)
    ws.require("pose")
    other = Workspace.create(tmp_path / "other", ws.photos_dir)
    other.copy_stage_records(ws, ["pose"])
    assert other.stage_record("pose") == rec


# --------------------------------------------------------------------------- cameras, images
def test_cameras_round_trip_byte_for_byte(tmp_path):
    ws = tiny_ws(tmp_path)
    before = ws.cameras_json.read_bytes()
    cams = read_cameras(ws)
    assert cams.stems == STEMS and view_stems(ws) == STEMS
    write_cameras(ws, cams)
    assert ws.cameras_json.read_bytes() == before


def test_unreadable_image_is_one_line_naming_it(tmp_path):
    ws = tiny_ws(tmp_path)
    ws.image_path("b").write_bytes(b"not a png")
    with pytest.raises(UserError) as e:
        read_view_image(ws, "b")
    one_line_naming(e, ws.image_path("b"))
    assert "deflare-scene pose" in str(e.value)
    img = read_view_image(ws, "a", as_float=True)
    assert img.dtype == np.float32 and img.shape == (12, 16, 3) and img.max() <= 1.0


def test_one_photo_extension_list():
    from pipeline.decode import RAW_EXTS
    from pipeline.images import PHOTO_EXTS, is_photo

    assert not set(PHOTO_EXTS) & RAW_EXTS
    assert PHOTO_EXTS[0] == ".png" and is_photo("X.JPG") and not is_photo("x.dng")


# --------------------------------------------------------------------------- masks
def test_one_mask_threshold_everywhere(tmp_path):
    """Grey 127 is clear and 128 flare for every reader of WS/masks."""
    from pipeline.depth import load_views
    from pipeline.training_scenes import load_workspace

    ws = tiny_ws(tmp_path)
    grey = np.zeros((12, 16), np.uint8)
    grey[:, 8:] = MASK_THRESHOLD + 1
    grey[:6, :8] = MASK_THRESHOLD
    for s in STEMS:
        atomic_imwrite(ws.mask_path(s), grey)
    expect = grey > 127
    assert MASK_THRESHOLD == 127
    assert np.array_equal(read_mask(ws, "a"), expect)
    assert all(np.array_equal(m, expect) for m in read_masks(ws, STEMS).values())
    views = load_views(ws, read_cameras(ws), STEMS)
    assert np.array_equal(views["a"].valid, ~expect)
    scene = load_workspace(ws.root)
    assert np.array_equal(scene.masks[0, 0].numpy().astype(bool), expect)
    small = read_mask(ws, "a", size=(8, 6))  # nearest resize after the cut
    assert small.shape == (6, 8) and small[:, 4:].all() and not small[:, :4].any()


def test_write_mask_round_trips(tmp_path):
    ws = tiny_ws(tmp_path)
    m = np.random.default_rng(1).random((12, 16)) > 0.7
    write_mask(ws, "a", m)
    from pipeline.images import read_gray

    assert set(np.unique(read_gray(ws.mask_path("a")))) <= {0, 255}
    assert np.array_equal(read_mask(ws, "a"), m)


@pytest.mark.parametrize("broken", ["corrupt", "missing"])
def test_bad_mask_is_one_line_user_error_naming_it(tmp_path, broken):
    from pipeline.depth import load_views
    from pipeline.training_scenes import load_workspace

    ws = tiny_ws(tmp_path)
    for s in STEMS:
        write_mask(ws, s, np.zeros((12, 16), bool))
    bad = ws.mask_path("c")
    if broken == "corrupt":
        bad.write_bytes(b"\x89PNG\r\n\x1a\n truncated")
    else:
        bad.unlink()
    for read in (lambda: read_mask(ws, "c"), lambda: read_masks(ws, STEMS),
                 lambda: load_workspace(ws.root)):
        with pytest.raises(UserError) as e:
            read()
        one_line_naming(e, bad)
        assert "deflare-scene mask" in str(e.value)
    if broken == "corrupt":  # depth reads a mask where there is one file, and it is broken
        with pytest.raises(UserError) as e:
            load_views(ws, read_cameras(ws), STEMS)
        one_line_naming(e, bad)


def test_cli_names_a_corrupt_mask_in_one_line(tmp_path, capsys):
    from workflows.cli import main

    ws = tiny_ws(tmp_path)
    for s in STEMS:
        write_mask(ws, s, np.zeros((12, 16), bool))
    ws.mask_path("b").write_bytes(b"junk")
    code = main(["depth", str(ws.root), "--planes", "4", "--neighbours", "1", "--keep", "1"])
    err = capsys.readouterr().err
    assert code == 2 and str(ws.mask_path("b")) in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


# --------------------------------------------------------------------------- depth
def test_depth_round_trip_and_corrupt_file(tmp_path):
    ws = tiny_ws(tmp_path)
    d = np.random.default_rng(2).random((12, 16)).astype(np.float32)
    c = np.full((12, 16), 0.5, np.float16)
    write_depth(ws.depth_path("a"), d, c)
    got_d, got_c = read_depth(ws, "a")
    assert np.array_equal(got_d, d) and got_c.dtype == np.float16 and np.array_equal(got_c, c)
    ws.depth_path("b").write_bytes(b"nope")
    with pytest.raises(UserError) as e:
        read_depth(ws, "b")
    one_line_naming(e, ws.depth_path("b"))


# --------------------------------------------------------------------------- flare.json
def test_flare_json_round_trip_byte_for_byte(tmp_path):
    ws = tiny_ws(tmp_path)
    flare = FlareFile("fmg", 0.55, "fmg.safetensors@sha256:0123456789abcdef",
                      {s: FlareEntry(round(0.01 * i, 6), "fmg") for i, s in enumerate(STEMS)})
    write_flare(ws, flare)
    text = ws.flare_json.read_text()
    assert list(json.loads(text)) == ["source", "threshold", "weights", "views"]
    assert json.loads(text)["views"]["b"] == {"flare_fraction": 0.01, "source": "fmg"}
    back = read_flare(ws)
    assert back == flare and back.fractions()["d"] == 0.03
    write_flare(ws, back)
    assert ws.flare_json.read_text() == text
    ws.flare_json.write_text('{"views": {"a": {}}}')
    with pytest.raises(UserError) as e:
        read_flare(ws)
    one_line_naming(e, ws.flare_json)


# --------------------------------------------------------------------------- views.json
def test_views_json_round_trip_and_select_writes_the_same(tmp_path):
    from pipeline.select import build_views

    ws = tiny_ws(tmp_path)
    cams = read_cameras(ws)
    frac = {"a": 0.0, "b": 0.3, "c": 0.05, "d": 0.1}
    views = make_views(cams.stems, cams.centers(), frac, 0.1)
    assert views.to_json() == build_views(cams.stems, cams.centers(), frac, 0.1)
    write_views(ws, views)
    text = ws.views_json.read_text()
    back = read_views(ws)
    assert back == views
    write_views(ws, back)
    assert ws.views_json.read_text() == text
    entry = json.loads(text)["views"]["a"]
    assert list(entry) == ["flare_fraction", "target", "sources"]
    assert list(entry["sources"][0]) == ["stem", "distance", "flare_fraction"]


def test_target_rule_benchmark_counts_targets_against_the_truth(tmp_path):
    """benchmarks/target_rule.py: a view its mask marks at 8 % with 12 % true flare is a
    target over the rule by the truth; one marked at 11 % with 5 % true flare is kept out
    under it; the counts and the JSON say so, and a folder without masks_gt is one error."""
    from tests.conftest import load_benchmark

    tr = load_benchmark("target_rule")
    ws = tiny_ws(tmp_path)
    H, W = 12, 16
    truth = {"a": 0.12, "b": 0.05, "c": 0.0, "d": 0.20}
    marked = {"a": 0.08, "b": 0.11, "c": 0.0, "d": 0.30}
    synth = tmp_path / "synth"
    (synth / "masks_gt").mkdir(parents=True)
    for s, share in truth.items():
        m = np.zeros(H * W, np.uint8)
        m[:round(share * H * W)] = 255
        atomic_imwrite(synth / "masks_gt" / f"{s}.png", m.reshape(H, W))
    cams = read_cameras(ws)
    write_views(ws, make_views(cams.stems, cams.centers(), marked, 0.1))
    got = tr.rule_rows(synth, ws.root)
    assert [s for s, r in got["views"].items() if r["target"]] == ["a", "c"]
    assert got["views"]["a"] == {"marked": 0.08, "true": round(23 / 192, 6), "target": True}
    assert got["targets_over_truth"] == 1 and got["kept_out_under_truth"] == 1
    out = tmp_path / "rule.json"
    assert tr.main([f"{synth}={ws.root}", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["workspaces"][0]["targets"] == 2
    assert tr.main([f"{tmp_path}={ws.root}"]) == 2  # no masks_gt there: one error line


def test_views_one_filtering_rule(tmp_path):
    ws = tiny_ws(tmp_path)
    cams = read_cameras(ws)
    frac = {"a": 0.0, "b": 0.3, "c": 0.05, "d": 0.1}
    views = make_views(cams.stems, cams.centers(), frac, 0.1)
    assert views.targets() == ["a", "c", "d"]           # at most max_flare, inclusive
    assert views.sources("b") == ["a", "c", "d"]         # nearest first, never itself
    assert views.sources("b", among=["b", "d", "a"]) == ["a", "d"]
    assert views.sources("zz") == []
    assert views.fractions(["a", "zz"]) == {"a": 0.0, "zz": 0.0}
    assert views.ranked(["a", "c"]) == {"a": ["c"], "c": ["a"]}
    assert views.ranked(["a", "zz"]) is None             # views.json does not list zz
    # the scene a model trains on uses the same rule
    from pipeline.training_scenes import load_workspace

    write_views(ws, views)
    for s in STEMS:
        write_mask(ws, s, np.zeros((12, 16), bool))
    scene = load_workspace(ws.root, stems=["a", "b", "d"])
    assert scene.ranked == views.ranked(["a", "b", "d"])
    assert scene.flare == {"a": 0.0, "b": 0.3, "d": 0.1}
    assert scene.targets == views.targets()                # the flags, not a max_flare
    from gnfr.view_sampler import is_target
    from pipeline.ws_files import is_target as ws_is_target

    assert ws_is_target is is_target                       # one target rule


def test_views_json_malformed_is_one_line(tmp_path):
    ws = tiny_ws(tmp_path)
    atomic_write_json(ws.views_json, {"views": {"a": {"target": True}}})
    with pytest.raises(UserError) as e:
        read_views(ws)
    one_line_naming(e, ws.views_json)
    assert isinstance(ViewsFile(0.1).views, dict)


# --------------------------------------------------------------------------- normalisation
def test_normalising_scale():
    c = np.array([[0.0, 0, 0], [2.0, 0, 0], [0, 4.0, 0]])
    assert normalising_scale(c, np.zeros(3)) == 0.25
    assert normalising_scale(c, np.zeros(3), min_radius=8.0) == 0.125
    assert normalising_scale(np.zeros((2, 3)), np.zeros(3)) == 1.0
