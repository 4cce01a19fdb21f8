import json

import pytest

from pipeline.errors import UserError
from pipeline.workspace import Workspace, atomic_path, atomic_write_json, digest_paths
from workflows.cli import main


def test_atomic_write_leaves_old_file_on_failure(tmp_path):
    target = tmp_path / "a.json"
    atomic_write_json(target, {"v": 1})
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("killed")
    assert json.loads(target.read_text()) == {"v": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_atomic_dir_replaces_whole_folder(tmp_path):
    target = tmp_path / "sparse"
    with atomic_path(target) as tmp:
        tmp.mkdir()
        (tmp / "x.bin").write_bytes(b"1")
    with atomic_path(target) as tmp:
        tmp.mkdir()
        (tmp / "y.bin").write_bytes(b"2")
    assert sorted(p.name for p in target.iterdir()) == ["y.bin"]


def test_digest_changes_with_content_and_ignores_hidden(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    (d / "a.png").write_bytes(b"1")
    before = digest_paths([d])
    (d / ".a.tmp1.png").write_bytes(b"junk")
    assert digest_paths([d]) == before
    (d / "a.png").write_bytes(b"2")
    assert digest_paths([d]) != before


def test_depth_inputs_leave_the_novel_frames_maps_out_of_the_stages_that_never_read_them(
        tmp_path):
    """The stages that read WS/depth name its maps, not the folder: the digest equals the
    folder's while there is no WS/depth/frames (records of earlier versions stay up to
    date), the frames' maps leave it unchanged and change only the novel frames' inputs; a
    missing or empty folder is the folder itself."""
    (tmp_path / "photos").mkdir()
    ws = Workspace.create(tmp_path / "ws", tmp_path / "photos")
    assert ws.depth_inputs() == [ws.depth] == ws.depth_inputs(frames=True)
    ws.depth.mkdir(parents=True)
    for s in ("b", "a"):
        (ws.depth / f"{s}.npz").write_bytes(s.encode())
    folder = digest_paths([ws.cameras_json, ws.depth, ws.images], ws.root)
    maps = digest_paths([ws.cameras_json, *ws.depth_inputs(), ws.images], ws.root)
    assert maps == folder
    assert [p.name for p in ws.depth_inputs()] == ["a.npz", "b.npz"]
    before = digest_paths(ws.depth_inputs(frames=True), ws.root)
    ws.depth_frames.mkdir()
    (ws.depth_frames / "a.npz").write_bytes(b"aggregated")
    assert digest_paths([ws.cameras_json, *ws.depth_inputs(), ws.images], ws.root) == maps
    assert digest_paths(ws.depth_inputs(frames=True), ws.root) != before
    assert digest_paths([ws.depth], ws.root) != folder  # what naming the folder would do


def test_stage_skip_and_staleness(tmp_path):
    photos = tmp_path / "photos"
    photos.mkdir()
    ws = Workspace.create(tmp_path / "ws", photos)
    inp = ws.root / "in.txt"
    inp.write_text("a")
    run = ws.begin_stage("s", {"p": 1}, [inp])
    assert not run.skip
    out = ws.root / "out.txt"
    out.write_text("o")
    run.finish([out])
    assert ws.begin_stage("s", {"p": 1}, [inp]).skip
    assert not ws.begin_stage("s", {"p": 2}, [inp]).skip  # params changed
    run = ws.begin_stage("s", {"p": 1}, [inp])
    run.finish([out])
    inp.write_text("b")  # upstream output changed -> stale
    assert not ws.begin_stage("s", {"p": 1}, [inp]).skip
    assert not ws.begin_stage("s", {"p": 1}, [inp], force=True).skip


def test_same_params_matches_options_added_or_dropped_at_their_defaults():
    """A key on one side only matches at its default (nested too); set, it does not; a key
    with no default, or a changed value, never matches."""
    from pipeline.workspace import same_params

    old = {"a": 1, "train": {"lr": 0.1, "model": {"width": 32}}}
    defaults = {"new": False, "train": {"restart": 0.0, "model": {"drop": 0.0}}, "gone": 3}
    assert same_params(old, {**old, "new": False}, defaults)
    assert not same_params(old, {**old, "new": True}, defaults)
    grown = {"a": 1, "new": False, "train": {"lr": 0.1, "restart": 0.0,
                                             "model": {"width": 32, "drop": 0.0}}}
    assert same_params(old, grown, defaults) and same_params(grown, old, defaults)
    grown["train"]["model"]["drop"] = 0.1
    assert not same_params(old, grown, defaults)
    assert not same_params(old, {**old, "other": None}, defaults)    # no default: a change
    assert not same_params(old, {**old, "a": 2}, defaults)
    assert same_params({**old, "gone": 3}, old, defaults)           # dropped at its default
    assert not same_params({**old, "gone": 4}, old, defaults)
    assert not same_params(None, old, defaults) and same_params(old, old)


def test_a_stage_of_an_earlier_version_stays_up_to_date_until_a_new_option_is_set(tmp_path):
    """A finished stage recorded before an option existed is skipped while the option is at
    its default, runs again when it is set, and its record then holds every parameter."""
    photos = tmp_path / "photos"
    photos.mkdir()
    ws = Workspace.create(tmp_path / "ws", photos)
    out = ws.root / "out.txt"
    out.write_text("o")
    ws.begin_stage("s", {"p": 1}, []).finish([out])
    defaults = {"p": 1, "new": False}
    assert ws.begin_stage("s", {"p": 1, "new": False}, [], defaults=defaults).skip
    run = ws.begin_stage("s", {"p": 1, "new": True}, [], defaults=defaults)
    assert not run.skip and not ws.resumable(run)
    run.finish([out])
    assert ws.stage_record("s")["params"] == {"p": 1, "new": True}
    assert not ws.begin_stage("s", {"p": 1, "new": False}, [], defaults=defaults).skip


def test_a_finished_stage_run_again_says_why(tmp_path, monkeypatch):
    """A finished stage that runs again says so in one line: its changed settings with old
    and new values (an option added since at its default is no change), else its changed
    inputs, else a missing output; a first or resumed run says nothing of it."""
    import pipeline.progress

    said = []
    monkeypatch.setattr(pipeline.progress, "info", said.append)
    photos = tmp_path / "photos"
    photos.mkdir()
    ws = Workspace.create(tmp_path / "ws", photos)
    inp, out = ws.root / "in.txt", ws.root / "out.txt"
    inp.write_text("a")
    out.write_text("o")
    ws.begin_stage("s", {"p": 1, "t": {"x": 1}}, [inp]).finish([out])
    assert said == []
    ws.begin_stage("s", {"p": 2, "t": {"x": 1}, "new": True}, [inp],
                   defaults={"new": False})
    assert said == ["s: running again: its settings changed (new false -> true, p 1 -> 2)"]
    ws.begin_stage("s", {"p": 2, "t": {"x": 1}, "new": True}, [inp])  # resumed: nothing said
    assert len(said) == 1
    ws.begin_stage("s", {"p": 1, "t": {"x": 1}}, [inp]).finish([out])
    ws.begin_stage("s", {"p": 1, "t": {"x": 2}, "new": False}, [inp], defaults={"new": False})
    assert said[-1] == "s: running again: its settings changed (t.x 1 -> 2)"
    ws.begin_stage("s", {"p": 1}, [inp]).finish([out])
    inp.write_text("b")
    ws.begin_stage("s", {"p": 1}, [inp])
    assert said[-1] == "s: running again: its inputs changed since it ran"
    ws.begin_stage("s", {"p": 1}, [inp]).finish([out])
    out.unlink()
    ws.begin_stage("s", {"p": 1}, [inp])
    assert said[-1] == "s: running again: an output it wrote is missing"


def test_interrupted_stage_is_resumable_but_not_skipped(tmp_path):
    photos = tmp_path / "photos"
    photos.mkdir()
    ws = Workspace.create(tmp_path / "ws", photos)
    run = ws.begin_stage("s", {"p": 1}, [])
    assert not run.skip  # never finished: it is "running" in the manifest
    again = ws.begin_stage("s", {"p": 1}, [])
    assert not again.skip and ws.resumable(again)
    forced = ws.begin_stage("s", {"p": 1}, [], force=True)
    assert not ws.resumable(forced)


def test_workspace_refuses_bad_locations(tmp_path):
    photos = tmp_path / "photos"
    photos.mkdir()
    with pytest.raises(UserError, match="inside the photo folder"):
        Workspace.create(photos / "ws", photos)
    other = tmp_path / "other"
    other.mkdir()
    (other / "keep.txt").write_text("x")
    with pytest.raises(UserError, match="not a deflare-scene workspace"):
        Workspace.create(other, photos)
    with pytest.raises(UserError, match="not a deflare-scene workspace"):
        Workspace.open(other)


def test_a_workspace_follows_its_photos_when_they_move_only(tmp_path, capsys):
    """A workspace opened for another photo folder: refused while the folder it was made
    from is still there; followed, with a warning, once that folder is gone (moved)."""
    photos, other = tmp_path / "photos", tmp_path / "other"
    photos.mkdir()
    other.mkdir()
    ws = Workspace.create(tmp_path / "ws", photos)
    with pytest.raises(UserError, match="was made from"):
        Workspace.create(ws.root, other)
    photos.rename(tmp_path / "moved")
    Workspace.create(ws.root, tmp_path / "moved")
    assert ws.photos_dir == (tmp_path / "moved").resolve()
    assert "no longer there" in capsys.readouterr().err


def test_cli_one_line_error_and_exit_code(tmp_path, capsys):
    code = main([str(tmp_path / "missing")])
    err = capsys.readouterr().err
    assert code == 2
    assert "does not exist" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_cli_help_lists_commands(capsys):
    from pathlib import Path

    from workflows.cli import COMMAND_MODULES, command_names

    modules = {p.stem for p in (Path(__file__).parents[2] / "workflows" / "commands").glob("*.py")}
    assert modules - {"__init__"} == set(COMMAND_MODULES)  # no command module left unregistered
    code = main(["--help"])
    out = capsys.readouterr().out
    assert code == 0
    for name in ("run", "decode", "pose", "mask", "finetune", "render", "eval", "bench"):
        assert name in command_names() and name in out
    from workflows.cli import app

    for info in app.registered_commands:  # each summary one line, as written in its docstring
        assert info.short_help and "\n" not in info.short_help, info.name
    from workflows.cli import short_help

    assert short_help("Write A and\n        B.\n\n        More.") == "Write A and B."


def test_scene_name_of_a_scene_images_folder_is_the_scene(tmp_path):
    """``<scene>`` is the photo folder's name, or its parent's for COLMAP's and LLFF's
    ``images`` / ``images_<N>`` folders (lund/images -> lund.mp4, not images.mp4)."""
    from pipeline.workspace import scene_folder_name

    for rel, name in (("lund/images", "lund"), ("fern/images_8", "fern"),
                      ("my_photos", "my_photos"), ("trip/images_day2", "images_day2"),
                      ("lantern/photos", "photos")):
        photos = tmp_path / rel
        photos.mkdir(parents=True)
        assert scene_folder_name(photos) == name
        ws = Workspace.create(tmp_path / f"{name}_{photos.name}.deflare", photos)
        assert ws.scene_name == name and ws.video.name == f"{name}.mp4"


def test_stage_summary_keeps_seconds_status_and_known_extras(tmp_path):
    (tmp_path / "photos").mkdir()
    ws = Workspace.create(tmp_path / "ws", tmp_path / "photos")
    (ws.root / "o.txt").write_text("o")
    for name, extra in (("depth", {"coverage": 0.5, "sweeps_from_mask_stage": 3}),
                        ("mask", {"views": 4})):
        ws.begin_stage(name, {}, []).finish([ws.root / "o.txt"], extra=extra)
    summary = ws.stage_summary()
    assert set(summary) == {"depth", "mask"}
    assert summary["depth"]["sweeps_from_mask_stage"] == 3 and "coverage" not in summary["depth"]
    assert set(summary["mask"]) == {"seconds", "status"}
    assert summary["mask"]["status"] == "complete" and summary["mask"]["seconds"] >= 0
