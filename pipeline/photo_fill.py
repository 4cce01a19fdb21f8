"""Detail from the photos: clean pixels of neighbouring photos warped into a camera by depth.

The network's fill is a smooth estimate; the neighbours usually saw the same surface sharp
and flare-free. For a camera (an input view's flare region, or a novel frame) this module
splats the neighbours' depth maps (WS/depth) into it, warps the neighbours' clean pixels
(flare masks respected, occlusion checked against each neighbour's own depth) through that
depth at full source resolution, and keeps a pixel's colour only where at least
``min_support`` neighbours agree on it. Render uses the network where support is lacking
(docs/depth.md, "Fill").
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from pipeline.stereo import (
    AGREE,
    PosedView,
    Warped,
    fill_holes,
    fuse,
    harmonize_sources,
    match_gains,
    splat_depth,
    sweep_consensus,
    warp_sources,
)

CONSENSUS_VAR = 0.002
"""Largest windowed colour variance (per channel, 0..1 colours; about 0.045 standard
deviation) at which a consensus-sweep depth is trusted."""


@dataclass
class PhotoFill:
    """Photo colours for a camera, at its own size."""

    colour: np.ndarray
    """[H, W, 3] float32 0..1 (meaningful where ``support >= min_support``)."""
    support: np.ndarray
    """[H, W] int: neighbours that agree on the colour."""
    depth: np.ndarray
    """[H, W] float32 splatted z-depth (0 = no neighbour saw the surface)."""
    warped: Warped | None = None
    """Each source warped into the camera (gains matched), nearest first."""


def photo_fill(K: np.ndarray, c2w: np.ndarray, size: tuple[int, int],
               sources: list[PosedView], agree: float = AGREE,
               occlusion_tol: float = 0.03, reference: np.ndarray | None = None,
               ref_valid: np.ndarray | None = None, dense: bool = True,
               near: float | None = None, far: float | None = None,
               beyond: int = 0, agree_window: int = 1, harmonize: float = 0.0,
               prior_depth: np.ndarray | None = None, prior_only: bool = False) -> PhotoFill:
    """Warp ``sources`` (with ``depth`` and ``valid`` set) into the camera (K, c2w) of
    ``size`` = (W, H), match their gains (to ``reference`` where ``ref_valid``, e.g. the
    view's own clean pixels, else to each other) and fuse them (``pipeline.stereo.fuse``).
    ``dense``: holes of the splatted depth are filled: where ``near``/``far`` are given, by
    a plane sweep for the depth on which the sources agree best (``stereo.sweep_consensus``,
    kept where their colour variance is below CONSENSUS_VAR), the rest by interpolation
    (``stereo.fill_holes``); the agreement test then decides whether the photos support
    the depth. ``beyond``: planes of that sweep past ``far`` (``stereo.beyond_depths``).
    ``agree_window``: the agreement test over that window (``stereo.fuse``).
    ``harmonize``: without a reference, each warped source is first brought to the others
    by a smooth local offset, a Gaussian of this fraction of the long side
    (``stereo.harmonize_sources``; 0 = off). ``prior_depth`` [H, W] (0 = unknown): the
    depth where the splatted depth maps do not reach, before the sweep and interpolation
    (a network's own depth of the camera); with ``prior_only`` the depth everywhere (the
    depth maps are not splatted)."""
    if prior_depth is not None and prior_only:
        depth = np.asarray(prior_depth, np.float32).copy()
    else:
        depth = splat_depth(K, c2w, size, sources, fill=2)
        if prior_depth is not None:
            depth = np.where(depth > 0, depth, prior_depth).astype(np.float32)
    if dense and near is not None and (depth <= 0).any():
        holes = depth <= 0
        cdepth, cost = sweep_consensus(K, c2w, size, sources, near, far, where=holes,
                                       beyond=beyond)
        ok = holes & (cost < CONSENSUS_VAR)
        depth[ok] = cdepth[ok]
    if dense:
        depth = fill_holes(depth)
    w = warp_sources(K, c2w, depth, sources, occlusion_tol)
    w = match_gains(w, reference, ref_valid)
    if harmonize > 0 and reference is None:
        w = harmonize_sources(w, harmonize * max(size))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN medians where none sees
        colour, support = fuse(w, agree, window=agree_window)
    return PhotoFill(colour, support, depth, w)


def support_weight(support: np.ndarray, min_support: int, feather: int = 3) -> np.ndarray:
    """[H, W] float 0..1 weight of the photo fill: 1 where ``support >= min_support`` (or
    where ``support`` is a bool mask that is set), eroded by one pixel (edges of the warped
    region are where depth is least sure) and feathered over ``feather`` pixels towards the
    network's fill."""
    import cv2

    ok = (support if support.dtype == bool else support >= min_support).astype(np.uint8)
    ok = cv2.erode(ok, np.ones((3, 3), np.uint8))
    if feather <= 0:
        return ok.astype(np.float32)
    dist = cv2.distanceTransform(ok, cv2.DIST_L2, 3)
    return np.clip(dist / feather, 0.0, 1.0).astype(np.float32)


def lean_to_nearest(colour: np.ndarray, weight: np.ndarray, warped: Warped,
                    share: float) -> tuple[np.ndarray, np.ndarray]:
    """The hybrid fill's (colour, weight) leaning by ``share`` (0..1) to the nearest photo
    (``warped``'s first source) where that photo sees the frame (``support_weight`` of its
    valid pixels: in view, unflared, unoccluded): the frame the fill composes,
    ``weight * colour + (1 - weight) * network``, becomes ``share * photo + (1 - share) *
    that`` there. At a photo's own camera with ``share`` 1 the frame is the photo outside
    its flare mask."""
    if share <= 0:
        return colour, weight
    lean = share * support_weight(warped.ok[0], 1)
    total = lean + (1.0 - lean) * weight
    mixed = (lean[..., None] * warped.colours[0]
             + ((1.0 - lean) * weight)[..., None] * colour) / np.maximum(total, 1e-6)[..., None]
    return mixed.astype(np.float32), total.astype(np.float32)


def nearest_seen(fill: PhotoFill, occluded: bool = False,
                 spot: list[int] | None = None) -> Warped:
    """The fill's nearest photo (its first source) as the fill warped it (through the
    fill's depth, with the gains the fill gave it), valid wherever it sees the frame outside
    its flare mask, without the occlusion test against the photo's own depth map (near the
    photo's camera depth hides little, at it nothing); with ``occluded``, only where it
    passes that test too. ``spot``: the fill's sources taken from the nearest photo's spot
    (indices, the nearest first; ``pipeline.render.fill.at_spot``): each where the ones
    before it do not see the frame. For :func:`lean_to_nearest`."""
    w = fill.warped
    valid = w.ok if occluded or w.seen is None else w.seen
    colour, ok = w.colours[0].copy(), valid[0].copy()
    for i in (spot or [0])[1:]:
        take = valid[i] & ~ok
        colour[take] = w.colours[i][take]
        ok |= take
    return Warped(colour[None], ok[None])


def small_holes(ok: np.ndarray, radius: float) -> np.ndarray:
    """[H, W] bool: the pixels of the holes of ``ok`` (connected parts of ``~ok``,
    8-connected) whose widest inscribed disc has at most ``radius`` pixels: every pixel of
    such a hole lies within ``radius`` of ``ok``."""
    import cv2

    holes = ~ok
    if radius <= 0 or not holes.any() or not ok.any():
        return np.zeros(ok.shape, bool)
    dist = cv2.distanceTransform(holes.astype(np.uint8), cv2.DIST_L2, 3)
    n, labels = cv2.connectedComponents(holes.astype(np.uint8), connectivity=8)
    widest = np.zeros(n, np.float32)
    np.maximum.at(widest, labels[holes], dist[holes])
    return holes & (widest[labels] <= radius)


def sharp_hole_weight(ok: np.ndarray, radius: float, feather: int = 3) -> np.ndarray:
    """:func:`support_weight` of ``ok`` where only the holes wider than ``radius`` pixels
    (:func:`small_holes`) erode and feather the photos around them; the small holes are
    the network's (weight 0) with a hard edge, so one disagreeing pixel no longer takes
    the photos' weight from a disc around it."""
    small = small_holes(ok, radius)
    return np.where(small, 0.0, support_weight(ok | small, 0, feather)).astype(np.float32)


def close_small_holes(colour: np.ndarray, ok: np.ndarray, radius: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Fill the small holes of the photos' agreed region from the agreed pixels around them.

    ``ok`` [H, W] bool marks where the photos agree (``support >= min_support``). A hole (a
    connected part of ``~ok``, 8-connected) whose pixels all lie within ``radius`` pixels of
    an agreed pixel (its widest inscribed disc has at most that radius) gets the agreed
    colours around it, averaged by a Gaussian of that radius normalised by the agreed
    pixels' weight, and counts as agreed. Larger holes are left for the network. Returns
    (colour, ok) as new arrays."""
    import cv2

    small = small_holes(ok, radius)
    if not small.any():
        return colour, ok
    w = ok.astype(np.float32)
    c = np.where(ok[..., None], np.nan_to_num(colour), 0.0).astype(np.float32)
    k = 2 * int(np.ceil(3 * radius)) + 1
    num = cv2.GaussianBlur(c, (k, k), radius)
    den = cv2.GaussianBlur(w, (k, k), radius)
    small &= den > 1e-3
    out = colour.copy()
    out[small] = num[small] / den[small][:, None]
    return out, ok | small


def coarse_mean(img: np.ndarray, ok: np.ndarray, scale: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """``img`` [H, W, C] as seen at ``scale`` of its size: area-averaged over its ``ok`` [H, W]
    pixels, then bilinearly upsampled back to [H, W]. Returns (the average [H, W, C], the
    share of ``ok`` pixels behind each [H, W]); at scale 1 the image and ``ok`` themselves."""
    import cv2

    H, W = img.shape[:2]
    w, h = max(1, round(W * scale)), max(1, round(H * scale))
    okf = ok.astype(np.float32)
    num = img * okf[..., None]
    if (w, h) != (W, H):
        def down_up(x: np.ndarray) -> np.ndarray:
            return cv2.resize(cv2.resize(x, (w, h), interpolation=cv2.INTER_AREA), (W, H),
                              interpolation=cv2.INTER_LINEAR)
        num, okf = down_up(num), down_up(okf)
    return num / np.maximum(okf, 1e-6)[..., None], okf


def network_vote(net: np.ndarray, warped: Warped, scale: float, tol: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Sharp photo colours where a single photo agrees with the network.

    Where fewer than ``min_support`` photos agree, the network's render (``net`` [H, W, 3],
    drawn at ``scale`` of the frame's size and upsampled) is a second opinion: each warped
    source is brought to the network's resolution the same way (area-averaged over its own
    valid pixels to ``scale``, then bilinearly upsampled), and at every pixel the source
    closest to ``net`` there (largest channel difference) wins if that difference is below
    ``tol``; its full-resolution colour is returned. The network vouches for the colour at
    its own scale, the photo adds the detail the network cannot draw. Returns (colour [H, W,
    3], ok [H, W] bool)."""
    H, W = net.shape[:2]
    best = np.full((H, W), np.inf, np.float32)
    colour = np.zeros((H, W, 3), np.float32)
    for k in range(warped.colours.shape[0]):
        if not warped.ok[k].any():
            continue
        low, den = coarse_mean(np.nan_to_num(warped.colours[k]), warped.ok[k], scale)
        diff = np.abs(low - net).max(-1)
        diff[(warped.ok[k] == 0) | (den < 0.5)] = np.inf  # mostly unseen at the coarse scale
        win = diff < best  # strict: ties go to the nearer source (earlier k)
        best[win] = diff[win]
        colour[win] = warped.colours[k][win]
    return colour, best < tol
