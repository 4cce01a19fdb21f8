"""Flare rays: starburst spikes and streaks found as light running straight out of a light.

The FMG marks the glow around a light well but loses thin spikes and long streaks drawn
differently from its training flare (gnfr/weights/fmg.md). Those two kinds share a geometry
no scene has by chance: they leave the light source along straight lines. In polar
coordinates about the light (rows = angle, columns = radius) a spike or streak is a row that
stays brighter than its angular neighbourhood from the light outwards; scene structure and
texture are not consistently brighter along one ray for long, and a round glow is as bright
at every angle. The rule (``ray_mask``):

1. **Lights**: connected regions of saturated pixels (any channel >= ``saturated``), no
   larger than ``max_light`` of the image and filling at least ``compact`` of their bounding
   box (the sky, a white wall, a ragged sunlit patch are not lights), with few bright pixels
   around them (``isolation``: a bit of a white cloud is surrounded by more cloud); the
   ``max_lights`` largest are kept.
2. **Polar resampling** of linear-light luminance about each light's centre (``cv2.warpPolar``,
   one column per pixel of radius, about two pixels of arc per row at the far corner).
3. **Background** at each angle and radius: the ``quantile`` (0.3) of ``samples`` angles
   within ``window`` degrees either side: spikes and streaks, narrow in angle, drop out of
   it; a round glow and the scene stay in.
4. **The rule**: a pixel may be flare where its excess over the background, in linear light,
   passes the synthesizer's own mask rule, ``excess > max(abs_threshold, rel_threshold x
   background)`` (``pipeline.flare``: 0.012 and 0.1), and it is a **ridge**: brighter by the
   same amount than both pixels at one of the ``flanks`` distances either side across the
   ray (a radial scene edge is a step: one side is as bright).
5. **Runs from the light**: along each angle, the run starting at the light goes on while
   ``density`` of a ``run_window`` window passes the rule (saturated pixels, the light and
   its core, continue a run but are not marked); runs shorter than ``min_length`` of the
   diagonal are dropped, and so are runs that do not **fade**: the mean excess over the
   first half must be ``fade`` times that over the second (a cloud or a wall lying along
   the ray is as bright far from the light as near it).
6. **Several rays**: a light keeps its runs only if they leave it in at least
   ``min_rays`` (3) separate directions (``ray_gap`` degrees apart): a starburst does; a
   kerb, a roof edge or a white cord that starts at a bright object gives one or two.
7. Back to the image (inverse polar map), the union over lights.

It marks nothing around a bare lamp or a specular highlight (no excess along a ray), and
nothing on a photo without a saturated light. It does not find ghosts (discs away from the
light) or veiling glare (round): those stay the FMG's. The mask stage adds it to the FMG's
mask (on by default, ``mask --no-rays`` to leave it out; docs/history/fmg.md, "Fifth
session", has its scores).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.colour import LUMA, srgb_to_linear
from pipeline.options import option


@dataclass
class RayConfig:
    """Parameters of the flare-ray rule (module docstring)."""

    saturated: float = option(0.98, gt=0, le=1)
    """sRGB level (0..1) from which a pixel counts as saturated (a light)."""
    min_light: int = option(2, ge=1)
    """Fewest saturated pixels of a light."""
    max_light: float = option(0.003, gt=0, le=1)
    """Largest light, as a fraction of the image (larger saturated regions are not lights)."""
    compact: float = option(0.5, ge=0, le=1)
    """Least share of its bounding box a light fills (a disc fills 0.79; the ragged saturated
    patches of a sunlit wall fill less)."""
    isolation: float = option(0.4, ge=0, le=1)
    """Largest share of bright pixels (any channel >= 0.9) in the ring from 1 % to 4 % of
    the diagonal around a light: a lamp or the sun stands alone; the saturated bits of
    clouds, white walls and sunlit ground are surrounded by more of the same."""
    max_lights: int = option(6, ge=1)
    """Lights per image (the largest)."""
    window: float = option(45.0, gt=0, le=90)
    """Half-width (degrees) of the angular neighbourhood whose ``quantile`` is the
    background."""
    quantile: float = option(0.3, gt=0, lt=1)
    """Which quantile of the neighbourhood is the background (0.5: the median; lower stays
    at the scene where several spikes share the neighbourhood)."""
    samples: int = option(31, ge=3)
    """Angles sampled across the neighbourhood for the background."""
    abs_threshold: float = option(0.012, gt=0)
    """Excess (linear luminance) above which a pixel may be flare."""
    rel_threshold: float = option(0.1, ge=0)
    """... and above this fraction of the background."""
    flanks: tuple[float, ...] = option((0.01, 0.03, 0.08), gt=0)
    """Distances (fraction of the diagonal, across the ray) at which both sides of a ray
    pixel must be darker by the rule, at one distance at least: a spike or streak is a
    ridge, a radial scene edge a step (one side as bright)."""
    run_window: float = option(0.02, ge=0)
    """Length (fraction of the diagonal) of the window along a ray over which ...
    ``density`` of the pixels must pass the rule for a run to go on."""
    slack: float = option(0.0, ge=0)
    """Distance from the light (fraction of the diagonal) within which a run may begin
    (near the light broad streaks and the glow leave no ray narrow enough to see)."""
    density: float = option(0.6, gt=0, le=1)
    """... at least this share (texture passes the rule here and there, a spike all along)."""
    fade: float = option(1.5, ge=0)
    """Least ratio of a run's mean excess over its first half to its second half (0: no
    test): the light of a spike or streak fades away from the lamp."""
    min_length: float = option(0.05, gt=0)
    """Shortest run kept, fraction of the image diagonal."""
    min_rays: int = option(3, ge=1)
    """Fewest separate rays (runs at angles at least ``ray_gap`` degrees apart) a light
    must send out for any of them to be kept: a starburst has 4 or more spikes; a scene
    line or two that happen to start at a bright object (a roof edge, a kerb, a white
    cord) give one or two. 3 was chosen on the development scenes (docs/history/fmg.md,
    "Fifth session"): 1 and 2 marked kerbs and roof edges of a daylight scene; 3 loses a
    little of the single streaks (they leave a light in one or two directions)."""
    ray_gap: float = option(10.0, gt=0)
    """Angular gap (degrees) that separates two rays of one light (``min_rays``)."""
    opposite: float = option(0.0, ge=0, le=90)
    """With ``min_rays`` > 2: two rays also suffice when they leave the light in opposite
    directions within this many degrees (a streak runs through the light); 0: off."""
    lines: bool = False
    """Also mark streak lines through each light (``pipeline.flare_lines``): thin straight
    streaks, one each way, that the rays' polar runs lose (`mask --streak-lines`)."""
    line_scales: tuple[float, ...] = option((1.0,), gt=0, le=1, metavar="S1,S2")
    """With ``lines``: the fractions of the image's size the streak lines are looked for at
    (``flare_lines.line_mask_scaled``; 0.25 also finds a beam tens of pixels wide; `mask
    --streak-scales`)."""
    cores: bool = False
    """A saturated region too large or too ragged to be a light (``max_light``,
    ``compact``) is looked at again by its core: its pixels at least half its largest
    inscribed radius deep, the part around the deepest one, grown back by that much
    (``light_core``). A lamp whose saturated streak runs out of it (a long thin arm of the
    region) is then found at its lamp, where alone its rays can be seen; the core must pass
    the same tests, and its rays are kept when two of them leave it in opposite directions
    within ``core_opposite`` degrees, as well as by ``min_rays`` (the saturated arm is a
    streak through the lamp; `mask --light-cores`)."""
    core_opposite: float = option(8.0, ge=0, le=90)
    """With ``cores``: the opposite rays' tolerance (degrees) for a light found by its core
    (0: such a light needs ``min_rays`` as any other)."""


def find_lights(img: np.ndarray, cfg: RayConfig) -> list[tuple[float, float, float]]:
    """(x, y, radius) of the lights of sRGB ``img`` [H, W, 3] float 0..1: saturated regions
    of ``min_light`` pixels up to ``max_light`` of the image, ``compact`` and isolated
    (``isolation``), largest first (at most ``max_lights``)."""
    sat = (img.max(-1) >= cfg.saturated).astype(np.uint8)
    n, labels, stats, cents = cv2.connectedComponentsWithStats(sat, connectivity=8)
    area_max = cfg.max_light * sat.size
    area = stats[:, cv2.CC_STAT_AREA]
    box = stats[:, cv2.CC_STAT_WIDTH] * stats[:, cv2.CC_STAT_HEIGHT]
    lights = []  # (area, label, x, y): a whole region, or (``cores``) its core
    for i in range(1, n):
        if area[i] < cfg.min_light:
            continue
        if area[i] <= area_max and area[i] >= cfg.compact * box[i]:
            lights.append((int(area[i]), i, *map(float, cents[i])))
        elif cfg.cores:
            x0, y0, bw, bh = stats[i, :4]
            core = light_core(labels[y0:y0 + bh, x0:x0 + bw] == i)
            ys, xs = np.nonzero(core)
            a = len(xs)
            if (cfg.min_light <= a <= area_max
                    and a >= cfg.compact * (np.ptp(xs) + 1) * (np.ptp(ys) + 1)):
                lights.append((a, i, x0 + float(xs.mean()), y0 + float(ys.mean())))
    lights.sort(reverse=True)
    bright = img.max(-1) >= 0.9
    h, w = sat.shape
    diag = float(np.hypot(h, w))
    out = []
    for a, _, x, y in lights:
        rad = float(np.sqrt(a / np.pi))
        r_out = rad + 0.04 * diag  # the ring, looked at in its own window only
        x0, x1 = max(0, int(x - r_out)), min(w, int(x + r_out) + 2)
        y0, y1 = max(0, int(y - r_out)), min(h, int(y + r_out) + 2)
        yy, xx = np.mgrid[y0:y1, x0:x1]
        d = np.hypot(xx - x, yy - y)
        ring = (d >= rad + 0.01 * diag) & (d <= r_out)
        if ring.any() and bright[y0:y1, x0:x1][ring].mean() > cfg.isolation:
            continue
        out.append((float(x), float(y), rad))
        if len(out) == cfg.max_lights:
            break
    return out


def light_core(region: np.ndarray) -> np.ndarray:
    """[h, w] bool: the core of the saturated ``region`` [h, w] bool: its pixels at least half
    its largest inscribed radius from its edge, the connected part holding the deepest one,
    grown back by that half radius within the region (an opening that keeps a lamp and
    drops the thin arms of a saturated streak through it)."""
    region = region.astype(np.uint8)
    depth = cv2.distanceTransform(np.pad(region, 1), cv2.DIST_L2, 5)[1:-1, 1:-1]
    half = 0.5 * float(depth.max())
    _, parts = cv2.connectedComponents((depth >= half).astype(np.uint8), connectivity=8)
    y, x = np.unravel_index(int(depth.argmax()), depth.shape)
    r = max(1, int(round(half)))
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    grown = cv2.dilate((parts == parts[y, x]).astype(np.uint8), disk,
                       borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return (grown > 0) & (region > 0)


def found_by_core(img: np.ndarray, lights: list[tuple[float, float, float]],
                  cfg: RayConfig) -> list[bool]:
    """Per light of ``lights`` (``find_lights``), whether its saturated region fails the
    whole-region tests (``max_light``, ``compact``): a light ``cores`` found by its core."""
    sat = (img.max(-1) >= cfg.saturated).astype(np.uint8)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(sat, connectivity=8)
    h, w = sat.shape
    out = []
    for x, y, _ in lights:
        i = labels[min(h - 1, max(0, int(round(y)))), min(w - 1, max(0, int(round(x))))]
        a = stats[i, cv2.CC_STAT_AREA]
        box = stats[i, cv2.CC_STAT_WIDTH] * stats[i, cv2.CC_STAT_HEIGHT]
        out.append(bool(i > 0 and (a > cfg.max_light * sat.size or a < cfg.compact * box)))
    return out


def _angular_quantile(p: np.ndarray, window: float, samples: int, bins: int = 240,
                      quantile: float = 0.5) -> np.ndarray:
    """The ``quantile`` of ``samples`` angles within +-``window`` degrees of each row of
    the polar image ``p`` [A, R] (rows = angles over 360 degrees, wrapping), computed on
    ``bins`` angles (area-averaged) and interpolated back to A rows. NaN (outside the
    image) is left out."""
    a = p.shape[0]
    valid = np.isfinite(p)
    coarse = cv2.resize(np.where(valid, p, 0).astype(np.float32), (p.shape[1], bins),
                        interpolation=cv2.INTER_AREA)
    cover = cv2.resize(valid.astype(np.float32), (p.shape[1], bins),
                       interpolation=cv2.INTER_AREA)
    coarse = np.where(cover > 0.5, coarse / np.maximum(cover, 1e-6), np.nan)
    offs = np.round(np.linspace(-window, window, samples) / 360.0 * bins).astype(int)
    stack = np.sort(np.stack([np.roll(coarse, -o, axis=0) for o in offs], 0), axis=0)
    n = np.isfinite(stack).sum(0)  # NaN sorts last
    k = np.clip(np.round(quantile * (n - 1)), 0, None).astype(int)[None]
    med = np.take_along_axis(stack, k, 0)[0]
    med = np.where((n > 0) & np.isfinite(med), med, 0.0).astype(np.float32)
    ext = np.concatenate([med[-1:], med, med[:1]], 0)  # wrap for the interpolation
    rows = (np.arange(a) + 0.5) * bins / a - 0.5 + 1  # row centres in ``ext`` coordinates
    i0 = np.clip(np.floor(rows).astype(int), 0, bins)
    t = (rows - i0)[:, None].astype(np.float32)
    return ext[i0] * (1 - t) + ext[i0 + 1] * t


def _ridge(pol: np.ndarray, thresh: np.ndarray, dist: float, na: int,
           rmax: float) -> np.ndarray:
    """[A, R] bool: pixels of the polar image ``pol`` brighter by ``thresh`` than both
    pixels ``dist`` pixels away across the ray (at their radius), on either side."""
    a, r = pol.shape
    radius = (np.arange(r) + 0.5) * rmax / r
    shift = np.clip(np.round(dist / np.maximum(radius, 1e-6) / (2 * np.pi) * na), 1, a // 4)
    rows = np.arange(a)[:, None]
    cols = np.arange(r)[None, :]
    s = shift.astype(int)[None, :]
    side = np.maximum(pol[(rows - s) % a, cols], pol[(rows + s) % a, cols])
    return pol - side > thresh


def _runs_from_light(on: np.ndarray, linked: np.ndarray, start: int, window: int,
                     density: float, min_len: int, slack: int = 0) -> np.ndarray:
    """[A, R] bool: per row, the ``on`` pixels of the run that starts at column ``start``
    and goes on while at least ``density`` of the ``window`` columns centred on each column
    are ``on`` or ``linked`` (``linked`` pixels alone also continue it); runs shorter than
    ``min_len`` columns are dropped."""
    a, r = on.shape
    both = (on | linked).astype(np.float32)
    if window > 1:
        dense = cv2.blur(both, (window, 1), borderType=cv2.BORDER_REPLICATE) >= density
    else:
        dense = both > 0
    cont = dense | linked
    cont[:, :start + slack] = True  # inside the light, and where a run may begin
    cols = np.arange(r)[None, :]
    stop = np.where(~cont, cols, r).min(1)  # first column that breaks the run
    run = (cols >= start) & (cols < stop[:, None]) & ((stop - start) >= min_len)[:, None]
    return run & on, stop


def _fading(run: np.ndarray, excess: np.ndarray, start: int, stop: np.ndarray,
            ratio: float) -> np.ndarray:
    """[A] bool: rows whose run is brighter over the excess in its first half than in its
    second by ``ratio``: light from the lamp fades along a spike or streak; a cloud or a wall
    that happens to lie along the ray does not."""
    e = np.where(run, excess, 0.0)
    c = np.concatenate([np.zeros((e.shape[0], 1)), np.cumsum(e, 1)], 1)
    n = np.concatenate([np.zeros((e.shape[0], 1)), np.cumsum(run, 1)], 1)
    rows = np.arange(e.shape[0])
    half = (start + stop) // 2
    first = (c[rows, half] - c[rows, start]) / np.maximum(n[rows, half] - n[rows, start], 1)
    second = (c[rows, stop] - c[rows, half]) / np.maximum(n[rows, stop] - n[rows, half], 1)
    return first >= ratio * second


def ray_directions(rows: np.ndarray, gap: float) -> list[float]:
    """Directions (degrees, 0..360) of the separate rays among the angles ``rows`` [A] bool
    (all 360 degrees, wrapping): groups of marked angles split by at least ``gap`` degrees
    of unmarked ones, each at its middle angle."""
    a = rows.shape[0]
    idx = np.flatnonzero(rows)
    if len(idx) == 0:
        return []
    steps = np.diff(np.concatenate([idx, idx[:1] + a]))  # to the next marked row, wrapping
    ends = np.flatnonzero(steps > gap / 360.0 * a)
    if len(ends) == 0:  # one group all round (or gaps all smaller than ``gap``)
        return [float(np.degrees(np.angle(np.exp(2j * np.pi * idx / a).mean())) % 360.0)]
    first = ends[-1] + 1  # a group starts after the last gap: unroll the circle there
    order = np.concatenate([idx[first:], idx[:first] + a])
    groups = np.split(order, np.flatnonzero(np.diff(order) > gap / 360.0 * a) + 1)
    return [float((g.mean() + 0.5) * 360.0 / a % 360.0) for g in groups]


def enough_rays(directions: list[float], cfg: RayConfig, core: bool = False) -> bool:
    """Whether a light's rays look like flare: at least ``min_rays`` of them, or (with
    ``opposite``, or ``core_opposite`` for a light found by its ``core``) two leaving it in
    opposite directions, as a streak through the light does."""
    if len(directions) >= cfg.min_rays:
        return True
    tol = max(cfg.opposite, cfg.core_opposite if core and cfg.cores else 0.0)
    if tol > 0:
        d = np.asarray(directions)
        diff = np.abs((d[:, None] - d[None, :]) % 360.0 - 180.0)
        return bool((diff <= tol).any())
    return False


def ray_mask(img: np.ndarray, cfg: RayConfig | None = None,
             lights: list[tuple[float, float, float]] | None = None) -> np.ndarray:
    """[H, W] bool: pixels of flare rays (spikes, streaks) of sRGB ``img`` [H, W, 3] float
    0..1 (see the module docstring); ``lights``: ``find_lights(img, cfg)`` if already
    found."""
    cfg = cfg or RayConfig()
    h, w = img.shape[:2]
    out = np.zeros((h, w), bool)
    lights = find_lights(img, cfg) if lights is None else lights
    if not lights:
        return out
    lum = (srgb_to_linear(np.clip(img, 0, 1)).astype(np.float32) @ LUMA).astype(np.float32)
    sat = (img.max(-1) >= cfg.saturated).astype(np.float32)
    ones = np.ones((h, w), np.float32)
    diag = float(np.hypot(h, w))
    cores = found_by_core(img, lights, cfg) if cfg.cores else [False] * len(lights)
    for (x, y, rad), core in zip(lights, cores, strict=True):
        rmax = float(max(np.hypot(cx - x, cy - y) for cx in (0, w) for cy in (0, h)))
        nr = max(8, int(np.ceil(rmax)))
        na = int(np.clip(np.pi * rmax, 360, 2048))
        flags = cv2.WARP_POLAR_LINEAR | cv2.INTER_LINEAR | cv2.WARP_FILL_OUTLIERS
        pol = cv2.warpPolar(lum, (nr, na), (x, y), rmax, flags)
        inside = cv2.warpPolar(ones, (nr, na), (x, y), rmax, flags) > 0.99
        psat = cv2.warpPolar(sat, (nr, na), (x, y), rmax, flags) > 0.5
        p = np.where(inside, pol, np.nan).astype(np.float32)
        bg = _angular_quantile(p, cfg.window, cfg.samples, quantile=cfg.quantile)
        excess = np.where(inside, pol - bg, 0.0)
        thresh = np.maximum(cfg.abs_threshold, cfg.rel_threshold * bg)
        ridge = np.zeros_like(inside)
        for d in cfg.flanks:
            ridge |= _ridge(pol, thresh, d * diag, na, rmax)
        on = (excess > thresh) & ridge & inside & ~psat
        start = int(np.ceil(rad)) + 1
        run, stop = _runs_from_light(on, psat, start,
                                     max(1, int(round(cfg.run_window * diag))), cfg.density,
                                     max(1, int(round(cfg.min_length * diag))),
                                     int(round(cfg.slack * diag)))
        if cfg.fade > 0:
            run &= _fading(run, excess, min(start, nr), np.maximum(stop, start), cfg.fade)[:, None]
        if cfg.min_rays > 1 and not enough_rays(ray_directions(run.any(1), cfg.ray_gap), cfg,
                                                core):
            continue
        back = cv2.warpPolar(run.astype(np.float32), (w, h), (x, y), rmax,
                             flags | cv2.WARP_INVERSE_MAP)
        out |= back > 0.5
    if cfg.lines:
        from pipeline.flare_lines import line_mask_scaled

        out |= line_mask_scaled(img, lights, tuple(cfg.line_scales), saturated=cfg.saturated)
    return out
