"""Streak lines: thin straight streaks that cross a saturated light, found line by line.

An anamorphic lens draws one thin, nearly straight streak through each light, often across
the whole frame, barely fading. The flare rays (``pipeline.flare_rays``) look for it in a
polar image about the light, where a line that misses the light's centre by a pixel wanders
across rows, and their ``fade`` test drops a streak that does not fade; the FMG marks none
of it (docs/history/fmg.md, "Sixty-first session"). This looks for it as a line instead.

For each light (``pipeline.flare_rays.find_lights``), every line that passes within
``offsets`` pixels of its centre, at every ``step`` degrees, is sampled pixel by pixel in
linear luminance, each half out from the light on its own. A sample is *on* where it is
brighter than both samples ``flank`` pixels away across the line by ``abs_threshold`` and
``rel_threshold`` of the brighter flank (a ridge, as the rays' test). Saturated samples
count neither way. A half's run starts ``slack`` beyond the light (its glow hides the ridge
there) and ends at the farthest sample up to which at least ``density`` of the samples are
on: gaps, where the streak crosses something as bright, are fine while the share holds. A
line is a streak when each half's run holds ``density`` x ``min_length`` of the diagonal in
on samples, or reaches the frame's edge, and the weaker half's mean ridge excess near the
light is at least ``symmetry`` of the stronger's (the streak adds the same light both
ways), and neither half's ridge samples more than ``bright`` near white (a lit scene edge
is bright itself, a streak's ridge mostly is not). A light keeps its ``max_lines`` streaks
with the most on samples that are ``separation`` degrees apart. A streak's marks are its
on samples and, across each, the pixels up to ``half_width`` away brighter than the
background beyond them (``half_width`` + ``flank`` away) by the same thresholds.

Shaped on the one-kind streak scenes of seed 31 (one anamorphic lens) and the clean
development photos; judged as the mask stage's default and not made it (it finds bright
long streaks, not faint short ones; docs/history/fmg.md, "Sixty-second session: streak
lines through a light"): `mask --streak-lines`. A beam tens of pixels wide (broader than
``flank``) is a ridge on the photo shrunk: ``line_mask_scaled`` runs the rule at fractions of
the working size (`mask --streak-scales`, an option; docs/history/fmg.md, "Ninety-sixth
session").
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.colour import LUMA, srgb_to_linear
from pipeline.options import option


@dataclass
class LineConfig:
    """The streak-line rule (see the module docstring). Lengths are in pixels at the
    working size (512 px long side), or fractions of the image diagonal where so said."""

    step: float = option(0.25, gt=0, le=5)
    """Angle between two lines tried through a light (degrees)."""
    offsets: float = option(1.5, ge=0, le=5)
    """Farthest a line may pass from the light's centre (pixels; tried every 0.5)."""
    flank: float = option(4.0, gt=0)
    """Distance across the line of the two samples a ridge must be brighter than."""
    abs_threshold: float = option(0.012, gt=0)
    """Linear luminance a ridge must exceed its brighter flank by."""
    rel_threshold: float = option(0.1, ge=0)
    """... and this fraction of that flank."""
    density: float = option(0.6, gt=0, le=1)
    """Share of a half's samples, from where its run may begin, that must be on up to where
    the run ends."""
    min_length: float = option(0.1, gt=0)
    """Shortest run each way from the light (fraction of the diagonal) unless it meets the
    frame's edge."""
    slack: float = option(0.03, ge=0)
    """Stretch beyond the light (fraction of the diagonal) where a run may begin: the
    light's glow hides the streak's ridge next to it."""
    edge: float = option(3.0, ge=0)
    """A run that stops this close (pixels) to where the line leaves the frame reaches it."""
    max_lines: int = option(2, ge=1)
    """Most streaks kept per light."""
    separation: float = option(3.0, gt=0)
    """Fewest degrees between two streaks kept through one light."""
    bright: float = option(0.5, ge=0, le=1)
    """Largest share of either half's ridge samples that may be near white (sRGB at least
    ``bright_level`` in some channel); 1: no limit."""
    bright_level: float = option(0.9, gt=0, le=1)
    """The sRGB level of ``bright``."""
    symmetry: float = option(0.3, ge=0, le=1)
    """The weaker half's mean ridge excess near the light (over ``min_length``) at least
    this share of the stronger's: a streak adds the same light both ways."""
    half_width: int = option(3, ge=0)
    """Farthest (pixels) across a streak its marks may spread."""


def _sample(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear samples of ``img`` at float coordinates; NaN outside the image."""
    flat = x.ndim == 1
    x, y = (x[None], y[None]) if flat else (x, y)
    out = cv2.remap(img, np.asarray(x, np.float32), np.asarray(y, np.float32),
                    cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan)
    return out[0] if flat else out


def _ridge_on(lum: np.ndarray, x: np.ndarray, y: np.ndarray, nx: np.ndarray, ny: np.ndarray,
              shift: float, cfg: LineConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(on, inside, excess): the ridge test at the samples ``shift`` pixels across the lines
    (unit normals ``nx``, ``ny``) from (``x``, ``y``), whether those samples are in the
    frame, and how much brighter they are than the brighter flank."""
    cx, cy = x + shift * nx, y + shift * ny
    c = _sample(lum, cx, cy)
    a = _sample(lum, cx + cfg.flank * nx, cy + cfg.flank * ny)
    b = _sample(lum, cx - cfg.flank * nx, cy - cfg.flank * ny)
    inside = np.isfinite(c)
    side = np.fmax(a, b)  # a flank outside the frame does not count
    side = np.where(np.isfinite(side), side, np.inf)
    thresh = np.maximum(cfg.abs_threshold, cfg.rel_threshold * side)
    return inside & (c - side > thresh), inside, c - side


def _prefix_run(on: np.ndarray, valid: np.ndarray, begin: int,
                density: float) -> tuple[np.ndarray, np.ndarray]:
    """(stop, count) per row: the farthest column ``stop`` such that at least ``density``
    of the ``valid`` samples from ``begin`` up to it are ``on``, and how many are on there
    (0 and ``begin`` where none is)."""
    o = on[:, begin:]
    if o.shape[1] == 0:
        return np.full(on.shape[0], begin), np.zeros(on.shape[0])
    n_on = np.cumsum(o, 1, dtype=np.int32)  # counts: exact
    n_valid = np.maximum(np.cumsum(valid[:, begin:], 1, dtype=np.int32), 1)
    good = (n_on >= density * n_valid) & (n_on > 0)
    cols = np.arange(o.shape[1], dtype=np.int32)[None]
    last = np.where(good, cols, -1).max(1)
    count = np.where(last >= 0, np.take_along_axis(n_on, np.maximum(last, 0)[:, None], 1)[:, 0],
                     0)
    return begin + last + 1, count


def _in_frame(x: np.ndarray, y: np.ndarray, dx: np.ndarray, dy: np.ndarray, w: int, h: int,
              reach: int) -> np.ndarray:
    """[N] int: per ray from (``x``, ``y``) along (``dx``, ``dy``), how many unit steps from
    the start can still sample the image (a pixel past where it leaves [-1, W] x [-1, H]),
    at most ``reach``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(dx > 0, (w - x) / dx, np.where(dx < 0, (-1 - x) / dx, np.inf))
        ty = np.where(dy > 0, (h - y) / dy, np.where(dy < 0, (-1 - y) / dy, np.inf))
    steps = np.floor(np.minimum(tx, ty)) + 2
    return np.clip(np.nan_to_num(steps, posinf=reach), 0, reach).astype(int)


def _by_length(lengths: np.ndarray, groups: int = 6):
    """(rows, length) groups of about equal size, rows sorted by ``lengths``, each group's
    length its longest; groups of length 0 are left out."""
    order = np.argsort(lengths, kind="stable")
    for rows in np.array_split(order, groups):
        if len(rows) and lengths[rows].max() > 0:
            yield rows, int(lengths[rows].max())


def _halves_alike(excess: np.ndarray, stop: np.ndarray, begin: int, length: int,
                  symmetry: float) -> np.ndarray:
    """[M] bool, for M lines given as 2M rows (first halves, then second): whether the weaker
    half's mean ridge excess, over the stretch from ``begin`` both halves' runs have (at
    most ``length``), is at least ``symmetry`` of the stronger's. A streak adds the same
    light both ways."""
    m = len(stop) // 2
    common = np.minimum(np.minimum(stop[:m], stop[m:]), begin + length)
    cols = np.arange(excess.shape[1])[None]
    e = np.where(np.isfinite(excess), np.clip(excess, 0, None), 0.0)
    span = (cols >= begin) & (cols < np.concatenate([common, common])[:, None])
    mean = (e * span).sum(1) / np.maximum(span.sum(1), 1)
    return np.minimum(mean[:m], mean[m:]) >= symmetry * np.maximum(mean[:m], mean[m:])


def _halves_not_white(on: np.ndarray, stop: np.ndarray, begin: int, white: np.ndarray,
                      bright: float) -> np.ndarray:
    """[M] bool, for M lines given as 2M rows: whether neither half's run (its on samples
    from ``begin`` to ``stop``) has more than ``bright`` of them ``white``. A lit scene edge
    is bright itself; a streak's ridge mostly is not."""
    m = len(stop) // 2
    cols = np.arange(on.shape[1])[None]
    run = on & (cols >= begin) & (cols < stop[:, None])
    share = (run & white).sum(1) / np.maximum(run.sum(1), 1)
    return np.maximum(share[:m], share[m:]) <= bright


def _mark_across(out: np.ndarray, lum: np.ndarray, xs: np.ndarray, ys: np.ndarray,
                 nx: float, ny: float, cfg: LineConfig) -> None:
    """Mark in ``out`` the on samples (``xs``, ``ys``) of one half-line (unit normal
    ``nx``, ``ny``) and, up to ``half_width`` across, the pixels brighter than the
    background beyond the marks' reach by the thresholds."""
    h, w = out.shape
    far = cfg.half_width + cfg.flank
    bg = np.fmax(_sample(lum, xs + far * nx, ys + far * ny),
                 _sample(lum, xs - far * nx, ys - far * ny))
    bg = np.where(np.isfinite(bg), bg, np.inf)
    thresh = np.maximum(cfg.abs_threshold, cfg.rel_threshold * bg)
    for d in range(-cfg.half_width, cfg.half_width + 1):
        sx, sy = xs + d * nx, ys + d * ny
        sel = (_sample(lum, sx, sy) - bg > thresh) | (d == 0)
        xi = np.round(sx[sel]).astype(int)
        yi = np.round(sy[sel]).astype(int)
        good = (xi >= 0) & (xi < w) & (yi >= 0) & (yi < h)
        out[yi[good], xi[good]] = True


@dataclass
class _Fan:
    """The lines tried through every light of one image: ``n`` angles ``step`` apart (unit
    direction ``ux``, ``uy``, normal ``nx``, ``ny``), each passed at ``offs`` pixels from the
    light's centre; a line's two halves are rows ``i`` (+u) and ``n + i`` (-u) of ``dx``,
    ``dy`` (and of their normals ``nxx``, ``nyy``)."""

    n: int
    nx: np.ndarray
    ny: np.ndarray
    offs: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    nxx: np.ndarray
    nyy: np.ndarray

    @classmethod
    def of(cls, cfg: LineConfig) -> _Fan:
        theta = np.deg2rad(np.arange(0.0, 180.0, cfg.step))
        ux, uy = np.cos(theta).astype(np.float32), np.sin(theta).astype(np.float32)
        nx, ny = -uy, ux
        n_off = int(round(cfg.offsets / 0.5))
        offs = np.arange(-n_off, n_off + 1, dtype=np.float32) * np.float32(0.5)
        return cls(n=len(theta), nx=nx, ny=ny, offs=offs,
                   dx=np.concatenate([ux, -ux])[:, None], dy=np.concatenate([uy, -uy])[:, None],
                   nxx=np.concatenate([nx, nx])[:, None], nyy=np.concatenate([ny, ny])[:, None])


@dataclass
class _Planes:
    """One image's planes the rule samples: linear luminance, saturated and near white."""

    lum: np.ndarray
    sat: np.ndarray
    near_white: np.ndarray

    @classmethod
    def of(cls, img: np.ndarray, cfg: LineConfig, saturated: float) -> _Planes:
        lum = (srgb_to_linear(np.clip(img, 0, 1)).astype(np.float32) @ LUMA).astype(np.float32)
        return cls(lum=lum, sat=(img.max(-1) >= saturated).astype(np.float32),
                   near_white=(img.max(-1) >= cfg.bright_level).astype(np.float32))


def _streaks_at(planes: _Planes, fan: _Fan, light: tuple[float, float, float],
                cfg: LineConfig) -> tuple[list[tuple[float, int, int]], dict]:
    """The lines through ``light`` whose two halves hold as a streak: (on samples, angle
    index, offset index) for each, and by (angle, offset) its two halves' sample positions,
    on samples and run ends."""
    h, w = planes.lum.shape
    x0, y0, rad = light
    diag = float(np.hypot(h, w))
    slack = int(round(cfg.slack * diag))
    min_len = cfg.min_length * diag
    n, dx, dy, nxx, nyy = fan.n, fan.dx, fan.dy, fan.nxx, fan.nyy
    reach = int(np.ceil(max(np.hypot(cx - x0, cy - y0) for cx in (0, w) for cy in (0, h))))
    t = np.arange(reach, dtype=np.float32)
    start = int(np.ceil(rad)) + 1
    best: list[tuple[float, int, int]] = []
    found: dict[tuple[int, int], tuple] = {}
    for k, o in enumerate(fan.offs):
        px = np.float32(x0) + o * nxx + t[None] * dx
        py = np.float32(y0) + o * nyy + t[None] * dy
        on = np.zeros(px.shape, bool)
        inside = np.zeros(px.shape, bool)
        excess = np.full(px.shape, np.nan, np.float32)
        linked = np.zeros(px.shape, bool)
        # sampled only as far as each half-line can be in the frame (beyond, a sample is
        # outside: neither on nor inside)
        for rows, length in _by_length(_in_frame(px[:, 0], py[:, 0], dx[:, 0], dy[:, 0],
                                                 w, h, reach)):
            cut = (rows, slice(0, length))
            on[cut], inside[cut], excess[cut] = _ridge_on(
                planes.lum, px[cut], py[cut], nxx[rows], nyy[rows], 0.0, cfg)
            linked[cut] = _sample(planes.sat, px[cut], py[cut]) > 0.5
        on &= ~linked
        begin = min(start + slack, reach)
        stop, count = _prefix_run(on, inside & ~linked, begin, cfg.density)
        # where each half leaves the frame
        end = np.where(inside, np.arange(reach, dtype=np.int32)[None], -1).max(1) + 1
        ok = (count >= cfg.density * min_len) | ((stop >= end - cfg.edge) & (count >= 3))
        sel = np.flatnonzero(ok[:n] & ok[n:])  # lines whose two halves hold
        if len(sel):
            rows = np.concatenate([sel, sel + n])
            keep = np.ones(len(sel), bool)
            if cfg.symmetry > 0:
                keep &= _halves_alike(excess[rows], stop[rows], begin, int(min_len),
                                      cfg.symmetry)
            if cfg.bright < 1:
                keep &= _halves_not_white(on[rows], stop[rows], begin,
                                          _sample(planes.near_white, px[rows], py[rows]) > 0.5,
                                          cfg.bright)
            sel = sel[keep]
        for i in sel:
            best.append((float(count[i] + count[n + i]), int(i), k))
            found[(int(i), k)] = (px[[i, n + i]], py[[i, n + i]], on[[i, n + i]],
                                  stop[[i, n + i]])
    return best, found


def _mark_streaks(out: np.ndarray, lum: np.ndarray, fan: _Fan, best: list, found: dict,
                  cfg: LineConfig) -> None:
    """Mark in ``out`` the ``max_lines`` streaks of ``best`` with the most on samples that
    are ``separation`` degrees apart."""
    kept: list[int] = []
    for _, i, k in sorted(best, reverse=True):
        if any(min(abs(i - j), fan.n - abs(i - j)) * cfg.step < cfg.separation
               for j in kept):
            continue
        kept.append(i)
        lx, ly, lon, lstop = found[(i, k)]
        for r in range(2):
            m = np.flatnonzero(lon[r, :lstop[r]])
            if len(m):
                _mark_across(out, lum, lx[r, m], ly[r, m], fan.nx[i], fan.ny[i], cfg)
        if len(kept) == cfg.max_lines:
            break


def line_mask(img: np.ndarray, lights: list[tuple[float, float, float]],
              cfg: LineConfig | None = None, saturated: float = 0.98) -> np.ndarray:
    """[H, W] bool: the streak lines through ``lights`` ((x, y, radius) at ``img``'s size)
    of sRGB ``img`` [H, W, 3] float 0..1 (see the module docstring)."""
    cfg = cfg or LineConfig()
    out = np.zeros(img.shape[:2], bool)
    if not lights:
        return out
    planes, fan = _Planes.of(img, cfg, saturated), _Fan.of(cfg)
    for light in lights:
        best, found = _streaks_at(planes, fan, light, cfg)
        _mark_streaks(out, planes.lum, fan, best, found, cfg)
    return out


def line_mask_scaled(img: np.ndarray, lights: list[tuple[float, float, float]],
                     scales: tuple[float, ...] = (1.0,), cfg: LineConfig | None = None,
                     saturated: float = 0.98) -> np.ndarray:
    """[H, W] bool: ``line_mask`` run on ``img`` shrunk to each of ``scales`` (fractions of
    its size; 1: as it is) with ``lights`` scaled alike, each mask brought back to full
    size (bilinear, kept at 0.5) and the masks added."""
    h, w = img.shape[:2]
    out = np.zeros((h, w), bool)
    for s in scales:
        if s == 1.0:
            out |= line_mask(img, lights, cfg, saturated)
            continue
        size = (max(8, int(round(w * s))), max(8, int(round(h * s))))
        sx, sy = size[0] / w, size[1] / h
        small = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
        found = line_mask(small, [(x * sx, y * sy, r * min(sx, sy)) for x, y, r in lights],
                          cfg, saturated)
        if found.any():
            out |= cv2.resize(found.astype(np.float32), (w, h),
                              interpolation=cv2.INTER_LINEAR) >= 0.5
    return out
