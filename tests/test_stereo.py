"""Plane-sweep depth, depth splatting and photo warping (pipeline/stereo.py, photo_fill.py)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pipeline.photo_fill import photo_fill, support_weight
from pipeline.stereo import (
    PosedView,
    SweepConfig,
    backproject,
    homography,
    project_points,
    splat_depth,
    sweep_depth,
    warp_sources,
)

W, H = 160, 120
K = np.array([[150.0, 0, W / 2], [0, 150.0, H / 2], [0, 0, 1]])


def look(center, target=(0.0, 0.0, 0.0)) -> np.ndarray:
    """c2w (OpenCV) at ``center`` looking at ``target`` with y roughly down."""
    c, t = np.asarray(center, float), np.asarray(target, float)
    z = (t - c) / np.linalg.norm(t - c)
    x = np.cross(np.array([0.0, 1.0, 0.0]), z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, :3] = np.stack([x, y, z], 1)
    m[:3, 3] = c
    return m


def plane_views(rng, centers, plane_z=0.0, tilt=0.3):
    """Views of a textured plane through world point (0, 0, plane_z) with normal tilted
    about y; returns views and the true depth of the first."""
    tex = cv2.resize(rng.random((48, 64, 3)).astype(np.float32), (640, 480),
                     interpolation=cv2.INTER_CUBIC)
    tex = cv2.GaussianBlur(tex, (0, 0), 1.0)
    n = np.array([np.sin(tilt), 0.0, -np.cos(tilt)])
    u = np.array([np.cos(tilt), 0.0, np.sin(tilt)])
    v = np.array([0.0, 1.0, 0.0])
    p0 = np.array([0.0, 0.0, plane_z])
    # plane coordinates (a, b) in [-2, 2] x [-1.5, 1.5] -> texture pixels
    A = np.array([[160.0, 0, 320], [0, 160.0, 240], [0, 0, 1]])  # (a, b, 1) -> tex px
    views, depth0 = [], None
    for i, c in enumerate(centers):
        c2w = look(c)
        w2c = np.linalg.inv(c2w)
        # world plane point X = p0 + a u + b v; camera = R X + t
        M = w2c[:3, :3] @ np.stack([u, v, p0], 1) + np.outer(w2c[:3, 3], [0, 0, 1])
        Hp = K @ M @ np.linalg.inv(A)  # tex px -> image px (continuous)
        half = np.array([[1, 0, 0.5], [0, 1, 0.5], [0, 0, 1.0]])
        Hcv = np.linalg.inv(half) @ Hp @ half
        img = cv2.warpPerspective(tex, Hcv, (W, H), flags=cv2.INTER_LINEAR)
        views.append(PosedView(img, K.copy(), c2w))
        if i == 0:
            xs, ys = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
            rays = np.stack([xs, ys, np.ones_like(xs)], -1) @ np.linalg.inv(K).T
            d_w = rays @ c2w[:3, :3].T
            t = ((p0 - c2w[:3, 3]) @ n) / (d_w @ n)
            depth0 = t  # rays have camera z = 1, so t is z-depth
    del n
    return views, depth0


def test_homography_maps_plane_points():
    c2w_t, c2w_s = look([0.0, 0.0, -3.0]), look([0.4, 0.1, -3.0])
    d = 2.7
    Hm = homography(K, c2w_t, K, c2w_s, d)
    px = np.array([37.5, 80.5])  # continuous target pixel
    X = backproject(K, c2w_t, np.full((H, W), d, np.float32))[int(px[1]), int(px[0])]
    xy, _ = project_points(X[None], K, c2w_s)
    got = Hm @ np.array([px[0] - 0.5, px[1] - 0.5, 1.0])
    np.testing.assert_allclose(got[:2] / got[2] + 0.5, xy[0], atol=1e-3)


def test_sweep_recovers_a_textured_plane():
    rng = np.random.default_rng(0)
    views, true = plane_views(rng, [[0.0, 0.0, -3.0], [0.35, 0.0, -3.0], [-0.35, 0.05, -3.0],
                                    [0.0, 0.3, -3.0]])
    depth, conf = sweep_depth(views[0], views[1:], 2.0, 5.0, SweepConfig(planes=64, keep=2))
    known = depth > 0
    assert known.mean() > 0.7, "most of a textured plane must get a depth"
    rel = np.abs(depth[known] - true[known]) / true[known]
    assert np.median(rel) < 0.01, f"median relative depth error {np.median(rel):.4f}"
    assert conf[known].min() >= 0.5


def test_sweep_ignores_a_flared_neighbour():
    rng = np.random.default_rng(1)
    views, true = plane_views(rng, [[0.0, 0.0, -3.0], [0.35, 0.0, -3.0], [-0.35, 0.05, -3.0],
                                    [0.0, 0.3, -3.0]])
    flared = views[1]
    flared.image = flared.image.copy()
    flared.image[:, : W // 2] = 1.0  # a blown-out flare over half the neighbour
    flared.valid = np.ones((H, W), bool)
    flared.valid[:, : W // 2] = False
    depth, _ = sweep_depth(views[0], views[1:], 2.0, 5.0, SweepConfig(planes=64, keep=2))
    known = depth > 0
    rel = np.abs(depth[known] - true[known]) / true[known]
    assert known.mean() > 0.7 and np.median(rel) < 0.01


def test_warp_reproduces_a_source_at_its_own_camera():
    rng = np.random.default_rng(2)
    views, _ = plane_views(rng, [[0.0, 0.0, -3.0], [0.3, 0.0, -3.0]])
    src = views[1]
    src.depth = np.full((H, W), 3.0, np.float32)
    w = warp_sources(src.K, src.c2w, src.depth, [src])
    assert w.ok[0].all()
    np.testing.assert_allclose(w.colours[0], src.image, atol=1e-5)


def test_splat_and_fill_reproduce_a_neighbour_view():
    rng = np.random.default_rng(3)
    centers = [[0.0, 0.0, -3.0], [0.3, 0.0, -3.0], [-0.3, 0.0, -3.0]]
    views, true0 = plane_views(rng, centers)
    for v in views[1:]:
        v.depth, _ = sweep_depth(v, [u for u in views if u is not v], 2.0, 5.0,
                                 SweepConfig(planes=64))
    d = splat_depth(K, views[0].c2w, (W, H), views[1:])
    known = d > 0
    assert known.mean() > 0.6
    assert np.median(np.abs(d[known] - true0[known]) / true0[known]) < 0.01
    pf = photo_fill(K, views[0].c2w, (W, H), views[1:])
    ok = support_weight(pf.support, 2) >= 1
    assert ok.mean() > 0.4
    err = np.abs(pf.colour[ok] - views[0].image[ok]).mean()
    assert err < 0.03, f"mean abs colour error {err:.3f} where two photos agree"


def test_fill_has_no_support_where_every_neighbour_is_flared():
    rng = np.random.default_rng(4)
    views, _ = plane_views(rng, [[0.0, 0.0, -3.0], [0.3, 0.0, -3.0], [-0.3, 0.0, -3.0]])
    for v in views[1:]:
        v.depth = None
    for v in views[1:]:
        v.depth, _ = sweep_depth(v, [u for u in views if u is not v], 2.0, 5.0)
        v.valid = np.zeros((H, W), bool)
    pf = photo_fill(K, views[0].c2w, (W, H), views[1:])
    assert pf.support.max() == 0


@pytest.mark.parametrize("bad", [{"window": 4}, {"keep": 9}, {"planes": 1}])
def test_depth_config_rejects_bad_values(bad):
    from pipeline.depth import DepthConfig
    from pipeline.errors import UserError

    with pytest.raises(UserError, match="--"):
        DepthConfig(**bad).check()
