"""Camera paths: builders that return poses, and the JSON camera-path formats.

Pure numpy, no files. Poses are camera-to-world ``[4, 4]`` matrices in the OpenCV
convention (x right, y down, z forward), the convention of ``WS/cameras.json``.

- :func:`order_tour` orders camera centres into a short tour (nearest neighbour + 2-opt).
- :func:`interpolate_path` runs a smooth path through key poses: Catmull-Rom positions
  (centripetal knots) and spherical Catmull-Rom rotations (the Barry-Goldman pyramid with
  slerp in place of lerp), resampled to an even pace of image motion where the scene's
  points are given (:func:`image_shift`), else to constant speed. It passes through every
  key pose; :func:`interpolate_tour` also carries each key's zoom along the tour.
- :func:`spiral_path` is the LLFF spiral for forward-facing captures, and an orbit with a
  vertical wave for captures that surround the scene.
- :class:`PathCamera`, :func:`path_from_json`, :func:`path_to_json` read and write the
  project's camera-path JSON; :func:`path_from_nerfstudio` and :func:`path_to_nerfstudio`
  map nerfstudio's ``camera_path`` JSON (OpenGL convention, vertical fov in degrees).
See ``docs/camera_paths.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# flip of the y and z camera axes: OpenCV (x right, y down, z forward) <-> OpenGL (y up, z back)
CV_GL = np.diag([1.0, -1.0, -1.0, 1.0])


# --------------------------------------------------------------------------- rotations
def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Rotation matrices [..., 3, 3] -> unit quaternions [..., 4] (w, x, y, z), w >= 0."""
    R = np.asarray(R, np.float64)
    m = R.reshape(-1, 3, 3)
    q = np.empty((len(m), 4))
    for i, r in enumerate(m):
        # Shepperd: pick the largest of the four squared components for stability
        t = np.array([1 + r[0, 0] + r[1, 1] + r[2, 2], 1 + r[0, 0] - r[1, 1] - r[2, 2],
                      1 - r[0, 0] + r[1, 1] - r[2, 2], 1 - r[0, 0] - r[1, 1] + r[2, 2]])
        k = int(np.argmax(t))
        s = 2.0 * np.sqrt(max(t[k], 1e-300))
        if k == 0:
            v = [s / 4, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
        elif k == 1:
            v = [(r[2, 1] - r[1, 2]) / s, s / 4, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s]
        elif k == 2:
            v = [(r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, s / 4, (r[1, 2] + r[2, 1]) / s]
        else:
            v = [(r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, s / 4]
        q[i] = v
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q.reshape(R.shape[:-2] + (4,))


def matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """Quaternions [..., 4] (w, x, y, z; normalised here) -> rotation matrices [..., 3, 3]."""
    q = np.asarray(q, np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical interpolation of quaternions [..., 4] at weights t [...] (any real t)."""
    d = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(d < 0, -q1, q1)
    d = np.abs(d).clip(max=1.0)
    t = np.asarray(t, np.float64)[..., None]
    theta = np.arccos(d)
    small = theta < 1e-6
    s = np.where(small, 1.0, np.sin(theta))
    w0 = np.where(small, 1 - t, np.sin((1 - t) * theta) / s)
    w1 = np.where(small, t, np.sin(t * theta) / s)
    out = w0 * q0 + w1 * q1
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def rotation_angle(Ra: np.ndarray, Rb: np.ndarray) -> np.ndarray:
    """Angle in radians between rotations [..., 3, 3]."""
    c = (np.trace(np.swapaxes(Ra, -1, -2) @ Rb, axis1=-2, axis2=-1) - 1) / 2
    return np.arccos(np.clip(c, -1.0, 1.0))


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """[4, 4] OpenCV camera-to-world at ``eye`` looking at ``target``; ``up`` is world-up."""
    z = np.asarray(target, float) - np.asarray(eye, float)
    z /= np.linalg.norm(z)
    x = np.cross(-np.asarray(up, float), z)  # x = y × z with y pointing down (-up)
    if np.linalg.norm(x) < 1e-9:  # looking straight along up: any perpendicular x
        x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    c2w = np.eye(4)
    c2w[:3, :3] = np.stack([x, y, z], 1)
    c2w[:3, 3] = eye
    return c2w


def world_up(c2ws: np.ndarray, iters: int = 3) -> np.ndarray:
    """[3] unit world-up estimated from cameras [N, 4, 4].

    Start from the mean of the cameras' up axes (-y in OpenCV); then, since a photo may be
    taken rolled by 90 or 180 degrees (portrait or upside-down shots whose pixels were not
    rotated), take from every camera whichever of its four in-image axes (-y, y, -x, x) is
    closest to the current estimate and average again. Cameras held upright dominate."""
    R = np.asarray(c2ws, np.float64)[:, :3, :3]
    up = -R[:, :, 1].mean(0)
    if np.linalg.norm(up) < 1e-9:
        up = -R[0, :, 1]
    up = up / np.linalg.norm(up)
    cands = np.stack([-R[:, :, 1], R[:, :, 1], -R[:, :, 0], R[:, :, 0]], 1)  # [N, 4, 3]
    for _ in range(iters):
        pick = np.argmax(cands @ up, axis=1)
        new = cands[np.arange(len(R)), pick].mean(0)
        if np.linalg.norm(new) < 1e-9:
            break
        up = new / np.linalg.norm(new)
    return up


def upright(c2ws: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Cameras [N, 4, 4] rolled about their viewing axis so their image up is as close to
    ``up`` as their viewing direction allows (positions and viewing directions kept)."""
    out = np.array(c2ws, np.float64, copy=True)
    for i, c in enumerate(out):
        out[i] = look_at(c[:3, 3], c[:3, 3] + c[:3, 2], up)
    return out


# --------------------------------------------------------------------------- tour ordering
def order_tour(centers: np.ndarray, start: int | None = None,
               rotations: np.ndarray | None = None, depth: float | None = None) -> np.ndarray:
    """Order camera centres [N, 3] into a short open tour; returns indices [N].

    Nearest-neighbour from an end of the capture (the centre farthest from the mean unless
    ``start`` is given), then 2-opt segment reversals until no reversal shortens the tour.
    The length of a step is its travel; with ``rotations`` [N, 3, 3] (the cameras' own, e.g.
    rolled upright) and the scene's typical ``depth`` it is the image motion the step makes
    (:func:`tour_lengths`), so the tour does not pair two cameras at one spot looking apart,
    and a capture that turns on the spot is toured by its turns.
    """
    c = np.asarray(centers, np.float64)
    n = len(c)
    if n <= 2:
        return np.arange(n)
    d = np.linalg.norm(c[:, None] - c[None], axis=-1)
    if rotations is not None:
        if depth is None:
            raise ValueError("a tour with rotations needs the scene's depth")
        d = tour_lengths(d, rotations, depth)
    cur = int(np.argmax(np.linalg.norm(c - c.mean(0), axis=1))) if start is None else start
    order, left = [cur], set(range(n)) - {cur}
    while left:
        cur = min(left, key=lambda j: (d[cur, j], j))
        order.append(cur)
        left.remove(cur)
    order = np.array(order)
    improved = True
    while improved:
        improved = False
        for i in range(0, n - 2):
            for j in range(i + 2, n):
                a, b = order[i], order[i + 1]
                cj = order[j]
                nj = order[j + 1] if j + 1 < n else None
                old = d[a, b] + (d[cj, nj] if nj is not None else 0.0)
                new = d[a, cj] + (d[b, nj] if nj is not None else 0.0)
                if new < old - 1e-12:
                    order[i + 1: j + 1] = order[i + 1: j + 1][::-1].copy()
                    improved = True
    return order


def tour_lengths(dist: np.ndarray, rotations: np.ndarray, depth: float) -> np.ndarray:
    """[N, N] step lengths of :func:`order_tour` with turns: the travel ``dist`` [N, N] over
    the scene's typical ``depth`` plus the angle in radians between ``rotations``
    [N, 3, 3], each about the image motion it makes (a step sideways by the depth moves
    the scene by as much as a turn of one radian)."""
    R = np.asarray(rotations, np.float64)
    return (np.asarray(dist, np.float64) / max(float(depth), 1e-9)
            + rotation_angle(R[:, None], R[None]))


# --------------------------------------------------------------------------- interpolation
def _lerp(a, b, w):
    return a + (b - a) * w[..., None]


def _catmull_rom(p: np.ndarray, q: np.ndarray, knots: np.ndarray, t: np.ndarray):
    """Barry-Goldman evaluation of one segment from key 1 to key 2 of four keys.

    p [4, 3] positions, q [4, 4] quaternions, knots [4], t [F] in [knots[1], knots[2]].
    Positions use lerp, rotations slerp (spherical Catmull-Rom). Returns ([F, 3], [F, 4]).
    """
    t0, t1, t2, t3 = knots

    def w(a, b):
        return (t - a) / (b - a)

    a = [_lerp(p[i], p[i + 1], w(knots[i], knots[i + 1])) for i in range(3)]
    qa = [slerp(q[i], q[i + 1], w(knots[i], knots[i + 1])) for i in range(3)]
    b1, b2 = _lerp(a[0], a[1], w(t0, t2)), _lerp(a[1], a[2], w(t1, t3))
    qb1, qb2 = slerp(qa[0], qa[1], w(t0, t2)), slerp(qa[1], qa[2], w(t1, t3))
    return _lerp(b1, b2, w(t1, t2)), slerp(qb1, qb2, w(t1, t2))


@dataclass
class PoseSpline:
    """A C1 spline through key poses: Catmull-Rom positions, spherical Catmull-Rom rotations.

    Knots are centripetal (alpha 0.5) in a distance that adds camera travel and rotation
    angle (scaled to a length), so keys with equal centres but different views still get
    room to turn. ``closed`` joins the last key back to the first.
    """

    positions: np.ndarray  # [N, 3]
    quats: np.ndarray  # [N, 4], consecutive ones in one hemisphere
    knots: np.ndarray  # [N + 1] if closed else [N]
    closed: bool

    @classmethod
    def fit(cls, c2ws: np.ndarray, closed: bool = False) -> PoseSpline:
        c2ws = np.asarray(c2ws, np.float64)
        pos, q = c2ws[:, :3, 3].copy(), quat_from_matrix(c2ws[:, :3, :3])
        for i in range(1, len(q)):  # shortest arcs between neighbours
            if np.dot(q[i - 1], q[i]) < 0:
                q[i] = -q[i]
        idx = list(range(len(pos))) + ([0] if closed else [])
        dp = np.linalg.norm(np.diff(pos[idx], axis=0), axis=1)
        da = rotation_angle(c2ws[idx[:-1], :3, :3], c2ws[idx[1:], :3, :3])
        scale = dp.mean() / max(da.mean(), 1e-9) if dp.mean() > 0 else 1.0
        step = np.sqrt(dp + scale * da) + 1e-9
        knots = np.concatenate([[0.0], np.cumsum(step)])
        return cls(pos, q, knots, closed)

    def _four(self, seg: int):
        """Keys and knots around segment ``seg`` (key seg -> seg + 1), phantom ends if open."""
        n = len(self.positions)
        if self.closed:
            ids = [(seg + k) % n for k in (-1, 0, 1, 2)]
            p, q = self.positions[ids], self.quats[ids].copy()
            k = self.knots  # [n + 1]; key n is key 0 again
            before = k[seg - 1] if seg > 0 else k[0] - (k[n] - k[n - 1])
            after = k[seg + 2] if seg + 2 <= n else k[n] + (k[1] - k[0])
            kn = np.array([before, k[seg], k[seg + 1], after])
        else:
            ids = [max(seg - 1, 0), seg, seg + 1, min(seg + 2, n - 1)]
            p, q = self.positions[ids].copy(), self.quats[ids].copy()
            kn = self.knots[ids].copy()
            if seg == 0:  # reflect the first key through the second
                p[0], q[0] = 2 * p[1] - p[2], slerp(q[2], q[1], np.array(2.0))
                kn[0] = kn[1] - (kn[2] - kn[1])
            if seg + 2 > n - 1:
                p[3], q[3] = 2 * p[2] - p[1], slerp(q[1], q[2], np.array(2.0))
                kn[3] = kn[2] + (kn[2] - kn[1])
        for i in range(1, 4):
            if np.dot(q[i - 1], q[i]) < 0:
                q[i] = -q[i]
        return p, q, kn

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Poses [F, 4, 4] at spline parameters t [F] in [knots[0], knots[-1]]."""
        t = np.clip(np.asarray(t, np.float64), self.knots[0], self.knots[-1])
        seg = np.clip(np.searchsorted(self.knots, t, side="right") - 1, 0, len(self.knots) - 2)
        out = np.tile(np.eye(4), (len(t), 1, 1))
        for s in np.unique(seg):
            sel = seg == s
            p, q, kn = self._four(int(s))
            pos, quat = _catmull_rom(p, q, kn, t[sel])
            out[sel, :3, :3] = matrix_from_quat(quat)
            out[sel, :3, 3] = pos
        return out


@dataclass
class Tour:
    """A path through key poses (:func:`interpolate_tour`): the frames' poses and zooms."""

    poses: np.ndarray  # [F, 4, 4]
    zoom: np.ndarray  # [F], each frame's focal length over the path's base one (1: none)


def key_blend(values: np.ndarray, knots: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Per-key positive ``values`` [K] (one per knot, in tour order) at spline parameters
    ``t``: between two keys a smoothstep in the log, so each key's value is met exactly,
    held still there (no jump in the rate of change at a key) and never overshot."""
    v = np.log(np.asarray(values, np.float64))
    t = np.clip(np.asarray(t, np.float64), knots[0], knots[-1])
    seg = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)
    w = (t - knots[seg]) / (knots[seg + 1] - knots[seg])
    w = w * w * (3 - 2 * w)
    return np.exp(v[seg] + (v[seg + 1] - v[seg]) * w)


def interpolate_tour(c2ws: np.ndarray, n_frames: int, closed: bool = False,
                     order: bool = True, up: np.ndarray | None = None,
                     points: np.ndarray | None = None,
                     fov: tuple[float, float] = (1.0, 0.75),
                     tour: str = "position", depth: float | None = None,
                     zoom: np.ndarray | None = None) -> Tour:
    """A smooth path of ``n_frames`` through key poses c2ws [N, 4, 4] at an even pace.

    ``order`` first sorts the keys into a short tour (:func:`order_tour`; ``tour``
    ``view``: by travel over the scene's ``depth`` plus turn, ``position``: by travel;
    without ``depth`` a tenth of the keys' spread, as the arc below); the path starts
    at the first key of the tour and (open path) ends at its last. With ``up`` the keys are
    first rolled upright (:func:`upright`), so portrait or upside-down photos do not make
    the video spin.

    The frames lie evenly along an arc. With ``points`` [P, 3] (the scene, e.g.
    :func:`bounds_points`) the arc is the image motion: between two of the spline's dense
    samples, the median shift of the points both see (:func:`image_shift`, ``fov`` the
    half-width and half-height of the view at unit focal length), so a whip-pan and a walk
    towards a close wall get the frames their motion needs. Without, it is the travel plus
    0.1 x the keys' spread per radian turned.

    ``zoom`` [N] (each key's focal length over the path's base one, positive) is carried
    along the tour (:func:`key_blend`): every frame at a key has that key's zoom. The arc
    then measures the image motion in each sample's zoomed view (a zoomed-in stretch moves
    the image faster, and a change of zoom moves it too); without ``points``, the travel
    and turn times the zoom, plus 0.1 x the keys' spread per unit of log zoom (as a
    radian's turn). Without ``zoom`` every frame's is 1.
    """
    c2ws = np.asarray(c2ws, np.float64)
    keys_zoom = np.ones(len(c2ws)) if zoom is None else np.asarray(zoom, np.float64)
    if keys_zoom.shape != (len(c2ws),) or not np.all(keys_zoom > 0):
        raise ValueError("zoom must be one positive number per key pose")
    if up is not None:
        c2ws = upright(c2ws, up)
    if n_frames < 1:
        raise ValueError("n_frames must be >= 1")
    if len(c2ws) == 1:
        return Tour(np.repeat(c2ws, n_frames, axis=0), np.repeat(keys_zoom, n_frames))
    span = np.linalg.norm(np.ptp(c2ws[:, :3, 3], axis=0)) or 1.0  # the keys' spread
    if order:
        if tour not in ("position", "view"):
            raise ValueError(f"tour must be position or view, not {tour!r}")
        rots = c2ws[:, :3, :3] if tour == "view" else None
        if rots is not None and depth is None:
            depth = 0.1 * span
        keys = order_tour(c2ws[:, :3, 3], rotations=rots, depth=depth)
        c2ws, keys_zoom = c2ws[keys], keys_zoom[keys]
    if closed:
        keys_zoom = np.append(keys_zoom, keys_zoom[0])
    spline = PoseSpline.fit(c2ws, closed)
    dense_t = np.linspace(spline.knots[0], spline.knots[-1], 64 * len(c2ws) + 1)
    dense = spline(dense_t)
    da = rotation_angle(dense[:-1, :3, :3], dense[1:, :3, :3])
    dense_zoom = key_blend(keys_zoom, spline.knots, dense_t) if zoom is not None else None
    if points is not None and len(points):
        step = image_shift(dense, np.asarray(points, np.float64), fov, fallback=da,
                           zoom=dense_zoom)
    else:
        dp = np.linalg.norm(np.diff(dense[:, :3, 3], axis=0), axis=1)
        step = dp + 0.1 * span * da
        if dense_zoom is not None:  # zoomed in: faster; a zoom weighs as much as a turn
            dz = np.log(dense_zoom)
            step = step * np.exp((dz[:-1] + dz[1:]) / 2) + 0.1 * span * np.abs(np.diff(dz))
    arc = np.concatenate([[0.0], np.cumsum(step)])
    s = np.linspace(0.0, arc[-1], n_frames + (1 if closed else 0))[: n_frames]
    if n_frames == 1:
        s = np.zeros(1)
    t = np.interp(s, arc, dense_t)
    frames_zoom = key_blend(keys_zoom, spline.knots, t) if zoom is not None else np.ones(len(t))
    return Tour(spline(t), frames_zoom)


def interpolate_path(c2ws: np.ndarray, n_frames: int, closed: bool = False,
                     order: bool = True, up: np.ndarray | None = None,
                     points: np.ndarray | None = None,
                     fov: tuple[float, float] = (1.0, 0.75),
                     tour: str = "position", depth: float | None = None) -> np.ndarray:
    """The poses [n_frames, 4, 4] of :func:`interpolate_tour` (one zoom for every frame)."""
    return interpolate_tour(c2ws, n_frames, closed, order, up, points, fov, tour, depth).poses


def image_shift(c2ws: np.ndarray, points: np.ndarray, fov: tuple[float, float],
                fallback: np.ndarray, zoom: np.ndarray | None = None) -> np.ndarray:
    """[F - 1] image motion between consecutive cameras c2ws [F, 4, 4]: the median shift,
    in the image plane at unit focal length, of the ``points`` [P, 3] both cameras see in
    front of them within ``fov`` = (tan of the half-width, tan of the half-height angle);
    ``fallback`` [F - 1] (e.g. the angle turned) where they share no point. With ``zoom``
    [F] (each camera's focal length over the unit one) every camera sees its points that
    much larger and its view that much narrower, so the shift is in each frame's own
    pixels over the unit focal length, a change of zoom moving the points too."""
    tx, ty = fov
    zoom = np.ones(len(c2ws)) if zoom is None else np.asarray(zoom, np.float64)

    def view(c2w, z):
        R, t = c2w[:3, :3], c2w[:3, 3]
        cam = (points - t) @ R
        depth = cam[:, 2]
        xy = z * cam[:, :2] / np.where(depth > 1e-9, depth, 1.0)[:, None]
        seen = (depth > 1e-9) & (np.abs(xy[:, 0]) <= tx) & (np.abs(xy[:, 1]) <= ty)
        return xy, seen

    return median_shift((view(c, z) for c, z in zip(c2ws, zoom, strict=True)), fallback)


def median_shift(views, fallback: np.ndarray) -> np.ndarray:
    """[F - 1] the median shift between consecutive ``views`` (an iterable of F (xy [P, 2],
    seen [P] bool) projections of the same points) of the points both see; ``fallback``
    [F - 1] where they share none. Consumes ``views`` one at a time."""
    out = np.asarray(fallback, np.float64).copy()
    views = iter(views)
    prev = next(views)
    for i, cur in enumerate(views):
        both = prev[1] & cur[1]
        if both.any():
            out[i] = float(np.median(np.linalg.norm(cur[0][both] - prev[0][both], axis=1)))
        prev = cur
    return out


def bounds_points(c2ws: np.ndarray, near: np.ndarray, far: np.ndarray,
                  fov: tuple[float, float], grid: int = 8) -> np.ndarray:
    """[N * grid * grid, 3] stand-in scene points where no depth is known: for each camera
    c2ws [N, 4, 4] a ``grid`` x ``grid`` of points across its view (``fov`` as in
    :func:`image_shift`) at sqrt(near x far) of its bounds [N], the middle of its depth
    range on a log scale."""
    c2ws = np.asarray(c2ws, np.float64)
    z = np.sqrt(np.maximum(np.asarray(near, float), 1e-9) * np.maximum(np.asarray(far, float),
                                                                      1e-9))
    u = (np.arange(grid) + 0.5) / grid * 2 - 1
    gx, gy = np.meshgrid(u * fov[0], u * fov[1])
    rays = np.stack([gx.ravel(), gy.ravel(), np.ones(grid * grid)], -1)  # [G, 3], z = 1
    pts = z[:, None, None] * rays[None]  # [N, G, 3] in each camera
    return (pts @ np.swapaxes(c2ws[:, :3, :3], 1, 2) + c2ws[:, None, :3, 3]).reshape(-1, 3)


# --------------------------------------------------------------------------- spiral / orbit
def focus_point(c2ws: np.ndarray) -> np.ndarray:
    """[3] the point closest (least squares) to every camera's optical axis."""
    c2ws = np.asarray(c2ws, np.float64)
    A, b = np.zeros((3, 3)), np.zeros(3)
    for m in c2ws:
        d, o = m[:3, 2], m[:3, 3]
        P = np.eye(3) - np.outer(d, d)
        A += P
        b += P @ o
    return np.linalg.lstsq(A, b, rcond=None)[0]


def is_surrounding(c2ws: np.ndarray) -> bool:
    """True when the cameras look inward from around the scene (not forward-facing)."""
    fwd = np.asarray(c2ws)[:, :3, 2]
    return bool(np.linalg.norm(fwd.mean(0)) < 0.7)


def spiral_path(c2ws: np.ndarray, near: np.ndarray, far: np.ndarray, n_frames: int,
                n_rots: float = 2.0, zrate: float = 0.5) -> np.ndarray:
    """A path [n_frames, 4, 4] around the scene, sized from the cameras and near/far.

    Forward-facing captures get the LLFF spiral: an ellipse with the 90th-percentile spread
    of the camera centres (in the mean camera's frame) as radii, looking at a focus depth
    ``1 / ((1 - 0.75) / (0.9 near_min) + 0.75 / (5 far_max))`` ahead of the mean camera.
    Captures that surround the scene get an orbit at the cameras' mean distance around the
    point nearest to all optical axes, with a vertical wave of the cameras' height spread.
    """
    c2ws = np.asarray(c2ws, np.float64)
    up = world_up(c2ws)
    centers = c2ws[:, :3, 3]
    theta = np.linspace(0.0, 2 * np.pi * n_rots, n_frames + 1)[:-1]
    if is_surrounding(c2ws):
        return _orbit(centers, focus_point(c2ws), up, theta / n_rots, n_rots)
    fwd = c2ws[:, :3, 2].mean(0)
    fwd /= np.linalg.norm(fwd)
    x = np.cross(-up, fwd)
    x /= np.linalg.norm(x)
    y = np.cross(fwd, x)
    R = np.stack([x, y, fwd], 1)  # mean camera, OpenCV axes
    mean_c = centers.mean(0)
    rads = np.percentile(np.abs((centers - mean_c) @ R), 90, axis=0)
    rads = np.maximum(rads, 1e-3 * max(rads.max(), 1e-9))
    close, inf = 0.9 * float(np.min(near)), 5.0 * float(np.max(far))
    focal = 1.0 / ((1 - 0.75) / close + 0.75 / inf)
    target = mean_c + focal * fwd
    out = []
    for th in theta:
        local = np.array([np.cos(th), -np.sin(th), -np.sin(th * zrate)]) * rads
        out.append(look_at(mean_c + R @ local, target, up))
    return np.stack(out)


def _orbit(centers, focus, up, phase, n_rots):
    rel = centers - focus
    h = rel @ up
    flat = rel - np.outer(h, up)
    radius = np.linalg.norm(flat, axis=1).mean()
    e1 = flat[0] / max(np.linalg.norm(flat[0]), 1e-12)
    e2 = np.cross(up, e1)
    amp = max(h.std(), 0.05 * radius)
    out = []
    for ph in phase:
        th = ph * n_rots
        eye = focus + radius * (np.cos(th) * e1 + np.sin(th) * e2) + up * (h.mean()
                                                                            + amp * np.sin(ph))
        out.append(look_at(eye, focus, up))
    return np.stack(out)


# --------------------------------------------------------------------------- JSON formats
@dataclass
class PathCamera:
    """One camera of a path: pinhole intrinsics, pose and image size."""

    name: str
    K: np.ndarray  # [3, 3] pinhole intrinsics, pixel centres at (i + 0.5) in COLMAP style
    c2w: np.ndarray  # [4, 4] camera-to-world, OpenCV convention
    width: int
    height: int

    def to_json(self) -> dict:
        return {"name": self.name, "K": np.asarray(self.K, float).tolist(),
                "c2w": np.asarray(self.c2w, float).tolist(),
                "width": int(self.width), "height": int(self.height)}


def _matrix(value, shape: tuple[int, int], what: str) -> np.ndarray:
    a = np.asarray(value, np.float64)
    if a.size == shape[0] * shape[1]:
        a = a.reshape(shape)
    if a.shape == (3, 4) and shape == (4, 4):
        a = np.vstack([a, [0, 0, 0, 1]])
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be a finite {shape[0]}x{shape[1]} matrix")
    return a


def path_from_json(d: dict) -> list[PathCamera]:
    """Parse a camera path dict: the project's format or nerfstudio's ``camera_path``.

    Project format: ``{"frames": [{"name", "K", "c2w", "width", "height"}, ...]}``.
    Raises ``ValueError`` naming the first problem.
    """
    if isinstance(d, dict) and "camera_path" in d:
        return path_from_nerfstudio(d)
    if not isinstance(d, dict) or not isinstance(d.get("frames"), list) or not d["frames"]:
        raise ValueError('expected {"frames": [...]} (or a nerfstudio camera_path file)')
    out, names = [], set()
    for i, f in enumerate(d["frames"]):
        try:
            name = str(f.get("name", f"{i:05d}"))
            cam = PathCamera(name, _matrix(f["K"], (3, 3), "K"),
                             _matrix(f["c2w"], (4, 4), "c2w"), int(f["width"]),
                             int(f["height"]))
        except (KeyError, TypeError, ValueError) as e:
            raise ValueError(f"frame {i}: {e}") from None
        if cam.width < 1 or cam.height < 1:
            raise ValueError(f"frame {i}: width and height must be positive")
        if name in names or not name or "/" in name or "\\" in name or name.startswith("."):
            raise ValueError(f"frame {i}: name {name!r} is empty, repeated or not a file name")
        names.add(name)
        out.append(cam)
    return out


def path_to_json(cams: list[PathCamera]) -> dict:
    return {"frames": [c.to_json() for c in cams]}


def path_from_nerfstudio(d: dict) -> list[PathCamera]:
    """nerfstudio ``camera_path`` JSON -> cameras (names 00000, 00001, ...).

    ``camera_to_world``: 16 numbers, row-major 4x4, OpenGL axes (x right, y up, z back);
    ``fov``: vertical field of view in degrees; ``render_width`` / ``render_height`` (or
    ``aspect`` with the height); principal point at the image centre, square pixels.
    Only perspective cameras map faithfully; others raise ``ValueError``.
    """
    kind = d.get("camera_type", "perspective")
    if kind != "perspective":
        raise ValueError(f"camera_type {kind!r} cannot be rendered: only perspective")
    H = int(d["render_height"])
    out = []
    for i, c in enumerate(d["camera_path"]):
        W = int(d.get("render_width") or round(H * float(c["aspect"])))
        c2w_gl = _matrix(c["camera_to_world"], (4, 4), "camera_to_world")
        f = H / 2.0 / np.tan(np.radians(float(c["fov"])) / 2.0)
        K = np.array([[f, 0, W / 2.0], [0, f, H / 2.0], [0, 0, 1.0]])
        out.append(PathCamera(f"{i:05d}", K, c2w_gl @ CV_GL, W, H))
    return out


def path_to_nerfstudio(cams: list[PathCamera], fps: float = 24.0) -> dict:
    """Cameras -> nerfstudio ``camera_path`` JSON (inverse of :func:`path_from_nerfstudio`).

    Needs one image size, square pixels (fx == fy) and a centred principal point for all.
    """
    W, H = cams[0].width, cams[0].height
    path = []
    for c in cams:
        K = c.K
        if (c.width, c.height) != (W, H) or abs(K[0, 0] - K[1, 1]) > 1e-6 * K[0, 0] or \
                abs(K[0, 2] - W / 2) > 1e-6 * W or abs(K[1, 2] - H / 2) > 1e-6 * H:
            raise ValueError(f"camera {c.name}: nerfstudio paths need one size, fx == fy and "
                             "a centred principal point")
        fov = float(np.degrees(2 * np.arctan(H / 2.0 / K[1, 1])))
        path.append({"camera_to_world": (c.c2w @ CV_GL).reshape(-1).tolist(), "fov": fov,
                     "aspect": W / H})
    return {"camera_type": "perspective", "render_height": H, "render_width": W,
            "fps": fps, "seconds": len(cams) / fps, "camera_path": path}
