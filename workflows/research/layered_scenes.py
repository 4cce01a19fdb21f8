"""Synthetic layered scenes for pretraining: more scenes for the prior from the photos at hand.

The ``quick`` prior has ten real training scenes; GNT pretrains on hundreds. A layered scene
is a small world of textured planes (a large back plane and one to three cut-out planes in
front of it, each tilted a little), their textures cut from the training scenes' own photos,
seen by a dozen pinhole cameras around a point of interest. Each view is rendered exactly
(every plane warped into the view by its homography, the planes composited per pixel by
depth, cut-outs with soft edges), so geometry, occlusions and bounds are known and the
cameras agree with the images as well as any posed photo does. What such a world lacks:
view-dependent light, curved surfaces, fine depth detail; hence ``pretrain --layered`` mixes
them in at a share of the steps (``PretrainConfig.layered_share``), not in place of the real
scenes.

Frames as in ``pipeline.training_scenes``: OpenCV cameras (x right, y down, z forward),
pixel centres at +0.5, camera centres normalised into the unit sphere (``normalise``).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from gnfr.paths import look_at
from gnfr.train import Scene


@dataclass(frozen=True)
class LayeredConfig:
    """How a layered scene is drawn (ranges are drawn uniformly)."""

    views: int = 12
    """Views per scene."""
    size: tuple[int, int] = (504, 378)
    """(width, height) of every view: the pretraining's load size."""
    fov_deg: tuple[float, float] = (40.0, 70.0)
    """Horizontal field of view."""
    front: tuple[int, int] = (1, 3)
    """Cut-out planes in front of the back plane (inclusive)."""
    tilt_deg: float = 20.0
    """Largest tilt of a plane away from facing the cameras."""
    spread: tuple[float, float] = (0.3, 0.9)
    """Half-width of the camera positions, as a fraction of the distance to the point of
    interest (the baseline; real captures span from a step sideways to an orbit)."""


def tilted_normal(rng: np.random.Generator, max_deg: float) -> np.ndarray:
    """A unit normal within ``max_deg`` of -z (a plane facing cameras that look along +z)."""
    a = np.radians(rng.uniform(0, max_deg))
    phi = rng.uniform(0, 2 * np.pi)
    return np.array([np.sin(a) * np.cos(phi), np.sin(a) * np.sin(phi), -np.cos(a)])


@dataclass
class Plane:
    """A textured rectangle: world point ``origin`` + u * ``axis_u`` + v * ``axis_v`` at
    texel (u, v) (texel centres at +0.5); ``rgba`` is [h, w, 4] float 0..1."""

    origin: np.ndarray
    axis_u: np.ndarray
    axis_v: np.ndarray
    rgba: np.ndarray

    @property
    def normal(self) -> np.ndarray:
        n = np.cross(self.axis_u, self.axis_v)
        return n / np.linalg.norm(n)

    def homography(self, K: np.ndarray, w2c: np.ndarray) -> np.ndarray:
        """Texture pixel (OpenCV integer-centre convention) -> image pixel (same)."""
        R, t = w2c[:3, :3], w2c[:3, 3]
        H = K @ np.stack([R @ self.axis_u, R @ self.axis_v, R @ self.origin + t], 1)
        shift = np.array([[1, 0, 0.5], [0, 1, 0.5], [0, 0, 1.0]])   # texel centre at +0.5
        unshift = np.array([[1, 0, -0.5], [0, 1, -0.5], [0, 0, 1.0]])
        return unshift @ H @ shift


def plane_depth(plane: Plane, K: np.ndarray, w2c: np.ndarray, xs: np.ndarray,
                ys: np.ndarray) -> np.ndarray:
    """z-depth of ``plane`` (infinite) along the rays of pixels (xs, ys) (+0.5 centres);
    inf where the ray meets it behind the camera or not at all."""
    R, t = w2c[:3, :3], w2c[:3, 3]
    n = R @ plane.normal
    c = float(n @ (R @ plane.origin + t))   # the plane n . X = c in camera coordinates
    Kinv = np.linalg.inv(K)
    d = Kinv[0, 0] * xs + Kinv[0, 2], Kinv[1, 1] * ys + Kinv[1, 2]
    denom = n[0] * d[0] + n[1] * d[1] + n[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = c / denom
    return np.where(np.isfinite(z) & (z > 0), z, np.inf)


def crop(photo: np.ndarray, w: int, h: int, rng: np.random.Generator) -> np.ndarray:
    """A random crop of ``photo`` [H, W, 3] with the aspect of (w, h), resized to it."""
    H, W = photo.shape[:2]
    scale = rng.uniform(0.4, 1.0)
    cw = max(8, int(min(W, H * w / h) * scale))
    ch = max(8, int(cw * h / w))
    x0 = int(rng.integers(0, W - cw + 1))
    y0 = int(rng.integers(0, H - ch + 1))
    patch = photo[y0:y0 + ch, x0:x0 + cw]
    if rng.random() < 0.5:
        patch = patch[:, ::-1]
    interp = cv2.INTER_AREA if cw > w else cv2.INTER_LINEAR
    return cv2.resize(np.ascontiguousarray(patch), (w, h), interpolation=interp)


def mosaic(photos: list[np.ndarray], w: int, h: int, rng: np.random.Generator) -> np.ndarray:
    """A back-plane texture [h, w, 3] float: one crop, or a 2x1 / 1x2 / 2x2 mosaic of crops
    (a world with edges where surfaces meet)."""
    nx, ny = [(1, 1), (2, 1), (1, 2), (2, 2)][int(rng.integers(4))]
    out = np.zeros((h, w, 3), np.float32)
    xs, ys = np.linspace(0, w, nx + 1).astype(int), np.linspace(0, h, ny + 1).astype(int)
    for i in range(nx):
        for j in range(ny):
            p = photos[int(rng.integers(len(photos)))]
            out[ys[j]:ys[j + 1], xs[i]:xs[i + 1]] = crop(
                p, xs[i + 1] - xs[i], ys[j + 1] - ys[j], rng) / 255.0
    return out


def cutout(w: int, h: int, rng: np.random.Generator) -> np.ndarray:
    """An alpha matte [h, w] float 0..1: one to three ellipses or polygons, edges softened by
    a pixel (an object's silhouette, not a rectangle)."""
    m = np.zeros((h, w), np.uint8)
    for _ in range(int(rng.integers(1, 4))):
        cx, cy = rng.uniform(0.3, 0.7) * w, rng.uniform(0.3, 0.7) * h
        rx, ry = rng.uniform(0.15, 0.45) * w, rng.uniform(0.15, 0.45) * h
        if rng.random() < 0.5:
            cv2.ellipse(m, (int(cx), int(cy)), (int(rx), int(ry)), float(rng.uniform(0, 180)),
                        0, 360, 255, -1, cv2.LINE_AA)
        else:
            k = int(rng.integers(3, 9))
            ang = np.sort(rng.uniform(0, 2 * np.pi, k))
            r = rng.uniform(0.5, 1.0, k)
            pts = np.stack([cx + rx * r * np.cos(ang), cy + ry * r * np.sin(ang)], 1)
            cv2.fillPoly(m, [pts.astype(np.int32)], 255, cv2.LINE_AA)
    return cv2.GaussianBlur(m, (3, 3), 0).astype(np.float32) / 255.0


def plane_axes(normal: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Unit axes (u, v) of a plane facing ``normal``: u about horizontal, turned in the plane
    by up to 0.3 rad."""
    up = np.array([0.0, 1.0, 0.0])
    u = np.cross(up, normal)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    roll = rng.uniform(-0.3, 0.3)
    return np.cos(roll) * u + np.sin(roll) * v, -np.sin(roll) * u + np.cos(roll) * v


def texel_plane(centre: np.ndarray, axes: tuple[np.ndarray, np.ndarray], half_w: float,
                half_h: float, texels_per_unit: float, rgb_alpha) -> Plane:
    """A plane of world size (2 half_w, 2 half_h) centred at ``centre`` along ``axes``, its
    texture drawn by ``rgb_alpha(w, h) -> [h, w, 4]`` at ``texels_per_unit``."""
    w = int(np.clip(2 * half_w * texels_per_unit, 16, 2048))
    h = int(np.clip(2 * half_h * texels_per_unit, 16, 2048))
    u, v = axes
    du, dv = 2 * half_w / w * u, 2 * half_h / h * v
    return Plane(centre - half_w * u - half_h * v, du, dv, rgb_alpha(w, h))


def footprint(centre: np.ndarray, axes: tuple[np.ndarray, np.ndarray], K: np.ndarray,
              c2ws: list[np.ndarray], size: tuple[int, int]) -> tuple[float, float]:
    """Half-extents along ``axes`` of a plane through ``centre`` that hold where every
    camera's corner rays meet it (the whole view, when they meet it in front): a convex
    quadrilateral per view, so a rectangle around its corners covers the view."""
    W, H = size
    n = np.cross(*axes)
    corners = np.linalg.inv(K) @ np.array([[0.5, W - 0.5, 0.5, W - 0.5],
                                           [0.5, 0.5, H - 0.5, H - 0.5], [1, 1, 1, 1.0]])
    half_w = half_h = 0.0
    for c2w in c2ws:
        d = c2w[:3, :3] @ corners
        o = c2w[:3, 3]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((centre - o) @ n) / (n @ d)
        X = o[:, None] + d * np.where(t > 0, t, 0)          # behind: the draw is redrawn
        half_w = max(half_w, float(np.abs(axes[0] @ (X - centre[:, None])).max()))
        half_h = max(half_h, float(np.abs(axes[1] @ (X - centre[:, None])).max()))
    return half_w, half_h


def render(planes: list[Plane], K: np.ndarray, w2c: np.ndarray, size: tuple[int, int]
           ) -> tuple[np.ndarray, np.ndarray]:
    """(image [H, W, 3] float, depth [H, W] of the nearest opaque-ish surface) of the planes
    seen by one camera: each warped by its homography, composited per pixel back to front by
    its depth along the pixel's ray."""
    W, H = size
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64) + 0.5
    rgbs, alphas, depths = [], [], []
    for p in planes:
        Hm = p.homography(K, w2c)
        warped = cv2.warpPerspective(p.rgba, Hm, (W, H), flags=cv2.INTER_LINEAR,
                                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        z = plane_depth(p, K, w2c, xs, ys)
        a = np.where(np.isfinite(z), warped[..., 3], 0.0)
        rgbs.append(warped[..., :3])
        alphas.append(a)
        depths.append(z)
    depth = np.stack(depths)                          # [L, H, W]
    order = np.argsort(-depth, axis=0)                # farthest first
    img = np.zeros((H, W, 3))
    rgb, alpha = np.stack(rgbs), np.stack(alphas)
    for k in range(len(planes)):
        idx = order[k]
        a = np.take_along_axis(alpha, idx[None], 0)[0][..., None]
        c = np.take_along_axis(rgb, idx[None, ..., None], 0)[0]
        img = a * c + (1 - a) * img
    near_d = np.where(alpha > 0.5, depth, np.inf).min(0)
    return img, near_d


@dataclass
class World:
    """A layered world and its cameras, before normalisation (``draw_world``)."""

    planes: list[Plane]
    """Back plane first."""
    K: np.ndarray
    """[3, 3] intrinsics shared by every view."""
    c2w: np.ndarray
    """[N, 4, 4] camera-to-world (OpenCV)."""
    near: np.ndarray
    """[N] z-depth below every plane in each view (0.9 of the least at the image corners,
    where a plane's depth is extreme: 1/z is affine in the pixel)."""
    far: np.ndarray
    """[N] z-depth above every plane in each view (1.1 of the largest at the corners)."""
    size: tuple[int, int]
    """(width, height) of every view."""

    def render(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """View ``i``: (image [H, W, 3] float 0..1, depth [H, W]) (``render``)."""
        return render(self.planes, self.K, np.linalg.inv(self.c2w[i]), self.size)


def draw_world(photos: list[np.ndarray], rng: np.random.Generator,
               cfg: LayeredConfig = LayeredConfig()) -> World:
    """A random layered world (see the module's docstring), textures cut from ``photos``
    ([H, W, 3] uint8), every plane in front of every camera at each image corner."""
    W, H = cfg.size
    for _ in range(50):  # redraw the rare world a corner ray sees from behind
        fov = np.radians(rng.uniform(*cfg.fov_deg))
        f = W / 2 / np.tan(fov / 2)
        K = np.array([[f, 0, W / 2], [0, f, H / 2], [0, 0, 1.0]])
        dist = rng.uniform(1.5, 3.0)          # camera rig to the point of interest
        target = np.array([0.0, 0.0, dist])
        s = rng.uniform(*cfg.spread) * dist
        centres = np.stack([rng.uniform(-s, s, cfg.views), rng.uniform(-0.6 * s, 0.6 * s,
                            cfg.views), rng.uniform(-0.3 * s, 0.3 * s, cfg.views)], 1)
        up = np.array([0.0, -1.0, 0.0])     # world up: image rows run along +y
        c2ws = [look_at(c, target + rng.normal(0, 0.05 * dist, 3), up) for c in centres]
        w2cs = [np.linalg.inv(c) for c in c2ws]
        tpu = f / dist                        # about a texel per pixel at the point of interest
        # the back plane: far enough, large enough for every view's whole frustum
        z_back = dist * rng.uniform(1.1, 2.0)
        centre = np.array([0, 0, z_back])
        axes = plane_axes(tilted_normal(rng, cfg.tilt_deg), rng)
        half_w, half_h = footprint(centre, axes, K, c2ws, cfg.size)
        back = texel_plane(centre, axes, 1.02 * half_w + 1e-3, 1.02 * half_h + 1e-3,
                           tpu * dist / z_back,
                           lambda w, h: np.dstack([mosaic(photos, w, h, rng),
                                                   np.ones((h, w), np.float32)]))
        planes = [back]
        for _ in range(int(rng.integers(cfg.front[0], cfg.front[1] + 1))):
            z = rng.uniform(0.35, 0.85) * z_back
            direction = np.array([rng.uniform(-0.6, 0.6) * np.tan(fov / 2),
                                  rng.uniform(-0.4, 0.4) * np.tan(fov / 2), 1.0])
            ctr = direction * z
            hw = z * np.tan(fov / 2) * rng.uniform(0.25, 0.6)
            hh = hw * rng.uniform(0.6, 1.4)
            planes.append(texel_plane(
                ctr, plane_axes(tilted_normal(rng, cfg.tilt_deg), rng), hw, hh, tpu * dist / z,
                lambda w, h: np.dstack([crop(photos[int(rng.integers(len(photos)))], w, h,
                                             rng) / 255.0, cutout(w, h, rng)])))
        corners = np.array([0.5, W - 0.5]), np.array([0.5, H - 0.5])
        cx, cy = np.meshgrid(*corners)
        zs = np.array([[plane_depth(p, K, w2c, cx, cy) for p in planes] for w2c in w2cs])
        if np.isfinite(zs).all():
            break
    else:
        raise RuntimeError("layered scene: no world in front of every camera in 50 draws")
    return World(planes, K, np.stack(c2ws), 0.9 * zs.min((1, 2, 3)), 1.1 * zs.max((1, 2, 3)),
                 cfg.size)


def layered_scene(photos: list[np.ndarray], rng: np.random.Generator, name: str,
                  cfg: LayeredConfig = LayeredConfig()) -> Scene:
    """One layered scene (``draw_world``, every view rendered), normalised like a loaded
    scene (camera centres in the unit sphere, bounds scaled alike); no flare (pretraining
    imposes it)."""
    from pipeline.training_scenes import make_scene, normalise

    world = draw_world(photos, rng, cfg)
    images = [np.clip(np.round(world.render(i)[0] * 255), 0, 255).astype(np.uint8)
              for i in range(cfg.views)]
    c2w, near, far = normalise(world.c2w, world.near, world.far)
    stems = [f"{i:03d}" for i in range(cfg.views)]
    return make_scene(name, stems, images, np.repeat(world.K[None], cfg.views, 0), c2w, near,
                      far)


def layered_scenes(count: int, photos: list[np.ndarray], seed: int,
                   cfg: LayeredConfig = LayeredConfig()) -> list[Scene]:
    """``count`` layered scenes (``layered_scene``) drawn from ``seed``."""
    rng = np.random.default_rng([seed, 0x1A7E])
    return [layered_scene(photos, rng, f"layered{i:03d}", cfg) for i in range(count)]
