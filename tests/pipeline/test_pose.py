"""Pose stage: real scenes, the cameras.json contract, model import, retries, geometry.

Real scenes: kermit, temple with ground truth, a forward walk in lund; COLMAP model import
on a synthetic reconstruction, the relaxed mapping retry on a synthetic forward walk, and
the geometry helpers."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline import colmap_io, pose
from pipeline.cameras import Frame, load_cameras
from pipeline.scene_glb import read_scene_points, write_scene_glb
from pipeline.workspace import Workspace, atomic_imwrite
from tests.conftest import shared
from tests.fixtures import read_temple_par
from workflows.cli import main


def _posed(tmp_path_factory, scene: str, size: int) -> Workspace:
    out = tmp_path_factory.mktemp(scene) / f"{scene}.deflare"
    src = shared("scenes", scene)
    assert main(["decode", str(src), "--out", str(out), "--max-size", str(size)]) == 0
    assert main(["pose", str(out), "--threads", "2"]) == 0
    return Workspace.open(out)


@pytest.fixture(scope="module")
def kermit(tmp_path_factory) -> Workspace:
    return _posed(tmp_path_factory, "kermit", 640)


@pytest.fixture(scope="module")
def temple(tmp_path_factory) -> Workspace:
    return _posed(tmp_path_factory, "temple", 640)


# --------------------------------------------------------------------------- kermit
def test_kermit_all_registered(kermit):
    report = json.loads((kermit.colmap / "report.json").read_text())
    assert report["registered"] == report["images"] == 11
    assert report["unregistered"] == []
    assert report["matcher"] == "exhaustive"
    assert report["mapping"]["used"] == "default"  # no retry when the first pass works
    assert [p["init"] for p in report["mapping"]["passes"]] == ["default"]
    assert report["mean_reprojection_error"] < 1.5
    cams = load_cameras(kermit.cameras_json)
    assert [f.name for f in cams.frames] == [f"kermit{i:03d}.jpg" for i in range(11)]


def test_kermit_colmap_outputs_readable(kermit):
    import pycolmap

    assert (kermit.colmap / "database.db").is_file()
    rec = pycolmap.Reconstruction(str(kermit.colmap / "sparse" / "0"))
    assert rec.num_reg_images() == 11 and rec.num_points3D() > 200
    db = pycolmap.Database.open(str(kermit.colmap / "database.db"))
    assert db.num_images() == 11 and db.num_verified_image_pairs() > 10
    db.close()


def test_cameras_contract(kermit):
    cams = load_cameras(kermit.cameras_json)
    for f in cams.frames:
        img = cv2.imread(str(kermit.images / f"{f.stem}.png"))
        dec = cv2.imread(str(kermit.decoded / f"{f.stem}.png"))
        assert img.shape[:2] == (f.height, f.width)
        cc = f.colmap_camera
        assert (cc["height"], cc["width"]) == dec.shape[:2] and cc["model"] == "SIMPLE_RADIAL"
        assert f.K[0, 1] == 0 and f.K[2].tolist() == [0, 0, 1]
        assert 0 < f.K[0, 2] < f.width and 0 < f.K[1, 2] < f.height
        R = f.c2w[:3, :3]
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-6) and np.isclose(np.linalg.det(R), 1)
        assert 0 < f.near < f.far
    radii = np.linalg.norm(cams.centers(), axis=1)
    assert np.isclose(radii.max(), 1.0) and radii.min() > 0.1  # within the unit sphere
    T = cams.colmap_to_world
    assert np.allclose(T[:3, :3] / T[0, 0], np.eye(3)) and T[0, 0] > 0  # scale + shift only


def test_points_project_inside_views_and_between_near_far(kermit):
    """Sparse points seen by a view reproject (K, c2w of WS/images) onto the image, with
    depths inside [near, far]: the poses, intrinsics and bounds agree with each other."""
    rec = colmap_io.read_model(kermit.colmap / "sparse" / "0")
    cams = load_cameras(kermit.cameras_json).by_stem()
    T = load_cameras(kermit.cameras_json).colmap_to_world
    for im in colmap_io.registered_images(rec):
        f = cams[Path(im.name).stem]
        pts = colmap_io.points_seen(rec, im) @ T[:3, :3].T + T[:3, 3]
        cam = (pts - f.c2w[:3, 3]) @ f.c2w[:3, :3]  # world -> camera (OpenCV axes)
        assert (cam[:, 2] > 0).all()
        inside = (cam[:, 2] > f.near) & (cam[:, 2] < f.far)
        assert inside.mean() > 0.97
        uv = cam @ f.K.T
        uv = uv[:, :2] / uv[:, 2:]
        ok = (uv[:, 0] > -2) & (uv[:, 0] < f.width + 2) & (uv[:, 1] > -2) & (
            uv[:, 1] < f.height + 2)
        assert ok.mean() > 0.98


def test_undistortion_matches_colmap(kermit, tmp_path):
    import pycolmap

    name = "kermit003.png"
    pycolmap.undistort_images(str(tmp_path), str(kermit.colmap / "sparse" / "0"),
                              str(kermit.decoded), image_names=[name])
    ref = cv2.imread(str(tmp_path / "images" / name)).astype(int)
    ours = cv2.imread(str(kermit.images / name)).astype(int)
    assert ref.shape == ours.shape
    assert np.abs(ref - ours).mean() < 0.05
    und = pycolmap.Reconstruction(str(tmp_path / "sparse"))
    K = und.cameras[und.find_image_with_name(name).camera_id].calibration_matrix()
    assert np.allclose(load_cameras(kermit.cameras_json).by_stem()["kermit003"].K, K)


def test_scene_glb(kermit, tmp_path):
    import trimesh

    scene = trimesh.load(kermit.scene_glb)
    assert {"points", "cameras"} <= set(scene.geometry)
    assert len(scene.geometry["points"].vertices) > 200
    frames = load_cameras(kermit.cameras_json).frames
    path = np.stack([f.c2w for f in frames[:4]])
    out = write_scene_glb(tmp_path / "s.glb", np.zeros((0, 3)), np.zeros((0, 3), np.uint8),
                          frames, extra_paths=[path])
    assert "path0" in trimesh.load(out).geometry
    pts, rgb = read_scene_points(kermit.scene_glb)  # export can rewrite it without pycolmap
    rec = colmap_io.read_model(kermit.colmap / "sparse" / "0")
    xyz, rgb0 = colmap_io.all_points(rec)
    T = load_cameras(kermit.cameras_json).colmap_to_world
    assert np.allclose(pts, xyz @ T[:3, :3].T + T[:3, 3], atol=1e-5)
    assert (rgb == rgb0).all()


def test_rerun_is_skipped(kermit, capsys):
    before = kermit.stage_record("pose")
    assert main(["pose", str(kermit.root)]) == 0
    assert "up to date" in capsys.readouterr().err
    assert kermit.stage_record("pose") == before


# --------------------------------------------------------------------------- temple
def test_umeyama_recovers_similarity():
    rng = np.random.default_rng(0)
    src = rng.normal(size=(10, 3))
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    R = q * np.sign(np.linalg.det(q))
    s, R2, t = colmap_io.umeyama(src, 2.5 * src @ R.T + [1, 2, 3])
    assert np.isclose(s, 2.5) and np.allclose(R2, R) and np.allclose(t, [1, 2, 3])


def test_temple_accuracy(temple):
    """Camera centres within 1% of the camera-ring radius of the ground truth (RMS), every
    one within 2%, and viewing directions within 2 degrees, after a similarity alignment.

    (SIMPLE_RADIAL keeps the principal point at the image centre; the ground truth's is
    18 px off it at f = 1520 px, about 0.7 degrees that the rotation absorbs.)"""
    par = read_temple_par(shared("scenes", "temple", "templeSR_par.txt"))
    frames = load_cameras(temple.cameras_json).frames
    assert len(frames) >= 12  # 13/16 with pycolmap 4.2.1
    est = np.stack([f.center for f in frames])
    gt = np.stack([-par[f.name][1].T @ par[f.name][2] for f in frames])
    s, R, t = colmap_io.umeyama(est, gt)
    err = np.linalg.norm(s * est @ R.T + t - gt, axis=1)
    radius = np.linalg.norm(gt - gt.mean(0), axis=1).max()
    assert np.sqrt((err ** 2).mean()) < 0.01 * radius, err / radius
    assert err.max() < 0.02 * radius, err / radius
    for f in frames:
        z_est = R @ f.c2w[:3, 2]
        z_gt = par[f.name][1][2]  # third row of R (world->camera) = optical axis
        assert np.degrees(np.arccos(np.clip(z_est @ z_gt, -1, 1))) < 2.0


# --------------------------------------------------------------------------- forward walk
def _lund_walk(tmp_path: Path, n: int, size: int) -> Path:
    """A workspace of lund's first ``n`` photos (a walk down a street) decoded at ``size``."""
    photos = tmp_path / "photos"
    photos.mkdir()
    for i in range(1, n + 1):
        (photos / f"{i:02d}.jpg").symlink_to(shared("scenes", "lund", "images", f"{i:02d}.jpg"))
    out = tmp_path / "lund.deflare"
    assert main(["decode", str(photos), "--out", str(out), "--max-size", str(size)]) == 0
    return out


def test_lund_forward_walk_poses(tmp_path):
    """Ten photos walking down a street (lund, 768 px): COLMAP's default initial-pair
    constraints leave 2 images; the relaxed retry registers them all. One thread and a
    fixed seed: with two threads COLMAP's default pass registered all ten in one CI run of
    the fifty-sixth session (and fewer than five in the others), so the premise was a
    coin toss; one thread makes the solve repeat."""
    out = _lund_walk(tmp_path, 10, 768)
    assert main(["pose", str(out), "--threads", "1", "--seed", "0"]) == 0
    report = json.loads((Workspace.open(out).colmap / "report.json").read_text())
    default, relaxed, *rest = report["mapping"]["passes"]
    assert default["init"] == "default" and default["registered"] < 5
    assert relaxed["init"] == "relaxed" and relaxed["registered"] >= 9
    # the loose pass runs only while a photo is still left out, and is kept only if it
    # registers more
    assert [p["init"] for p in rest] == ([] if relaxed["registered"] == 10 else ["loose"])
    used = max(report["mapping"]["passes"], key=lambda p: p["registered"])
    assert report["mapping"]["used"] == used["init"] != "default"
    assert report["registered"] == used["registered"] >= 9
    assert report["mean_reprojection_error"] < 1.5


def _forward_walk_database(root: Path, n_images: int, n_points: int) -> Path:
    """A COLMAP database of a synthetic walk down a street: pycolmap's synthetic tracks, with
    the keypoints moved to the projections of points on two walls and the ground, seen by
    cameras stepping 0.5 along their viewing direction (0.5 px noise)."""
    import pycolmap

    pycolmap.set_random_seed(0)
    opts = pycolmap.SyntheticDatasetOptions()
    opts.num_rigs, opts.num_frames_per_rig, opts.num_points3D = 1, n_images, n_points
    opts.num_points2D_without_point3D = 0
    opts.camera_params = [800.0, 512.0, 384.0, 0.0]
    path = root / "database.db"
    db = pycolmap.Database.open(str(path))
    rec = pycolmap.synthesize_dataset(opts, db)
    rng = np.random.default_rng(0)
    ids = sorted(rec.points3D)
    side = rng.integers(0, 3, len(ids))  # left wall, right wall, ground
    xyz = np.stack([np.where(side == 2, rng.uniform(-3, 3, len(ids)), 6.0 * side - 3),
                    np.where(side == 2, 1.5, rng.uniform(-4, 1.5, len(ids))),
                    rng.uniform(8, 40, len(ids))], 1)
    point = dict(zip(ids, xyz, strict=True))
    cam = next(iter(rec.cameras.values()))
    for k, im in enumerate(sorted(rec.images.values(), key=lambda im: im.name)):
        center = np.array([*rng.normal(0, 0.02, 2), 0.5 * k])
        kp = db.read_keypoints(im.image_id).copy()
        for j, p2 in enumerate(im.points2D):
            kp[j, :2] = cam.img_from_cam((point[p2.point3D_id] - center)[None])[0]
        kp[:, :2] += rng.normal(0, 0.5, (len(kp), 2))
        db.update_keypoints(im.image_id, kp.astype(np.float32))
    db.close()
    return path


def test_relaxed_retry_on_forward_walk(tmp_path):
    db = _forward_walk_database(tmp_path, n_images=8, n_points=300)
    cfg = pose.PoseConfig(num_threads=1)
    recs, mapping = pose.map_with_retry(cfg, db, tmp_path, tmp_path / "mapping", 8)
    default, relaxed = mapping["passes"]
    assert (default["init"], relaxed["init"], mapping["used"]) == ("default", "relaxed",
                                                                   "relaxed")
    assert default["registered"] <= 2 and relaxed["registered"] == 8
    assert colmap_io.largest_model(recs).num_reg_images() == 8


def test_next_pass():
    """Relaxed after default when fewer than half register; loose after either while any
    photo is left out (unless turned off); nothing after loose or a full registration."""
    cfg = pose.PoseConfig()
    assert pose.next_pass("default", 10, 29, cfg) == "relaxed"
    assert pose.next_pass("default", 20, 29, cfg) == "loose"
    assert pose.next_pass("relaxed", 15, 29, cfg) == "loose"
    assert pose.next_pass("default", 29, 29, cfg) is None
    assert pose.next_pass("relaxed", 29, 29, cfg) is None
    assert pose.next_pass("loose", 20, 29, cfg) is None
    off = pose.PoseConfig(loose_pass=False)
    assert pose.next_pass("default", 20, 29, off) is None
    assert pose.next_pass("default", 10, 29, off) == "relaxed"
    assert pose.next_pass("relaxed", 15, 29, off) is None


def test_loose_pass_registers_a_walk_the_relaxed_pass_splits(tmp_path):
    """lund's first 20 photos at 504 px (one thread, seed 0): the relaxed pass leaves photos
    out (COLMAP splits the walk into models), the loose pass registers more of them in one
    model and is kept; with --no-loose-pass the stage keeps the relaxed model."""
    out = _lund_walk(tmp_path, 20, 504)
    assert main(["pose", str(out), "--threads", "1", "--seed", "0"]) == 0
    report = json.loads((Workspace.open(out).colmap / "report.json").read_text())
    passes = {p["init"]: p for p in report["mapping"]["passes"]}
    assert "loose" in passes and report["mapping"]["used"] == "loose"
    assert passes["loose"]["registered"] > max(passes["default"]["registered"],
                                               passes.get("relaxed", {"registered": 0})[
                                                   "registered"])
    assert report["registered"] == passes["loose"]["registered"]
    assert report["mean_reprojection_error"] < 1.5
    assert main(["pose", str(out), "--threads", "1", "--seed", "0", "--no-loose-pass"]) == 0
    again = json.loads((Workspace.open(out).colmap / "report.json").read_text())
    assert "loose" not in {p["init"] for p in again["mapping"]["passes"]}
    assert again["registered"] < report["registered"]


def test_needs_retry():
    cfg = pose.PoseConfig()
    assert pose.needs_retry(2, 29, cfg) and pose.needs_retry(14, 29, cfg)
    assert not pose.needs_retry(15, 29, cfg) and not pose.needs_retry(3, 4, cfg)
    assert pose.needs_retry(2, 3, cfg)  # fewer than 3 never passes
    assert pose.needs_retry(8, 10, pose.PoseConfig(min_registered_fraction=0.9))


# --------------------------------------------------------------------------- import
def _synthetic_workspace(root: Path, size: tuple[int, int]):
    """A decoded workspace whose images match a pycolmap synthetic reconstruction."""
    import pycolmap

    pycolmap.set_random_seed(1)
    opts = pycolmap.SyntheticDatasetOptions()
    opts.num_rigs, opts.num_frames_per_rig, opts.num_points3D = 1, 6, 200
    rec = pycolmap.synthesize_dataset(opts)
    model = root / "model"
    model.mkdir(parents=True)
    rec.write(str(model))
    photos = root / "photos"
    photos.mkdir()
    ws = Workspace.create(root / "ws", photos)
    rng = np.random.default_rng(0)
    sources = {}
    for im in rec.images.values():
        stem = Path(im.name).stem
        sources[stem] = f"{stem}.jpg"
        atomic_imwrite(ws.decoded / f"{stem}.png",
                       rng.integers(0, 255, (size[1], size[0], 3), dtype=np.uint8))
    ws.record_stage("decode", {"test": 1}, [ws.decoded], extra={"sources": sources})
    return ws, rec, model


def test_import_colmap_model(tmp_path):
    ws, rec, model = _synthetic_workspace(tmp_path, (512, 384))  # model cameras: 1024x768
    assert main(["pose", str(ws.root), "--colmap-model", str(model)]) == 0
    cams = load_cameras(ws.cameras_json)
    assert len(cams.frames) == rec.num_reg_images() == 6
    T = cams.colmap_to_world
    for f in cams.frames:
        im = rec.find_image_with_name(f"{f.stem}.png")
        expect = pose.transform_c2w(T, colmap_io.cam_to_world(im))
        assert np.allclose(f.c2w, expect, atol=1e-9)
        cc = f.colmap_camera
        assert (cc["width"], cc["height"]) == (512, 384)
        assert np.allclose(cc["params"][:3], [640.0, 256.0, 192.0])  # halved f, cx, cy
        assert f.name == f"{f.stem}.jpg"
    imported = colmap_io.read_model(ws.colmap / "sparse" / "0")
    a = imported.find_image_with_name(cams.frames[0].stem + ".png")
    b = rec.find_image_with_name(cams.frames[0].stem + ".png")
    assert np.allclose(a.points2D[0].xy, np.asarray(b.points2D[0].xy) / 2)
    assert np.allclose(np.linalg.norm(cams.centers(), axis=1).max(), 1.0)
    report = json.loads((ws.colmap / "report.json").read_text())
    assert report["matcher"] == "imported" and report["registered"] == 6


def test_import_rejects_other_aspect(tmp_path, capsys):
    ws, _, model = _synthetic_workspace(tmp_path, (384, 512))  # portrait vs landscape model
    assert main(["pose", str(ws.root), "--colmap-model", str(model)]) == 2
    assert "other aspect ratio" in capsys.readouterr().err


# --------------------------------------------------------------------------- helpers
def test_normalising_transform_and_near_far():
    rng = np.random.default_rng(0)
    points = rng.normal(size=(500, 3)) * 3 + [10, -5, 2]
    centers = rng.normal(size=(8, 3)) * 20 + [10, -5, 2]
    T = pose.normalising_transform(centers, points)
    c = centers @ T[:3, :3].T + T[:3, 3]
    assert np.isclose(np.linalg.norm(c, axis=1).max(), 1.0)
    p = points @ T[:3, :3].T + T[:3, 3]
    assert np.linalg.norm(np.median(p, 0)) < 1e-9
    c2w = np.eye(4)
    c2w[:3, :3] = cv2.Rodrigues(np.array([0.3, -0.2, 0.1]))[0]
    c2w[:3, 3] = [1, 2, 3]
    out = pose.transform_c2w(T, c2w)
    assert np.allclose(out[:3, :3], c2w[:3, :3]) and np.allclose(out[:3, 3], T[:3, :3] @ [
        1, 2, 3] + T[:3, 3])
    depths = np.r_[rng.uniform(2, 4, 1000), 1e-4, 500.0]  # two outliers
    near, far = pose.near_far(depths, 1.3, (0.1, 10))
    assert 2 / 1.3 - 0.05 < near < 2 and 4 < far < 4 * 1.3 + 0.05
    assert pose.near_far(np.array([1.0, 2.0]), 1.3, (0.1, 10)) == (0.1, 10)


def test_matcher_choice():
    cfg = pose.PoseConfig()
    small = [f"IMG_{i}.png" for i in (3, 7, 12)]
    video = [f"frame_{i:05d}.png" for i in range(40)]
    assert pose.choose_matcher(cfg, small) == "exhaustive"
    assert pose.choose_matcher(cfg, video) == "sequential"
    assert pose.choose_matcher(cfg, [f"a{i * 2}.png" for i in range(61)]) == "sequential"
    assert pose.choose_matcher(pose.PoseConfig(matcher="exhaustive"), video) == "exhaustive"


def test_frustum_corners_project_to_image_corners():
    from pipeline.scene_glb import frustum_segments

    K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    f = Frame("a.jpg", "a", K, 640, 480, np.eye(4), 0.1, 10)
    segs = frustum_segments(f.K, f.width, f.height, f.c2w, 2.0)
    corners = segs[:4, 1]
    assert np.allclose(corners[:, 2], 2.0)
    uv = corners @ K.T
    assert np.allclose(uv[:, :2] / uv[:, 2:], [[0, 0], [640, 0], [640, 480], [0, 480]])


def test_a_paths_frustums_take_each_frames_own_intrinsics(tmp_path):
    """scene.glb's path: each frame's frustum with its own K (a zoomed-in frame's narrower);
    poses alone are drawn with the first photo's; a broken path file is one line."""
    import trimesh

    from gnfr.paths import PathCamera, path_to_json
    from pipeline.errors import UserError
    from pipeline.render import path_cameras

    K = np.array([[50.0, 0, 32], [0, 50, 24], [0, 0, 1]])
    zoomed = K.copy()
    zoomed[:2, :2] *= 3
    eye = np.eye(4)
    near = np.eye(4)
    near[0, 3] = 1.0
    photo = Frame("a.jpg", "a", K, 64, 48, eye, 0.1, 10)
    path = [PathCamera("0", K, eye, 64, 48), PathCamera("1", zoomed, near, 64, 48)]
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "cameras.json").write_text(json.dumps(path_to_json(path)))
    got = path_cameras(tmp_path / "p")
    assert [np.asarray(c.K).tolist() for c in got] == [K.tolist(), zoomed.tolist()]
    assert path_cameras(tmp_path / "none") is None

    def frustum_widths(extra):
        out = write_scene_glb(tmp_path / "s.glb", np.zeros((0, 3)), np.zeros((0, 3), np.uint8),
                              [photo, replace(photo, c2w=near)], extra_paths=[extra])
        v = np.asarray(trimesh.load(out).geometry["path0"].vertices)
        return [np.ptp(v[(np.abs(v[:, 0] - x) < 0.5) & (v[:, 2] > 1e-6)][:, 1])
                for x in (0.0, 1.0)]

    wide, narrow = frustum_widths(got)
    assert narrow == pytest.approx(wide / 3, rel=0.05)
    same = frustum_widths(np.stack([c.c2w for c in got]))
    assert same[0] == pytest.approx(same[1])
    (tmp_path / "p" / "cameras.json").write_text(json.dumps({"frames": [{"name": "0"}]}))
    with pytest.raises(UserError, match="cameras.json: .*render the path again"):
        path_cameras(tmp_path / "p")


def test_plane_sweep_depth_agrees_with_the_sparse_points(kermit):
    """The depth stage on a real posed scene: where it gives a depth at a sparse point's
    pixel, the depth matches the point's (median relative error printed by the assert)."""
    from pipeline.depth import DepthConfig
    from pipeline.depth import run as depth_run

    depth_run(DepthConfig(), kermit)
    rec = colmap_io.read_model(kermit.colmap / "sparse" / "0")
    cams = load_cameras(kermit.cameras_json)
    T, by = cams.colmap_to_world, cams.by_stem()
    rel, covered = [], []
    for im in colmap_io.registered_images(rec):
        f = by[Path(im.name).stem]
        d = np.load(kermit.depth_path(f.stem))["depth"]
        pts = colmap_io.points_seen(rec, im) @ T[:3, :3].T + T[:3, 3]
        cam = (pts - f.c2w[:3, 3]) @ f.c2w[:3, :3]
        uv = cam @ f.K.T
        c, r = (uv[:, 0] / uv[:, 2]).astype(int), (uv[:, 1] / uv[:, 2]).astype(int)
        ok = (c >= 0) & (c < f.width) & (r >= 0) & (r < f.height)
        dz = d[r[ok], c[ok]]
        covered.append(float((dz > 0).mean()))
        rel += list(np.abs(dz[dz > 0] - cam[ok, 2][dz > 0]) / cam[ok, 2][dz > 0])
    med = float(np.median(rel))
    assert np.mean(covered) > 0.5, f"depth at {np.mean(covered):.2f} of the sparse points"
    assert med < 0.02, f"median relative depth error at the sparse points {med:.4f}"
