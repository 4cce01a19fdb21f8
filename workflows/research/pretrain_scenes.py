"""Posed pretraining workspaces from scenes that ship their own cameras (no SfM needed).

    python -m workflows.research.pretrain_scenes OUT [--data /work/shared/data/scenes]
        [--max-size 504]

* ``temple``, ``dino``: Middlebury ``*_par.txt`` (K, R, t per image) and the data set's
  tight bounding box (near/far from it);
* ``fox``: instant-ngp ``transforms.json`` (NeRF/OpenGL camera axes, flipped to OpenCV;
  lens distortion ignored), every third image present;
* ``buddha``: ``projections/<stem>_P.txt`` 3x4 ``P = K [R | t]`` split with
  ``cv2.decomposeProjectionMatrix``.

Cameras are centred and scaled into the unit sphere (the workspace convention,
``pipeline.cameras.normalising_scale``). Without a
bounding box, near/far come from the point the optical axes converge on (least squares):
an object around it of radius 0.6 x its mean camera distance. Scenes without cameras are
posed with ``deflare-scene decode`` + ``pose`` instead (see gnfr/weights/gnfr.md).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import cv2
import numpy as np

from pipeline.cameras import Cameras, Frame, normalising_scale
from pipeline.images import read_image
from pipeline.workspace import Workspace, atomic_imwrite
from pipeline.ws_files import write_cameras

BOXES = {"temple": [[-0.073568, 0.021728, -0.012445], [0.028855, 0.181892, 0.062736]],
         "dino": [[-0.061897, -0.018874, -0.057845], [0.010897, 0.068227, 0.015495]]}


def read_par(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """{image name: (K, R, t)} from a Middlebury ``*_par.txt`` (P = K [R | t])."""
    out = {}
    for line in path.read_text().splitlines()[1:]:
        fields = line.split()
        if len(fields) == 22:
            numbers = np.array(fields[1:], float)
            out[fields[0]] = (numbers[:9].reshape(3, 3), numbers[9:18].reshape(3, 3),
                              numbers[18:21])
    return out


def converge_point(c2w: np.ndarray) -> np.ndarray:
    """[3] least-squares closest point to every camera's optical axis. c2w: [N, 4, 4]."""
    A, b = np.zeros((3, 3)), np.zeros(3)
    for cam in c2w:
        axis = cam[:3, 2] / np.linalg.norm(cam[:3, 2])
        P = np.eye(3) - np.outer(axis, axis)
        A += P
        b += P @ cam[:3, 3]
    return np.linalg.lstsq(A, b, rcond=None)[0]


def write_workspace(root: Path, photos: Path, views: list[tuple[str, np.ndarray, np.ndarray]],
                    max_size: int, box: np.ndarray | None = None) -> Path:
    """views: (image path relative to ``photos``, K [3, 3] of the file, c2w [4, 4] OpenCV)."""
    ws = Workspace.create(root, photos)
    c2w = np.stack([v[2] for v in views])
    centre = box.mean(0) if box is not None else converge_point(c2w)
    scale = normalising_scale(c2w[:, :3, 3], centre)
    obj_r = (np.linalg.norm(box[1] - box[0]) / 2 * scale if box is not None
             else 0.6 * np.linalg.norm(c2w[:, :3, 3] - centre, axis=1).mean() * scale)
    frames = []
    for rel, K, cam in views:
        img = read_image(photos / rel, bgr=True)
        h, w = img.shape[:2]
        shrink = min(1.0, max_size / max(h, w))
        W, H = round(w * shrink), round(h * shrink)
        img = cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA)
        stem = Path(rel).stem
        atomic_imwrite(ws.image_path(stem), img)
        atomic_imwrite(ws.decoded_path(stem), img)
        Ks = K.copy()
        Ks[0] *= W / w
        Ks[1] *= H / h
        cw = cam.copy()
        cw[:3, 3] = scale * (cam[:3, 3] - centre)
        dist = np.linalg.norm(cw[:3, 3])
        frames.append(Frame(name=Path(rel).name, stem=stem, K=Ks, width=W, height=H, c2w=cw,
                            near=max(dist - 1.5 * obj_r, 0.05), far=dist + 1.5 * obj_r,
                            colmap_camera={"model": "PINHOLE", "width": W, "height": H,
                                           "params": [Ks[0, 0], Ks[1, 1], Ks[0, 2], Ks[1, 2]]}))
    sim = np.eye(4)
    sim[:3, :3] *= scale
    sim[:3, 3] = -scale * centre
    write_cameras(ws, Cameras(frames=frames, colmap_to_world=sim))
    for stage, outs in (("decode", [ws.decoded]), ("pose", [ws.images, ws.cameras_json])):
        ws.record_stage(stage, {"pretrain_scenes": photos.name}, outs)
    return root


def middlebury(folder: Path, name: str) -> list:
    """(image, K, c2w) of a Middlebury data set (``*_par.txt``)."""
    par = read_par(next(folder.glob("*_par.txt")))
    out = []
    for image in sorted(par):
        K, R, t = par[image]
        cam = np.eye(4)
        cam[:3, :3], cam[:3, 3] = R.T, -R.T @ t
        out.append((image, K, cam))
    return out


def fox(folder: Path, every: int = 3) -> list:
    """(image, K, c2w) of every ``every``-th image of an instant-ngp ``transforms.json``."""
    transforms = json.loads((folder / "transforms.json").read_text())
    K = np.array([[transforms["fl_x"], 0, transforms["cx"]],
                  [0, transforms["fl_y"], transforms["cy"]], [0, 0, 1.0]])
    out = []
    frames = [f for f in transforms["frames"] if (folder / f["file_path"]).is_file()]
    for frame in sorted(frames, key=lambda f: f["file_path"])[::every]:
        cam = np.array(frame["transform_matrix"], float)
        cam[:3, 1:3] *= -1  # OpenGL (y up, z back) -> OpenCV (y down, z forward)
        out.append((frame["file_path"], K, cam))
    return out


def buddha(folder: Path) -> list:
    """(image, K, c2w) from ``projections/<stem>_P.txt`` (P = K [R | t])."""
    out = []
    for img in sorted((folder / "images").glob("*.png")):
        P = np.loadtxt(folder / "projections" / f"{img.stem}_P.txt")
        K, R, c_h = cv2.decomposeProjectionMatrix(P)[:3]
        K = K / K[2, 2]
        cam = np.eye(4)
        cam[:3, :3], cam[:3, 3] = R.T, (c_h[:3] / c_h[3]).ravel()
        out.append((f"images/{img.name}", K, cam))
    return out


def main(argv: list[str] | None = None) -> int:
    """Write OUT/<scene>.deflare for each scene of --data that is present."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--data", type=Path, default=Path("/work/shared/data/scenes"))
    ap.add_argument("--max-size", type=int, default=504)
    args = ap.parse_args(argv)
    makers = {"temple": lambda p: middlebury(p, "temple"), "dino": lambda p: middlebury(p, "dino"),
              "fox": fox, "buddha": buddha}
    for name, make in makers.items():
        src = args.data / name
        if not src.is_dir():
            print(f"skip {name}: {src} is absent")
            continue
        box = np.array(BOXES[name]) if name in BOXES else None
        root = write_workspace(args.out / f"{name}.deflare", src, make(src), args.max_size, box)
        print(f"{name}: {root}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
