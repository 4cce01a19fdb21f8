"""The hybrid fill's glue: the posed photos a render warps and their depth-warped fill."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from pipeline.cameras import Cameras, Frame
from pipeline.render.config import RenderConfig
from pipeline.render.jobs import FrameJob
from pipeline.workspace import Workspace

if TYPE_CHECKING:
    from pipeline.stereo import Warped


def photo_views(ws: Workspace, cams: Cameras, jobs: list[FrameJob], cfg: RenderConfig,
                frames: bool = False,
                deflared: Callable[[Frame, np.ndarray], np.ndarray] | None = None) -> dict:
    """{stem: PosedView} (WS/images, flare masks, WS/depth or with ``frames`` the novel
    frames' WS/depth/frames) of every photo a job warps; with ``cfg.depth_min_blob`` the
    depth maps' islands under that share of the image removed
    (``pipeline.stereo.remove_specks``, at the depth stage's plane step). ``deflared``: a
    view's de-flared photo from its camera and its WS/images pixels (uint8;
    ``pipeline.render.sources.with_deflared`` at the de-flared photos' blend): each view also
    carries it (``PosedView.deflared``), for ``cfg.lean_deflared``."""
    from pipeline.depth import DepthConfig, load_views
    from pipeline.stereo import remove_specks

    stems = sorted(set().union(*(j.photo_stems(cfg.photo_sources + cfg.photo_fallback)
                                 for j in jobs)))
    masks = None
    if cfg.source_grow:  # novel frames: the photos' flare masks grown (RenderConfig.source_grow)
        from pipeline.ws_files import grow_mask, read_mask

        masks = {s: grow_mask(read_mask(ws, s), cfg.source_grow) for s in stems
                 if ws.mask_path(s).exists()}
        masks = masks if len(masks) == len(stems) else None
    views = load_views(ws, cams, stems, with_depth=True, masks=masks, frames=frames)
    if cfg.depth_min_blob:  # None (unresolved) or 0: every island kept
        params = ws.stage_record("depth").get("params", {})
        planes = int(params.get("planes", DepthConfig().planes))
        by = cams.by_stem()
        for s, v in views.items():
            if v.depth is not None:
                v.depth = remove_specks(v.depth, by[s].near, by[s].far, planes,
                                        round(cfg.depth_min_blob * v.depth.size))
    if deflared is not None:
        by = cams.by_stem()
        for s, v in views.items():
            u8 = np.clip(np.rint(v.image * 255.0), 0, 255).astype(np.uint8)
            v.deflared = deflared(by[s], u8).astype(np.float32) / 255.0
    return views


def lean_deflared_views(photos: dict, near: list[str], same_spot: float) -> dict:
    """``photos`` with the photos a novel frame leans to (the first of ``near``, its
    sources nearest first, and those at its spot, :func:`at_spot`) read de-flared: their
    ``PosedView.deflared`` as the image, no flare mask (``RenderConfig.lean_deflared``);
    a view without one is left as it is."""
    from dataclasses import replace

    if not near:
        return photos
    spot = at_spot([photos[s] for s in near], same_spot)
    return {**photos, **{near[i]: replace(photos[near[i]], image=photos[near[i]].deflared,
                                          valid=None)
                         for i in spot if photos[near[i]].deflared is not None}}


class HybridFill(NamedTuple):
    """The photos' share of one camera's hybrid fill."""

    colour: np.ndarray
    """[H, W, 3] float32 0..1 agreed colour of the photos."""
    weight: np.ndarray
    """[H, W] float32 0..1 weight of ``colour`` over the network's fill."""
    depth: np.ndarray
    """[H, W] float32 splatted depth where ``depth_support`` photos agree on it, else 0."""
    warped: Warped | None = None
    """Each photo warped into the camera, gains matched (None: no photo)."""


def fill_from_photos(K, c2w, size, job: FrameJob, photos: dict, cfg: RenderConfig,
                     reference: tuple[np.ndarray, np.ndarray] | None = None,
                     novel: bool = False, prior_depth: np.ndarray | None = None,
                     prior_only: bool = False) -> HybridFill:
    """The hybrid fill's photo share (:class:`HybridFill`) for one camera: the nearest
    ``photo_sources`` of the job's sources (its ``fill_first`` first when set) warped by depth
    (pipeline/photo_fill.py; where they do not agree, with ``photo_fallback`` more of them, the
    next nearest), their gains matched to ``reference`` = (image, valid) when given (an input
    view's own clean pixels). ``novel``: a novel frame, where the options for the small holes of
    the agreed region apply: ``cfg.close_holes`` (filled from the photos around them,
    :func:`pipeline.photo_fill.close_small_holes`), then ``cfg.sharp_holes`` (a hard edge
    instead of eroding and feathering the photos around them,
    :func:`pipeline.photo_fill.sharp_hole_weight`). ``prior_depth``: the camera's depth where
    the photos' depth maps do not reach, or everywhere with ``prior_only`` (``photo_fill``'s)."""
    from pipeline.photo_fill import (
        close_small_holes,
        lean_to_nearest,
        nearest_seen,
        photo_fill,
        sharp_hole_weight,
        support_weight,
    )

    if cfg.agree_window is None or cfg.novel_agree is None:
        raise ValueError("fill_from_photos: the config's fill defaults are not resolved "
                         "(pipeline.render.plan.resolve_fill)")
    K, c2w = np.asarray(K, float), np.asarray(c2w, float)
    c = c2w[:3, 3]
    near = job.fill_order(c, lambda s: photos[s].c2w[:3, 3], photos)
    share = key_share(c, [photos[s] for s in near], cfg.key_blend or 0.0,
                      cfg.key_power, job.same_spot) if novel else 0.0
    if share > 0 and cfg.lean_deflared:  # the photos it leans to, de-flared
        photos = lean_deflared_views(photos, near[:cfg.photo_sources], job.same_spot)
    if job.exposure is not None and job.photo_gains:  # the photos at the frame's exposure
        photos = at_frame_exposure(photos, near[:cfg.photo_sources + cfg.photo_fallback], job)
    srcs = [photos[s] for s in near[:cfg.photo_sources]]
    if not srcs:
        z = np.zeros(size[::-1], np.float32)
        return HybridFill(np.zeros((size[1], size[0], 3), np.float32), z, z)
    ref, ref_valid = reference if reference is not None else (None, None)

    def fill(views):
        return photo_fill(K, c2w, size, views, reference=ref, ref_valid=ref_valid,
                          near=job.near, far=job.far, beyond=cfg.beyond_planes,
                          agree_window=cfg.agree_window,
                          agree=cfg.novel_agree,  # resolved: 0.08 for the photos
                          harmonize=cfg.harmonize if novel else 0.0,
                          prior_depth=prior_depth, prior_only=prior_only)

    pf = fill(srcs)
    real = np.where((pf.depth > 0) & (pf.support >= cfg.depth_support), pf.depth,
                    0).astype(np.float32)
    ok = pf.support >= min(cfg.min_support, len(srcs))
    colour = pf.colour
    more = [photos[s] for s in near[:cfg.photo_sources + cfg.photo_fallback]]
    if len(more) > len(srcs) and not ok.all():
        wide = fill(more)  # the farther photos, only where the nearest do not agree
        take = ~ok & (wide.support >= min(cfg.min_support, len(more)))
        colour = np.where(take[..., None], wide.colour, colour)
        ok = ok | take
    close, sharp = (cfg.close_holes, cfg.sharp_holes) if novel else (0.0, 0.0)
    if close > 0:
        colour, ok = close_small_holes(colour, ok, close * max(size))
    weight = sharp_hole_weight(ok, sharp * max(size)) if sharp > 0 else support_weight(ok, 0)
    if share > 0:
        spot = at_spot([photos[s] for s in near[:len(srcs)]], job.same_spot)
        colour, weight = lean_to_nearest(colour, weight,
                                         nearest_seen(pf, cfg.key_occlusion, spot), share)
    return HybridFill(colour, weight, real, pf.warped)


def at_frame_exposure(photos: dict, stems: list[str], job: FrameJob) -> dict:
    """``photos`` ({stem: PosedView}) with the images of ``stems`` brought from each photo's
    exposure to the frame's (``FrameJob.exposure``, by the model's gains
    ``job.photo_gains``; a photo without a gain is left as it is). The fill then matches
    what is left of their differences to their median, as without
    (``pipeline.stereo.match_gains``)."""
    from dataclasses import replace

    from pipeline.exposure import between

    return {**photos, **{s: replace(photos[s], image=between(photos[s].image,
                                                             job.photo_gains[s], job.exposure))
                         for s in stems if s in job.photo_gains}}


def centre_of(view) -> np.ndarray:
    """The camera centre of ``view`` (anything with a 4x4 ``c2w``)."""
    return np.asarray(view.c2w)[:3, 3]


def from_first(views: list) -> np.ndarray:
    """The distances of ``views[1:]`` from the first's camera centre, in their order."""
    own = centre_of(views[0])
    return np.array([float(np.linalg.norm(centre_of(v) - own)) for v in views[1:]])


def at_spot(views: list, same_spot: float) -> list[int]:
    """The indices of ``views`` (nearest a frame first) standing within ``same_spot`` of the
    first's camera, the first included: the photos taken from its spot
    (``FrameJob.same_spot``; 0: the first alone)."""
    if same_spot <= 0:
        return [0]
    return [0] + [i for i, d in enumerate(from_first(views), 1) if d <= same_spot]


def key_spacing(views: list, same_spot: float = 0.0) -> float:
    """The distance :func:`key_share`'s reach is measured on: from the first of ``views``
    (nearest a frame first) to the nearest of the others standing farther than
    ``same_spot`` from it (0 without one)."""
    d = from_first(views)
    d = d[d > max(same_spot, 0.0)]
    return float(d.min()) if len(d) else 0.0


def key_share(centre: np.ndarray, views: list, reach: float, power: float = 1.0,
              same_spot: float = 0.0) -> float:
    """How much a novel frame at ``centre`` leans to the first of ``views`` (its sources
    nearest first; ``RenderConfig.key_blend``): 1 at that photo's camera, falling with the
    distance to none at ``reach`` times the distance from that camera to the nearest of the
    other sources' standing farther than ``same_spot`` from it (0 without one; the photos
    at its spot are leant to as well, ``RenderConfig.key_spot``): ``1 - x ** power`` of
    that fraction ``x`` of the way (``RenderConfig.key_power``; 1: linearly)."""
    spacing = key_spacing(views, same_spot)
    if spacing <= 0 or reach <= 0:
        return 0.0
    x = min(float(np.linalg.norm(centre - centre_of(views[0]))) / (reach * spacing), 1.0)
    return float(1.0 - x ** power)
