"""Test workspaces built without pycolmap, from ground-truth cameras.

``make_temple_workspace`` turns Middlebury templeSparseRing (ground-truth K, R, t in
``templeSR_par.txt``) into a posed workspace (``images/``, ``decoded/``, ``cameras.json``,
manifest with decode and pose complete), so model, mask and render tests need not run SfM.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from pipeline.cameras import Cameras, Frame, save_cameras
from pipeline.workspace import Workspace, atomic_imwrite
from tests.conftest import shared

# tight bounding box of the temple model (README of the data set)
TEMPLE_BOX = np.array([[-0.073568, 0.021728, -0.012445], [0.028855, 0.181892, 0.062736]])


def read_temple_par(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """{image name: (K [3,3], R [3,3], t [3])} with P = K [R | t]."""
    out = {}
    for line in path.read_text().splitlines()[1:]:
        parts = line.split()
        if len(parts) != 22:
            continue
        v = np.array(parts[1:], dtype=np.float64)
        out[parts[0]] = (v[:9].reshape(3, 3), v[9:18].reshape(3, 3), v[18:21])
    return out


def make_temple_workspace(root: Path, n_views: int = 8, scale: float = 0.5) -> Workspace:
    """A posed workspace of the first ``n_views`` temple views, resized by ``scale``."""
    src = shared("scenes", "temple")
    par = read_temple_par(src / "templeSR_par.txt")
    names = sorted(par)[:n_views]
    ws = Workspace.create(root, src)
    center = TEMPLE_BOX.mean(0)
    cam_centers = np.stack([-par[n][1].T @ par[n][2] for n in names])
    s = 1.0 / np.linalg.norm(cam_centers - center, axis=1).max()
    obj_r = np.linalg.norm(TEMPLE_BOX[1] - TEMPLE_BOX[0]) / 2 * s
    sim = np.eye(4)
    sim[:3, :3] *= s
    sim[:3, 3] = -s * center
    frames = []
    for name in names:
        K, R, t = par[name]
        img = cv2.imread(str(src / name), cv2.IMREAD_COLOR)
        h, w = img.shape[:2]
        W, H = round(w * scale), round(h * scale)
        img = cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA)
        stem = Path(name).stem
        atomic_imwrite(ws.images / f"{stem}.png", img)
        atomic_imwrite(ws.decoded / f"{stem}.png", img)
        Ks = K.copy()
        Ks[0] *= W / w
        Ks[1] *= H / h
        c2w = np.eye(4)
        c2w[:3, :3] = R.T
        c2w[:3, 3] = s * ((-R.T @ t) - center)
        dist = np.linalg.norm(c2w[:3, 3])
        frames.append(Frame(name=name, stem=stem, K=Ks, width=W, height=H, c2w=c2w,
                            near=max(dist - 1.5 * obj_r, 0.05), far=dist + 1.5 * obj_r,
                            colmap_camera={"model": "PINHOLE", "width": W, "height": H,
                                           "params": [Ks[0, 0], Ks[1, 1], Ks[0, 2], Ks[1, 2]]}))
    save_cameras(ws.cameras_json, Cameras(frames=frames, colmap_to_world=sim))
    for stage, outs in (("decode", [ws.decoded]), ("pose", [ws.images, ws.cameras_json])):
        ws.begin_stage(stage, {"fixture": "temple"}, []).finish(outs)
    return ws
