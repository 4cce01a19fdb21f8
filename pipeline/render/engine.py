"""Rendering jobs against the shared source cache: per-kind preparation, rays, writing."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pipeline.progress import make_progress
from pipeline.render.config import RenderConfig
from pipeline.render.frames import write_frame
from pipeline.render.full_res import prepare_full_res
from pipeline.render.inputs import prepare_input
from pipeline.render.jobs import FrameJob, Prepared
from pipeline.render.novel import prepare_novel
from pipeline.workspace import Workspace

CHUNK = {"cuda": 1024, "cpu": 256}
"""Default rays per forward pass. On CPU the per-chunk [rays, samples, views, channels]
tensors must stay cache-sized: 256-ray chunks render the quick model 1.9x faster per ray
than 1024-ray ones (0.39 vs 0.76 ms/ray, 1 thread; `deflare-scene bench --chunk N`)."""


def default_chunk(device_type: str) -> int:
    """Rays per forward pass on a device type (``cuda``, ``cpu``): see CHUNK."""
    return CHUNK.get(device_type, CHUNK["cpu"])


def render_jobs(model, src, index: dict[str, int], jobs: list[FrameJob], params: dict,
                cfg: RenderConfig, ws: Workspace, photos: dict | None = None,
                gains: dict | None = None, quiet: bool = False) -> None:
    """Render and write every job against the shared source cache, with progress bars (none
    when ``quiet``: a worker process, ``pipeline.render.workers``).
    ``gains``: the exposure the model was trained at (``pipeline.exposure``): its colours
    are taken back to each frame's (:func:`exposure_back`). A job with ``fades`` renders
    once per source set and writes their weighted mean."""
    with make_progress(quiet=quiet) as prog:
        t_frames = prog.add_task("frames", total=len(jobs))
        t_rays = prog.add_task("rays", total=1)
        for job in jobs:
            image = render_image(model, src, index, job, params, cfg, ws, photos, gains,
                                 prog, t_rays)
            if job.fades:  # other frames' sources, cross-faded in (RenderConfig.source_fade)
                acc = image.astype(np.float64) * (1.0 - sum(f.weight for f in job.fades))
                for f in job.fades:
                    other = replace(job, sources=list(f.sources), fill_first=f.fill_first,
                                    fades=())
                    acc += f.weight * render_image(model, src, index, other, params, cfg, ws,
                                                   photos, gains, prog, t_rays)
                image = np.clip(np.rint(acc), 0, np.iinfo(image.dtype).max).astype(image.dtype)
            write_frame(job.out, image, job.exif)
            prog.advance(t_frames)


def render_image(model, src, index: dict[str, int], job: FrameJob, params: dict,
                 cfg: RenderConfig, ws: Workspace, photos: dict | None, gains: dict | None,
                 prog, t_rays) -> np.ndarray:
    """One job's image (uint8 or uint16), GN-FR's rays rendered against the source cache
    with ``prog``'s ``t_rays`` bar following them (:func:`render_jobs`)."""
    import torch

    from gnfr.renderer import render_rays

    rays_o, rays_d, compose, guided, want_depth = prepare_job(job, cfg, ws, photos, params)
    prog.reset(t_rays, total=max(len(rays_o), 1))
    rgb, depth = np.zeros((0, 3), np.float32), np.zeros(0, np.float32)
    ids = torch.tensor([index[s] for s in job.sources], dtype=torch.long)
    if len(rays_o):
        n = len(rays_o)
        near, far = torch.full((n,), job.near), torch.full((n,), job.far)
        chunk = cfg.chunk or default_chunk(src.images.device.type)
        parts = split_guided(n, guided, params.get("depth_samples", 0))
        rgb, depth = np.zeros((n, 3), np.float32), np.zeros(n, np.float32)
        offset = 0
        for idx, lo, hi, ns in parts:
            if len(idx) == 0:
                continue
            out = render_rays(model, src, ids, rays_o[idx], rays_d[idx],
                              near[idx] if lo is None else lo,
                              far[idx] if hi is None else hi, ns or params["samples"],
                              chunk=chunk, point_sampler=params["point_sampler"],
                              progress=lambda k, o=offset: prog.update(t_rays, completed=o + k),
                              with_depth=want_depth, pad=cfg.compile, cpu_bf16=cfg.bf16,
                              flare_fallback=params.get("flare_fallback", "valid"))
            rgb[idx.numpy()] = out["rgb"].numpy()
            if want_depth:
                depth[idx.numpy()] = out["depth"].numpy()
            offset += len(idx)
    if gains and len(rgb):
        from pipeline.exposure import apply_gain

        rgb = apply_gain(rgb, exposure_back(job, gains))
    image = compose(rgb, depth) if want_depth else compose(rgb)
    if cfg.unseen_below > 0 and not job.is_input:
        from pipeline.render.unseen import fill_unseen, seen_map

        image = fill_unseen(image, seen_map(src, ids, job.camera, job.near, job.far,
                                            params["samples"]), cfg.unseen_below)
    return image


def exposure_back(job: FrameJob, gains: dict) -> np.ndarray:
    """The gain (or curve, ``pipeline.exposure``) from the model's common exposure to a
    frame's: an input view's own undone; a novel frame's exposure along the path
    (``FrameJob.exposure``) undone where its job holds one, else its sources' median."""
    from pipeline.exposure import inverse

    if job.is_input and job.camera.stem in gains:
        return inverse(gains[job.camera.stem])
    if job.exposure is not None:  # the exposure along the path (RenderConfig.path_exposure)
        return inverse(job.exposure)
    near = [np.asarray(gains[s], np.float64) for s in job.sources if s in gains]
    return inverse(np.median(near, axis=0)) if near else np.ones(3)


DEPTH_BAND = 1.25
"""Depth-guided rays sample z in [d / DEPTH_BAND, d * DEPTH_BAND] around the photos' depth d
(uniform in inverse depth, like the full range)."""


def split_guided(n: int, guided, depth_samples: int):
    """[(ray indices, near or None, far or None, samples or None)]: the rays with a known
    surface depth (``guided`` = (depth [n] tensor, known [n] bool tensor) or None) get a
    band of ``depth_samples`` samples around it, the rest the job's full range."""
    import torch

    every = torch.arange(n)
    if guided is None or depth_samples <= 0:
        return [(every, None, None, None)]
    depth, known = guided
    ks, us = every[known], every[~known]
    d = depth[known].float()
    return [(ks, d / DEPTH_BAND, d * DEPTH_BAND, depth_samples), (us, None, None, None)]


def prepare_job(job: FrameJob, cfg: RenderConfig, ws: Workspace, photos: dict | None = None,
                params: dict | None = None) -> Prepared:
    """The rays of ``job`` and how to compose its image (:class:`Prepared`), by kind: a
    full-resolution photo, an input view (de-flared over its photo) or a novel frame.
    ``photos``: {stem: PosedView with depth} for the hybrid fill (None: network only)."""
    if job.full_res is not None:
        return prepare_full_res(job, cfg, ws)
    if job.is_input:
        return prepare_input(job, cfg, ws, photos)
    return prepare_novel(job, cfg, photos, (params or {}).get("network_scale", 1.0))
