"""Multi-view geometry on posed photos: plane-sweep depth, depth splatting, photo warping.

No network: numpy and OpenCV on pinhole views (WS/images geometry). Used by the ``depth``
stage (per-view depth and confidence), by ``render`` (sharp fill of flare regions and novel
frames from the photos themselves, depth-guided ray samples) and by ``eval`` (the photo-warp
baseline). The algorithm is described in docs/depth.md.

Conventions are ``gnfr.geometry``'s: ``K`` maps camera coordinates to continuous pixel
coordinates with pixel (col j, row i) centred at (j + 0.5, i + 0.5); ``c2w`` is OpenCV
camera-to-world; depth is camera z. Images are float32 RGB in 0..1, ``valid`` maps are
bool (False = flare, padding or unknown).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import cv2
import numpy as np

_HALF = np.array([[1.0, 0.0, 0.5], [0.0, 1.0, 0.5], [0.0, 0.0, 1.0]])
"""Continuous (+0.5 centred) pixel coordinates = _HALF @ OpenCV integer-centred ones."""


@dataclass
class PosedView:
    """One posed pinhole photo."""

    image: np.ndarray
    """[H, W, 3] float32 RGB 0..1."""
    K: np.ndarray
    """[3, 3] intrinsics of ``image``."""
    c2w: np.ndarray
    """[4, 4] camera-to-world (OpenCV)."""
    valid: np.ndarray | None = None
    """[H, W] bool, False where the pixel must not be used (flare); None: all valid."""
    depth: np.ndarray | None = None
    """[H, W] float32 z-depth (0 = unknown), when known."""
    deflared: np.ndarray | None = None
    """[H, W, 3] float32 RGB 0..1: the photo with its flare region filled (the render's
    de-flared photo, in ``image``'s geometry), where a fill may read it whole; None: not
    loaded."""

    @property
    def size(self) -> tuple[int, int]:
        """(W, H)."""
        return self.image.shape[1], self.image.shape[0]


@dataclass
class SweepConfig:
    """Plane-sweep stereo settings (docs/depth.md)."""

    planes: int = 48
    """Depth hypotheses, uniform in inverse depth between near and far."""
    window: int = 7
    """Side of the square window of the matching cost (pixels, odd)."""
    keep: int = 2
    """Best-k: the matching cost of a pixel is the mean of its k best source costs, so an
    occluding or flared neighbour cannot spoil it."""
    min_confidence: float = 0.5
    """Depths with a lower confidence (1 - best cost, 0..1) are dropped (set to 0)."""
    consistency: float = 0.02
    """Multi-view check: a depth is kept when at least one neighbour's depth agrees within
    this relative difference after reprojection (0 disables the check)."""
    min_margin: float = 0.0
    """Uniqueness: a depth is dropped when its cost beats the best cost of the planes more
    than ``MARGIN_PLANES`` away by less than this (a flat cost curve: no parallax, or a
    repeated texture; 0 = no test)."""
    sgm: tuple[float, float] | None = None
    """(P1, P2): semi-global aggregation of the cost volume along four scanlines
    (:func:`aggregate_sgm`) before the winner is taken; None = the pixel's own cost alone."""


def homography(K_t: np.ndarray, c2w_t: np.ndarray, K_s: np.ndarray, c2w_s: np.ndarray,
               depth: float) -> np.ndarray:
    """[3, 3] map from target pixels (OpenCV integer-centred) to source pixels through the
    fronto-parallel plane z = ``depth`` of the target camera."""
    T = np.linalg.inv(c2w_s) @ c2w_t
    R, t = T[:3, :3], T[:3, 3:4]
    n = np.array([[0.0, 0.0, 1.0]])
    H = K_s @ (R + t @ n / depth) @ np.linalg.inv(K_t)
    return np.linalg.inv(_HALF) @ H @ _HALF


def inverse_depths(near: float, far: float, n: int) -> np.ndarray:
    """[n] depths uniform in inverse depth from near to far."""
    return 1.0 / np.linspace(1.0 / near, 1.0 / far, n)


BEYOND_FAR = 100.0
"""The farthest plane of a consensus sweep's planes past its far bound, in units of it."""


def beyond_depths(far: float, n: int) -> np.ndarray:
    """[n] depths past ``far``, uniform in inverse depth from ``far`` (excluded) to
    ``BEYOND_FAR * far`` (included)."""
    if n <= 0:
        return np.zeros(0)
    return 1.0 / np.linspace(1.0 / far, 1.0 / (BEYOND_FAR * far), n + 1)[1:]


def _grey(img: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(img @ np.array([0.299, 0.587, 0.114], np.float32))


def _warp(img: np.ndarray, H: np.ndarray, size: tuple[int, int],
          interp: int = cv2.INTER_LINEAR) -> np.ndarray:
    return cv2.warpPerspective(img, H, size, flags=interp | cv2.WARP_INVERSE_MAP,
                               borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def _zncc_cost(ref: np.ndarray, ref_stats, warped: np.ndarray, win: int,
               out: np.ndarray | None = None) -> np.ndarray:
    """[H, W] 1 - ZNCC over a win x win window, in 0..2 (flat windows cost 1).
    ``ref_stats`` = (windowed mean, windowed variance clipped at 0) of ``ref``; ``out``: an
    [H, W] float32 array to write into. Computed in place (the sweeps' inner loop)."""
    mu_r, var_r = ref_stats
    box = (win, win)
    mu_w = cv2.boxFilter(warped, -1, box)
    den = cv2.boxFilter(warped * warped, -1, box)
    den -= mu_w * mu_w
    cov = cv2.boxFilter(ref * warped, -1, box)
    cov -= mu_r * mu_w
    np.maximum(den, 0, out=den)
    den *= var_r
    np.sqrt(den, out=den)
    flat = den <= 1e-5
    np.maximum(den, 1e-5, out=den)
    np.divide(cov, den, out=cov)
    cov[flat] = 0.0
    np.clip(cov, -1.0, 1.0, out=cov)
    return np.subtract(1.0, cov, out=out if out is not None else cov)


def mean_of_smallest(values: np.ndarray, keep: int) -> np.ndarray:
    """[...] mean of the ``keep`` smallest of ``values`` [N, ...] along axis 0 (best-k
    costs). For ``keep`` 2 the two smallest are tracked with running min and max (the
    value of ``np.partition(values, 1, 0)[:2].mean(0)``, several times faster)."""
    n = values.shape[0]
    if keep >= n:
        return values.mean(0)
    if keep == 1:
        return values.min(0)
    if keep == 2:
        lo = np.minimum(values[0], values[1])
        second = np.maximum(values[0], values[1])
        for k in range(2, n):
            np.minimum(second, np.maximum(lo, values[k]), out=second)
            np.minimum(lo, values[k], out=lo)
        lo += second
        lo /= 2
        return lo
    return np.partition(values, keep - 1, axis=0)[:keep].mean(0)


_NETWORKS = {2: ((0, 1),), 3: ((0, 1), (1, 2), (0, 1)),
             4: ((0, 1), (2, 3), (0, 2), (1, 3), (1, 2))}
"""Sorting networks (compare-exchange pairs) for a few values."""


def _sort_few(values: np.ndarray) -> np.ndarray:
    """``np.sort(values, axis=0)`` of finite or infinite values; for up to four along the
    first axis by a sorting network (elementwise min and max, faster than a strided sort)."""
    pairs = _NETWORKS.get(values.shape[0])
    if pairs is None:
        return np.sort(values, axis=0)
    rows = list(values)
    for i, j in pairs:
        rows[i], rows[j] = np.minimum(rows[i], rows[j]), np.maximum(rows[i], rows[j])
    return np.stack(rows)


def nanmedian0(values: np.ndarray) -> np.ndarray:
    """``np.nanmedian(values, axis=0)`` of a few warped sources [N, ...] (NaN where a source
    does not see the pixel; NaN where none does), by sorting the small first axis: the same
    values, several times faster than numpy's masked-array path for small N."""
    missing = np.isnan(values)
    n = values.shape[0] - missing.sum(0)
    s = _sort_few(np.where(missing, np.inf, values))  # NaNs (as inf) sort last
    lo = np.take_along_axis(s, ((np.maximum(n, 1) - 1) // 2)[None], 0)[0]
    hi = np.take_along_axis(s, np.minimum(n // 2, values.shape[0] - 1)[None], 0)[0]
    out = np.where(n % 2 == 1, lo, (lo + hi) / np.asarray(2, values.dtype)).astype(values.dtype)
    out[n == 0] = np.nan
    return out


MARGIN_PLANES = 2
"""Planes either side of the best that the uniqueness test (``SweepConfig.min_margin``)
leaves out of the runner-up: the cost curve's own slope around its minimum."""


def sweep_depth(ref: PosedView, sources: list[PosedView], near: float, far: float,
                cfg: SweepConfig = SweepConfig()) -> tuple[np.ndarray, np.ndarray]:
    """Depth of ``ref`` from its neighbours ``sources``: (depth [H, W] float32, confidence
    [H, W] float32 in 0..1). Per plane, each source is warped into ``ref`` and scored by
    windowed ZNCC; a pixel's cost is the mean of its ``keep`` best sources (flared or
    out-of-view source pixels cost 2); the best plane wins, refined by a parabola through
    its neighbours' costs in inverse depth. Confidence = 1 - that cost, 0 where fewer than
    ``keep`` sources see the pixel."""
    return sweep_depths(ref, sources, near, far, cfg)[0]


def sweep_depths(ref: PosedView, sources: list[PosedView], near: float, far: float,
                 cfg: SweepConfig = SweepConfig(),
                 also: tuple[float, float] | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """[(depth, confidence)] of :func:`sweep_depth` with ``cfg``, then, with ``also``, the
    same sweep's winner with its costs aggregated at those penalties (``cfg`` with ``sgm =
    also``), from the one cost volume: each result the same to the bit as its own sweep."""
    W, H = ref.size
    win = cfg.window
    g_ref = _grey(ref.image)
    mu_r = cv2.boxFilter(g_ref, -1, (win, win))
    var_r = np.maximum(cv2.boxFilter(g_ref * g_ref, -1, (win, win)) - mu_r * mu_r, 0)
    greys = [_grey(s.image) for s in sources]
    valids = [(np.ones(s.image.shape[:2], np.uint8) if s.valid is None
               else s.valid.astype(np.uint8)) for s in sources]
    depths = inverse_depths(near, far, cfg.planes)
    keep = min(cfg.keep, len(sources))
    cost = np.empty((cfg.planes, H, W), np.float32)
    seen = np.zeros((H, W), np.int32)
    per = np.empty((len(sources), H, W), np.float32)
    best = np.zeros((H, W), np.intp)  # np.argmin(cost, 0), kept as the planes go: the
    lowest = np.full((H, W), np.inf, np.float32)  # strided argmin was a tenth of the sweep
    for p, d in enumerate(depths):
        for k, s in enumerate(sources):
            Hm = homography(ref.K, ref.c2w, s.K, s.c2w, d)
            w = _warp(greys[k], Hm, (W, H))
            v = _warp(valids[k], Hm, (W, H), cv2.INTER_NEAREST)
            _zncc_cost(g_ref, (mu_r, var_r), w, win, out=per[k])
            per[k][v == 0] = 2.0  # flared or out of view
            if p == cfg.planes // 2:
                seen += v
        cost[p] = mean_of_smallest(per, keep)
        lower = cost[p] < lowest  # strict: ties keep the first plane, as argmin does
        np.copyto(lowest, cost[p], where=lower)
        best[lower] = p
    cfgs = [cfg] + ([] if also is None else [replace(cfg, sgm=tuple(also))])
    return [_sweep_winner(ref, cost, best, lowest, seen, keep, depths, g_ref, c) for c in cfgs]


def _sweep_winner(ref: PosedView, cost: np.ndarray, best: np.ndarray, lowest: np.ndarray,
                  seen: np.ndarray, keep: int, depths: np.ndarray, g_ref: np.ndarray,
                  cfg: SweepConfig) -> tuple[np.ndarray, np.ndarray]:
    """(depth, confidence) of a swept cost volume ``cost`` (its plain winner ``best`` at
    cost ``lowest``), aggregated first when ``cfg.sgm``; reads its arrays, writes none."""
    if cfg.sgm is not None:
        agg = aggregate_sgm(cost, g_ref, *cfg.sgm)
        best = np.argmin(agg, 0)
        # the winner's own cost, or, where lower, how little the scanlines disagree with
        # it (0: every scanline's neighbours arrive at this plane; 1: each pays the large
        # jump), so a weakly textured pixel whose neighbours agree keeps their depth
        lowest = np.take_along_axis(cost, best[None], 0)[0]
        disagree = np.take_along_axis(agg, best[None], 0)[0] / len(SGM_PATHS) - lowest
        np.minimum(lowest, np.clip(disagree / cfg.sgm[1], 0, 1), out=lowest)
        depth = _refine(agg, best, depths)
    else:
        depth = _refine(cost, best, depths)
    c_best = lowest  # the cost at the best plane
    conf = np.clip(1.0 - c_best, 0.0, 1.0)
    if cfg.min_margin > 0:
        away = np.abs(np.arange(cfg.planes)[:, None, None] - best[None]) > MARGIN_PLANES
        second = np.where(away, cost, np.inf).min(0)
        conf[second - c_best < cfg.min_margin] = 0.0  # c_best: the cost at the best plane
    if ref.valid is not None:
        conf[~ref.valid] *= 0.5  # the reference pixel itself is flared: matched, not trusted
    conf[seen < keep] = 0.0
    depth[conf < cfg.min_confidence] = 0.0
    return depth.astype(np.float32), conf.astype(np.float32)


SGM_PATHS = ((0, 1), (0, -1), (1, 1), (1, -1))
"""Scanlines of :func:`aggregate_sgm` as (along, direction): along 0, a row is walked (left
to right, then right to left); along 1, a column (top to bottom, then bottom to top)."""

SGM_EDGE = 0.05
"""Grey-level step (0..1) at which the large-jump penalty P2 of :func:`aggregate_sgm` is
halved: depth may jump where the image has an edge."""


def aggregate_sgm(cost: np.ndarray, grey: np.ndarray, p1: float, p2: float) -> np.ndarray:
    """Semi-global aggregation of a plane-sweep cost volume ``cost`` [P, H, W] (Hirschmueller's
    recursion, in plane indices): along each scanline of ``SGM_PATHS``
    ``L(x, d) = C(x, d) + min(L(x-1, d), L(x-1, d+-1) + p1, min L(x-1) + p2') - min L(x-1)``
    with ``p2' = max(p1, p2 / (1 + |grey step| / SGM_EDGE))``; returns the sum over the
    scanlines [P, H, W] float32. Each scanline's term lies in [C, C + p2], so the sum over
    four is at most ``4 * (C + p2)``. Memory: the sum and one reordered copy of ``cost``
    besides ``cost`` itself."""
    total = np.zeros_like(cost, dtype=np.float32)
    for axis in dict.fromkeys(a for a, _ in SGM_PATHS):
        # lines along the scan axis first: [N, P, M], N steps of M parallel pixels; the copy
        # and the penalties serve both directions along the axis; each line's term is added
        # to the sum where it stands (a view of it in the same order)
        c = np.ascontiguousarray(cost.transpose(2, 0, 1) if axis == 0 else
                                 cost.transpose(1, 0, 2))
        g = np.ascontiguousarray(grey.T if axis == 0 else grey)
        jump = np.abs(np.diff(g, axis=0))
        pen = np.maximum(p2 / (1.0 + jump / SGM_EDGE), p1).astype(np.float32)
        n = c.shape[0]
        out = total.transpose(2, 0, 1) if axis == 0 else total.transpose(1, 0, 2)
        for step in (d for a, d in SGM_PATHS if a == axis):
            order = range(n) if step > 0 else range(n - 1, -1, -1)
            prev = None
            for i in order:
                if prev is None:
                    cur = c[i].copy()
                else:
                    j = i - 1 if step > 0 else i  # the grey step between lines i and i - step
                    m = prev.min(0)
                    cur = prev.copy()
                    np.minimum(cur[1:], prev[:-1] + p1, out=cur[1:])  # from d - 1
                    np.minimum(cur[:-1], prev[1:] + p1, out=cur[:-1])  # from d + 1
                    np.minimum(cur, m + pen[j], out=cur)
                    cur -= m
                    cur += c[i]
                out[i] += cur
                prev = cur
        del c  # before the next axis' copy
    return total


def sweep_consensus(K: np.ndarray, c2w: np.ndarray, size: tuple[int, int],
                    sources: list[PosedView], near: float, far: float, planes: int = 32,
                    window: int = 5, where: np.ndarray | None = None, beyond: int = 0
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Depth of a camera that has no photo of its own (a novel frame, or pixels no depth map
    covers): per plane the sources are warped in and a pixel's cost is the windowed mean of
    the variance of their colours (sources under flare or out of view left out; fewer than
    two: no cost). Returns (depth [H, W], cost [H, W]; inf where never two sources saw the
    pixel). ``where`` [H, W] bool limits the work to the bounding box of those pixels.
    ``beyond`` > 0 adds that many planes past ``far`` (:func:`beyond_depths`), out to
    ``BEYOND_FAR`` times it, where distant scenery and the sky are warped all but as a
    rotation."""
    W, H = size
    depth = np.zeros((H, W), np.float32)
    best = np.full((H, W), np.inf, np.float32)
    if where is not None:
        rows, cols = np.nonzero(where)
        if len(rows) == 0:
            return depth, best
        r0, r1 = max(rows.min() - window, 0), min(rows.max() + window + 1, H)
        c0, c1 = max(cols.min() - window, 0), min(cols.max() + window + 1, W)
    else:
        r0, r1, c0, c1 = 0, H, 0, W
    shift = np.array([[1.0, 0, c0], [0, 1.0, r0], [0, 0, 1.0]])  # crop px -> frame px
    cw, ch = c1 - c0, r1 - r0
    valids = [(np.ones(s.image.shape[:2], np.uint8) if s.valid is None
               else s.valid.astype(np.uint8)) for s in sources]
    sub_best = best[r0:r1, c0:c1]
    sub_depth = depth[r0:r1, c0:c1]
    ones = np.ones((1, 3), np.float32)  # cv2.transform by it: the sum of the 3 channels
    n = np.empty((ch, cw), np.float32)
    s1 = np.empty((ch, cw, 3), np.float32)
    s2 = np.empty((ch, cw), np.float32)
    for d in np.concatenate([inverse_depths(near, far, planes), beyond_depths(far, beyond)]):
        n.fill(0)
        s1.fill(0)
        s2.fill(0)
        for k, s in enumerate(sources):
            Hm = homography(K, c2w, s.K, s.c2w, d) @ shift
            col = _warp(s.image, Hm, (cw, ch))
            v = _warp(valids[k], Hm, (cw, ch), cv2.INTER_NEAREST)
            n += v
            cv2.accumulate(col, s1, mask=v)  # where the source is valid
            cv2.accumulate(cv2.transform(col * col, ones), s2, mask=v)
        nn = np.maximum(n, 1)
        mean = s1 / nn[..., None]
        var = s2 / nn
        var -= cv2.transform(mean * mean, ones)
        var /= 3.0
        np.maximum(var, 0, out=var)
        few = n < 2  # fewer than two sources: no cost (1 inside the window's mean, then inf)
        var[few] = 1.0
        c = cv2.blur(var, (window, window))
        c[few] = np.inf
        better = c < sub_best
        sub_best[better] = c[better]
        sub_depth[better] = d
    return depth, best


def _refine(cost: np.ndarray, best: np.ndarray, depths: np.ndarray):
    """Sub-plane depth by a parabola through the costs at best-1, best, best+1 (in the
    inverse-depth index)."""
    P = cost.shape[0]
    i0 = np.clip(best, 1, P - 2)
    take = lambda i: np.take_along_axis(cost, i[None], 0)[0]  # noqa: E731
    cm, c0, cp = take(i0 - 1), take(i0), take(i0 + 1)
    den = cm - 2 * c0 + cp
    off = np.where(den > 1e-6, 0.5 * (cm - cp) / np.maximum(den, 1e-6), 0.0)
    off = np.clip(off, -0.5, 0.5)
    idx = np.where((best == 0) | (best == P - 1), best, i0 + off)
    inv = np.interp(idx, np.arange(P), 1.0 / depths)
    return 1.0 / inv


# --------------------------------------------------------------------------- reprojection
def pixel_grid(W: int, H: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-centre coordinates (x, y) [H, W] in the continuous convention."""
    return np.meshgrid(np.arange(W, dtype=np.float32) + 0.5,
                       np.arange(H, dtype=np.float32) + 0.5)


def backproject(K: np.ndarray, c2w: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """[H, W, 3] world points of a z-depth map."""
    H, W = depth.shape
    x, y = pixel_grid(W, H)
    Ki = np.linalg.inv(K)
    cam = np.stack([x, y, np.ones_like(x)], -1) @ Ki.T.astype(np.float32) * depth[..., None]
    return cam @ c2w[:3, :3].T.astype(np.float32) + c2w[:3, 3].astype(np.float32)


def project_points(pts: np.ndarray, K: np.ndarray, c2w: np.ndarray):
    """(xy [..., 2] continuous pixels, z [...]) of world points in a camera."""
    w2c = np.linalg.inv(c2w)
    cam = pts @ w2c[:3, :3].T.astype(np.float32) + w2c[:3, 3].astype(np.float32)
    z = cam[..., 2]
    uv = cam @ K.T.astype(np.float32)
    zs = np.where(np.abs(uv[..., 2:]) < 1e-8, 1e-8, uv[..., 2:])
    return uv[..., :2] / zs, z


def consistency_count(views: list[PosedView], i: int, neighbours: list[int],
                      tol: float, inverse_tol: float | None = None) -> np.ndarray:
    """[H, W] number of ``neighbours`` whose own depth agrees with view ``i``'s depth after
    reprojection (relative z difference below ``tol``, or with ``inverse_tol`` an inverse
    depth difference below it)."""
    v = views[i]
    pts = backproject(v.K, v.c2w, v.depth)
    count = np.zeros(v.depth.shape, np.int32)
    for j in neighbours:
        n = views[j]
        if n.depth is None:
            continue
        xy, z = project_points(pts, n.K, n.c2w)
        dz = cv2.remap(n.depth, xy[..., 0] - 0.5, xy[..., 1] - 0.5, cv2.INTER_NEAREST,
                       borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        if inverse_tol is None:
            ok = (dz > 0) & (z > 0) & (np.abs(dz - z) < tol * z)
        else:
            ok = (dz > 0) & (z > 0) & (np.abs(1.0 / np.maximum(dz, 1e-12)
                                              - 1.0 / np.maximum(z, 1e-12)) < inverse_tol)
        count += ok
    count[v.depth <= 0] = 0
    return count


def remove_specks(depth: np.ndarray, near: float, far: float, planes: int,
                  max_area: int) -> np.ndarray:
    """``depth`` [H, W] (0 = unknown) without its specks: 4-connected groups of known pixels
    whose inverse depths step by at most one plane of the sweep (``planes`` uniform in
    inverse depth between ``near`` and ``far``) from neighbour to neighbour, of at most
    ``max_area`` pixels, become unknown (``cv2.filterSpeckles`` on the inverse depth in
    sixteenths of a plane). Such islands are where the sweep matched by chance (the sky
    between branches, a flat wall) and passed the consistency check."""
    if max_area <= 0 or not (depth > 0).any():
        return depth
    step = (1.0 / near - 1.0 / far) / max(planes - 1, 1)
    inv = np.where(depth > 0, 1.0 / np.maximum(depth, 1e-12), 0.0)
    disp = np.clip(np.round((inv - 1.0 / far) / step * 16), 0, 32000)
    img = np.where(depth > 0, disp, -16).astype(np.int16)
    cv2.filterSpeckles(img, -16, int(max_area), 16)
    return np.where(img == -16, 0, depth).astype(depth.dtype)


def splat_depth(K: np.ndarray, c2w: np.ndarray, size: tuple[int, int],
                views: list[PosedView], fill: int = 2) -> np.ndarray:
    """[H, W] z-depth of a target camera from the views' depth maps: every known depth
    pixel is projected into the target and the nearest surface wins (z-buffer); holes of up
    to ``fill`` pixels (the cracks of forward projection) are closed by a min filter of the
    surrounding depths; ``fill`` < 0 fills every hole (``fill_holes``). 0 where no view saw
    the surface."""
    W, H = size
    zbuf = np.full(H * W, np.inf, np.float32)
    for v in views:
        if v.depth is None:
            continue
        m = v.depth > 0
        if v.valid is not None:
            m &= v.valid
        pts = backproject(v.K, v.c2w, v.depth)[m]
        xy, z = project_points(pts, K, c2w)
        c, r = np.floor(xy[:, 0]).astype(np.int64), np.floor(xy[:, 1]).astype(np.int64)
        ok = (z > 0) & (c >= 0) & (c < W) & (r >= 0) & (r < H)
        np.minimum.at(zbuf, r[ok] * W + c[ok], z[ok])
    z = zbuf.reshape(H, W)
    z[~np.isfinite(z)] = 0
    if fill < 0:
        return fill_holes(z)
    if fill > 0:
        k = 2 * fill + 1
        big = np.where(z > 0, z, np.float32(1e9))
        closed = cv2.erode(big, np.ones((k, k), np.uint8))  # min filter: nearest surface
        hole = (z == 0) & (closed < 1e9)
        z[hole] = closed[hole]
    return z


def fill_holes(depth: np.ndarray, min_size: int = 4) -> np.ndarray:
    """[H, W] depth with every hole (0) filled by push-pull interpolation of inverse depth:
    the known values are averaged down an image pyramid and the holes of each level are
    filled from the coarser one, so a hole takes the smooth blend of the surfaces around
    it. Fills the sky and textureless walls with a plausible depth; whether the photos
    agree there is checked later (``fuse``). All zeros stay zeros."""
    known = depth > 0
    if known.all() or not known.any():
        return depth
    inv = np.where(known, 1.0 / np.maximum(depth, 1e-12), 0).astype(np.float32)
    levels = [(inv, known.astype(np.float32))]
    while min(levels[-1][0].shape) > min_size:
        v, w = levels[-1]
        h2, w2 = (v.shape[0] + 1) // 2, (v.shape[1] + 1) // 2
        vs = cv2.resize(v * w, (w2, h2), interpolation=cv2.INTER_AREA)
        ws = cv2.resize(w, (w2, h2), interpolation=cv2.INTER_AREA)
        levels.append((np.where(ws > 0, vs / np.maximum(ws, 1e-12), 0).astype(np.float32),
                       (ws > 0).astype(np.float32)))
    filled = levels[-1][0]
    for v, w in reversed(levels[:-1]):
        up = cv2.resize(filled, (v.shape[1], v.shape[0]), interpolation=cv2.INTER_LINEAR)
        filled = np.where(w > 0, v, up)
    out = np.where(known, depth, 1.0 / np.maximum(filled, 1e-12)).astype(np.float32)
    out[filled <= 0] = 0
    return out


@dataclass
class Warped:
    """Source photos warped into a target camera through a depth map."""

    colours: np.ndarray
    """[N, H, W, 3] float32 colour each source sees at the target's surface point."""
    ok: np.ndarray
    """[N, H, W] bool: in view, not flared, not occluded (its depth agrees)."""
    seen: np.ndarray | None = None
    """[N, H, W] bool: ``ok`` before the occlusion test (in view, not flared, the target's
    depth known), as ``warp_sources`` found it; None where not kept."""


def warp_sources(K: np.ndarray, c2w: np.ndarray, depth: np.ndarray,
                 sources: list[PosedView], occlusion_tol: float = 0.03) -> Warped:
    """Backward-warp every source into the target through ``depth`` (bilinear, full source
    resolution). A source pixel counts only where the target depth is known, the point is
    in front of the source, the source pixel is valid, and, when the source has a depth
    map, that depth agrees with the point's depth in the source (else it is occluded)."""
    H, W = depth.shape
    pts = backproject(K, c2w, depth)
    cols = np.zeros((len(sources), H, W, 3), np.float32)
    ok = np.zeros((len(sources), H, W), bool)
    seen = np.zeros((len(sources), H, W), bool)
    for k, s in enumerate(sources):
        xy, z = project_points(pts, s.K, s.c2w)
        mx, my = xy[..., 0] - 0.5, xy[..., 1] - 0.5
        cols[k] = cv2.remap(s.image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        sw, sh = s.size
        good = ((depth > 0) & (z > 0) & (mx >= -0.5) & (mx <= sw - 0.5) & (my >= -0.5)
                & (my <= sh - 0.5))
        if s.valid is not None:
            vv = cv2.remap(s.valid.astype(np.uint8), mx, my, cv2.INTER_NEAREST,
                           borderMode=cv2.BORDER_CONSTANT, borderValue=0)
            good &= vv > 0
        seen[k] = good
        if s.depth is not None:
            sd = cv2.remap(s.depth, mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                           borderValue=0)
            good &= (sd <= 0) | (np.abs(sd - z) < occlusion_tol * z)
        ok[k] = good
    return Warped(cols, ok, seen)


def sources_median(w: Warped) -> tuple[np.ndarray, np.ndarray]:
    """(median [H, W, 3] of the warped sources that see each pixel, 0 where none does;
    seen [H, W] bool: where at least two see it, so the median is a comparison)."""
    c = np.where(w.ok[..., None], w.colours, np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN where none sees
        med = nanmedian0(c)
    seen = np.isfinite(med).all(-1) & (w.ok.sum(0) >= 2)
    return np.nan_to_num(med), seen


def match_gains(w: Warped, reference: np.ndarray | None = None,
                ref_valid: np.ndarray | None = None, min_pixels: int = 200) -> Warped:
    """Per-source, per-channel gains (0.5..2) that bring each warped source to the
    ``reference`` image where it is valid (an input view's own clean pixels), or without a
    reference to the per-pixel median of the sources: photos of one scene differ in
    exposure and white balance, and agreement is judged on colour."""
    cols = w.colours.copy()
    if reference is None:
        ref, rv = sources_median(w)
    else:
        ref = reference
        rv = np.ones(ref.shape[:2], bool) if ref_valid is None else ref_valid
    for k in range(cols.shape[0]):
        m = w.ok[k] & rv
        if m.sum() < min_pixels:
            continue
        x, y = cols[k][m].astype(np.float64), ref[m].astype(np.float64)
        g = (x * y).sum(0) / np.maximum((x * x).sum(0), 1e-9)
        cols[k] *= np.clip(g, 0.5, 2.0).astype(np.float32)
    return Warped(cols, w.ok, w.seen)


HARMONIZE_MAX = 0.15
"""``harmonize_sources``: a warped photo's difference from the median (0..1 colours, any
channel) over which it shows another surface and is left out of its offset's fit."""
HARMONIZE_FADE = 0.1
"""``harmonize_sources``: the offset applies in full where at least this share of the
Gaussian's weight falls on pixels it was fitted on, and fades out where none does."""


def harmonize_sources(w: Warped, sigma: float) -> Warped:
    """Each warped source brought to the sources' per-pixel median by a smooth offset: its
    difference from the median where it sees the same surface (within HARMONIZE_MAX),
    averaged by a Gaussian of ``sigma`` pixels (normalised by the pixels it was fitted on,
    faded by HARMONIZE_FADE). Global gains (``match_gains``) leave the photos' local
    differences (vignetting, a sky's gradient, light falloff) which make the fused colour
    jump where the set of agreeing sources changes; this takes them out."""
    if w.colours.shape[0] < 2 or sigma <= 0:
        return w
    med, seen = sources_median(w)
    cols = w.colours.copy()
    for k in range(cols.shape[0]):
        d = med - w.colours[k]
        m = (w.ok[k] & seen & (np.abs(d).max(-1) <= HARMONIZE_MAX)).astype(np.float32)
        if not m.any():
            continue
        den = cv2.GaussianBlur(m, (0, 0), sigma, borderType=cv2.BORDER_REPLICATE)
        num = cv2.GaussianBlur(d * m[..., None], (0, 0), sigma,
                               borderType=cv2.BORDER_REPLICATE)
        off = num / np.maximum(den, 1e-6)[..., None]
        fade = np.clip(den / HARMONIZE_FADE, 0.0, 1.0)[..., None]
        cols[k] += np.clip(off, -HARMONIZE_MAX, HARMONIZE_MAX) * fade
    return Warped(cols, w.ok, w.seen)


AGREE = 0.08
"""The photos' agreement tolerance: a warped photo agrees where its largest channel
difference from the photos' median (0..1 colours) is under this (:func:`fuse`; the photo
fill's default, ``pipeline.photo_fill.AGREE``)."""


def fuse(w: Warped, agree: float = AGREE, min_views: int = 1, window: int = 1):
    """Robust per-pixel colour of warped sources: the median of the valid sources, then the
    mean of those within ``agree`` (max channel difference) of it, weighted by source
    order (nearer sources first get more weight). ``window`` > 1: a source's difference
    from the median is averaged over the ``window`` x ``window`` pixels around each pixel
    where that source is valid before the test, so a source agrees with a patch, not a
    single pixel that may match by chance. Returns (colour [H, W, 3], support [H, W] int =
    sources that agree; colour is 0 where support < min_views)."""
    N = w.colours.shape[0]
    c = np.where(w.ok[..., None], w.colours, np.nan)
    med = nanmedian0(c) if N > 1 else c[0]
    dev = np.nan_to_num(np.nanmax(np.abs(c - med[None]), axis=-1), nan=9.0)
    if window > 1:
        box = (window, window)
        for k in range(N):
            v = w.ok[k].astype(np.float32)
            num = cv2.boxFilter(np.where(w.ok[k], dev[k], 0.0).astype(np.float32), -1, box,
                                normalize=False)
            den = cv2.boxFilter(v, -1, box, normalize=False)
            dev[k] = np.where(den > 0, num / np.maximum(den, 1.0), 9.0)
    agree_m = w.ok & (dev < agree)
    wt = (1.0 / (1.0 + np.arange(N, dtype=np.float32)))[:, None, None] * agree_m
    tot = wt.sum(0)
    col = (np.nan_to_num(c) * wt[..., None]).sum(0) / np.maximum(tot, 1e-8)[..., None]
    support = agree_m.sum(0)
    col[support < min_views] = 0
    return col.astype(np.float32), support
