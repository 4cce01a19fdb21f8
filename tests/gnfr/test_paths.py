"""Camera path builders, camera-path JSON formats and COLMAP camera models."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gnfr.paths import (
    PathCamera,
    PoseSpline,
    bounds_points,
    image_shift,
    interpolate_path,
    interpolate_tour,
    is_surrounding,
    key_blend,
    look_at,
    matrix_from_quat,
    order_tour,
    path_from_json,
    path_from_nerfstudio,
    path_to_json,
    path_to_nerfstudio,
    quat_from_matrix,
    rotation_angle,
    spiral_path,
    tour_lengths,
)
from pipeline.camera_models import MODELS, CameraModel, warp_maps

UP = np.array([0.0, 0.0, 1.0])


def ring(n=8, seed=0, shuffle=True):
    """Cameras on a noisy ring around the origin, looking at it, in shuffled order."""
    rng = np.random.default_rng(seed)
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    if shuffle:
        rng.shuffle(th)
    eyes = np.stack([np.cos(th), np.sin(th), 0.2 + 0.05 * rng.standard_normal(n)], 1)
    return np.stack([look_at(e, 0.05 * rng.standard_normal(3), UP) for e in eyes])


def forward_facing(n=9, seed=1):
    rng = np.random.default_rng(seed)
    eyes = np.c_[rng.uniform(-0.3, 0.3, n), rng.uniform(-0.2, 0.2, n), np.zeros(n)]
    return np.stack([look_at(e, np.array([0.0, 4.0, 0.0]) + 0.1 * rng.standard_normal(3),
                             UP) for e in eyes])


def assert_rotations(P):
    R = P[:, :3, :3]
    assert np.abs(R @ R.transpose(0, 2, 1) - np.eye(3)).max() < 1e-9
    assert np.allclose(np.linalg.det(R), 1.0, atol=1e-9)
    assert np.allclose(P[:, 3], [0, 0, 0, 1])


def test_quaternion_round_trip():
    P = np.concatenate([ring(20), forward_facing()])
    q = quat_from_matrix(P[:, :3, :3])
    assert np.allclose(np.linalg.norm(q, axis=1), 1)
    assert np.abs(matrix_from_quat(q) - P[:, :3, :3]).max() < 1e-12
    # 180-degree turns (trace -1) are the unstable case of the naive formula
    flip = np.diag([1.0, -1.0, -1.0])
    assert np.abs(matrix_from_quat(quat_from_matrix(flip)) - flip).max() < 1e-12


def test_order_tour_follows_the_ring():
    P = ring(10)
    order = order_tour(P[:, :3, 3])
    assert sorted(order) == list(range(10))
    steps = np.linalg.norm(np.diff(P[order, :3, 3], axis=0), axis=1)
    neighbour = 2 * np.sin(np.pi / 10)  # chord between neighbours on the unit ring
    assert steps.max() < 1.3 * neighbour  # a tour around the ring, no jumps across it


def test_tour_by_view_keeps_cameras_at_one_spot_looking_apart_apart():
    """Six spots along a line, at each a camera looking ahead and one looking back (a walk
    out and back). By position the tour zig-zags between the two at each spot (turning 180
    degrees five times or more); by position and turn it walks out one way and back the
    other, turning once."""
    ahead = [turned(0.0, at=(x, 0.0, 0.0)) for x in range(6)]
    back = [turned(180.0, at=(x + 0.01, 0.0, 0.0)) for x in range(6)]
    keys = np.stack(ahead + back)
    R = keys[:, :3, :3]

    def turns(order):
        a = rotation_angle(R[order[:-1]], R[order[1:]])
        return int((a > np.pi / 2).sum())

    by_position = order_tour(keys[:, :3, 3])
    by_view = order_tour(keys[:, :3, 3], rotations=R, depth=2.0)
    assert sorted(by_view) == list(range(12))
    assert turns(by_position) >= 5
    assert turns(by_view) == 1
    for depth in (2.0, None):  # None: a tenth of the keys' spread
        P = interpolate_path(keys, 60, tour="view", depth=depth)
        assert rotation_angle(P[:-1, :3, :3], P[1:, :3, :3]).sum() < 1.2 * np.pi
    with pytest.raises(ValueError, match="tour must be"):
        interpolate_path(keys, 10, tour="angle")
    with pytest.raises(ValueError, match="needs the scene's depth"):
        order_tour(keys[:, :3, 3], rotations=R)


def test_tour_lengths_weigh_travel_by_depth_and_turns_in_radians():
    """A step is its travel over the depth plus its turn in radians; cameras at one spot
    (no travel) are toured by their turns alone: a shuffled pan comes out in order."""
    yaw = np.array([0, 50, 10, 40, 20, 30, 60], float)
    keys = np.stack([turned(a) for a in yaw])
    order = order_tour(keys[:, :3, 3], rotations=keys[:, :3, :3], depth=1.0)
    assert list(yaw[order]) in (sorted(yaw), sorted(yaw)[::-1])
    moved = keys.copy()
    moved[:, 0, 3] = np.arange(7) * 2.0
    d = np.linalg.norm(moved[:, None, :3, 3] - moved[None, :, :3, 3], axis=-1)
    L = tour_lengths(d, moved[:, :3, :3], depth=4.0)
    assert L[0, 2] == pytest.approx(4.0 / 4.0 + np.radians(10))
    assert L[3, 3] == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize(("make", "closed"), [(ring, False), (ring, True),
                                              (forward_facing, False)])
def test_interpolate_smooth_and_through_keys(make, closed):
    keys = make()
    P = interpolate_path(keys, 120, closed=closed)
    assert P.shape == (120, 4, 4)
    assert_rotations(P)
    step = np.linalg.norm(np.diff(P[:, :3, 3], axis=0), axis=1)
    second = np.linalg.norm(np.diff(P[:, :3, 3], 2, axis=0), axis=1)
    assert second.max() < step.mean()  # turns by less than 60 degrees a frame
    # C1: second differences shrink ~4x when the frame count doubles (a kink gives 2x)
    fine = [np.linalg.norm(np.diff(interpolate_path(keys, n, closed=closed)[:, :3, 3], 2,
                                   axis=0), axis=1).max() for n in (240, 480)]
    assert fine[1] / fine[0] < 0.35
    rot_step = np.arccos(np.clip((np.trace(P[:-1, :3, :3].transpose(0, 2, 1) @ P[1:, :3, :3],
                                           axis1=1, axis2=2) - 1) / 2, -1, 1))
    assert rot_step.max() < 0.2  # radians per frame: no rotation jumps
    # every key camera is passed closely (constant-speed resampling leaves < one step)
    near = np.linalg.norm(keys[:, None, :3, 3] - P[None, :, :3, 3], axis=-1).min(1)
    assert near.max() <= step.max() + 1e-9
    if not closed:  # the open path starts and ends on keys
        order = order_tour(keys[:, :3, 3])
        assert np.allclose(P[0], keys[order[0]], atol=1e-9)
        assert np.allclose(P[-1], keys[order[-1]], atol=1e-9)


def wall(z=2.0, half=3.0, n=41):
    """Points of a wall [n * n, 3] across x and y at depth ``z`` ahead of the origin."""
    u = np.linspace(-half, half, n)
    x, y = np.meshgrid(u, u)
    return np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], -1)


def turned(angle_deg, at=(0.0, 0.0, 0.0)):
    """[4, 4] an OpenCV camera at ``at`` turned right by ``angle_deg`` about its y axis."""
    a = np.radians(angle_deg)
    P = np.eye(4)
    P[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
    P[:3, 3] = at
    return P


def test_image_shift_of_a_sideways_step_and_of_a_turn():
    pts, fov = wall(), (0.5, 0.4)
    step = np.stack([turned(0), turned(0, (0.1, 0, 0))])
    # a step of 0.1 sideways moves a wall at depth 2 by 0.1 / 2 in the image at unit focal
    assert image_shift(step, pts, fov, np.zeros(1))[0] == pytest.approx(0.05, rel=1e-6)
    turn = np.stack([turned(0), turned(2)])
    # turning by a small angle moves the middle of the view by its tangent, the edges by
    # up to 1 + x ** 2 + y ** 2 times that: the median lies between
    shift, t = image_shift(turn, pts, fov, np.zeros(1))[0], np.tan(np.radians(2))
    assert t < shift < (1 + fov[0] ** 2 + fov[1] ** 2) * t
    away = np.stack([turned(0), turned(180)])  # they share no point: the fallback
    assert image_shift(away, pts, fov, np.array([7.0]))[0] == 7.0


def test_paced_path_spreads_a_whip_pan_and_still_passes_every_key():
    """Two photos from one spot 30 degrees apart, then a walk: by travel the turn is done in
    a frame or two; paced on the scene's image motion every frame moves the image alike,
    and the path still passes through every photo's camera."""
    keys = np.stack([turned(0), turned(30, (0.002, 0, 0)), turned(0, (0.3, 0, 0)),
                     turned(0, (0.6, 0, 0)), turned(0, (0.9, 0, 0))])
    pts, fov, n = wall(z=2.0, half=6.0, n=81), (0.5, 0.4), 40
    by_travel = interpolate_path(keys, n)
    paced = interpolate_path(keys, n, points=pts, fov=fov)
    assert_rotations(paced)
    fallback = np.zeros(n - 1)
    old = image_shift(by_travel, pts, fov, fallback)
    new = image_shift(paced, pts, fov, fallback)
    assert old.max() / np.median(old) > 3  # the whip-pan
    assert new.max() / np.median(new) < 1.25
    assert new.max() < 0.5 * old.max()
    # every key is passed: some frame within one step's turn and travel of it
    dp = np.linalg.norm(np.diff(paced[:, :3, 3], axis=0), axis=1).max()
    da = rotation_angle(paced[:-1, :3, :3], paced[1:, :3, :3]).max()
    for k in keys:
        near = (np.linalg.norm(paced[:, :3, 3] - k[:3, 3], axis=1) <= dp + 1e-9) & (
            rotation_angle(paced[:, :3, :3], k[None, :3, :3]) <= da + 1e-9)
        assert near.any()


def test_key_blend_meets_each_key_and_never_overshoots():
    knots, values = np.array([0.0, 1.0, 3.0, 3.5]), np.array([1.0, 1.0, 2.8, 0.7])
    assert np.allclose(key_blend(values, knots, knots), values)  # each key exactly
    t = np.linspace(0, 3.5, 701)
    v = key_blend(values, knots, t)
    for a, b in zip(knots[:-1], knots[1:], strict=True):  # between keys: from one to the
        seg = v[(t >= a) & (t <= b)]  # next, monotone, nothing past either
        lo, hi = sorted(key_blend(values, knots, np.array([a, b])))
        assert seg.min() >= lo - 1e-12 and seg.max() <= hi + 1e-12
        assert np.all(np.diff(seg) >= -1e-12) or np.all(np.diff(seg) <= 1e-12)
    assert np.allclose(v[(t >= 0) & (t <= 1)], 1.0)  # two equal keys: no breathing
    # held still at a key: the rate of change is ~0 on either side of it
    k = 1.0
    h = 1e-4
    assert abs(np.log(key_blend(values, knots, np.array([k + h]))[0] / 1.0)) < 1e-6


def test_tour_carries_the_keys_zoom_and_paces_on_it():
    """Each key's zoom is met where the path passes the key; a zoomed-in stretch moves
    the image that much faster, so it gets more frames; without zoom, or with every key's
    1, the path is interpolate_path's."""
    keys = np.stack([turned(0, (x, 0, 0)) for x in (0.0, 0.3, 0.6, 0.9)])
    pts, fov, n = wall(z=2.0, half=6.0, n=81), (0.5, 0.4), 41
    plain = interpolate_path(keys, n, points=pts, fov=fov)
    assert np.array_equal(interpolate_tour(keys, n, points=pts, fov=fov).poses, plain)
    ones = interpolate_tour(keys, n, points=pts, fov=fov, zoom=np.ones(4))
    assert np.array_equal(ones.poses, plain) and np.array_equal(ones.zoom, np.ones(n))
    zoom = np.array([1.0, 1.0, 3.0, 3.0])
    tour = interpolate_tour(keys, n, points=pts, fov=fov, zoom=zoom)
    x = tour.poses[:, 0, 3]
    assert np.all(np.diff(x) > 0) or np.all(np.diff(x) < 0)  # the same line, in order
    ends = {round(x[i], 6): tour.zoom[i] for i in (0, -1)}  # the tour starts at either end
    assert ends == pytest.approx({0.0: 1.0, 0.9: 3.0})
    assert tour.zoom.min() >= 1.0 - 1e-12 and tour.zoom.max() <= 3.0 + 1e-12
    assert (x > 0.6).sum() > 2 * (x < 0.3).sum()  # the zoomed-in end gets more frames
    # on the frames: the zoomed image motion a frame is about even
    shift = image_shift(tour.poses, pts, fov, np.zeros(n - 1), zoom=tour.zoom)
    assert shift.max() / np.median(shift) < 1.25
    unzoomed = image_shift(tour.poses, pts, fov, np.zeros(n - 1))
    assert unzoomed.max() / unzoomed.min() > 2  # what the zoom evens out
    # a zoom on the spot moves the image: each point by its distance from the centre
    still = np.stack([turned(0), turned(0)])
    assert image_shift(still, pts, fov, np.zeros(1))[0] == 0
    xy = pts[:, :2] / pts[:, 2:]  # the camera at the origin looking down +z
    inner = (np.abs(2 * xy) <= fov).all(1)  # what the zoomed-in view still sees
    assert image_shift(still, pts, fov, np.zeros(1), zoom=np.array([1.0, 2.0]))[0] == (
        pytest.approx(np.median(np.linalg.norm(xy[inner], axis=1))))
    # a key's zoom goes with the key when the tour reorders them
    shuffled = interpolate_tour(keys[[2, 0, 3, 1]], n, zoom=zoom[[2, 0, 3, 1]])
    ends = {round(shuffled.poses[i, 0, 3], 6): shuffled.zoom[i] for i in (0, -1)}
    assert ends == pytest.approx({0.0: 1.0, 0.9: 3.0})
    with pytest.raises(ValueError, match="zoom"):
        interpolate_tour(keys, n, zoom=np.array([1.0, 0.0, 1.0, 1.0]))
    closed = interpolate_tour(ring(5), 30, closed=True, zoom=np.linspace(1, 2, 5))
    assert closed.zoom.min() >= 1.0 - 1e-12 and closed.zoom.max() <= 2.0 + 1e-12


def test_bounds_points_stand_in_for_the_scene_across_each_view():
    cams = np.stack([turned(0), turned(90, (1.0, 0, 0))])
    near, far, fov = np.array([1.0, 4.0]), np.array([4.0, 9.0]), (0.5, 0.25)
    pts = bounds_points(cams, near, far, fov, grid=4).reshape(2, 16, 3)
    for c, z, p in zip(cams, np.sqrt(near * far), pts, strict=True):
        local = (p - c[:3, 3]) @ c[:3, :3]  # in the camera's own axes
        assert np.allclose(local[:, 2], z)  # at the middle of its depth range (log scale)
        xy = local[:, :2] / local[:, 2:]
        assert (np.abs(xy) <= np.array(fov) + 1e-12).all()  # across its view
        assert np.ptp(xy[:, 0]) > fov[0] and np.ptp(xy[:, 1]) > fov[1]


def test_spline_hits_keys_exactly():
    keys = ring(7, shuffle=False)
    for closed in (False, True):
        s = PoseSpline.fit(keys, closed)
        assert np.abs(s(s.knots[:7]) - keys).max() < 1e-9


@pytest.mark.parametrize("n", [1, 2, 5, 37])
def test_frame_counts(n):
    assert interpolate_path(ring(5), n).shape == (n, 4, 4)
    assert spiral_path(ring(5), np.full(5, 0.5), np.full(5, 2.0), n).shape == (n, 4, 4)


def test_spiral_forward_facing_looks_ahead():
    keys = forward_facing()
    assert not is_surrounding(keys)
    P = spiral_path(keys, np.full(9, 1.0), np.full(9, 8.0), 60)
    assert_rotations(P)
    # stays within the spread of the captured centres and looks the same way they do
    lo, hi = keys[:, :3, 3].min(0), keys[:, :3, 3].max(0)
    assert np.all(P[:, :3, 3] > lo - 0.1) and np.all(P[:, :3, 3] < hi + 0.1)
    assert np.all(P[:, :3, 2] @ keys[:, :3, 2].mean(0) > 0.9)
    assert np.all(P[:, :3, 1] @ UP < -0.9)  # upright
    assert np.abs(np.diff(P[:, :3, 3], 2, axis=0)).max() < 0.05


def test_spiral_surrounding_orbits_the_focus():
    keys = ring(12)
    assert is_surrounding(keys)
    P = spiral_path(keys, np.full(12, 0.5), np.full(12, 2.0), 90)
    assert_rotations(P)
    r = np.linalg.norm(P[:, :2, 3], axis=1)
    assert np.all(np.abs(r - 1.0) < 0.15)  # the ring's radius
    to_centre = -P[:, :3, 3] / np.linalg.norm(P[:, :3, 3], axis=1, keepdims=True)
    assert np.all(np.sum(P[:, :3, 2] * to_centre, 1) > 0.95)  # looking at the scene
    assert np.all(P[:, :3, 1] @ UP < -0.9)  # upright: image y points down the world


def test_look_at_convention():
    c2w = look_at(np.array([0.0, -2.0, 0.0]), np.zeros(3), UP)
    assert np.allclose(c2w[:3, 2], [0, 1, 0])  # z forward
    assert np.allclose(c2w[:3, 1], [0, 0, -1])  # y down
    assert np.allclose(c2w[:3, 0], [1, 0, 0])  # x right


# --------------------------------------------------------------------------- JSON paths
def sample_cams():
    K = np.array([[300.0, 0, 160], [0, 300.0, 120], [0, 0, 1]])
    return [PathCamera(f"view_{i}", K, c2w, 320, 240) for i, c2w in enumerate(ring(4))]


def test_json_round_trip():
    cams = sample_cams()
    text = json.dumps(path_to_json(cams))
    back = path_from_json(json.loads(text))
    assert [c.name for c in back] == [c.name for c in cams]
    for a, b in zip(cams, back, strict=True):
        assert np.array_equal(a.K, b.K) and np.array_equal(a.c2w, b.c2w)
        assert (a.width, a.height) == (b.width, b.height)


def test_json_errors_are_named():
    good = path_to_json(sample_cams())
    with pytest.raises(ValueError, match="frames"):
        path_from_json({"cameras": []})
    bad = json.loads(json.dumps(good))
    bad["frames"][2]["K"] = [[1, 2], [3, 4]]
    with pytest.raises(ValueError, match="frame 2: K"):
        path_from_json(bad)
    bad = json.loads(json.dumps(good))
    bad["frames"][1]["name"] = "view_0"
    with pytest.raises(ValueError, match="repeated"):
        path_from_json(bad)


def test_nerfstudio_round_trip_and_conventions():
    cams = sample_cams()
    ns = path_to_nerfstudio(cams, fps=30)
    assert len(ns["camera_path"][0]["camera_to_world"]) == 16
    back = path_from_json(json.loads(json.dumps(ns)))
    for a, b in zip(cams, back, strict=True):
        assert np.allclose(a.K, b.K) and np.allclose(a.c2w, b.c2w)
    # OpenGL: the camera looks down its -z; the OpenCV forward is +z of c2w
    gl = np.array(ns["camera_path"][0]["camera_to_world"]).reshape(4, 4)
    assert np.allclose(-gl[:3, 2], cams[0].c2w[:3, 2])
    assert np.allclose(gl[:3, 3], cams[0].c2w[:3, 3])
    # vertical fov: tan(fov / 2) = (H / 2) / f
    assert np.isclose(np.tan(np.radians(ns["camera_path"][0]["fov"]) / 2), 120 / 300)


def test_nerfstudio_refuses_what_it_cannot_map():
    cams = sample_cams()
    cams[0].K = cams[0].K.copy()
    cams[0].K[0, 2] += 5  # off-centre principal point has no nerfstudio equivalent
    with pytest.raises(ValueError, match="centred"):
        path_to_nerfstudio(cams)
    with pytest.raises(ValueError, match="perspective"):
        path_from_nerfstudio({"camera_type": "fisheye", "render_height": 10,
                              "camera_path": []})


# --------------------------------------------------------------------------- camera models
PARAMS = {
    "SIMPLE_PINHOLE": [500, 320, 240],
    "PINHOLE": [500, 510, 320, 240],
    "SIMPLE_RADIAL": [500, 320, 240, -0.12],
    "RADIAL": [500, 320, 240, -0.1, 0.02],
    "OPENCV": [500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002],
    "FULL_OPENCV": [500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002, 0.01, 0.05, 0.01, 0.001],
    "SIMPLE_RADIAL_FISHEYE": [300, 320, 240, 0.05],
    "RADIAL_FISHEYE": [300, 320, 240, 0.05, 0.01],
    "OPENCV_FISHEYE": [300, 310, 320, 240, 0.05, 0.01, 0.001, 0.0001],
}


@pytest.mark.parametrize("model", list(MODELS))
def test_camera_model_round_trip(model):
    cam = CameraModel.from_colmap({"model": model, "width": 640, "height": 480,
                                   "params": PARAMS[model]})
    uv = cam.pixel_grid()[::7, ::7].reshape(-1, 2)
    xy = cam.pixel_to_normalized(uv)
    assert np.abs(cam.normalized_to_pixel(xy) - uv).max() < 1e-6  # distort(undistort(x))
    xy2 = np.random.default_rng(0).uniform(-0.5, 0.5, (500, 2))
    assert np.abs(cam.undistort(cam.distort(xy2)) - xy2).max() < 1e-6
    if cam.dist.any():  # the distortion really does something
        assert np.abs(cam.distort(xy2) - xy2).max() > 1e-3


@pytest.mark.parametrize("model", ["OPENCV", "FULL_OPENCV", "OPENCV_FISHEYE"])
def test_camera_model_matches_opencv(model):
    import cv2

    cam = CameraModel.from_colmap({"model": model, "width": 640, "height": 480,
                                   "params": PARAMS[model]})
    xy = np.random.default_rng(1).uniform(-0.4, 0.4, (100, 2))
    pts3 = np.c_[xy, np.ones(len(xy))][:, None]
    if model == "OPENCV_FISHEYE":
        uv, _ = cv2.fisheye.projectPoints(pts3, np.zeros(3), np.zeros(3), cam.K, cam.dist)
    else:
        uv, _ = cv2.projectPoints(pts3, np.zeros(3), np.zeros(3), cam.K, cam.dist)
    assert np.abs(uv[:, 0] - cam.normalized_to_pixel(xy)).max() < 1e-6


def test_scaled_camera_and_warp_maps():
    cam = CameraModel.from_colmap({"model": "SIMPLE_RADIAL", "width": 640, "height": 480,
                                   "params": PARAMS["SIMPLE_RADIAL"]})
    half = cam.scaled(0.5)
    assert (half.width, half.height) == (320, 240)
    xy = np.array([[0.1, -0.2], [0.3, 0.25]])
    assert np.allclose(half.normalized_to_pixel(xy), cam.normalized_to_pixel(xy) * 0.5)
    aniso = cam.scaled(0.5, 0.25)
    assert aniso.model == "OPENCV"
    assert np.allclose(aniso.normalized_to_pixel(xy), cam.normalized_to_pixel(xy) * [0.5, 0.25])
    # warping the pinhole geometry into itself is the identity map
    pin = CameraModel.pinhole(cam.K, 640, 480)
    mx, my = warp_maps(pin, pin)
    j, i = np.meshgrid(np.arange(640), np.arange(480))
    assert np.abs(mx - j).max() < 1e-3 and np.abs(my - i).max() < 1e-3


def test_warp_maps_are_kept_for_equal_cameras_and_read_only():
    """The de-flared photos ask twice for one view's maps: the second time (equal cameras,
    other objects) gets the same arrays, which no caller can change; other cameras get
    their own maps."""
    import pipeline.camera_models as cm

    def cams():
        cam = CameraModel.from_colmap({"model": "SIMPLE_RADIAL", "width": 64, "height": 48,
                                       "params": PARAMS["SIMPLE_RADIAL"]})
        return CameraModel.pinhole(cam.K, 64, 48), cam

    cm._MAPS.clear()
    first = warp_maps(*cams())
    again = warp_maps(*cams())
    assert all(a is b for a, b in zip(first, again, strict=True))
    assert not first[0].flags.writeable and not first[1].flags.writeable
    pin, cam = cams()
    other = warp_maps(pin, cam.scaled(0.5))
    assert other[0].shape == (24, 32) and other[0] is not first[0]
    cm._MAPS.clear()
    fresh = warp_maps(*cams())
    assert fresh[0] is not first[0] and np.array_equal(fresh[0], first[0])
    for _ in range(cm._MAPS_KEPT + 2):  # the cache stays small
        warp_maps(pin, pin.scaled(1 + 0.1 * _))
    assert len(cm._MAPS) <= cm._MAPS_KEPT


def test_unknown_camera_model_is_a_user_error():
    from pipeline.errors import UserError

    with pytest.raises(UserError, match="not supported"):
        CameraModel.from_colmap({"model": "THIN_PRISM_FISHEYE", "width": 1, "height": 1,
                                 "params": []})


def test_rolled_photos_do_not_make_the_tour_spin():
    from gnfr.paths import world_up

    up = np.array([0.0, 0.0, 1.0])
    keys = []
    for i, a in enumerate(np.linspace(-0.6, 0.6, 8)):
        eye = np.array([3 * np.sin(a), -3 * np.cos(a), 0.2 * (i % 2)])
        c = look_at(eye, np.zeros(3), up)
        roll = {2: np.pi / 2, 5: np.pi}.get(i, 0.0)  # one portrait, one upside-down shot
        rz = np.array([[np.cos(roll), -np.sin(roll), 0], [np.sin(roll), np.cos(roll), 0],
                       [0, 0, 1]])
        c[:3, :3] = c[:3, :3] @ rz
        keys.append(c)
    keys = np.stack(keys)
    est = world_up(keys)
    assert est @ up > np.cos(np.radians(2))  # the rolled shots do not tilt the estimate
    path = interpolate_path(keys, 40, up=est)
    assert (-path[:, :3, 1] @ up > np.cos(np.radians(5))).all()  # every frame upright
    # viewing directions and positions of the keys are kept
    assert np.allclose(np.sort(path[[0, -1], :3, 3], 0), np.sort(keys[[0, -1], :3, 3], 0))
    spun = interpolate_path(keys, 40)  # without it, the rolled keys turn the frames
    assert (-spun[:, :3, 1] @ up < 0.5).any()
