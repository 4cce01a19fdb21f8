"""Stage `render`: de-flared input photos and novel camera paths from the fine-tuned model.

``--path inputs`` renders every input photo at its own camera with its full COLMAP model
(distortion included) at the size and framing of ``WS/decoded/<stem>.png`` into
``WS/deflared/<stem>.png``. By default only the flare region is rendered (the FMG mask
warped from ``WS/images`` geometry, dilated and feathered) and blended over the photo, so
clean pixels keep their detail; ``blend="none"`` writes the full render. ``interpolate``,
``spiral`` and a ``FILE.json`` path render novel cameras into ``WS/renders/<path>/``
(numbered frames; ``<name>.png`` for a JSON path), with the path's cameras beside them in
``cameras.json`` (the JSON path format, docs/camera_paths.md).

Every source view needed by any frame is encoded ONCE into a feature cache
(:class:`gnfr.renderer.SourceViews`) that all frames share. Frames are written atomically
and skipped on restart. Sources: for an input view its ranked pool from ``WS/views.json``
(itself excluded); for a novel frame every input view ranked by distance to the frame's
centre; from either, the nearest-10-least-flared (``gnfr.view_sampler.eval_sources``).

Modules (each imports only those listed before it): ``config`` (RenderConfig), ``jobs``
(the typed FrameJob), ``frames`` (frame files), ``sources`` (source views, model),
``plan`` (frame jobs, camera paths), ``fill`` (hybrid photo fill), ``inputs`` (input
views), ``novel`` (novel frames), ``full_res`` (original photos), ``engine`` (rendering
the jobs), ``workers`` (in this process or split over one-thread processes); this module is the
stage entry and re-exports their public names.
"""

from __future__ import annotations

from dataclasses import asdict, replace
from pathlib import Path

from pipeline.cameras import Cameras
from pipeline.errors import shell_path
from pipeline.options import resolve_device, validate
from pipeline.progress import info, warn
from pipeline.render.config import (
    FILLS,
    INPUTS_FRAMES,
    INPUTS_MIN_BLOB,
    NAMED_PATHS,
    RenderConfig,
)
from pipeline.render.engine import (
    CHUNK,
    DEPTH_BAND,
    default_chunk,
    prepare_job,
    render_jobs,
    split_guided,
)
from pipeline.render.fill import fill_from_photos, photo_views
from pipeline.render.frames import (
    clear_frames,
    path_cameras,
    rendered_frames,
    with_exif,
    write_frame,
    write_path_cameras,
)
from pipeline.render.full_res import plan_full_res, prepare_full_res
from pipeline.render.inputs import (
    MATCH_GAIN,
    MATCH_MIN_PIXELS,
    RING_TOLERANCE,
    blend_weights,
    decoded_camera,
    enclosed_holes,
    flare_mask_in,
    input_blend,
    input_rays,
    match_colours,
    prepare_input,
    require_masks,
)
from pipeline.render.jobs import FrameJob, FullRes, Prepared
from pipeline.render.novel import prepare_hybrid_novel, prepare_novel
from pipeline.render.plan import (
    depth_samples,
    exposure_along_path,
    novel_depth_range,
    novel_path,
    novel_scale,
    plan_jobs,
    reference_frame,
    resize_camera,
    resolve_fill,
    resolve_zoom,
)
from pipeline.render.sources import (
    encode_sources,
    find_checkpoint,
    input_sources,
    load_model,
    novel_sources,
    require_deflared,
    train_meta,
)
from pipeline.render.workers import (
    RenderSetup,
    frame_workers,
    render_here,
    render_in_workers,
)
from pipeline.workspace import Workspace
from pipeline.ws_files import read_cameras, read_views

__all__ = [
    "CHUNK", "DEPTH_BAND", "FILLS", "MATCH_GAIN", "MATCH_MIN_PIXELS", "NAMED_PATHS",
    "RING_TOLERANCE", "FrameJob", "FullRes", "Prepared", "RenderConfig", "RenderSetup",
    "blend_weights", "clear_frames", "decoded_camera", "default_chunk", "depth_samples",
    "enclosed_holes", "encode_sources", "fill_from_photos", "find_checkpoint", "flare_mask_in",
    "frame_workers", "input_blend", "input_rays", "input_sources", "load_model", "match_colours",
    "novel_depth_range", "novel_path", "novel_scale", "novel_sources", "path_cameras",
    "photo_views",
    "plan_full_res", "plan_jobs", "prepare_full_res", "prepare_hybrid_novel", "prepare_input",
    "prepare_job", "prepare_novel", "reference_frame", "render_here", "render_in_workers",
    "render_jobs", "rendered_frames", "require_masks", "resize_camera", "resolve_fill", "run",
    "split_guided", "train_meta", "with_exif", "write_frame", "write_path_cameras",
]


def options_for_path(cfg: RenderConfig, key: str, cams: Cameras) -> RenderConfig:
    """``cfg`` with the options of the other kind of render set aside, each with a warning:
    the de-flared photos (``key`` "inputs") and the video's frames each have options of
    their own; the depth maps' islands are dropped by the path's default; ``zoom`` is
    ``fixed`` where the path does not zoom (:func:`plan.resolve_zoom`: recorded resolved,
    so a capture at one zoom keeps its records of before the option)."""
    cfg = resolve_zoom(cfg, cams)
    if cfg.depth_min_blob is None:  # the de-flared photos lose the depth maps' islands
        cfg = replace(cfg, depth_min_blob=INPUTS_MIN_BLOB if key == "inputs" else 0.0)
    if key == "inputs" and cfg.novel_agree is not None:
        warn("render: --novel-agree is for the video's frames; the de-flared photos keep "
             "the photo fill's own tolerance")
    if key == "inputs" and cfg.from_deflared:
        warn("render: --from-deflared is for the video's frames; the de-flared photos are "
             "drawn from the photos")
        cfg = replace(cfg, from_deflared=False)
    if key == "inputs" and cfg.lean_deflared:
        warn("render: --lean-deflared is for the video's frames; the de-flared photos are "
             "drawn from the photos")
        cfg = replace(cfg, lean_deflared=False)
    if key == "inputs" and cfg.source_grow:
        warn("render: --source-grow is for the video's frames; the de-flared photos grow "
             "their masks by --dilate")
        cfg = replace(cfg, source_grow=0.0)
    if key != "inputs" and not cfg.band_rejected:
        warn("render: --no-band-rejected is for the de-flared photos (--path inputs); the "
             "video's frames have no ring check")
    return cfg


def record_params(cfg: RenderConfig, meta: dict, key: str, device: str, samples: int,
                  frames_maps: bool) -> dict:
    """The render stage's record of ``cfg`` for the path ``key``: the settings that change
    its images (the model's own from its training ``meta`` where ``cfg`` leaves them), less
    those the path has no use for; a change of any of them renders again."""
    params = {**asdict(cfg), "device": None, "chunk": None, "workers": None,
              "compile": None, "samples": samples,
              "source_scale": float(cfg.source_scale or meta.get("source_scale") or 1.0),
              "full_res_colour": bool(meta.get("full_res_colour", False)
                                      if cfg.full_res_colour is None else cfg.full_res_colour),
              "scale": novel_scale(cfg, device),
              "depth_samples": depth_samples(cfg, device, samples, novel=key != "inputs"),
              "point_sampler": bool(meta.get("point_sampler", True)),
              "encode_apart": bool(meta.get("encode_apart", False)),
              "flare_fallback": cfg.flare_fallback or meta.get("flare_fallback", "valid"),
              "depth_maps": "frames" if frames_maps else "depth",
              "bf16": cfg.bf16}
    if key != "interpolate":  # only the interpolate path is paced, toured and zoomed
        params.pop("pace")
        params.pop("tour")
        params.pop("zoom")
    if key != "inputs":  # the ring check and the fill's source are the de-flared photos'
        params.pop("band_rejected")
        params.pop("inputs_fill")
    if key == "inputs":  # the de-flared photos are no path: nothing to cross-fade, and
        params.pop("nearest_count")  # they never take themselves as a source
        params.pop("source_fade")
        params.pop("fade_cut")
        params.pop("fade_limit")
        params.pop("source_hold")
        params.pop("path_exposure")
        params.pop("from_deflared")  # they are what it reads
        params.pop("lean_deflared")
        params.pop("source_grow")
        params.pop("network_scale")  # their GN-FR renders at their full size
    return params


def record_defaults(key: str, device: str) -> dict:
    """What a render record written before a setting existed meant by it (the stage's
    ``defaults``), for the path ``key``: an old finished render stays finished."""
    defaults = {**asdict(resolve_fill(RenderConfig(), device, novel=key != "inputs")),
                "depth_maps": "depth", "bf16": False,  # records before bf16 rendered fp32
                "encode_apart": False,  # and before padded views could be encoded apart
                "flare_fallback": "valid"}  # and before the fallback was a choice
    if key != "inputs":  # records before the options: without the nearest view, no lean,
        from pipeline.photo_fill import AGREE  # and the photo fill's one tolerance

        defaults["nearest_source"] = False
        defaults["key_blend"] = 0.0
        defaults["novel_agree"] = AGREE
        defaults["pace"] = "travel"  # records before the fifty-second session's pace
        defaults["source_fade"] = 0  # and before the fifty-third's cross-fade
        defaults["source_hold"] = 0
        defaults["fade_cut"] = 0.0  # and before the fifty-fifth's cut by the path's steps
        defaults["fade_limit"] = 0.0  # and its step-back on a dense path
        defaults["path_exposure"] = 0.0
        defaults["tour"] = "position"  # records before the fifty-sixth session's tour
        defaults["zoom"] = "fixed"  # and before the ninety-eighth's zoom along it
        defaults["nearest_count"] = 1  # and before the eightieth's two nearest views
        defaults["key_spot"] = 0.0  # and before the eighty-first's lean past a twin
        defaults["unseen_below"] = 0.0  # and before the eighty-third's unseen fill
        defaults["from_deflared"] = False  # and before the eighty-eighth's options
        defaults["lean_deflared"] = False  # and before the ninety-ninth's
        defaults["source_grow"] = 0.0
    else:  # records before the forty-fifth session hold the novel frames' network scale
        # of then, which must not make finished de-flared photos render again
        defaults["network_scale"] = 1.0 if device.startswith("cuda") else 0.25
        defaults["inputs_fill"] = "photos"  # and before the ninety-ninth's frame fill
    return defaults


def warn_unshaped(cfg: RenderConfig, key: str) -> None:
    """Warn where the key blend's shaping options are set without the key blend."""
    shaping = [f for f, on in (("--key-occlusion", cfg.key_occlusion),
                               (f"--key-power {cfg.key_power:g}", cfg.key_power != 1.0)) if on]
    if shaping and not cfg.key_blend:
        warn(f"render: {' and '.join(shaping)} "
             f"{'does' if len(shaping) == 1 else 'do'} nothing without the key blend "
             f"({'the de-flared photos have none' if key == 'inputs' else '--key-blend 0'})")


def use_frames_maps(ws: Workspace, key: str, use_photos: bool) -> bool:
    """Whether the frames of ``key`` warp the photos through the depth stage's maps for
    them (WS/depth_frames, written by depth --frames-sgm) rather than WS/depth: novel frames
    where the stage wrote them (with a line saying how to get them where the depth stage is
    older than them); the de-flared photos always through WS/depth."""
    frames_maps = use_photos and key != "inputs" and ws.depth_frames.is_dir()
    if (use_photos and key != "inputs" and not frames_maps
            and "frames_sgm" not in ws.stage_record("depth").get("params", {})):
        info(f"render: {ws.depth} was made before the depth stage wrote maps of its own for "
             f"the novel frames; `deflare-scene depth {shell_path(ws.root)} --force` writes them "
             "(sharper video frames; the fine-tune and the de-flared photos stay as they are)")
    return frames_maps


def stage_inputs(ws: Workspace, cfg: RenderConfig, key: str, ckpt: Path, use_photos: bool,
                 frames_maps: bool) -> list[Path]:
    """The files whose change makes a finished render of ``key`` render again."""
    inputs = [ws.cameras_json, ws.views_json, ws.images, ws.masks, ckpt]
    inputs += ws.depth_inputs(frames=frames_maps) if use_photos else []
    inputs += [ws.decoded] if key == "inputs" else []
    inputs += [Path(cfg.path)] if key not in NAMED_PATHS else []
    inputs += [ws.deflared] if cfg.from_deflared or cfg.lean_deflared else []
    inputs += [ws.renders / INPUTS_FRAMES] if key == "inputs" and cfg.inputs_fill == "frame" else []
    return inputs


def resolve_inputs_fill(cfg: RenderConfig, device: str, use_photos: bool) -> str:
    """``cfg.inputs_fill`` as the de-flared photos apply it: ``photos`` where GN-FR renders
    every pixel (no photo fill to replace); where not given, ``frame`` on the CPU and
    ``photos`` on CUDA (not measured there)."""
    if not use_photos:
        return "photos"
    if cfg.inputs_fill is not None:
        return cfg.inputs_fill
    return "photos" if device.startswith("cuda") else "frame"


def render_inputs_frames(cfg: RenderConfig, ws: Workspace, cams: Cameras,
                         force: bool = False) -> None:
    """``RenderConfig.inputs_fill`` ``frame``: the novel frames at the flared photos' own
    cameras (WS/renders/inputs_frames, their path WS/renders/inputs_frames.json), drawn with
    the video's defaults (no cross-fade: they are no video) or found up to date."""
    import json

    from pipeline.render.frames import photos_path
    from pipeline.workspace import atomic_write_bytes
    from pipeline.ws_files import read_mask

    flared = [f for f in cams.frames
              if ws.mask_path(f.stem).exists() and read_mask(ws, f.stem).any()]
    if not flared:
        return
    path = ws.renders / f"{INPUTS_FRAMES}.json"
    text = json.dumps(photos_path(flared), indent=1).encode()
    if not path.is_file() or path.read_bytes() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, text)
    info(f"render inputs: the video's frames at the {len(flared)} flared photos' cameras "
         "first (--inputs-fill frame)")
    run(RenderConfig(path=str(path), device=cfg.device, workers=cfg.workers,
                     checkpoint=cfg.checkpoint, bf16=cfg.bf16, source_fade=0,
                     lean_deflared=False), ws, force)  # they are what the video leans to


def deflared_up_to_date(ws: Workspace, views, ckpt: Path) -> bool:
    """Whether WS/deflared is the render stage's finished ``--path inputs`` for today's
    inputs (the cameras, views, photos, masks, depth maps, decoded photos and ``ckpt``, as
    that stage digests them), every view's file there: what a frame leaning to the
    de-flared photos reads."""
    from pipeline.workspace import digest_paths

    rec = ws.stage_record("render:inputs")
    if rec.get("status") != "complete":
        return False
    if not all(ws.deflared_path(stem).is_file() for stem in views.views):
        return False
    params = rec.get("params", {})
    was = replace(RenderConfig(), path="inputs", lean_deflared=False,
                  inputs_fill=params.get("inputs_fill", "photos"))
    use_photos = params.get("fill", "hybrid") == "hybrid" and ws.depth.is_dir()
    inputs = stage_inputs(ws, was, "inputs", ckpt, use_photos, frames_maps=False)
    return digest_paths(inputs, ws.root) == rec.get("inputs_digest")


def resolve_lean(cfg: RenderConfig, ws: Workspace, views, ckpt: Path, key: str,
                 device: str) -> RenderConfig:
    """``cfg.lean_deflared`` as a novel path applies it (``cfg``'s fill resolved): where not
    given, on for the CPU's hybrid frames with the key blend where the de-flared photos are
    up to date (``deflared_up_to_date``; a line says how to get them where they are not),
    off on CUDA and where no photo is leaned to; the de-flared photos never lean."""
    if key == "inputs":
        return replace(cfg, lean_deflared=False)
    if cfg.lean_deflared is not None:
        return cfg
    if device.startswith("cuda") or cfg.fill != "hybrid" or not cfg.key_blend:
        return replace(cfg, lean_deflared=False)
    if deflared_up_to_date(ws, views, ckpt):
        return replace(cfg, lean_deflared=True)
    info(f"render {key}: the de-flared photos are not up to date, so at the photos' cameras "
         "the frames show GN-FR's fill inside the flare, not the de-flared photos'; "
         f"`deflare-scene render {shell_path(ws.root)} --path inputs` first makes them lean "
         "to those (--no-lean-deflared: never)")
    return replace(cfg, lean_deflared=False)


def render_todo(setup: RenderSetup, cams: Cameras, todo: list[FrameJob]) -> None:
    """Render ``todo`` in worker processes where the device wants them, else here."""
    workers = frame_workers(setup.cfg, setup.device, len(todo))
    if workers > 1:
        render_in_workers(setup, todo, workers)
    else:
        render_here(setup, cams, todo)


def run(cfg: RenderConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Render ``cfg.path``; returns the written folders (and the full-res one if asked)."""
    validate(cfg)
    ws.require("pose")
    cams = read_cameras(ws)
    views = read_views(ws)
    device = resolve_device(cfg.device)
    ckpt = find_checkpoint(ws, cfg.checkpoint)
    meta = train_meta(ckpt)
    cfg = replace(cfg, n_sources=cfg.source_count(meta.get("eval_views")))
    use_photos = cfg.fill == "hybrid" and ws.depth.is_dir()
    if cfg.fill == "hybrid" and not use_photos:
        warn(f"render: no {ws.depth} (run `deflare-scene depth {shell_path(ws.root)}`): GN-FR "
             "renders every pixel")
        cfg = replace(cfg, fill="network")
    key, out_dir, jobs = plan_jobs(cfg, ws, cams, views, device)
    if key == "inputs":  # the frames the de-flared photos take their fill from, first
        cfg = replace(cfg, inputs_fill=resolve_inputs_fill(cfg, device, use_photos))
        if cfg.inputs_fill == "frame":
            render_inputs_frames(cfg, ws, cams, force)
    if key != "inputs":  # the video's exposure glides along the path (path_exposure)
        jobs = exposure_along_path(jobs, cams, meta.get("exposure_gains"), cfg.path_exposure,
                                   cfg.photo_sources)
    if key == "inputs" and cfg.blend == "mask":  # before the stage clears WS/deflared
        require_masks(ws, [job.camera.stem for job in jobs])
    frames_maps = use_frames_maps(ws, key, use_photos)
    cfg = options_for_path(cfg, key, cams)
    cfg = resolve_fill(cfg, device, novel=key != "inputs")
    cfg = resolve_lean(cfg, ws, views, ckpt, key, device)
    deflared_blend = (require_deflared(ws, views, cfg)
                      if cfg.from_deflared or cfg.lean_deflared else None)
    warn_unshaped(cfg, key)
    from gnfr.renderer import cpu_bf16, emulated_bf16

    cfg = replace(cfg, bf16=cpu_bf16(cfg.bf16, device))  # recorded resolved: CUDA always
    if note := emulated_bf16("render", cfg.bf16):
        warn(note)
    if key != "inputs":  # novel frames record how they chose their sources: a render made
        # another way re-renders (for the de-flared photos neither applies)
        cfg = replace(cfg, sources_equal_below=cfg.equal_below(novel=True),
                      nearest_source=cfg.keeps_nearest(), nearest_count=cfg.nearest_n())
    samples = int(cfg.samples or meta.get("samples") or meta.get("n_samples")
                  or (64 if device.startswith("cuda") else 32))
    params = record_params(cfg, meta, key, device, samples, frames_maps)
    inputs = stage_inputs(ws, cfg, key, ckpt, use_photos, frames_maps)
    defaults = record_defaults(key, device)
    stage_run = ws.begin_stage(f"render:{key}", params, inputs, force, defaults=defaults)
    if stage_run.skip:
        info(f"render {key}: up to date ({out_dir})")
        return stage_run.outputs
    if not ws.resumable(stage_run):
        clear_frames(out_dir)
    if key != "inputs":
        write_path_cameras(out_dir, jobs)
    full = plan_full_res(ws, jobs) if key == "inputs" and cfg.full_res else []
    if full and not ws.resumable(stage_run):
        clear_frames(ws.deflared_full)
    todo = [j for j in jobs + full if not j.out.exists()]
    if len(todo) < len(jobs) + len(full):
        info(f"render {key}: {len(jobs) + len(full) - len(todo)} of {len(jobs) + len(full)} "
             "images already done")
    if todo:
        setup = RenderSetup(ws, ckpt, cfg, params, device,
                            sorted({s for j in todo for s in j.all_sources}),
                            meta.get("exposure_gains") or None, deflared_blend)
        render_todo(setup, cams, todo)
    outputs = [out_dir] + ([ws.deflared_full] if full else [])
    return stage_run.finish(outputs, extra={"frames": len(jobs)}, versions=["torch"])
