"""Shared COLMAP helpers (pycolmap): reading, writing and importing sparse models, poses.

Conventions: COLMAP stores ``cam_from_world`` (world-to-camera, x right, y down, z
forward: the OpenCV convention), so a camera-to-world matrix is its inverse with no axis
flips. pycolmap is imported inside the functions: only the pose stage (and tests) call them.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pipeline import interrupts
from pipeline.errors import UserError
from pipeline.workspace import atomic_path

if TYPE_CHECKING:  # pragma: no cover
    import pycolmap

MODEL_FILES = ("cameras.bin", "cameras.txt")


def import_pycolmap():
    """The pycolmap module, imported on first use (the GPU machine has none), with SIGTERM
    taken back from glog's failure handler when the CLI owns it (``pipeline.interrupts``)."""
    import pycolmap

    interrupts.reclaim()
    return pycolmap


# --------------------------------------------------------------------------- models
def find_model_dir(path: str | os.PathLike) -> Path:
    """The folder holding cameras/images/points3D files: ``path``, ``path/sparse/0``,
    ``path/0`` or ``path/sparse``; a clear error when none is a COLMAP model."""
    path = Path(path)
    if not path.exists():
        raise UserError(f"COLMAP model {path} does not exist: pass the folder holding "
                        "cameras.bin, images.bin and points3D.bin (e.g. sparse/0)")
    for cand in (path, path / "sparse" / "0", path / "0", path / "sparse"):
        if any((cand / f).is_file() for f in MODEL_FILES):
            return cand
    raise UserError(f"{path} is not a COLMAP model (no cameras.bin or cameras.txt in it, in "
                    "sparse/0 or in 0): pass the folder of a COLMAP sparse reconstruction")


def read_model(path: str | os.PathLike) -> pycolmap.Reconstruction:
    """Read a COLMAP sparse model (binary or text); clear error when it is not one."""
    pycolmap = import_pycolmap()
    folder = find_model_dir(path)
    try:
        return pycolmap.Reconstruction(str(folder))
    except (ValueError, RuntimeError) as e:
        raise UserError(f"{folder} could not be read as a COLMAP model ({e}): export it "
                        "again from COLMAP (File > Export model)") from None


def write_model(rec: pycolmap.Reconstruction, folder: str | os.PathLike) -> Path:
    """Write ``rec`` as a binary COLMAP model into ``folder``, atomically."""
    folder = Path(folder)
    with atomic_path(folder) as tmp:
        tmp.mkdir(parents=True)
        rec.write(str(tmp))
    return folder


def largest_model(recs: dict[int, pycolmap.Reconstruction]) -> pycolmap.Reconstruction | None:
    """The model with the most registered images (then the most points); None if empty."""
    if not recs:
        return None
    return max(recs.values(), key=lambda r: (r.num_reg_images(), r.num_points3D()))


def registered_images(rec: pycolmap.Reconstruction) -> list:
    """Registered images sorted by name."""
    return sorted((rec.images[i] for i in rec.reg_image_ids()), key=lambda im: im.name)


# --------------------------------------------------------------------------- cameras/poses
def camera_dict(cam: pycolmap.Camera) -> dict:
    """{"model", "width", "height", "params"}: the contract's ``colmap_camera``."""
    return {"model": cam.model_name, "width": int(cam.width), "height": int(cam.height),
            "params": [float(p) for p in cam.params]}


def cam_to_world(image: pycolmap.Image) -> np.ndarray:
    """[4, 4] camera-to-world of a registered image (OpenCV axes, COLMAP world)."""
    w2c = np.eye(4)
    w2c[:3, :4] = image.cam_from_world().matrix()
    return np.linalg.inv(w2c)


def points_seen(rec: pycolmap.Reconstruction, image: pycolmap.Image) -> np.ndarray:
    """[M, 3] COLMAP-frame 3D points observed by ``image``."""
    ids = [p.point3D_id for p in image.points2D if p.has_point3D()]
    if not ids:
        return np.zeros((0, 3))
    return np.stack([rec.points3D[i].xyz for i in ids])


def all_points(rec: pycolmap.Reconstruction) -> tuple[np.ndarray, np.ndarray]:
    """([N, 3] float xyz, [N, 3] uint8 rgb) of every 3D point, in point id order."""
    pts = [p for _, p in sorted(rec.points3D.items(), key=lambda kv: kv[0])]
    if not pts:
        return np.zeros((0, 3)), np.zeros((0, 3), np.uint8)
    xyz = np.stack([p.xyz for p in pts])
    rgb = np.stack([np.asarray(p.color, np.uint8) for p in pts])
    return xyz, rgb


def umeyama(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Similarity (s, R [3, 3], t [3]) minimising |dst - (s R src + t)|^2; src, dst [N, 3]."""
    mu_s, mu_d = src.mean(0), dst.mean(0)
    xs, xd = src - mu_s, dst - mu_d
    U, S, Vt = np.linalg.svd(xd.T @ xs / len(src))
    D = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        D[2, 2] = -1
    R = U @ D @ Vt
    s = float(np.trace(np.diag(S) @ D) / (xs ** 2).sum(1).mean())
    return s, R, mu_d - s * R @ mu_s


# --------------------------------------------------------------------------- import
def import_model(src: str | os.PathLike, sizes: dict[str, tuple[int, int]]
                 ) -> pycolmap.Reconstruction:
    """Read an existing reconstruction and fit it to the workspace's decoded images.

    ``sizes`` maps each decoded stem to its (width, height). Model images are matched by
    file stem (``photos/IMG_1.JPG`` matches ``IMG_1``) and renamed ``<stem>.png``; cameras
    and 2D points are rescaled to the decoded size; images with no decoded counterpart are
    deregistered. Raises UserError when no image matches or an aspect ratio differs.
    """
    rec = read_model(src)
    targets: dict[int, tuple[int, int]] = {}
    for image_id in list(rec.reg_image_ids()):
        image = rec.images[image_id]
        stem = Path(image.name).stem
        if stem not in sizes:
            rec.deregister_frame(image.frame_id)
            continue
        _check_aspect(rec.cameras[image.camera_id], sizes[stem], image.name)
        targets[image.camera_id] = sizes[stem]
        image.name = f"{stem}.png"
    if not targets:
        raise UserError(f"no image of the COLMAP model {src} matches a decoded photo by name "
                        f"(decoded: {', '.join(sorted(sizes)[:5])}, ...): pass the model made "
                        "from these photos")
    scales = {}
    for cam_id, (w, h) in targets.items():
        cam = rec.cameras[cam_id]
        scales[cam_id] = np.array([w / cam.width, h / cam.height])
        cam.rescale(w, h)
    for image_id in rec.reg_image_ids():
        image = rec.images[image_id]
        for p in image.points2D:
            p.xy = np.asarray(p.xy) * scales[image.camera_id]
    return rec


def _check_aspect(cam: pycolmap.Camera, size: tuple[int, int], name: str) -> None:
    sx, sy = size[0] / cam.width, size[1] / cam.height
    if abs(sx - sy) > 0.01 * max(sx, sy):
        raise UserError(f"image {name} of the COLMAP model is {cam.width}x{cam.height} but its "
                        f"decoded photo is {size[0]}x{size[1]} (other aspect ratio: rotated or "
                        "cropped?): pass a model made from the same, uncropped photos")
