"""``WS/scene.glb``: sparse points and camera frustums for a quick look (trimesh).

Pose writes the sparse points and the input cameras; export rewrites the file with the
rendered camera path(s) added through ``extra_paths``. Coordinates are the workspace's
normalised world frame (cameras.json); glTF viewers show it as is (no axis change).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pipeline.cameras import Frame
from pipeline.workspace import atomic_write_bytes

INPUT_COLOR = (40, 110, 255, 255)
PATH_COLOR = (255, 140, 0, 255)


def frustum_segments(K: np.ndarray, width: int, height: int, c2w: np.ndarray,
                     depth: float) -> np.ndarray:
    """[9, 2, 3] line segments of a camera frustum of the given depth.

    K [3, 3] pinhole intrinsics, c2w [4, 4] camera-to-world (OpenCV axes). Four edges from
    the centre to the image corners, the image rectangle, and a tick on the top edge
    pointing "up" (-y in the image) so the camera's roll is visible.
    """
    px = np.array([[0, 0], [width, 0], [width, height], [0, height],
                   [width / 2, 0], [width / 2, -0.15 * height]], np.float64)
    rays = np.linalg.solve(K, np.c_[px, np.ones(len(px))].T).T * depth  # [6, 3] camera frame
    pts = rays @ c2w[:3, :3].T + c2w[:3, 3]
    c = c2w[:3, 3]
    segs = [(c, pts[i]) for i in range(4)]
    segs += [(pts[i], pts[(i + 1) % 4]) for i in range(4)]
    segs.append((pts[4], pts[5]))
    return np.asarray(segs)


def _path_segments(c2ws: np.ndarray, Ks: Sequence[np.ndarray], sizes: Sequence[tuple[int, int]],
                   depth: float) -> np.ndarray:
    """[S, 2, 3] a polyline through the camera centres plus a small frustum per pose, each
    with its own intrinsics ``Ks`` and image size ``sizes`` (a zoomed-in frame's narrower)."""
    centers = c2ws[:, :3, 3]
    segs = [np.stack([centers[:-1], centers[1:]], 1)] if len(c2ws) > 1 else []
    segs += [frustum_segments(K, w, h, c, depth)
             for c, K, (w, h) in zip(c2ws, Ks, sizes, strict=True)]
    return np.concatenate(segs, 0) if segs else np.zeros((0, 2, 3))


def write_scene_glb(path: str | os.PathLike, points: np.ndarray, colors: np.ndarray,
                    frames: Sequence[Frame], extra_paths: Sequence = ()) -> Path:
    """Write a GLB with a point cloud, one frustum per frame and optional camera paths.

    points [N, 3] float, colors [N, 3] uint8 RGB, frames: the posed input views,
    extra_paths: camera paths, in another colour, each a list of path cameras (anything with
    ``c2w``, ``K``, ``width`` and ``height``: ``gnfr.paths.PathCamera``), each frustum drawn
    with its own intrinsics, or [M, 4, 4] camera-to-world poses alone (drawn with the first
    frame's intrinsics). The frustum depth is 8% of the camera spread.
    """
    import trimesh

    scene = trimesh.Scene()
    if len(points):
        rgba = np.c_[np.asarray(colors, np.uint8).reshape(-1, 3),
                     np.full(len(points), 255, np.uint8)]
        scene.add_geometry(trimesh.PointCloud(np.asarray(points, np.float64), colors=rgba),
                           geom_name="points")
    centers = np.stack([f.center for f in frames]) if frames else np.zeros((0, 3))
    spread = np.linalg.norm(centers - centers.mean(0), axis=1).max() if len(centers) > 1 else 1
    depth = 0.08 * (spread if spread > 0 else 1.0)
    if frames:
        segs = np.concatenate([frustum_segments(f.K, f.width, f.height, f.c2w, depth)
                               for f in frames])
        scene.add_geometry(_lines(segs, INPUT_COLOR), geom_name="cameras")
    for i, path_cams in enumerate(extra_paths):
        if not len(path_cams):
            continue
        if isinstance(path_cams, np.ndarray):  # poses alone: the first frame's intrinsics
            c2ws = np.asarray(path_cams, np.float64).reshape(-1, 4, 4)
            ref = frames[0] if frames else None
            K = ref.K if ref else np.array([[1.0, 0, 0.5], [0, 1.0, 0.5], [0, 0, 1]])
            Ks, sizes = [K] * len(c2ws), [(ref.width, ref.height) if ref else (1, 1)] * len(c2ws)
        else:
            c2ws = np.stack([np.asarray(c.c2w, np.float64) for c in path_cams])
            Ks = [np.asarray(c.K, np.float64) for c in path_cams]
            sizes = [(c.width, c.height) for c in path_cams]
        segs = _path_segments(c2ws, Ks, sizes, 0.5 * depth)
        scene.add_geometry(_lines(segs, PATH_COLOR), geom_name=f"path{i}")
    return atomic_write_bytes(path, scene.export(file_type="glb"))


def read_scene_points(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """([N, 3] float points, [N, 3] uint8 RGB) of the point cloud in a scene.glb written
    by :func:`write_scene_glb` (empty arrays when it has none): lets a later stage rewrite
    the file with a camera path without pycolmap."""
    import trimesh

    scene = trimesh.load(str(path), force="scene")
    cloud = scene.geometry.get("points")
    if cloud is None:
        return np.zeros((0, 3)), np.zeros((0, 3), np.uint8)
    colors = np.asarray(cloud.colors, np.uint8)[:, :3] if len(cloud.colors) else np.full(
        (len(cloud.vertices), 3), 200, np.uint8)
    return np.asarray(cloud.vertices, np.float64), colors


def _lines(segs: np.ndarray, color: tuple[int, int, int, int]):
    """A trimesh Path3D of segments [S, 2, 3] in one colour."""
    import trimesh

    path = trimesh.load_path(np.asarray(segs, np.float64))
    path.colors = np.tile(np.asarray(color, np.uint8), (len(path.entities), 1))
    return path
