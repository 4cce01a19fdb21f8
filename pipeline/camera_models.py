"""COLMAP camera models in numpy: pixels <-> normalised image coordinates.

``WS/cameras.json`` keeps, per view, ``colmap_camera = {"model", "width", "height",
"params"}``: the full model of ``WS/decoded/<stem>.png`` as COLMAP estimated it. This module
maps pixels of that image to normalised coordinates ``(x, y)`` on the plane ``z = 1`` of the
camera (undistortion: ray direction ``(x, y, 1)`` in camera axes, OpenCV convention) and
back (distortion), following COLMAP's ``src/colmap/sensor/models.h`` formulas. Pixel centres
are at integer + 0.5 in COLMAP's convention; this module uses COLMAP's convention throughout
(``u = fx * x_distorted + cx``), callers add 0.5 to integer pixel indices.

Undistortion inverts the distortion with Newton steps (analytic-free: a central-difference
Jacobian, as COLMAP does), so every model only needs its forward ``distort`` formula.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.errors import UserError

# model name -> parameter names, in COLMAP's order
MODELS: dict[str, tuple[str, ...]] = {
    "SIMPLE_PINHOLE": ("f", "cx", "cy"),
    "PINHOLE": ("fx", "fy", "cx", "cy"),
    "SIMPLE_RADIAL": ("f", "cx", "cy", "k"),
    "RADIAL": ("f", "cx", "cy", "k1", "k2"),
    "OPENCV": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"),
    "FULL_OPENCV": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"),
    "SIMPLE_RADIAL_FISHEYE": ("f", "cx", "cy", "k"),
    "RADIAL_FISHEYE": ("f", "cx", "cy", "k1", "k2"),
    "OPENCV_FISHEYE": ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"),
}


@dataclass
class CameraModel:
    """One COLMAP camera: model name, image size and parameters."""

    model: str
    width: int
    height: int
    params: np.ndarray  # [P] in COLMAP's order for ``model``

    @classmethod
    def from_colmap(cls, d: dict) -> CameraModel:
        """From ``{"model", "width", "height", "params"}`` (``colmap_camera``)."""
        model = str(d.get("model", "")).upper()
        if model not in MODELS:
            raise UserError(f"camera model {model or '(none)'} is not supported (supported: "
                            f"{', '.join(MODELS)}): pose the scene with one of those")
        params = np.asarray(d["params"], np.float64)
        if len(params) != len(MODELS[model]):
            raise UserError(f"camera model {model} needs {len(MODELS[model])} parameters, "
                            f"got {len(params)}: rerun `deflare-scene pose WS --force`")
        return cls(model, int(d["width"]), int(d["height"]), params)

    @classmethod
    def pinhole(cls, K: np.ndarray, width: int, height: int) -> CameraModel:
        K = np.asarray(K, np.float64)
        return cls("PINHOLE", width, height, np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]]))

    def to_colmap(self) -> dict:
        return {"model": self.model, "width": self.width, "height": self.height,
                "params": [float(p) for p in self.params]}

    # intrinsics ------------------------------------------------------------
    @property
    def focal(self) -> tuple[float, float]:
        p = self.params
        return (p[0], p[0]) if MODELS[self.model][0] == "f" else (p[0], p[1])

    @property
    def principal(self) -> tuple[float, float]:
        p = self.params
        return (p[1], p[2]) if MODELS[self.model][0] == "f" else (p[2], p[3])

    @property
    def dist(self) -> np.ndarray:
        n = 3 if MODELS[self.model][0] == "f" else 4
        return self.params[n:]

    @property
    def K(self) -> np.ndarray:
        """[3, 3] the linear part (focal lengths, principal point)."""
        (fx, fy), (cx, cy) = self.focal, self.principal
        return np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])

    def scaled(self, sx: float, sy: float | None = None) -> CameraModel:
        """The same camera for the image resized by (sx, sy) (distortion unchanged)."""
        sy = sx if sy is None else sy
        p = self.params.copy()
        if MODELS[self.model][0] == "f":
            if abs(sx - sy) > 1e-6 * max(sx, sy):
                return self.as_two_focal().scaled(sx, sy)
            p[0] *= sx
            p[1] *= sx
            p[2] *= sy
        else:
            p[0] *= sx
            p[1] *= sy
            p[2] *= sx
            p[3] *= sy
        return CameraModel(self.model, round(self.width * sx), round(self.height * sy), p)

    def as_two_focal(self) -> CameraModel:
        """An equivalent model with separate fx, fy (OPENCV / FULL_OPENCV / PINHOLE family)."""
        f, cx, cy, *d = self.params
        m = self.model
        if m == "SIMPLE_PINHOLE":
            return CameraModel("PINHOLE", self.width, self.height, np.array([f, f, cx, cy]))
        if m in ("SIMPLE_RADIAL", "RADIAL"):
            k = list(d) + [0.0] * (2 - len(d))
            return CameraModel("OPENCV", self.width, self.height,
                               np.array([f, f, cx, cy, k[0], k[1], 0.0, 0.0]))
        if m in ("SIMPLE_RADIAL_FISHEYE", "RADIAL_FISHEYE"):
            k = list(d) + [0.0] * (4 - len(d))
            return CameraModel("OPENCV_FISHEYE", self.width, self.height,
                               np.array([f, f, cx, cy, *k]))
        return self

    # distortion in normalised coordinates ------------------------------------
    def distort(self, xy: np.ndarray) -> np.ndarray:
        """Undistorted normalised coordinates [N, 2] -> distorted ones [N, 2]."""
        xy = np.asarray(xy, np.float64)
        x, y = xy[:, 0], xy[:, 1]
        d, m = self.dist, self.model
        if m in ("SIMPLE_PINHOLE", "PINHOLE"):
            return xy.copy()
        if m.endswith("FISHEYE"):
            return self._distort_fisheye(x, y)
        r2 = x * x + y * y
        if m == "SIMPLE_RADIAL":
            radial = 1 + d[0] * r2
            return np.stack([x * radial, y * radial], 1)
        if m == "RADIAL":
            radial = 1 + d[0] * r2 + d[1] * r2 * r2
            return np.stack([x * radial, y * radial], 1)
        k1, k2, p1, p2 = d[:4]
        if m == "OPENCV":
            radial = 1 + k1 * r2 + k2 * r2 * r2
        else:  # FULL_OPENCV: rational model
            k3, k4, k5, k6 = d[4:]
            r4 = r2 * r2
            r6 = r4 * r2
            radial = (1 + k1 * r2 + k2 * r4 + k3 * r6) / (1 + k4 * r2 + k5 * r4 + k6 * r6)
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        yd = y * radial + 2 * p2 * x * y + p1 * (r2 + 2 * y * y)
        return np.stack([xd, yd], 1)

    def _distort_fisheye(self, x, y):
        d = self.dist
        r = np.sqrt(x * x + y * y)
        theta = np.arctan(r)
        t2 = theta * theta
        if self.model == "SIMPLE_RADIAL_FISHEYE":
            thetad = theta * (1 + d[0] * t2)
        elif self.model == "RADIAL_FISHEYE":
            thetad = theta * (1 + d[0] * t2 + d[1] * t2 * t2)
        else:
            thetad = theta * (1 + d[0] * t2 + d[1] * t2**2 + d[2] * t2**3 + d[3] * t2**4)
        s = np.where(r > 1e-12, thetad / np.maximum(r, 1e-300), 1.0)
        return np.stack([x * s, y * s], 1)

    def undistort(self, xyd: np.ndarray, iters: int = 100, tol: float = 1e-14) -> np.ndarray:
        """Distorted normalised coordinates [N, 2] -> undistorted ones [N, 2] (Newton)."""
        xyd = np.asarray(xyd, np.float64)
        if self.model in ("SIMPLE_PINHOLE", "PINHOLE") or not np.any(self.dist):
            return xyd.copy()
        xy = xyd.copy()
        eps = 1e-7
        ex, ey = np.array([eps, 0.0]), np.array([0.0, eps])
        active = np.ones(len(xy), bool)
        for _ in range(iters):
            a = xy[active]
            res = self.distort(a) - xyd[active]  # [M, 2]
            jx = (self.distort(a + ex) - self.distort(a - ex)) / (2 * eps)
            jy = (self.distort(a + ey) - self.distort(a - ey)) / (2 * eps)
            det = jx[:, 0] * jy[:, 1] - jy[:, 0] * jx[:, 1]
            det = np.where(np.abs(det) < 1e-12, 1e-12, det)
            dx = (jy[:, 1] * res[:, 0] - jy[:, 0] * res[:, 1]) / det
            dy = (-jx[:, 1] * res[:, 0] + jx[:, 0] * res[:, 1]) / det
            a = a - np.stack([dx, dy], 1)
            xy[active] = a
            done = np.abs(dx) + np.abs(dy) < tol
            idx = np.flatnonzero(active)
            active[idx[done]] = False
            if not active.any():
                break
        return xy

    # pixels ------------------------------------------------------------------
    def pixel_to_normalized(self, uv: np.ndarray) -> np.ndarray:
        """Pixels [N, 2] (COLMAP convention) -> undistorted normalised coordinates [N, 2]."""
        (fx, fy), (cx, cy) = self.focal, self.principal
        uv = np.asarray(uv, np.float64)
        return self.undistort(np.stack([(uv[:, 0] - cx) / fx, (uv[:, 1] - cy) / fy], 1))

    def normalized_to_pixel(self, xy: np.ndarray) -> np.ndarray:
        """Undistorted normalised coordinates [N, 2] -> pixels [N, 2]."""
        (fx, fy), (cx, cy) = self.focal, self.principal
        d = self.distort(xy)
        return np.stack([fx * d[:, 0] + cx, fy * d[:, 1] + cy], 1)

    def pixel_grid(self) -> np.ndarray:
        """[H, W, 2] COLMAP pixel coordinates of every pixel centre (index + 0.5)."""
        u, v = np.meshgrid(np.arange(self.width) + 0.5, np.arange(self.height) + 0.5)
        return np.stack([u, v], -1)


_MAPS: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
"""The last few ``warp_maps`` results by their cameras (the de-flared photos ask for one
view's maps twice: its flare mask, then its fill)."""
_MAPS_KEPT = 4


def _camera_key(c: CameraModel) -> tuple:
    return c.model, c.width, c.height, tuple(float(p) for p in c.params)


def warp_maps(src: CameraModel, dst: CameraModel) -> tuple[np.ndarray, np.ndarray]:
    """cv2.remap maps [H_dst, W_dst] float32 that resample an image of camera ``src`` into
    the geometry of camera ``dst`` (same pose; e.g. the pinhole ``WS/images`` camera into the
    distorted ``WS/decoded`` one). Map values are OpenCV pixel indices (centre at integer).
    The last few are kept (read-only arrays): undistorting every pixel is the slow part.
    """
    key = (_camera_key(src), _camera_key(dst))
    if key in _MAPS:
        return _MAPS[key]
    grid = dst.pixel_grid().reshape(-1, 2)
    xy = dst.pixel_to_normalized(grid)
    uv = src.normalized_to_pixel(xy) - 0.5
    shape = (dst.height, dst.width)
    maps = (uv[:, 0].reshape(shape).astype(np.float32),
            uv[:, 1].reshape(shape).astype(np.float32))
    for m in maps:
        m.setflags(write=False)
    while len(_MAPS) >= _MAPS_KEPT:
        del _MAPS[next(iter(_MAPS))]  # the oldest
    _MAPS[key] = maps
    return maps
