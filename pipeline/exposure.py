"""The views' exposures evened out: one gain per view and channel, from the depth maps.

Photos of one scene are rarely taken at one exposure: a camera's auto exposure moves by a
stop between views as the sky or the light comes into the frame (the development scenes:
0.9-1.1 EV between their darkest and brightest view, the camera's own EXIF saying the same;
``benchmarks/exposure_spread.py``). GN-FR's fine-tune asks the network for a target's
colours from sources exposed otherwise, which no ray can explain.

``estimate_gains``: each view's known depth (WS/depth) warps its ``neighbours`` nearest
views into it (``pipeline.stereo.warp_sources``: in view, unflared, unoccluded); on the
pixels both see, neither near black nor clipped, the median log ratio of linear colours is
the two views' exposure difference, per channel. A least-squares fit of one log gain per
view to all those differences (mean zero) gives the gains: multiplying a view's linear
colours by its gain brings it to the views' common exposure. A view no pair reaches keeps
gain 1.

``finetune --exposure-model`` chooses how (``MODELS``): ``gain`` (the default), ``view-curves``
(``solve_curves``: one curve per view, a gain at mid grey and a slope about it, fitted on
each pair's pixels in five brightness bins, for tone curves that make two exposures differ
more in the shadows than in the highlights; judged in the forty-second session and not the
default: docs/history/gnfr.md) or ``camera-curve`` (``solve_camera_curve``: one tone curve
shared by the camera's photos and a gain per view).

Where used: ``finetune --exposure-match`` trains on every view brought to the common
exposure and stores the gains in the checkpoint's provenance; ``render`` then reads its
sources at the same gains and takes the network's colours back to the frame's exposure
(an input view's own, a novel frame's nearest sources' median).
"""

from __future__ import annotations

import numpy as np

DARK = 0.01
"""Linear values below this are left out of a ratio (noise and crushed shadows)."""
CLIPPED = 0.95
"""sRGB values above this in any channel are left out (clipped highlights, light cores)."""
MIN_PIXELS = 200
"""Fewest shared pixels for a pair's difference to count."""
MAX_EV = 3.0
"""Gains are held to +-3 stops."""
PIVOT = 0.18
"""Linear level a curve's slope turns about (mid grey): its gain is the gain there."""
BINS = 5
"""Brightness bins per pair for the curves (equal pixel counts)."""
SLOPES = (0.75, 1.33)
"""A curve's slope is held to this range."""
SLOPE_PRIOR = 2.0
"""Weight of each view's pull of its slope towards 1 in the curves' least squares."""
CAMERA_C = (-0.3, 0.3)
"""The camera curve's coefficient is held to this range."""
FLAT = 0.25
"""Where the camera curve's slope falls to this, it goes on as a straight line (so that it
stays monotone and invertible over every level)."""
CENTRE = 0.6
"""Only pixels within this fraction of the half-diagonal from the image centre, in both
views, are compared: lens vignetting darkens the edges, and on a walk forward a point moves
outwards from view to view, which would read as the later view being darker."""


def central(h: int, w: int, x: np.ndarray | None = None, y: np.ndarray | None = None
            ) -> np.ndarray:
    """[H, W] bool: pixels (or the points ``x``, ``y``) within ``CENTRE`` of the centre."""
    if x is None:
        y, x = np.mgrid[0:h, 0:w].astype(np.float32) + 0.5
    r = np.hypot((x - w / 2) / (w / 2), (y - h / 2) / (h / 2)) / np.sqrt(2)
    return r < CENTRE


def srgb_to_lin(x: np.ndarray) -> np.ndarray:
    from pipeline.colour import srgb_to_linear

    return srgb_to_linear(np.clip(x, 0.0, 1.0), exact=True)


def lin_to_srgb(x: np.ndarray) -> np.ndarray:
    from pipeline.colour import linear_to_srgb

    return linear_to_srgb(np.clip(x, 0.0, 1.0), exact=True)


def apply_gain(srgb: np.ndarray, gain) -> np.ndarray:
    """sRGB colours [..., 3] (float 0..1, or uint8) times a linear ``gain`` [3], as the input's
    type (clipped). A curve [g_r, g_g, g_b, s] (:func:`solve_curves`) maps linear x to
    PIVOT * g * (x / PIVOT) ** s: the gain g at mid grey, the slope s about it. A camera
    transform [g_r, g_g, g_b, s, c] (:func:`solve_camera_curve`) takes the level
    l = log(x / PIVOT) to log radiance by the camera curve ``c`` (:func:`to_radiance`),
    scales it by s, adds log g and goes back by the same curve."""
    g = np.asarray(gain, np.float32)

    def lin(x: np.ndarray) -> np.ndarray:
        x = srgb_to_lin(x)
        if len(g) == 3:
            return x * g  # the default, kept as a plain product
        # a curve or camera transform: the level through corrected_level and back by the
        # camera curve (none for a curve)
        level = np.log(np.maximum(x, 1e-6) / PIVOT)
        c = float(g[4]) if len(g) == 5 else 0.0
        u = from_radiance(corrected_level(g, level), c)
        return np.where(x > 0, PIVOT * np.exp(u), 0.0).astype(np.float32)

    if srgb.dtype == np.uint8:
        out = lin_to_srgb(lin(srgb.astype(np.float32) / 255.0))
        return np.clip(np.round(out * 255.0), 0, 255).astype(np.uint8)
    return lin_to_srgb(lin(srgb)).astype(srgb.dtype, copy=False)


def corrected_level(gain, level: np.ndarray) -> np.ndarray:
    """What ``gain`` (a gain, curve or camera transform, :func:`apply_gain`) makes of the
    levels [..., 3] (log(linear / PIVOT)), in the log-radiance terms its fit compares views
    in: log g + level, log g + s level, or log g + s to_radiance(level, c)."""
    g = np.asarray(gain, np.float64)
    if len(g) == 3:
        return np.log(g) + level
    if len(g) == 4:
        return np.log(g[:3]) + g[3] * level
    return np.log(g[:3]) + g[3] * to_radiance(level, float(g[4]))


def _knee(c: float) -> float:
    """The level where the camera curve's slope 1 + 2 c l falls to ``FLAT``."""
    return (FLAT - 1.0) / (2.0 * c)


def to_radiance(level: np.ndarray, c: float) -> np.ndarray:
    """The camera curve: level l = log(linear / PIVOT) to log radiance l + c l^2 (to second
    order about mid grey), a straight line of slope ``FLAT`` beyond the knee."""
    if c == 0.0:
        return level
    k = _knee(c)
    quad = level + c * level * level
    line = k + c * k * k + FLAT * (level - k)
    beyond = level < k if c > 0 else level > k
    return np.where(beyond, line, quad)


def from_radiance(u: np.ndarray, c: float) -> np.ndarray:
    """The inverse of :func:`to_radiance`."""
    if c == 0.0:
        return u
    k = _knee(c)
    uk = k + c * k * k
    beyond = u < uk if c > 0 else u > uk
    root = (-1.0 + np.sqrt(np.maximum(1.0 + 4.0 * c * u, 0.0))) / (2.0 * c)
    return np.where(beyond, k + (u - uk) / FLAT, root)


def shared_pixels(views: dict, cams, neighbours: int = 4):
    """Yield (a, b, [M, 3] linear colours of ``a``, the same pixels seen in ``b``) for each
    view ``a`` with depth and each of its nearest ``neighbours`` b: the pixels both see,
    unflared, central in both, neither dark nor clipped; pairs under ``MIN_PIXELS`` are
    left out. ``views``: {stem: PosedView} with depth."""
    from pipeline.depth import nearest_views
    from pipeline.stereo import backproject, project_points, warp_sources

    near = nearest_views(cams, neighbours)
    for a, va in views.items():
        if va.depth is None:
            continue
        srcs = [b for b in near.get(a, []) if b in views]
        if not srcs:
            continue
        w = warp_sources(va.K, va.c2w, va.depth, [views[b] for b in srcs])
        own_ok = (va.depth > 0) & (va.image.max(-1) < CLIPPED)
        if va.valid is not None:
            own_ok &= va.valid
        own = srgb_to_lin(va.image)
        h, wd = va.depth.shape
        own_ok &= central(h, wd)
        pts = backproject(va.K, va.c2w, va.depth)
        for k, b in enumerate(srcs):
            vb = views[b]
            xy, _ = project_points(pts, vb.K, vb.c2w)
            bh, bw = vb.image.shape[:2]
            m = own_ok & w.ok[k] & (w.colours[k].max(-1) < CLIPPED)
            m &= central(bh, bw, xy[..., 0], xy[..., 1])
            other = srgb_to_lin(w.colours[k])
            m &= (own.min(-1) > DARK) & (other.min(-1) > DARK)
            if int(m.sum()) < MIN_PIXELS:
                continue
            yield a, b, own[m], other[m]


def pair_differences(views: dict, cams, neighbours: int = 4) -> list[tuple[str, str, np.ndarray]]:
    """(a, b, [3] log(b / a)) for each pair of :func:`shared_pixels`: the median log ratio."""
    return [(a, b, np.median(np.log(other) - np.log(own), axis=0))
            for a, b, own, other in shared_pixels(views, cams, neighbours)]


def pair_bins(views: dict, cams, neighbours: int = 4, bins: int = BINS
              ) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
    """(a, b, [bins, 3] level in a, [bins, 3] level in b) for each pair of
    :func:`shared_pixels` (level = log(linear / PIVOT)): its pixels cut into ``bins`` equal
    counts by their brightness in both views together, per bin the median level in each. A
    camera's tone curve makes two photos a stop apart differ by more in the shadows than in
    the highlights, which one gain cannot follow. (Cut by one view's brightness alone, a
    bin's pixels would be that view's darkest or brightest by chance too, and the other
    view would look brighter in the dark bins and darker in the bright ones, whatever the
    exposures.)"""
    out = []
    for a, b, own, other in shared_pixels(views, cams, neighbours):
        la, lb = np.log(own / PIVOT), np.log(other / PIVOT)
        order = np.argsort(la.mean(-1) + lb.mean(-1), kind="stable")
        parts = np.array_split(order, bins)
        out.append((a, b, np.stack([np.median(la[p], axis=0) for p in parts]),
                    np.stack([np.median(lb[p], axis=0) for p in parts])))
    return out


def solve_gains(stems: list[str], diffs: list[tuple[str, str, np.ndarray]]
                ) -> dict[str, np.ndarray]:
    """{stem: [3] linear gain} from pairwise log differences log(b / a) = e_b - e_a: least
    squares with the mean log exposure of the reached views at zero; gain = exp(-e)."""
    index = {s: i for i, s in enumerate(stems)}
    reached = sorted({index[a] for a, _, _ in diffs} | {index[b] for _, b, _ in diffs})
    gains = {s: np.ones(3) for s in stems}
    if len(reached) < 2:
        return gains
    col = {v: j for j, v in enumerate(reached)}
    A = np.zeros((len(diffs) + 1, len(reached)))
    y = np.zeros((len(diffs) + 1, 3))
    for r, (a, b, d) in enumerate(diffs):
        A[r, col[index[b]]], A[r, col[index[a]]] = 1.0, -1.0
        y[r] = d
    A[-1] = 1.0  # mean zero
    e = np.linalg.lstsq(A, y, rcond=None)[0]
    e = np.clip(e, -MAX_EV * np.log(2), MAX_EV * np.log(2))
    for v, j in col.items():
        gains[stems[v]] = np.exp(-e[j])
    return gains


def _solve_bins(stems: list[str], bins: list[tuple[str, str, np.ndarray, np.ndarray]],
                extra, bin_terms, more_rows=lambda n, heavy, width: ()):
    """The least squares of :func:`solve_curves` and :func:`solve_camera_curve`: unknowns a
    log gain e per reached view and channel, then ``extra(n)`` more for the n reached views;
    one equation per bin and channel of every pair, e_a - e_b + terms = rhs, where
    ``bin_terms(row, n, ja, jb, level_a, level_b)`` writes the terms into ``row`` and returns
    rhs; heavy rows hold the reached views' mean e at zero, ``more_rows(n, heavy, width)``
    adds (row, rhs) after them. Returns ({view index: j}, [n, 3] e clipped to ``MAX_EV``,
    the extra unknowns), or None when fewer than two views are reached."""
    index = {s: i for i, s in enumerate(stems)}
    reached = sorted({index[a] for a, _, _, _ in bins} | {index[b] for _, b, _, _ in bins})
    if len(reached) < 2:
        return None
    col = {v: j for j, v in enumerate(reached)}
    n = len(reached)
    width = 3 * n + extra(n)
    rows, rhs = [], []
    for a, b, level_a, level_b in bins:
        ja, jb = col[index[a]], col[index[b]]
        for k in range(len(level_a)):
            for c in range(3):
                r = np.zeros(width)
                r[3 * ja + c], r[3 * jb + c] = 1.0, -1.0
                rhs.append(bin_terms(r, n, ja, jb, level_a[k, c], level_b[k, c]))
                rows.append(r)
    heavy = 10.0 * np.sqrt(len(rows) / n)
    for c in range(3):
        r = np.zeros(width)
        r[[3 * j + c for j in range(n)]] = heavy
        rows.append(r)
        rhs.append(0.0)
    for r, y in more_rows(n, heavy, width):
        rows.append(r)
        rhs.append(y)
    x = np.linalg.lstsq(np.stack(rows), np.array(rhs), rcond=None)[0]
    e = np.clip(x[:3 * n].reshape(n, 3), -MAX_EV * np.log(2), MAX_EV * np.log(2))
    return col, e, x[3 * n:]


def solve_curves(stems: list[str], bins: list[tuple[str, str, np.ndarray, np.ndarray]]
                 ) -> dict[str, np.ndarray]:
    """{stem: [4] curve} from :func:`pair_bins`: per view a log gain e (per channel) and a
    slope s (all channels) such that e_a + s_a * level_a = e_b + s_b * level_b on every bin
    of every pair; least squares with the reached views' mean e at zero and mean s at 1,
    each s pulled towards 1 by ``SLOPE_PRIOR``. A curve [g_r, g_g, g_b, s] maps linear x to
    PIVOT * g * (x / PIVOT) ** s (:func:`apply_gain`); a view no pair reaches keeps
    [1, 1, 1, 1]."""

    def slopes(r, n, ja, jb, level_a, level_b):
        r[3 * n + ja] += level_a
        r[3 * n + jb] -= level_b
        return 0.0

    def mean_and_prior(n, heavy, width):
        r = np.zeros(width)
        r[3 * n:] = heavy
        yield r, heavy * n
        for j in range(n):
            r = np.zeros(width)
            r[3 * n + j] = SLOPE_PRIOR
            yield r, SLOPE_PRIOR

    curves = {s: np.ones(4) for s in stems}
    fit = _solve_bins(stems, bins, lambda n: n, slopes, mean_and_prior)
    if fit is None:
        return curves
    col, e, slope = fit
    slope = np.clip(slope, *SLOPES)
    for v, j in col.items():
        curves[stems[v]] = np.append(np.exp(e[j]), slope[j])
    return curves


def solve_camera_curve(stems: list[str], bins: list[tuple[str, str, np.ndarray, np.ndarray]]
                       ) -> dict[str, np.ndarray]:
    """{stem: [5] camera transform [g_r, g_g, g_b, 1, c]} from :func:`pair_bins`: one tone
    curve for the camera, shared by every view (log radiance = l + c l^2 of the level l,
    :func:`to_radiance`), and a log gain e per view and channel, such that
    e_a + to_radiance(level_a) = e_b + to_radiance(level_b) on every bin of every pair:
    linear in (e, c), least squares with the reached views' mean e at zero. Photos of one
    camera share its curve; what differs between them is the exposure. A view no pair
    reaches keeps gain 1 (and the curve)."""

    def shared(r, n, ja, jb, level_a, level_b):
        r[-1] = level_a ** 2 - level_b ** 2
        return level_b - level_a

    out = {s: np.array([1.0, 1.0, 1.0, 1.0, 0.0]) for s in stems}
    fit = _solve_bins(stems, bins, lambda n: 1, shared)
    if fit is None:
        return out
    col, e, rest = fit
    c = float(np.clip(rest[0], *CAMERA_C))
    for s in stems:
        out[s][4] = c
    for v, j in col.items():
        out[stems[v]][:3] = np.exp(e[j])
    return out


MODELS = ("gain", "view-curves", "camera-curve")
"""How the views are brought to one exposure: a gain per view and channel
(:func:`solve_gains`), a curve per view (:func:`solve_curves`), or one tone curve for the
camera and a gain per view (:func:`solve_camera_curve`)."""


def estimate_gains(ws, neighbours: int = 4, model: str = "gain") -> dict[str, np.ndarray]:
    """{stem: [3] linear gain to the common exposure} of a workspace's views (WS/images,
    WS/masks, WS/depth); with ``model`` "view-curves" {stem: [4] curve}, "camera-curve"
    {stem: [5] camera transform} (``MODELS``). Every gain 1 without depth maps."""
    from pipeline.depth import load_views
    from pipeline.ws_files import read_cameras

    cams = read_cameras(ws)
    views = load_views(ws, cams, cams.stems, with_depth=True)
    if model == "gain":
        return solve_gains(cams.stems, pair_differences(views, cams, neighbours))
    solve = {"view-curves": solve_curves, "camera-curve": solve_camera_curve}[model]
    return solve(cams.stems, pair_bins(views, cams, neighbours))


def darkest_reference(gains: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The same gains (or curves, camera transforms) to a darker common exposure: each
    gain's three channel factors divided by the largest of any view, so that no plain gain
    brightens a view (nothing clips at the common exposure). Ratios between views, and so
    what the render's inverse takes back to each frame, are unchanged."""
    if not gains:
        return {}
    top = max(float(np.max(np.asarray(g, np.float64)[:3])) for g in gains.values())
    out = {}
    for s, g in gains.items():
        g = np.array(g, np.float64)
        g[:3] /= top
        out[s] = g
    return out


def inverse(gain) -> np.ndarray:
    """The gain, curve or camera transform that undoes ``gain``: 1 / g; for a curve [g, s]
    the curve [g ** (-1 / s), 1 / s]; for a camera transform [g, s, c] the transform
    [g ** (-1 / s), 1 / s, c]."""
    g = np.asarray(gain, np.float64)
    if len(g) == 3:
        return 1.0 / g
    return np.concatenate([g[:3] ** (-1.0 / g[3]), [1.0 / g[3]], g[4:]])


def mean_gain(gains: list, weights) -> np.ndarray:
    """The weighted mean of gains (or curves, camera transforms; one kind) in the terms they
    act in: the log gains averaged, a curve's slope averaged, a camera transform's shared
    curve kept."""
    G = np.asarray(gains, np.float64)
    w = np.asarray(weights, np.float64)
    w = w / w.sum()
    out = G[0].copy()
    out[:3] = np.exp(w @ np.log(G[:, :3]))
    if G.shape[1] >= 4:
        out[3] = w @ G[:, 3]
    return out


def path_gain(centre: np.ndarray, centres: np.ndarray, gains: list, sigma: float
              ) -> np.ndarray:
    """The ``gains`` of cameras at ``centres`` [N, 3] averaged by :func:`mean_gain` with a
    Gaussian weight of their distance from ``centre`` (``sigma``, scene units): a gain that
    glides as the camera moves (``render --path-exposure``: the path's frames' own)."""
    d = np.linalg.norm(np.asarray(centres, np.float64) - np.asarray(centre, np.float64),
                       axis=1)
    e = 0.5 * (d / max(sigma, 1e-12)) ** 2
    return mean_gain(gains, np.exp(-(e - e.min())))  # the nearest photo's weight is 1


def between(srgb: np.ndarray, from_gain, to_gain) -> np.ndarray:
    """sRGB colours of a view whose gain to the common exposure is ``from_gain`` brought to
    the exposure whose gain is ``to_gain`` (:func:`apply_gain` of the one, then of the
    other's :func:`inverse`; one product for two plain gains)."""
    a, b = np.asarray(from_gain, np.float64), np.asarray(to_gain, np.float64)
    if len(a) == 3 and len(b) == 3:
        return apply_gain(srgb, a / b)
    return apply_gain(apply_gain(srgb, a), inverse(b))


def gains_json(gains: dict[str, np.ndarray]) -> dict[str, list[float]]:
    return {s: [round(float(x), 5) for x in g] for s, g in sorted(gains.items())}


def spread_ev(gains: dict[str, np.ndarray]) -> float:
    """Stops between the darkest and the brightest view (grey: the channels' mean log)."""
    e = [float(np.mean(np.log2(np.asarray(g)[:3]))) for g in gains.values()]
    return max(e) - min(e) if e else 0.0
