"""`WS/cameras.json`: the camera contract every stage after pose reads.

```
{"colmap_to_world": 4x4 similarity (normalised frame = this @ COLMAP frame),
 "frames": [{"name", "stem", "K" (3x3 of WS/images/<stem>.png), "width", "height",
             "c2w" (4x4 camera-to-world, OpenCV: x right, y down, z forward),
             "near", "far", "colmap_camera": {"model", "width", "height", "params"}}]}
```
The normalised frame puts the scene's centre at the origin and the farthest camera at
distance 1 (``normalising_scale``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pipeline.errors import UserError, shell_path
from pipeline.workspace import atomic_write_json, read_json


@dataclass
class Frame:
    """One posed view in the normalised world frame."""

    name: str
    """Original photo file name (the video's, for a video's frame)."""
    stem: str
    """File name without extension: the key of the view everywhere in the workspace."""
    K: np.ndarray
    """[3, 3] pinhole intrinsics of WS/images/<stem>.png."""
    width: int
    height: int
    c2w: np.ndarray
    """[4, 4] camera-to-world, OpenCV convention (x right, y down, z forward)."""
    near: float
    far: float
    colmap_camera: dict = field(default_factory=dict)
    """Full COLMAP camera of WS/decoded/<stem>.png: {"model", "width", "height", "params"}."""

    @property
    def center(self) -> np.ndarray:
        """[3] camera centre in the world frame."""
        return self.c2w[:3, 3]

    @property
    def w2c(self) -> np.ndarray:
        """[4, 4] world-to-camera."""
        return np.linalg.inv(self.c2w)

    def to_json(self) -> dict:
        return {
            "name": self.name, "stem": self.stem,
            "K": np.asarray(self.K, float).tolist(),
            "width": int(self.width), "height": int(self.height),
            "c2w": np.asarray(self.c2w, float).tolist(),
            "near": float(self.near), "far": float(self.far),
            "colmap_camera": self.colmap_camera,
        }

    @classmethod
    def from_json(cls, d: dict) -> Frame:
        return cls(name=d["name"], stem=d["stem"], K=np.asarray(d["K"], np.float64),
                   width=int(d["width"]), height=int(d["height"]),
                   c2w=np.asarray(d["c2w"], np.float64), near=float(d["near"]),
                   far=float(d["far"]), colmap_camera=d.get("colmap_camera", {}))


@dataclass
class Cameras:
    frames: list[Frame]
    colmap_to_world: np.ndarray = field(default_factory=lambda: np.eye(4))
    """[4, 4] similarity: normalised frame = this @ COLMAP frame."""

    def by_stem(self) -> dict[str, Frame]:
        return {f.stem: f for f in self.frames}

    @property
    def stems(self) -> list[str]:
        return [f.stem for f in self.frames]

    def centers(self) -> np.ndarray:
        """[N, 3] camera centres."""
        return np.stack([f.center for f in self.frames]) if self.frames else np.zeros((0, 3))


def normalising_scale(centers: np.ndarray, origin: np.ndarray, min_radius: float = 0.0
                      ) -> float:
    """The scale of the normalised world frame: the farthest camera centre [N, 3] ends at
    distance 1 from ``origin`` (the frame's new origin). ``min_radius`` floors the radius
    (forward-facing captures whose cameras barely move); 1.0 when all centres coincide.
    Every normalisation (pose, LLFF / COLMAP scenes, pretraining scenes) scales with this."""
    radius = max(float(np.linalg.norm(np.asarray(centers) - origin, axis=1).max()), min_radius)
    return 1.0 / radius if radius > 1e-12 else 1.0


def save_cameras(path: str | os.PathLike, cams: Cameras) -> Path:
    return atomic_write_json(path, {
        "colmap_to_world": np.asarray(cams.colmap_to_world, float).tolist(),
        "frames": [f.to_json() for f in cams.frames],
    })


def load_cameras(path: str | os.PathLike) -> Cameras:
    """Read cameras.json; a clear error when it is missing or malformed."""
    path = Path(path)
    if not path.exists():
        raise UserError(f"{path} is missing: run "
                        f"`deflare-scene pose {shell_path(path.parent)}` first")
    d = read_json(path)
    try:
        frames = [Frame.from_json(f) for f in d["frames"]]
        c2w = np.asarray(d.get("colmap_to_world", np.eye(4)), np.float64)
    except (KeyError, TypeError, ValueError) as e:
        raise UserError(f"{path} is malformed ({e!r}): rerun `deflare-scene pose "
                        f"{shell_path(path.parent)} --force`") from None
    return Cameras(frames=frames, colmap_to_world=c2w)
