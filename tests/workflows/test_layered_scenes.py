"""Synthetic layered scenes for pretraining: exact rendering, views that agree on one world."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from gnfr.paths import look_at
from workflows.research.layered_scenes import (
    LayeredConfig,
    Plane,
    draw_world,
    layered_scene,
    plane_depth,
    render,
)


def _photos(n=4, size=(96, 128), seed=0):
    """Random colour fields with detail about 4 pixels across (so a fraction of a pixel's
    misregistration shows in the colours)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        small = rng.uniform(0, 255, (size[0] // 4, size[1] // 4, 3)).astype(np.float32)
        out.append(cv2.resize(small, size[::-1], interpolation=cv2.INTER_CUBIC)
                   .clip(0, 255).astype(np.uint8))
    return out


def test_render_matches_the_ray_plane_intersection():
    """A pixel of a rendered tilted plane has the texture's colour where the pixel's ray
    meets the plane (computed independently: ray, intersection, texel coordinates), and the
    depth of that intersection."""
    rng = np.random.default_rng(1)
    tex = np.dstack([_photos(1, (80, 120))[0] / 255.0, np.ones((80, 120))]).astype(np.float32)
    n = np.array([0.2, -0.1, -1.0])
    n /= np.linalg.norm(n)
    u = np.cross([0.0, 1.0, 0.0], n)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    plane = Plane(np.array([0.0, 0.0, 4.0]) - 60 * 0.05 * u - 40 * 0.05 * v, u * 0.05,
                  v * 0.05, tex)                           # 6 x 4 world units centred at z 4
    K = np.array([[60.0, 0, 40], [0, 60.0, 30], [0, 0, 1]])
    c2w = look_at(np.array([0.2, 0.1, 0.0]), np.array([0.0, 0.0, 4.0]), np.array([0, -1.0, 0]))
    w2c = np.linalg.inv(c2w)
    img, depth = render([plane], K, w2c, (80, 60))
    ys, xs = rng.integers(5, 55, 200), rng.integers(5, 75, 200)
    d_cam = np.linalg.inv(K) @ np.stack([xs + 0.5, ys + 0.5, np.ones(200)])
    d_world = c2w[:3, :3] @ d_cam
    o = c2w[:3, 3]
    t = ((plane.origin - o) @ plane.normal) / (plane.normal @ d_world)
    X = o[:, None] + d_world * t
    uv = np.linalg.lstsq(np.stack([plane.axis_u, plane.axis_v], 1), X - plane.origin[:, None],
                         rcond=None)[0]                     # continuous texel coordinates
    inside = (uv[0] > 1) & (uv[0] < 119) & (uv[1] > 1) & (uv[1] < 79)
    assert inside.sum() > 100
    want = cv2.remap(tex[..., :3], (uv[0] - 0.5).astype(np.float32)[None],
                     (uv[1] - 0.5).astype(np.float32)[None], cv2.INTER_LINEAR)[0]
    np.testing.assert_allclose(img[ys, xs][inside], want[inside], atol=2e-3)
    np.testing.assert_allclose(depth[ys, xs][inside], t[inside], rtol=1e-9)   # camera z = t
    assert np.isclose(plane_depth(plane, K, w2c, np.array([40.5]), np.array([30.5]))[0],
                      depth[30, 40])


def test_the_views_of_a_world_agree_on_it():
    """A surface point seen by view 0 projects into view 1 at the colour view 1 shows there,
    wherever view 1 sees the same point (not occluded; away from cut-out edges), and every
    rendered depth lies within the view's bounds."""
    cfg = LayeredConfig(views=3, size=(160, 120))
    world = draw_world(_photos(), np.random.default_rng(4), cfg)
    (img0, dep0), (img1, dep1) = world.render(0), world.render(1)
    for i in range(cfg.views):
        d = world.render(i)[1]
        assert (world.near[i] <= d.min()) and (d[np.isfinite(d)].max() <= world.far[i])
    ys, xs = np.mgrid[0:120, 0:160]
    pix = np.stack([xs.ravel() + 0.5, ys.ravel() + 0.5, np.ones(xs.size)])
    X = world.c2w[0, :3, :3] @ (np.linalg.inv(world.K) @ pix * dep0.ravel()) \
        + world.c2w[0, :3, 3:]
    w2c1 = np.linalg.inv(world.c2w[1])
    Xc = w2c1[:3, :3] @ X + w2c1[:3, 3:]
    p = world.K @ Xc
    x1, y1 = p[0] / p[2] - 0.5, p[1] / p[2] - 0.5
    xi, yi = np.round(x1).astype(int), np.round(y1).astype(int)
    ok = (xi >= 2) & (xi < 158) & (yi >= 2) & (yi < 118)
    ok[ok] &= np.abs(dep1[yi[ok], xi[ok]] - Xc[2, ok]) < 1e-2 * Xc[2, ok]     # the same point
    lap = np.abs(cv2.Laplacian(dep0.astype(np.float32), cv2.CV_32F))
    depth_edges = cv2.dilate((lap > 1e-3 * dep0).astype(np.uint8), np.ones((5, 5), np.uint8)
                             ).ravel() > 0                 # where a cut-out's edge is
    ok &= ~depth_edges
    assert ok.sum() > 2000, "views 0 and 1 share too few visible points to compare"
    seen = cv2.remap(img1.astype(np.float32), x1.astype(np.float32)[None],
                     y1.astype(np.float32)[None], cv2.INTER_LINEAR)[0]
    diff = np.abs(seen[ok] - img0.reshape(-1, 3)[ok])
    # a third of a pixel's error in view 1's position fails this (95th percentile 0.06)
    assert np.median(diff) < 0.003 and np.percentile(diff, 95) < 0.03


def test_layered_scene_is_normalised_like_a_loaded_scene():
    """Camera centres inside the unit sphere (the largest on it), the bounds scaled by the
    same factor, proper rotations, every view the configured size."""
    cfg = LayeredConfig(views=5, size=(64, 48))
    rng_a, rng_b = np.random.default_rng(7), np.random.default_rng(7)
    world = draw_world(_photos(), rng_a, cfg)
    scene = layered_scene(_photos(), rng_b, "l0", cfg)
    centres = scene.c2w[:, :3, 3].numpy()
    assert np.isclose(np.linalg.norm(centres, axis=1).max(), 1.0, atol=1e-6)
    scale = np.linalg.norm(centres[1] - centres[0]) / np.linalg.norm(
        world.c2w[1, :3, 3] - world.c2w[0, :3, 3])
    np.testing.assert_allclose(scene.near.numpy(), world.near * scale, rtol=1e-9)
    np.testing.assert_allclose(scene.far.numpy(), world.far * scale, rtol=1e-9)
    np.testing.assert_allclose(np.linalg.det(scene.c2w[:, :3, :3].numpy()), 1.0, atol=1e-9)
    assert tuple(scene.images.shape) == (5, 3, 48, 64) and scene.name == "l0"
    assert set(scene.ranked) == set(scene.stems)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_drawn_world_is_in_front_of_its_cameras(seed):
    world = draw_world(_photos(), np.random.default_rng(seed), LayeredConfig(size=(64, 48)))
    assert (world.near > 0).all() and (world.far > world.near).all()
    for i in range(len(world.c2w)):
        assert np.isfinite(world.render(i)[1]).all()  # the back plane covers every pixel
