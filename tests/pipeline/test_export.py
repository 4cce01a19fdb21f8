"""Export stage: H.264 video, comparisons, scene.glb with the path, nerfstudio transforms."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from pipeline.cameras import load_cameras, save_cameras
from pipeline.video import read_frames_cv2, write_video
from pipeline.workspace import atomic_imwrite, atomic_write_json

CV_GL = np.diag([1.0, -1.0, -1.0, 1.0])


def test_video_decodes_to_the_right_frames():
    import tempfile
    from pathlib import Path

    rng = np.random.default_rng(0)
    frames = [np.full((37, 50, 3), 20 * i, np.uint8) for i in range(9)]
    frames[4] = rng.integers(0, 255, (37, 50, 3), dtype=np.uint8)
    with tempfile.TemporaryDirectory() as d:
        out = write_video(Path(d) / "v.mp4", frames, fps=12, crf=10)
        got = read_frames_cv2(out)
        cap = cv2.VideoCapture(str(out))
        fps = cap.get(cv2.CAP_PROP_FPS)
        cap.release()
    assert len(got) == 9
    assert got[0].shape == (38, 50, 3)  # odd height padded to even (yuv420p)
    assert abs(fps - 12) < 1e-3
    for i in (1, 6, 8):  # flat grey frames survive H.264 closely
        assert abs(float(got[i][:37].mean()) - 20 * i) < 2.5


def test_video_rejects_mixed_sizes(tmp_path):
    with pytest.raises(ValueError, match="size"):
        write_video(tmp_path / "v.mp4", [np.zeros((8, 8, 3), np.uint8),
                                         np.zeros((10, 8, 3), np.uint8)])
    assert not (tmp_path / "v.mp4").exists()
    assert not list(tmp_path.iterdir())  # no temporary left behind


def test_bundled_ffmpeg_has_libx264():
    import subprocess

    from pipeline.video import ffmpeg_exe

    out = subprocess.run([ffmpeg_exe(), "-hide_banner", "-encoders"], capture_output=True,
                         text=True, check=True).stdout
    assert "libx264" in out


@pytest.fixture
def ews(tmp_path):
    """A workspace with a fake rendered path and fake de-flared photos (no model needed)."""
    from gnfr.paths import PathCamera, interpolate_path, path_to_json
    from tests.pipeline.render_ws import make_render_ws

    ws = make_render_ws(tmp_path / "ws", n_views=4)
    cams = load_cameras(ws.cameras_json)
    poses = interpolate_path(np.stack([f.c2w for f in cams.frames]), 6)
    K = cams.frames[0].K / 4
    K[2, 2] = 1
    pcs = [PathCamera(f"{i:05d}", K, p, 40, 30) for i, p in enumerate(poses)]
    for i, _ in enumerate(pcs):
        atomic_imwrite(ws.renders / "interpolate" / f"{i:05d}.png",
                       np.full((30, 40, 3), 30 * i, np.uint8))
    atomic_write_json(ws.renders / "interpolate" / "cameras.json", path_to_json(pcs))
    for f in cams.frames:
        img = cv2.imread(str(ws.decoded / f"{f.stem}.png"))
        atomic_imwrite(ws.deflared / f"{f.stem}.png", 255 - img)
    return ws


def test_export_writes_every_output(ews):
    import trimesh

    from pipeline.export import ExportConfig, run
    from tests.pipeline.render_ws import BOX, FLARED

    outs = run(ExportConfig(fps=6), ews)
    scene = ews.scene_name
    for name in (f"{scene}.mp4", f"{scene}_compare.mp4", f"{scene}_compare.jpg",
                 "scene.glb", "transforms.json"):
        assert ews.root / name in outs
    video = read_frames_cv2(ews.root / f"{scene}.mp4")
    assert len(video) == 6 and video[0].shape == (30, 40, 3)
    assert abs(float(video[3].mean()) - 90) < 3  # the frames, in order
    compare = read_frames_cv2(ews.root / f"{scene}_compare.mp4")
    assert len(compare) == 4 * 6 and compare[0].shape == (120, 320, 3)  # 4 views, 1 s each
    glb = trimesh.load(str(ews.scene_glb), force="scene")
    assert "path0" in glb.geometry and "cameras" in glb.geometry
    # transforms.json: nerfstudio conventions
    tr = json.loads(ews.transforms_json.read_text())
    cams = load_cameras(ews.cameras_json).by_stem()
    assert tr["camera_model"] == "OPENCV" and len(tr["frames"]) == 4
    for fr in tr["frames"]:
        stem = fr["file_path"].split("/")[-1][:-4]
        assert fr["file_path"] == f"decoded/{stem}.png"
        assert np.allclose(np.array(fr["transform_matrix"]) @ CV_GL, cams[stem].c2w)
        assert (fr["w"], fr["h"]) == (160, 120)
        m = cv2.imread(str(ews.root / fr["mask_path"]), cv2.IMREAD_GRAYSCALE)
        assert m.shape == (120, 160)
        if stem == FLARED:
            assert m[BOX].max() == 0 and m.mean() > 200  # flare = 0 (ignore), rest 255
        else:
            assert m.min() == 255
    assert ews.masks_nerfstudio in outs
    # up to date on a rerun
    assert run(ExportConfig(fps=6), ews) == sorted(outs)


def test_a_portrait_pair_sits_centred_among_landscape_ones():
    from pipeline.export import centred, contact_sheet, side_by_side

    land = np.full((30, 40, 3), 200, np.uint8)
    tall = np.full((40, 30, 3), 100, np.uint8)
    pairs = centred([side_by_side(land, land, 30), side_by_side(tall, tall, 30)])
    assert {p.shape for p in pairs} == {(30, 80, 3)}
    filled = np.flatnonzero(pairs[1][15].max(axis=1))  # the portrait pair's columns
    left, right = filled[0], 80 - 1 - filled[-1]
    assert len(filled) == 2 * 22 and abs(left - right) <= 1  # 30 x 22.5 each, in the middle
    assert (pairs[0] == 200).all()  # a full-width pair is as it was
    sheet = contact_sheet(pairs)
    assert sheet.shape == (30, 160, 3) and (sheet[:, 80 + left:80 + 80 - right] == 100).all()


def test_transforms_camera_models(ews):
    from pipeline.export import nerfstudio_transforms

    cams = load_cameras(ews.cameras_json)
    for f in cams.frames:
        f.colmap_camera = {"model": "SIMPLE_RADIAL", "width": 160, "height": 120,
                           "params": [150.0, 80.0, 60.0, -0.07]}
    tr = nerfstudio_transforms(ews, cams, with_masks=False)
    assert tr["camera_model"] == "OPENCV"
    assert tr["frames"][0]["k1"] == -0.07 and tr["frames"][0]["fl_y"] == 150.0
    assert "mask_path" not in tr["frames"][0]
    cams.frames[1].colmap_camera = {"model": "FULL_OPENCV", "width": 160, "height": 120,
                                    "params": [150, 150, 80, 60] + [0.01] * 8}
    tr = nerfstudio_transforms(ews, cams, with_masks=True)
    assert tr["camera_model"] == "PINHOLE"  # rational model: fall back to undistorted images
    assert all(fr["file_path"].startswith("images/") for fr in tr["frames"])
    assert tr["frames"][0]["fl_x"] == cams.frames[0].K[0, 0]


def test_export_without_renders_is_a_clear_message(tmp_path):
    from pipeline.errors import UserError
    from pipeline.export import ExportConfig, run
    from tests.fixtures import make_temple_workspace

    ws = make_temple_workspace(tmp_path / "ws", n_views=3, scale=0.25)
    cams = load_cameras(ws.cameras_json)
    save_cameras(ws.cameras_json, cams)
    with pytest.raises(UserError, match="render"):
        run(ExportConfig(glb=False, transforms=False), ws)
    from workflows.cli import main

    assert main(["export", str(ws.root), "--no-glb", "--no-transforms"]) == 2


def test_points_ply_holds_the_depth_maps_as_a_coloured_cloud(tmp_path, capsys):
    """WS/points.ply of a textured plane's workspace after the depth stage: a binary PLY
    that trimesh reads back, one point per known depth pixel, lying on one plane (RMS off
    the fitted plane under 1 % of the cloud's extent), coloured by the photos; capped at
    ``max_points``; without WS/depth, one warning and no file."""
    import trimesh

    from pipeline.depth import DepthConfig, depth_points
    from pipeline.depth import run as depth_run
    from pipeline.export import write_points
    from pipeline.ws_files import read_cameras, read_depth, read_view_image
    from tests.fixtures import make_plane_workspace

    ws = make_plane_workspace(tmp_path / "ws", n_views=4)
    cams = read_cameras(ws)
    assert write_points(ws, cams, 10) is None and not ws.points_ply.exists()
    assert "no depth maps" in capsys.readouterr().err
    depth_run(DepthConfig(neighbours=3), ws)
    known = sum(int((read_depth(ws, f.stem)[0] > 0).sum()) for f in cams.frames)
    assert write_points(ws, cams, 10**7) == ws.points_ply
    cloud = trimesh.load(str(ws.points_ply), file_type="ply")
    pts = np.asarray(cloud.vertices)
    assert len(pts) == known > 1000
    centred = pts - pts.mean(0)
    rms_off = np.linalg.svd(centred, full_matrices=False)[1][-1] / np.sqrt(len(pts))
    assert rms_off < 0.01 * np.ptp(pts, axis=0).max()
    xyz, rgb = depth_points(ws, cams)
    assert np.array_equal(np.asarray(cloud.colors)[:, :3], rgb)
    f0 = cams.frames[0]
    first = read_depth(ws, f0.stem)[0] > 0
    assert np.array_equal(rgb[:int(first.sum())], read_view_image(ws, f0.stem)[first])
    # every 4th pixel each way, without reading the photos: those pixels' points
    sub, none = depth_points(ws, cams, stride=4, colour=False)
    assert none is None
    assert len(sub) == sum(int((read_depth(ws, f.stem)[0][::4, ::4] > 0).sum())
                           for f in cams.frames)
    i, j = np.nonzero(first)
    on_grid = (i % 4 == 0) & (j % 4 == 0)
    assert np.array_equal(sub[:int(on_grid.sum())], xyz[:int(first.sum())][on_grid])
    write_points(ws, cams, 500)
    assert len(trimesh.load(str(ws.points_ply), file_type="ply").vertices) == 500


def test_another_paths_video_does_not_replace_the_first(ews):
    """Exporting a second rendered path writes WS/<scene>_<path>.mp4 beside WS/<scene>.mp4
    (the interpolate path's), which stays as it was."""
    import shutil

    from pipeline.export import ExportConfig, run

    run(ExportConfig(fps=6), ews)
    first = ews.video.read_bytes()
    shutil.copytree(ews.renders / "interpolate", ews.renders / "spiral")
    outs = run(ExportConfig(fps=6, path="spiral"), ews)
    spiral = ews.root / f"{ews.scene_name}_spiral.mp4"
    assert spiral in outs and spiral == ews.video_of("spiral")
    assert len(read_frames_cv2(spiral)) == 6
    assert ews.video.read_bytes() == first
