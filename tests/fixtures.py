"""Test workspaces built without pycolmap, from ground-truth cameras.

``make_temple_workspace`` turns Middlebury templeSparseRing (ground-truth K, R, t in
``templeSR_par.txt``) into a posed workspace (``images/``, ``decoded/``, ``cameras.json``,
manifest with decode and pose complete) through ``workflows.research.pretrain_scenes`` (the
same code that makes pretraining workspaces), so model, mask and render tests need not run SfM.
"""

from __future__ import annotations

import numpy as np

from pipeline.workspace import Workspace
from tests.conftest import shared
from workflows.research.pretrain_scenes import BOXES, middlebury, write_workspace
from workflows.research.pretrain_scenes import read_par as read_temple_par

__all__ = ["look_at", "make_plane_workspace", "make_temple_workspace", "plane_views",
           "read_temple_par"]


def make_temple_workspace(root, n_views: int = 8, scale: float = 0.5) -> Workspace:
    """A posed workspace of the first ``n_views`` temple views (640x480) resized by ``scale``."""
    src = shared("scenes", "temple")
    views = middlebury(src, "temple")[:n_views]
    write_workspace(root, src, views, max_size=round(640 * scale),
                    box=np.array(BOXES["temple"]))
    return Workspace(root)


def look_at(center, target=(0.0, 0.0, 0.0)) -> np.ndarray:
    """c2w [4, 4] (OpenCV) at ``center`` looking at ``target``, y roughly down."""
    c, t = np.asarray(center, float), np.asarray(target, float)
    z = (t - c) / np.linalg.norm(t - c)
    x = np.cross(np.array([0.0, 1.0, 0.0]), z)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, :3] = np.stack([x, np.cross(z, x), z], 1)
    m[:3, 3] = c
    return m


def plane_views(rng, centers, K, size, tilt: float = 0.3):
    """Photos of a randomly textured plane through the origin (normal tilted ``tilt`` about
    y from -z) from cameras at ``centers`` looking at the origin: (images [H, W, 3] float
    0..1, c2ws, true z-depth of each view [H, W])."""
    import cv2

    W, H = size
    tex = cv2.resize(rng.random((48, 64, 3)).astype(np.float32), (640, 480),
                     interpolation=cv2.INTER_CUBIC)
    tex = np.clip(cv2.GaussianBlur(tex, (0, 0), 1.0), 0, 1)
    n = np.array([np.sin(tilt), 0.0, -np.cos(tilt)])
    u, v = np.array([np.cos(tilt), 0.0, np.sin(tilt)]), np.array([0.0, 1.0, 0.0])
    A = np.array([[160.0, 0, 320], [0, 160.0, 240], [0, 0, 1]])  # plane (a, b, 1) -> tex px
    half = np.array([[1, 0, 0.5], [0, 1, 0.5], [0, 0, 1.0]])
    xs, ys = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    rays = np.stack([xs, ys, np.ones_like(xs)], -1) @ np.linalg.inv(K).T
    images, c2ws, depths = [], [], []
    for c in centers:
        c2w = look_at(c)
        w2c = np.linalg.inv(c2w)
        M = w2c[:3, :3] @ np.stack([u, v, np.zeros(3)], 1) + np.outer(w2c[:3, 3], [0, 0, 1])
        Hp = np.linalg.inv(half) @ K @ M @ np.linalg.inv(A) @ half
        images.append(cv2.warpPerspective(tex, Hp, (W, H), flags=cv2.INTER_LINEAR))
        c2ws.append(c2w)
        d_w = rays @ c2w[:3, :3].T
        depths.append(((-c2w[:3, 3]) @ n) / (d_w @ n))  # rays have camera z 1
    return images, c2ws, depths


def make_plane_workspace(root, n_views: int = 6, size=(160, 120), seed: int = 0) -> Workspace:
    """A posed workspace (decode and pose complete) of a textured plane seen by ``n_views``
    cameras on a short arc, exact cameras; near/far bracket the plane."""
    from pathlib import Path

    import cv2

    root = Path(root)
    W, H = size
    K = np.array([[1.0 * W, 0, W / 2], [0, 1.0 * W, H / 2], [0, 0, 1]])
    ang = np.linspace(-0.25, 0.25, n_views)
    centers = [[3.0 * np.sin(a), 0.1 * np.cos(3 * a), -3.0 * np.cos(a)] for a in ang]
    images, c2ws, depths = plane_views(np.random.default_rng(seed), centers, K, size)
    photos = root.parent / f"{root.name}_photos"
    photos.mkdir(parents=True, exist_ok=True)
    views = []
    for i, (img, c2w) in enumerate(zip(images, c2ws, strict=True)):
        name = f"plane{i:02d}.png"
        cv2.imwrite(str(photos / name), (img[..., ::-1] * 255).round().astype(np.uint8))
        views.append((name, K, c2w))
    write_workspace(root, photos, views, max_size=max(size),
                    box=np.array([[-1.5, -1.0, -0.6], [1.5, 1.0, 0.6]]))
    from pipeline.cameras import load_cameras, save_cameras

    ws = Workspace(root)
    cams = load_cameras(ws.cameras_json)
    scale = cams.colmap_to_world[0, 0]
    for f, d in zip(cams.frames, depths, strict=True):  # near/far from the true depths
        f.near, f.far = float(d.min() * scale / 1.3), float(d.max() * scale * 1.3)
    save_cameras(ws.cameras_json, cams)
    return ws
