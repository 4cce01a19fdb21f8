"""Videos in the photo folder: which frames become views, how decode writes and resumes
them, and a real scene filmed as a video posed from its frames."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline import video_input as vi
from pipeline.video import write_video
from pipeline.workspace import Workspace, digest_paths
from pipeline.ws_files import read_cameras
from tests.conftest import shared
from workflows.cli import main


def test_choose_gives_a_pause_no_stretch_of_its_own_and_takes_the_sharpest():
    """Four moves with a long pause after the second: cut by motion, each move gives one
    frame, its sharpest, and the pause's frames (the view the second move ended on) count
    with that move; cut by time (what a still video falls back to) the pause would take
    half the frames."""
    change = np.concatenate([np.full(10, 2.0), np.full(10, 2.0), np.zeros(40),
                             np.full(10, 2.0), np.full(10, 2.0)])
    sharp = np.ones(len(change))
    best = [3, 17, 64, 75]  # one sharp frame in each move
    sharp[best] = 5.0
    sharp[30] = 9.0  # the sharpest frame of the video, in the pause
    assert vi.choose(vi.Scan(sharp, change, 30.0, (64, 48)), 4) == [3, 30, 64, 75]
    sharp[30] = 1.0
    assert vi.choose(vi.Scan(sharp, change, 30.0, (64, 48)), 4) == best
    sharp[30] = 9.0
    still = vi.choose(vi.Scan(sharp, np.zeros(len(change)), 30.0, (64, 48)), 4)
    assert still == [3, 30, 40, 64]  # equal time: 20 frames each, the sharpest of each
    assert vi.choose(vi.Scan(sharp[:5], change[:5], 30.0, (64, 48)), 8) == [0, 1, 2, 3, 4]
    # a jump longer than a stretch: 3 of 6 stretches empty, filled from the widest gaps
    jumpy = vi.Scan(np.arange(10.0), np.array([0, 1, 1, 1, 1, 1, 1, 1, 1, 20.0]), 30.0,
                    (64, 48))
    picked = vi.choose(jumpy, 6)
    assert len(picked) == 6 and picked[-1] == 9


def test_frame_measures_rank_blur_and_motion():
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur(rng.integers(0, 255, (240, 320, 3), np.uint8), (3, 3), 0)
    blurred = cv2.blur(img, (9, 1))
    s_sharp, small = vi.frame_measures(img)
    s_blur, _ = vi.frame_measures(blurred)
    assert s_sharp > 3 * s_blur
    assert max(small.shape) == vi.MOTION_SIZE
    _, moved = vi.frame_measures(np.roll(img, 12, axis=1))
    _, noisy = vi.frame_measures(np.clip(img + rng.normal(0, 4, img.shape), 0, 255)
                                 .astype(np.uint8))
    assert np.abs(moved - small).mean() > 5 * np.abs(noisy - small).mean()


def _pan_video(path: Path, holds: int = 6, hold_len: int = 9, pause_after: int = 2,
               pause_len: int = 30) -> list[int]:
    """A pan over a texture that stops at ``holds`` places (hand shake, two of three frames
    motion-blurred, a long pause at one), moving between them. Returns the index of the
    sharp frames."""
    rng = np.random.default_rng(1)
    tex = cv2.GaussianBlur(rng.integers(0, 255, (120, 900, 3), np.uint8), (5, 5), 0)
    frames, sharp = [], []
    for h in range(holds):
        x = 40 + h * 120
        for t in range(hold_len):
            f = tex[:, x + t % 2: x + t % 2 + 160]
            if t % 3 == 1:
                sharp.append(len(frames))
            else:
                f = cv2.blur(f, (11, 1))
            frames.append(f)
        if h == pause_after:
            frames += [frames[-1]] * pause_len
        if h + 1 < holds:
            for t in range(1, 5):
                x2 = x + t * 24
                frames.append(cv2.blur(tex[:, x2: x2 + 160], (15, 1)))
    write_video(path, [f[..., ::-1] for f in frames], fps=24, crf=12)
    return sharp


def test_decode_takes_one_sharp_frame_per_stop_of_a_video(tmp_path, capsys, monkeypatch):
    photos = tmp_path / "walk"
    photos.mkdir()
    sharp = set(_pan_video(photos / "pan.mp4"))
    before = digest_paths([photos])
    out = tmp_path / "ws"
    assert main(["decode", str(photos), "--out", str(out), "--video-frames", "6"]) == 0
    assert digest_paths([photos]) == before
    ws = Workspace.open(out)
    stems = sorted(p.stem for p in ws.decoded.glob("*.png"))
    rec = ws.stage_record("decode")
    frames = rec["video_frames"]
    idx = [frames[s]["frame"] for s in stems]
    assert stems == [f"pan_f{i:05d}" for i in idx] and len(idx) == 6
    assert set(idx) <= sharp  # never a blurred frame
    stops = [i // 13 if i < 3 * 13 else (i - 30) // 13 for i in idx]  # hold + move = 13
    assert stops == list(range(6))  # one frame per stop, none more from the pause
    assert rec["sources"] == {s: "pan.mp4" for s in stems}
    assert frames[stems[1]]["seconds"] == pytest.approx(idx[1] / 24, abs=1e-3)
    assert cv2.imread(str(ws.decoded_path(stems[0]))).shape == (120, 160, 3)
    assert "pan.mp4: 6 of 104 frames taken" in capsys.readouterr().err
    # an interrupted rerun keeps the frames already written; a finished one is up to date
    ws.update_manifest("decode", {**rec, "status": "running"})
    first = ws.decoded_path(stems[0])
    first.unlink()
    kept = {s: ws.decoded_path(s).stat().st_mtime_ns for s in stems[1:]}
    written = []
    real = vi.read_chosen
    monkeypatch.setattr(vi, "read_chosen", lambda p, chosen, adv: (
        written.extend(chosen), real(p, chosen, adv))[1])
    assert main(["decode", str(photos), "--out", str(out), "--video-frames", "6"]) == 0
    assert written == [idx[0]] and first.exists()
    assert {s: ws.decoded_path(s).stat().st_mtime_ns for s in stems[1:]} == kept
    assert main(["decode", str(photos), "--out", str(out), "--video-frames", "6"]) == 0
    assert written == [idx[0]] and "up to date" in capsys.readouterr().err


def test_live_photo_clips_and_unreadable_videos_are_named(tmp_path, capsys):
    """A phone's Live Photo clip (IMG_1.MOV beside IMG_1.JPG) is not a walk: left out in one
    warning. A video that cannot be read is named and skipped like a bad photo."""
    d = tmp_path / "phone"
    d.mkdir()
    rng = np.random.default_rng(0)
    for i in range(3):
        cv2.imwrite(str(d / f"IMG_{i}.JPG"), rng.integers(0, 255, (48, 64, 3), np.uint8))
    _pan_video(d / "IMG_1.MOV", holds=2)
    (d / "broken.mp4").write_bytes(b"\x00\x00\x00\x18ftypmp42 not a video")
    assert main(["decode", str(d), "--out", str(tmp_path / "ws")]) == 0
    err = capsys.readouterr().err
    live = [ln for ln in err.splitlines() if "IMG_1.MOV" in ln]
    broken = [ln for ln in err.splitlines() if "broken.mp4" in ln]
    assert len(live) == 1 and "Live Photo" in live[0]
    assert len(broken) == 1 and "not a readable video" in broken[0]
    ws = Workspace.open(tmp_path / "ws")
    assert sorted(p.stem for p in ws.decoded.iterdir()) == ["IMG_0", "IMG_1", "IMG_2"]
    assert ws.stage_record("decode")["skipped"] == {"broken.mp4": "not a readable video "
                                                    "(corrupt or unsupported)"}


def test_a_real_scene_filmed_as_a_video_is_posed_from_its_frames(tmp_path):
    """instant-ngp's fox (frames of a phone video) put back into an H.264 video: decode
    takes 12 frames and every one of them registers, one camera for all."""
    fox = shared("scenes", "fox", "images")
    d = tmp_path / "fox_video"
    d.mkdir()
    files = sorted(fox.glob("*.jpg"))[:30]
    write_video(d / "fox.mp4", (cv2.resize(cv2.imread(str(p)), (270, 480),
                                           interpolation=cv2.INTER_AREA)[..., ::-1]
                                for p in files), fps=10, crf=16)
    out = tmp_path / "fox.deflare"
    assert main(["decode", str(d), "--out", str(out), "--video-frames", "12"]) == 0
    assert main(["pose", str(out), "--threads", "2"]) == 0
    cams = read_cameras(Workspace.open(out))
    assert len(cams.frames) == 12 and {f.name for f in cams.frames} == {"fox.mp4"}
    lenses = {json.dumps(f.colmap_camera["params"]) for f in cams.frames}
    assert len(lenses) == 1  # one COLMAP camera for the video's frames


def test_a_phone_video_held_upright_gives_upright_frames(tmp_path):
    """A phone stores a portrait video as landscape frames with a rotation in its metadata:
    the frames taken are turned as the phone showed them."""
    import subprocess

    from pipeline.video import ffmpeg_exe

    frame = np.zeros((120, 160, 3), np.uint8)
    frame[:20, :40] = 255  # a block in the top-left corner of the stored frame
    write_video(tmp_path / "land.mp4", [frame] * 4, fps=4, crf=10)
    (tmp_path / "phone").mkdir()
    subprocess.run([ffmpeg_exe(), "-y", "-loglevel", "error", "-display_rotation", "90",
                    "-i", str(tmp_path / "land.mp4"), "-c", "copy",
                    str(tmp_path / "phone" / "clip.mp4")], check=True)
    assert main(["decode", str(tmp_path / "phone"), "--out", str(tmp_path / "ws"),
                 "--video-frames", "3"]) == 0
    first = sorted(Workspace.open(tmp_path / "ws").decoded.glob("*.png"))[0]
    img = cv2.imread(str(first))
    assert img.shape[:2] == (160, 120)  # portrait
    ys, xs = np.nonzero(img[..., 0] > 128)
    assert ys.mean() > 120 and xs.mean() < 30  # turned a quarter anticlockwise: bottom left
