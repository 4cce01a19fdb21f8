"""Bad input: one clear line, non-zero exit, no traceback, the photo folder untouched."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from pipeline.workspace import Workspace, digest_paths
from tests.conftest import shared
from workflows.cli import main


def _fails(capsys, argv: list[str], *needles: str) -> str:
    """Run the CLI; assert exit 2 with one `error:` line containing every needle."""
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1, err
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]


SAMPLE = Path(__file__).resolve().parents[2] / "samples" / "cyprus"


def _sample_photos(folder: Path, n: int = 3) -> Path:
    """The first ``n`` photos of the shipped sample copied into ``folder`` (no shared data)."""
    folder.mkdir(parents=True)
    for f in sorted(SAMPLE.glob("*.jpg"))[:n]:
        shutil.copy(f, folder)
    return folder


def _kermit(folder: Path, n: int) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(n):
        shutil.copy(shared("scenes", "kermit", f"kermit00{i}.jpg"), folder)
    return folder


def test_missing_path(tmp_path, capsys):
    _fails(capsys, ["decode", str(tmp_path / "nope")], "does not exist")
    _fails(capsys, [str(tmp_path / "nope")], "does not exist")  # one-shot form
    assert not (tmp_path / "nope.deflare").exists()


def test_empty_folder(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    _fails(capsys, ["decode", str(tmp_path / "empty")], "is empty")
    assert list((tmp_path / "empty").iterdir()) == []


def test_folder_without_images(tmp_path, capsys):
    d = tmp_path / "docs"
    d.mkdir()
    (d / "notes.txt").write_text("hello")
    (d / "data.csv").write_text("1,2")
    before = digest_paths([d])
    _fails(capsys, ["decode", str(d)], "has no photos")
    assert digest_paths([d]) == before


def _photos(folder: Path, n: int) -> Path:
    """n small synthetic JPEGs (no shared data needed for decode)."""
    import cv2
    import numpy as np

    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    for i in range(n):
        cv2.imwrite(str(folder / f"p{i}.jpg"), rng.integers(0, 255, (48, 64, 3), np.uint8))
    return folder


def test_photos_and_videos_in_formats_not_read_are_named(tmp_path, capsys):
    """HEIC photos and a video that cannot be decoded beside readable photos: one warning
    line each, naming the file and what to do; decode goes on with the rest. A folder of
    HEIC alone: the error line says files were skipped, and the warnings name them. A video
    passed where the folder belongs: one line saying to pass a folder that holds it."""
    d = _photos(tmp_path / "mixed", 3)
    (d / "IMG_0001.HEIC").write_bytes(b"\x00\x00\x00\x18ftypheic")
    (d / "walk.MOV").write_bytes(b"\x00\x00\x00\x14ftypqt  ")
    (d / "notes.txt").write_text("hello")
    (d / "p0.heic").write_bytes(b"\x00")  # a phone's pair of p0.jpg: nothing is missed
    before = digest_paths([d])
    assert main(["decode", str(d), "--out", str(tmp_path / "ws")]) == 0
    err = capsys.readouterr().err
    heic = [ln for ln in err.splitlines() if "IMG_0001.HEIC" in ln]
    mov = [ln for ln in err.splitlines() if "walk.MOV" in ln]
    assert len(heic) == 1 and "HEIC files are not read" in heic[0] and "JPEG" in heic[0]
    assert len(mov) == 1 and "not a readable video" in mov[0] and "replace" in mov[0]
    assert "notes.txt" not in err and "p0.heic" not in err
    assert digest_paths([d]) == before
    assert sorted(p.stem for p in Workspace.open(tmp_path / "ws").decoded.iterdir()) == [
        "p0", "p1", "p2"]
    only = tmp_path / "iphone"
    only.mkdir()
    for i in range(3):
        (only / f"IMG_{i}.heic").write_bytes(b"\x00")
    _fails(capsys, ["decode", str(only)], "has no photos", "3 file(s) in formats it does not read")
    _fails(capsys, [str(d / "walk.MOV")], "walk.MOV is a video", "folder of its own",
           "pass the folder")


def test_photos_in_subfolders_are_pointed_at(tmp_path, capsys):
    """A camera's DCIM folder (photos one level down): not "empty" but one line naming the
    subfolders that hold photos and the one to pass; a folder of empty subfolders has no
    photos; nothing written."""
    dcim = tmp_path / "DCIM"
    _photos(dcim / "100CANON", 3)
    _photos(dcim / "101CANON", 5)
    (dcim / "MISC").mkdir()
    before = digest_paths([dcim])
    line = _fails(capsys, ["decode", str(dcim)], "no photos of its own",
                  "101CANON (5 photos), 100CANON (3 photos)", str(dcim / "101CANON"))
    assert "empty" not in line
    assert digest_paths([dcim]) == before and not (tmp_path / "DCIM.deflare").exists()
    _fails(capsys, ["decode", str(dcim / "MISC")], "is empty")
    hollow = tmp_path / "hollow"
    (hollow / "sub").mkdir(parents=True)
    _fails(capsys, ["decode", str(hollow)], "has no photos")
    # a stray photo beside the subfolders: too few of its own, and the line names the
    # subfolder that has enough
    _photos(tmp_path / "stray", 1)
    _photos(tmp_path / "stray" / "100CANON", 4)
    _fails(capsys, ["decode", str(tmp_path / "stray")], "has only 1 photo(s)",
           f"its subfolder 100CANON holds 4: pass {tmp_path / 'stray' / '100CANON'}")


def test_photos_left_in_subfolders_are_named(tmp_path, capsys):
    """Enough photos of its own and more in a subfolder (an export/ beside the originals):
    the folder's own are decoded and one line names the subfolder left out."""
    d = _photos(tmp_path / "walk", 3)
    _photos(d / "export", 2)
    assert main(["decode", str(d), "-o", str(tmp_path / "ws")]) == 0
    err = capsys.readouterr().err
    assert "photos in subfolders are left out" in err and "export/ (2)" in err
    assert len(list((tmp_path / "ws" / "decoded").glob("*.png"))) == 3


def test_too_few_images(tmp_path, capsys):
    d = _kermit(tmp_path / "two", 2)
    before = digest_paths([d])
    _fails(capsys, ["decode", str(d)], "only 2 photo", "at least 3")
    assert digest_paths([d]) == before


def test_corrupt_files_named_and_skipped(tmp_path, capsys):
    d = _kermit(tmp_path / "mixed", 4)
    jpeg = shared("scenes", "kermit", "kermit005.jpg").read_bytes()
    (d / "cut.jpg").write_bytes(jpeg[: len(jpeg) // 2])
    dng = shared("raw", "Blackmagic.dng").read_bytes()
    (d / "cutraw.dng").write_bytes(dng[: len(dng) // 3])
    (d / "junk.png").write_bytes(b"not a png at all")
    before = digest_paths([d])
    assert main(["decode", str(d), "--out", str(tmp_path / "ws"), "--max-size", "160"]) == 0
    err = capsys.readouterr().err
    assert digest_paths([d]) == before
    for name in ("cut.jpg", "cutraw.dng", "junk.png"):
        lines = [ln for ln in err.splitlines() if name in ln and "skipping" in ln]
        assert len(lines) == 1, err
    assert "Traceback" not in err
    ws = Workspace.open(tmp_path / "ws")
    assert sorted(p.stem for p in ws.decoded.iterdir()) == [f"kermit00{i}" for i in range(4)]
    assert sorted(ws.stage_record("decode")["skipped"]) == ["cut.jpg", "cutraw.dng", "junk.png"]


def test_copies_of_a_photo_are_named_and_left_out(tmp_path, capsys):
    """A byte-identical copy of a photo (``X copy.jpg``) is named in one warning and left
    out of the workspace; a folder of one photo and its copies fails as too few photos."""
    d = _sample_photos(tmp_path / "photos")
    first = sorted(d.iterdir())[0]
    shutil.copy(first, d / f"{first.stem} copy.jpg")
    before = digest_paths([d])
    assert main(["decode", str(d), "--out", str(tmp_path / "ws"), "--max-size", "96"]) == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "copy.jpg" in ln]
    assert len(lines) == 1 and "same file as " + first.name in lines[0], err
    ws = Workspace.open(tmp_path / "ws")
    assert sorted(p.stem for p in ws.decoded.iterdir()) == sorted(p.stem for p in
                                                                 SAMPLE.glob("*.jpg"))[:3]
    assert digest_paths([d]) == before
    one = tmp_path / "one"
    one.mkdir()
    for name in ("a.jpg", "b.jpg", "c.jpg"):
        shutil.copy(first, one / name)
    _fails(capsys, ["decode", str(one), "--out", str(tmp_path / "ws1")], "only 1 photo")


def test_a_workspace_passed_for_photos(tmp_path, capsys):
    """A workspace (or its decoded folder) where photos belong: `decode` says which folder
    to pass, in one line; the one-shot command on a workspace resumes it on the photos it
    was made from, refuses a different --out, and says so when those photos are gone.
    Another program's manifest.json does not make a folder a workspace."""
    from pipeline.workspace import enclosing_workspace
    from workflows.oneshot import resume_target

    photos = _sample_photos(tmp_path / "my photos")
    ws = tmp_path / "ws"
    assert main(["decode", str(photos), "--out", str(ws), "--max-size", "96"]) == 0
    capsys.readouterr()
    before = digest_paths([ws])
    _fails(capsys, ["decode", str(ws)], "is a deflare-scene workspace",
           f"'{photos}'", "to resume")
    _fails(capsys, ["decode", str(ws / "decoded")], "inside the deflare-scene workspace",
           str(photos))
    assert digest_paths([ws]) == before
    assert resume_target(ws, None, tmp_path / "x") == (photos.resolve(), ws.resolve())
    assert resume_target(photos, None, ws) == (photos, ws)
    _fails(capsys, [str(ws), "--out", str(tmp_path / "other")], "--out names another")
    shutil.move(photos, tmp_path / "moved")
    _fails(capsys, [str(ws)], "no longer there", "--out")
    # a command a message suggests can be pasted: the path with a space is quoted
    _fails(capsys, ["finetune", str(ws)], f"`deflare-scene pose {ws}` first")
    spaced = tmp_path / "my ws"
    shutil.copytree(ws, spaced)
    _fails(capsys, ["finetune", str(spaced)], f"`deflare-scene pose '{spaced.resolve()}'` first")
    other = tmp_path / "webapp"
    other.mkdir()
    (other / "manifest.json").write_text('{"name": "app", "icons": []}')
    assert enclosing_workspace(other) is None


def test_too_few_usable_after_skipping(tmp_path, capsys):
    d = _kermit(tmp_path / "bad", 2)
    (d / "broken.jpg").write_bytes(b"\xff\xd8\xff\xe0garbage")
    before = digest_paths([d])
    _fails(capsys, ["decode", str(d), "--out", str(tmp_path / "ws")],
           "only 2 of 3", "broken.jpg")
    assert digest_paths([d]) == before
    assert not (tmp_path / "ws").exists()  # the failed first decode left no workspace


def test_a_first_run_whose_photos_all_fail_leaves_no_workspace(tmp_path, capsys):
    """`deflare-scene ./photos` with no readable photo: one line naming them, rc 2, and no
    empty `photos.deflare/` left beside the folder (a workspace that existed stays: the test
    above of a rerun)."""
    d = tmp_path / "photos"
    d.mkdir()
    for i in range(3):
        (d / f"p{i}.jpg").write_bytes(b"\xff\xd8\xff\xe0 not a photo " + bytes([i]))
    before = digest_paths([d])
    _fails(capsys, [str(d)], "only 0 of 3", "p0.jpg")
    assert not (tmp_path / "photos.deflare").exists()
    assert digest_paths([d]) == before


def test_output_inside_photo_folder(tmp_path, capsys):
    d = _kermit(tmp_path / "photos", 3)
    before = digest_paths([d])
    _fails(capsys, ["decode", str(d), "--out", str(d / "ws")], "inside the photo folder")
    _fails(capsys, ["decode", str(d), "--out", str(d)], "inside the photo folder")
    assert digest_paths([d]) == before
    assert sorted(p.name for p in d.iterdir()) == [f"kermit00{i}.jpg" for i in range(3)]


def test_pose_on_non_workspace(tmp_path, capsys):
    d = _kermit(tmp_path / "photos", 3)
    before = digest_paths([d])
    _fails(capsys, ["pose", str(d)], "not a deflare-scene workspace")
    _fails(capsys, ["pose", str(tmp_path / "missing")], "does not exist")
    assert digest_paths([d]) == before


def test_bad_matcher_and_bad_model(tmp_path, capsys):
    d = _kermit(tmp_path / "photos", 3)
    ws = tmp_path / "ws"
    assert main(["decode", str(d), "--out", str(ws), "--max-size", "160"]) == 0
    _fails(capsys, ["pose", str(ws), "--matcher", "fancy"], "--matcher fancy")
    _fails(capsys, ["pose", str(ws), "--colmap-model", str(tmp_path)], "is not a COLMAP model")


@pytest.mark.filterwarnings("ignore")
def test_unposable_scene(tmp_path, capsys):
    """dino (nearly textureless): 3/16 register with pycolmap 4.2.1 -> clear failure."""
    src = shared("scenes", "dino")
    before = digest_paths([src])
    line = _fails(capsys, [str(src), "--out", str(tmp_path / "dino"), "--max-size", "640"],
                  "could be posed", "of 16 images", "dinoSR0001.png", "report.json")
    assert "overlapping photos" in line
    assert digest_paths([src]) == before
    report = (tmp_path / "dino" / "colmap" / "report.json")
    assert report.exists()
    assert not (tmp_path / "dino" / "cameras.json").exists()


def test_oneshot_mask_options_that_need_one_another_fail_before_anything_is_written(
        tmp_path, capsys):
    """`--set mask.ghost_views=true` with mask.ghost_lines off (and the like) is one line
    before the decode stage runs: no workspace is made, the photos are untouched."""
    d = tmp_path / "photos"
    d.mkdir()
    for i in range(3):
        (d / f"p{i}.png").write_bytes(b"not read")
    before = digest_paths([d])
    _fails(capsys, [str(d), "--set", "mask.ghost_lines=false", "--set",
                    "mask.ghost_views=true"], "--ghost-views", "--ghost-lines")
    _fails(capsys, [str(d), "--set", "mask.confirm_keep=first"], "--confirm")
    _fails(capsys, [str(d), "--set", "depth.sgm=2,1"], "--sgm 2,1", "P1 <= P2")
    _fails(capsys, [str(d), "--set", "depth.sgm=0,1"], "depth.sgm=0,1")
    assert not (tmp_path / "photos.deflare").exists()
    assert digest_paths([d]) == before


def test_a_rerun_with_too_few_readable_photos_keeps_the_earlier_decoded_ones(tmp_path, capsys):
    """decode again after the photos were replaced by unreadable files: one error line, and
    the earlier run's decoded photos are still there (they were removed before the count)."""
    d = _sample_photos(tmp_path / "photos")
    ws = tmp_path / "ws"
    assert main(["decode", str(d), "--out", str(ws), "--max-size", "96"]) == 0
    before = digest_paths([ws / "decoded"])
    for i, f in enumerate(sorted(d.glob("*.jpg"))[1:]):
        f.write_bytes(b"\xff\xd8\xff\xe0 not a photo any more " + bytes([i]))
    capsys.readouterr()
    _fails(capsys, ["decode", str(d), "--out", str(ws), "--max-size", "96"], "only 1 of 3")
    assert digest_paths([ws / "decoded"]) == before
