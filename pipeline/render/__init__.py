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
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from pipeline.camera_models import CameraModel, warp_maps
from pipeline.cameras import Cameras, Frame, load_cameras
from pipeline.errors import UserError
from pipeline.options import option, resolve_device, validate
from pipeline.progress import info, make_progress, warn
from pipeline.workspace import (
    Workspace,
    atomic_imwrite,
    atomic_write_bytes,
    atomic_write_json,
    read_json,
)

NAMED_PATHS = ("inputs", "interpolate", "spiral")
FILLS = ("hybrid", "network")


@dataclass
class RenderConfig:
    """Options of the render stage."""

    path: str = option("inputs", choices=NAMED_PATHS, suffix=".json")
    """inputs, interpolate, spiral, or a camera-path FILE.json (docs/camera_paths.md)."""
    frames: int | None = option(None, ge=1)
    """Frames of an interpolate / spiral path (default: seconds x fps)."""
    seconds: float = option(4.0, gt=0)
    """Length of an interpolate / spiral path when ``frames`` is not given."""
    fps: float = option(24.0, gt=0)
    """Frame rate used with ``seconds`` to count frames."""
    size: tuple[int, int] | None = option(None, ge=1, sep="x", metavar="WIDTHxHEIGHT")
    """Render size (width, height) of novel frames; overrides ``scale``."""
    scale: float | None = option(None, gt=0)
    """Novel frames at this fraction of the input image size (default 1/4 on CPU, 1 on
    CUDA; a JSON path keeps its own sizes unless ``scale`` or ``size`` is given)."""
    chunk: int | None = option(None, ge=1)
    """Rays per forward pass (default: ``default_chunk`` of the device; lower it if memory
    runs out)."""
    device: str = option("auto", device=True)
    """auto (CUDA when available), cpu, cuda or cuda:N."""
    samples: int | None = option(None, ge=1)
    """Samples per ray (default: the checkpoint's training value, else 64 CUDA / 32 CPU)."""
    blend: str = option("mask", choices=("mask", "none"))
    """inputs: ``mask`` renders and replaces only the flare region; ``none`` the full image."""
    dilate: float = option(0.01, ge=0)
    """inputs: the flare mask is grown by this fraction of the image's long side."""
    feather: float = option(0.01, ge=0)
    """inputs: width of the soft blend edge as a fraction of the image's long side."""
    color_match: bool = True
    """inputs (with ``blend mask``): before blending, map the rendered fill's colours to the
    photo by a per-channel gain and offset fitted on the rendered pixels just outside the
    flare mask (the dilation ring, where both the render and the clean photo exist); this
    removes the fill's colour and exposure drift (docs/eval.md)."""
    full_res: bool = False
    """inputs: also render the flare region at the original photo's full resolution and
    blend it into the original (into WS/deflared_full/)."""
    n_sources: int | None = option(None, ge=1)
    """Source views per frame, the least flared of the nearest ``pool`` (default: the
    checkpoint's eval_views, else 10)."""
    pool: int = option(20, ge=1)
    """Nearest views from which the ``n_sources`` least-flared are kept."""
    source_scale: float | None = option(None, gt=0)
    """Resolution of the encoded source views relative to WS/images (default: the
    checkpoint's training value, else 1)."""
    checkpoint: str | None = None
    """Model weights (default: the latest checkpoint in WS/model/)."""
    fill: str = option("hybrid", choices=FILLS)
    """``hybrid``: where WS/depth exists (`deflare-scene depth`), pixels are taken from the
    nearest photos warped by depth wherever ``min_support`` of them agree (flare masks and
    occlusions respected), and GN-FR renders only the rest; ``network``: GN-FR renders every
    pixel (docs/depth.md)."""
    min_support: int = option(2, ge=1)
    """hybrid: photos that must agree on a pixel's colour before it is taken from them."""
    photo_sources: int = option(4, ge=1)
    """hybrid: nearest clean photos warped into each image."""
    network_scale: float | None = option(None, gt=0)
    """hybrid novel frames: GN-FR renders the pixels the photos do not cover at this
    fraction of the frame size, upsampled under the photos' detail (default 1/4 on CPU, 1
    on CUDA)."""
    depth_samples: int | None = option(None, ge=0)
    """hybrid: rays whose surface depth the photos confirm (``depth_support``) are sampled
    with this many samples in a band around it instead of the full near-far range
    (default: a third of ``samples``; 0 = off)."""
    depth_support: int = option(2, ge=1)
    """hybrid: photos that must agree on a pixel before its ray is sampled around their
    depth (docs/depth.md: 2 was the best worst case on the development scenes)."""


@dataclass
class FrameJob:
    """One image to render: where it goes, which camera, which sources, depth range."""

    out: Path
    sources: list[str]
    near: float
    far: float
    camera: object  # gnfr.paths.PathCamera (novel) or pipeline.cameras.Frame (input view)
    extra: dict = field(default_factory=dict)


# --------------------------------------------------------------------------- entry point
def run(cfg: RenderConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Render ``cfg.path``; returns the written folders (and the full-res one if asked)."""
    validate(cfg)
    import torch

    ws.require("pose")
    cams = load_cameras(ws.cameras_json)
    views = _load_views(ws)
    device = _device(cfg.device)
    ckpt = _checkpoint(ws, cfg.checkpoint)
    meta = _train_meta(ckpt)
    cfg = replace(cfg, n_sources=int(cfg.n_sources or meta.get("eval_views") or 10))
    use_photos = cfg.fill == "hybrid" and _depth_dir(ws).is_dir()
    if cfg.fill == "hybrid" and not use_photos:
        warn(f"render: no {_depth_dir(ws)} (run `deflare-scene depth {ws.root}`): GN-FR "
             "renders every pixel")
        cfg = replace(cfg, fill="network")
    key, out_dir, jobs = plan_jobs(cfg, ws, cams, views, device)
    samples = int(cfg.samples or meta.get("samples") or meta.get("n_samples")
                  or (64 if device.startswith("cuda") else 32))
    params = {**asdict(cfg), "device": None, "chunk": None, "samples": samples,
              "source_scale": float(cfg.source_scale or meta.get("source_scale") or 1.0),
              "scale": _scale(cfg, device), "network_scale": _network_scale(cfg, device),
              "depth_samples": (int(cfg.depth_samples) if cfg.depth_samples is not None
                                else max(4, samples // 3)) if cfg.fill == "hybrid" else 0,
              "point_sampler": bool(meta.get("point_sampler", True))}
    inputs = [ws.cameras_json, ws.views_json, ws.images, ws.masks, ckpt]
    inputs += [_depth_dir(ws)] if use_photos else []
    inputs += [ws.decoded] if key == "inputs" else []
    inputs += [Path(cfg.path)] if key not in NAMED_PATHS else []
    run_ = ws.begin_stage(f"render:{key}", params, inputs, force)
    if run_.skip:
        info(f"render {key}: up to date ({out_dir})")
        return run_.outputs
    if not ws.resumable(run_):
        _clear_frames(out_dir, jobs)
    if key != "inputs":
        _write_path_cameras(out_dir, jobs)
    full = full_res_jobs(ws, jobs) if key == "inputs" and cfg.full_res else []
    if full and not ws.resumable(run_):
        _clear_frames(full[0].out.parent, full)
    todo = [j for j in jobs + full if not j.out.exists()]
    if len(todo) < len(jobs) + len(full):
        info(f"render {key}: {len(jobs) + len(full) - len(todo)} of {len(jobs) + len(full)} "
             "images already done")
    if todo:
        with torch.inference_mode():
            model = _load_model(ckpt, device)
            stems = sorted({s for j in todo for s in j.sources})
            src, index = encode_sources(model, ws, cams, stems, device, params["source_scale"])
            photos = photo_views(ws, cams, todo, cfg) if use_photos else None
            render_jobs(model, src, index, todo, params, cfg, ws, photos)
    outputs = [out_dir] + ([full_dir(ws)] if full else [])
    return run_.finish(outputs, extra={"frames": len(jobs)}, versions=["torch"])


def full_dir(ws: Workspace) -> Path:
    return ws.root / "deflared_full"


def full_res_jobs(ws: Workspace, jobs: list[FrameJob]) -> list[FrameJob]:
    """Jobs of ``--full-res`` (see pipeline/render/full_res.py)."""
    from pipeline.render.full_res import plan_full_res

    return plan_full_res(ws, jobs, full_dir(ws))


def plan_jobs(cfg: RenderConfig, ws: Workspace, cams: Cameras, views: dict,
              device: str) -> tuple[str, Path, list[FrameJob]]:
    """(path key, output folder, frame jobs) for ``cfg.path``."""
    if cfg.path == "inputs":
        if cfg.blend not in ("mask", "none"):
            raise UserError(f"--blend {cfg.blend!r} is not known: use mask or none")
        jobs = [FrameJob(ws.deflared / f"{f.stem}.png", input_sources(f.stem, views, cfg),
                         f.near, f.far, f) for f in cams.frames]
        return "inputs", ws.deflared, jobs
    path_cams, key = novel_path(cfg, cams, device)
    out_dir = ws.renders / key
    jobs = []
    for i, pc in enumerate(path_cams):
        near, far = novel_depth_range(pc.c2w[:3, 3], cams)
        name = pc.name if key not in NAMED_PATHS else f"{i:05d}"
        jobs.append(FrameJob(out_dir / f"{name}.png", novel_sources(pc.c2w[:3, 3], cams, views,
                                                                    cfg), near, far, pc))
    return key, out_dir, jobs


# --------------------------------------------------------------------------- cameras
def novel_path(cfg: RenderConfig, cams: Cameras, device: str):
    """(list of gnfr.paths.PathCamera, path key) for interpolate / spiral / FILE.json."""
    from gnfr import paths

    if cfg.path not in NAMED_PATHS:
        file = Path(cfg.path)
        if file.suffix.lower() != ".json":
            raise UserError(f"--path {cfg.path}: use inputs, interpolate, spiral or a .json "
                            "camera path file (docs/camera_paths.md)")
        try:
            pcs = paths.path_from_json(read_json(file))
        except ValueError as e:
            raise UserError(f"{file}: {e} (format: docs/camera_paths.md)") from None
        if cfg.size or cfg.scale:
            pcs = [_resize(pc, cfg, device) for pc in pcs]
        return pcs, file.stem
    if len(cams.frames) < 2:
        raise UserError(f"--path {cfg.path} needs at least 2 posed views; the workspace has "
                        f"{len(cams.frames)}")
    n = cfg.frames or max(1, round(cfg.seconds * cfg.fps))
    c2ws = np.stack([f.c2w for f in cams.frames])
    if cfg.path == "interpolate":
        poses = paths.interpolate_path(c2ws, n, closed=paths.is_surrounding(c2ws),
                                       up=paths.world_up(c2ws))
    else:
        near = np.array([f.near for f in cams.frames])
        far = np.array([f.far for f in cams.frames])
        poses = paths.spiral_path(c2ws, near, far, n)
    ref = reference_frame(cams)
    base = paths.PathCamera("ref", ref.K, ref.c2w, ref.width, ref.height)
    base = _resize(base, cfg, device)
    return [paths.PathCamera(f"{i:05d}", base.K, p, base.width, base.height)
            for i, p in enumerate(poses)], cfg.path


def reference_frame(cams: Cameras) -> Frame:
    """The first view with the most common image size (its K sets novel intrinsics)."""
    sizes = [(f.width, f.height) for f in cams.frames]
    common = max(set(sizes), key=sizes.count)
    return cams.frames[sizes.index(common)]


def _resize(pc, cfg: RenderConfig, device: str):
    """A PathCamera scaled to ``cfg.size`` or by ``cfg.scale`` (default by device)."""
    from gnfr.paths import PathCamera

    if cfg.size:
        W, H = (int(v) for v in cfg.size)
    else:
        s = _scale(cfg, device)
        W, H = max(1, round(pc.width * s)), max(1, round(pc.height * s))
    K = np.asarray(pc.K, np.float64).copy()
    K[0] *= W / pc.width
    K[1] *= H / pc.height
    return PathCamera(pc.name, K, pc.c2w, W, H)


def _scale(cfg: RenderConfig, device: str) -> float:
    """Novel frames' size as a fraction of the input views': 1 on CUDA and with the hybrid
    fill (the photos give the detail), 1/4 for the network alone on CPU."""
    if cfg.scale:
        return float(cfg.scale)
    return 1.0 if device.startswith("cuda") or cfg.fill == "hybrid" else 0.25


def _network_scale(cfg: RenderConfig, device: str) -> float:
    """Fraction of a hybrid novel frame's size at which GN-FR renders its uncovered pixels."""
    if cfg.network_scale:
        return float(cfg.network_scale)
    return 1.0 if device.startswith("cuda") else 0.25


def novel_depth_range(center: np.ndarray, cams: Cameras, k: int = 3) -> tuple[float, float]:
    """(near, far) of a novel camera: the range spanned by its ``k`` nearest input views."""
    d = np.linalg.norm(cams.centers() - center, axis=1)
    idx = np.argsort(d, kind="stable")[:k]
    return (float(min(cams.frames[i].near for i in idx)),
            float(max(cams.frames[i].far for i in idx)))


# --------------------------------------------------------------------------- sources
def _eval_sources(ranked: list[str], fractions: list[float], n: int, pool: int) -> list[str]:
    from gnfr.view_sampler import eval_sources

    return list(eval_sources(ranked, fractions, n=n, pool=pool))


def input_sources(stem: str, views: dict, cfg: RenderConfig) -> list[str]:
    """Sources of an input view: its ranked pool in views.json (itself excluded)."""
    pool = [s for s in views[stem]["sources"] if s["stem"] != stem] if stem in views else []
    if not pool:
        raise UserError(f"{stem} has no source views in views.json: rerun "
                        "`deflare-scene select WS`")
    return _eval_sources([s["stem"] for s in pool], [s["flare_fraction"] for s in pool],
                         cfg.n_sources, cfg.pool)


def novel_sources(center: np.ndarray, cams: Cameras, views: dict,
                  cfg: RenderConfig) -> list[str]:
    """Sources of a novel camera: all input views ranked by distance to ``center``."""
    d = np.linalg.norm(cams.centers() - center, axis=1)
    ranked = [cams.frames[i].stem for i in np.argsort(d, kind="stable")]
    ranked = [s for s in ranked if s in views]
    return _eval_sources(ranked, [views[s]["flare_fraction"] for s in ranked],
                         cfg.n_sources, cfg.pool)


def _load_views(ws: Workspace) -> dict:
    if not ws.views_json.exists():
        raise UserError(f"{ws.views_json} is missing: run `deflare-scene select {ws.root}` "
                        "first")
    return read_json(ws.views_json)["views"]


# --------------------------------------------------------------------------- model, cache
def _device(name: str) -> str:
    return resolve_device(name)  # pipeline.options: the one device resolver


def _checkpoint(ws: Workspace, path: str | None) -> Path:
    """The weights to render with: ``path``, else the newest checkpoint in WS/model/."""
    if path:
        p = Path(path)
        if not p.is_file():
            raise UserError(f"checkpoint {p} does not exist")
        return p
    found = ws.model / "gnfr.safetensors"  # what `finetune` writes (pipeline/finetune.py)
    if not found.is_file():
        cands = sorted(ws.model.glob("*.safetensors"), key=lambda p: p.stat().st_mtime)
        found = cands[-1] if cands else None
    if not found:
        raise UserError(f"no model checkpoint in {ws.model}: run `deflare-scene finetune "
                        f"{ws.root}` first (or pass --checkpoint FILE.safetensors)")
    return Path(found)


def _train_meta(ckpt: Path) -> dict:
    """Training settings recorded in a checkpoint's metadata (flattened one level)."""
    try:
        from gnfr.checkpoint import read_metadata

        meta = read_metadata(ckpt)[1]
    except Exception:  # unreadable metadata is reported when the model loads
        return {}
    flat = {}
    for v in meta.values():
        if isinstance(v, dict):
            flat.update(v)
    flat.update({k: v for k, v in meta.items() if not isinstance(v, dict)})
    return flat


def _load_model(ckpt: Path, device: str):
    from gnfr.checkpoint import CheckpointError
    from gnfr.renderer import load_model

    try:
        return load_model(ckpt, device)
    except CheckpointError as e:
        raise UserError(f"{e}: retrain with `deflare-scene finetune WS --force`") from None


def read_rgb(path: Path) -> np.ndarray:
    """[H, W, 3] uint8 RGB; a clear error if unreadable."""
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise UserError(f"cannot read image {path}: rerun the stage that writes it")
    return img[..., ::-1].copy()


def encode_sources(model, ws: Workspace, cams: Cameras, stems: list[str], device: str,
                   scale: float = 1.0):
    """Encode the views ``stems`` once, at ``scale`` of WS/images: (SourceViews, {stem: i}).

    Images of different sizes are padded to the largest; the padding is marked as flare so
    the Point Sampler ignores it. Without masks (no WS/masks) the Point Sampler is off.
    """
    import cv2
    import torch

    from gnfr.renderer import SourceViews

    by = cams.by_stem()
    imgs = [_resize_img(read_rgb(ws.images / f"{s}.png"), scale) for s in stems]
    H, W = max(i.shape[0] for i in imgs), max(i.shape[1] for i in imgs)
    have_masks = all((ws.masks / f"{s}.png").exists() for s in stems)
    if not have_masks:
        warn(f"no flare masks in {ws.masks} for every source: rendering without the Point "
             "Sampler (run `deflare-scene mask WS`)")
    padded = any(i.shape[:2] != (H, W) for i in imgs)
    images = torch.zeros(len(stems), 3, H, W)
    masks = torch.ones(len(stems), 1, H, W) if (have_masks or padded) else None
    for v, (s, img) in enumerate(zip(stems, imgs, strict=True)):
        h, w = img.shape[:2]
        images[v, :, :h, :w] = torch.from_numpy(img).permute(2, 0, 1).float() / 255
        if masks is not None:
            m = np.zeros((h, w), np.float32)
            if have_masks:
                m = cv2.imread(str(ws.masks / f"{s}.png"), cv2.IMREAD_GRAYSCALE)
                if m is None or m.shape != (by[s].height, by[s].width):
                    raise UserError(f"{ws.masks / f'{s}.png'} is unreadable or not the size "
                                    "of its image: rerun `deflare-scene mask WS --force`")
                m = (_resize_img(m, scale, like=img) > 127).astype(np.float32)
            masks[v, 0, :h, :w] = torch.from_numpy(m)
    K = np.stack([by[s].K for s in stems])
    for v, (s, img) in enumerate(zip(stems, imgs, strict=True)):  # exact K of resized images
        K[v, 0] *= img.shape[1] / by[s].width
        K[v, 1] *= img.shape[0] / by[s].height
    K = torch.tensor(K, dtype=torch.float32)
    c2w = torch.tensor(np.stack([by[s].c2w for s in stems]), dtype=torch.float32)
    src = SourceViews.encode(model, images, K, c2w, masks, device)
    return src, {s: i for i, s in enumerate(stems)}


def _resize_img(img: np.ndarray, scale: float, like: np.ndarray | None = None) -> np.ndarray:
    """Area-resize by ``scale`` (or to the size of ``like``)."""
    import cv2

    if like is not None:
        h, w = like.shape[:2]
    elif scale == 1.0:
        return img
    else:
        h, w = max(8, round(img.shape[0] * scale)), max(8, round(img.shape[1] * scale))
    if (h, w) == img.shape[:2]:
        return img
    return cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)


# --------------------------------------------------------------------------- rendering
CHUNK = {"cuda": 1024, "cpu": 256}
"""Default rays per forward pass. On CPU the per-chunk [rays, samples, views, channels]
tensors must stay cache-sized: 256-ray chunks render the quick model 1.9x faster per ray
than 1024-ray ones (0.39 vs 0.76 ms/ray, 1 thread; `deflare-scene bench --chunk N`)."""


def default_chunk(device_type: str) -> int:
    return CHUNK.get(device_type, CHUNK["cpu"])


def render_jobs(model, src, index: dict[str, int], jobs: list[FrameJob], params: dict,
                cfg: RenderConfig, ws: Workspace, photos: dict | None = None) -> None:
    """Render and write every job against the shared source cache, with progress bars."""
    import torch

    from gnfr.renderer import render_rays

    with make_progress() as prog:
        t_frames = prog.add_task("frames", total=len(jobs))
        t_rays = prog.add_task("rays", total=1)
        for job in jobs:
            prep = prepare_job(job, cfg, ws, photos, params)
            rays_o, rays_d, compose = prep[:3]
            guided = prep[3] if len(prep) > 3 else None
            prog.reset(t_rays, total=max(len(rays_o), 1))
            rgb = np.zeros((0, 3), np.float32)
            if len(rays_o):
                ids = torch.tensor([index[s] for s in job.sources], dtype=torch.long)
                n = len(rays_o)
                near, far = torch.full((n,), job.near), torch.full((n,), job.far)
                chunk = cfg.chunk or default_chunk(src.images.device.type)
                parts = split_guided(n, guided, params.get("depth_samples", 0))
                rgb = np.zeros((n, 3), np.float32)
                offset = 0
                for idx, lo, hi, ns in parts:
                    if len(idx) == 0:
                        continue
                    out = render_rays(model, src, ids, rays_o[idx], rays_d[idx],
                                      near[idx] if lo is None else lo,
                                      far[idx] if hi is None else hi, ns or params["samples"],
                                      chunk=chunk, point_sampler=params["point_sampler"],
                                      progress=lambda k, o=offset: prog.update(
                                          t_rays, completed=o + k), with_depth=False)
                    rgb[idx.numpy()] = out["rgb"].numpy()
                    offset += len(idx)
            write_frame(job.out, compose(rgb), job.extra.get("exif"))
            prog.advance(t_frames)


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


def write_frame(path: Path, rgb: np.ndarray, exif_from: Path | None = None) -> None:
    """Write one RGB frame atomically: uint8 (PNG, JPEG with the EXIF of ``exif_from``) or
    uint16 (TIFF). Module-level so tests can interrupt it."""
    import cv2

    bgr = np.ascontiguousarray(rgb[..., ::-1])
    if path.suffix.lower() in (".jpg", ".jpeg"):
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, 95])
        if not ok:
            raise OSError(f"could not encode {path}")
        from pipeline.render.full_res import with_exif

        atomic_write_bytes(path, with_exif(buf.tobytes(), exif_from))
    else:
        atomic_imwrite(path, bgr)


def prepare_job(job: FrameJob, cfg: RenderConfig, ws: Workspace, photos: dict | None = None,
                params: dict | None = None):
    """(rays_o [R, 3], rays_d [R, 3], compose(rgb [R, 3] float) -> image [H, W, 3] uint8[,
    (depth [R], known [R]) for depth-guided sampling]). ``photos``: {stem: PosedView with
    depth} for the hybrid fill (None: network only)."""
    import torch

    from gnfr.geometry import image_pixels, pixel_rays

    if isinstance(job.camera, Frame):
        if "full" in job.extra:
            from pipeline.render.full_res import prepare_full_res

            return prepare_full_res(job, cfg, ws)
        return _prepare_input(job, cfg, ws, photos)
    pc = job.camera
    H, W = pc.height, pc.width
    if photos is None:
        pix = image_pixels(H, W)
        rays_o, rays_d = pixel_rays(torch.tensor(pc.K, dtype=torch.float32),
                                    torch.tensor(pc.c2w, dtype=torch.float32), pix)
        return rays_o, rays_d, lambda rgb: _to_u8(rgb.reshape(H, W, 3))
    return _prepare_hybrid_novel(job, cfg, photos, (params or {}).get("network_scale", 1.0))


def _prepare_hybrid_novel(job: FrameJob, cfg: RenderConfig, photos: dict, net_scale: float):
    """A novel frame: the photos warped by depth at full frame size; GN-FR renders the
    pixels they do not cover at ``net_scale`` of the size (rays through the low-resolution
    pixel grid, sampled around the splatted depth where known), upsampled beneath them."""
    import cv2
    import torch

    from gnfr.geometry import image_pixels, pixel_rays

    pc = job.camera
    H, W = pc.height, pc.width
    colour, wgt, real_depth = _photo_fill(pc.K, pc.c2w, (W, H), job, photos, cfg)
    w, h = max(1, round(W * net_scale)), max(1, round(H * net_scale))
    K = np.asarray(pc.K, float).copy()
    K[0] *= w / W
    K[1] *= h / H
    # a low-res pixel is rendered when any full-res pixel it covers lacks the photos
    need = cv2.resize((wgt < 1).astype(np.float32), (w, h), interpolation=cv2.INTER_AREA) > 0
    need = cv2.dilate(need.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # for upsampling
    sel = torch.from_numpy(need.reshape(-1))
    rays_o, rays_d = pixel_rays(torch.tensor(K, dtype=torch.float32),
                                torch.tensor(pc.c2w, dtype=torch.float32),
                                image_pixels(h, w)[sel])
    d_lo = cv2.resize(real_depth, (w, h),
                      interpolation=cv2.INTER_NEAREST).reshape(-1)[need.reshape(-1)]
    known = torch.from_numpy((d_lo > job.near) & (d_lo < job.far))
    small_photo = cv2.resize(colour, (w, h), interpolation=cv2.INTER_AREA)

    def compose(rgb):
        low = small_photo.copy()
        low[need] = rgb
        up = cv2.resize(low, (W, H), interpolation=cv2.INTER_LINEAR)
        out = up * (1 - wgt[..., None]) + colour * wgt[..., None]
        return _to_u8(out)

    return rays_o, rays_d, compose, (torch.from_numpy(d_lo), known)


def _depth_dir(ws: Workspace) -> Path:
    return ws.root / "depth"


def photo_views(ws: Workspace, cams: Cameras, jobs: list[FrameJob], cfg: RenderConfig) -> dict:
    """{stem: PosedView} (WS/images, flare masks, WS/depth) of every photo a job warps."""
    from pipeline.depth import load_views

    stems = sorted({s for j in jobs for s in j.sources[:cfg.photo_sources]})
    return load_views(ws, cams, stems, with_depth=True)


def _photo_fill(K, c2w, size, job: FrameJob, photos: dict, cfg: RenderConfig,
                reference: tuple[np.ndarray, np.ndarray] | None = None):
    """(colour [H, W, 3], weight [H, W], depth [H, W]: the splatted depth where some photo
    agree on it, else 0) of the hybrid fill for one camera: the nearest
    ``photo_sources`` of the job's sources warped by depth (pipeline/photo_fill.py), their
    gains matched to ``reference`` = (image, valid) when given (an input view's own clean
    pixels)."""
    from pipeline.photo_fill import photo_fill, support_weight

    c = np.asarray(c2w, float)[:3, 3]
    near = sorted((s for s in job.sources if s in photos),
                  key=lambda s: float(np.linalg.norm(photos[s].c2w[:3, 3] - c)))
    srcs = [photos[s] for s in near[:cfg.photo_sources]]
    if not srcs:
        z = np.zeros(size[::-1], np.float32)
        return np.zeros((size[1], size[0], 3), np.float32), z, z
    ref, ref_valid = reference if reference is not None else (None, None)
    pf = photo_fill(np.asarray(K, float), np.asarray(c2w, float), size, srcs,
                    reference=ref, ref_valid=ref_valid, near=job.near, far=job.far)
    real = np.where((pf.depth > 0) & (pf.support >= cfg.depth_support), pf.depth,
                    0).astype(np.float32)
    return pf.colour, support_weight(pf.support, min(cfg.min_support, len(srcs))), real


def _own_clean_pixels(ws: Workspace, frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    """(image float [H, W, 3], valid [H, W]) of WS/images/<stem>.png outside its flare mask
    grown by 2% of the long side: the reference the warped photos' gains are matched to."""
    import cv2

    img = read_rgb(ws.images / f"{frame.stem}.png").astype(np.float32) / 255.0
    m = cv2.imread(str(ws.masks / f"{frame.stem}.png"), cv2.IMREAD_GRAYSCALE)
    if m is None:
        return img, np.ones(img.shape[:2], bool)
    r = max(1, round(0.02 * max(m.shape)))
    grown = cv2.dilate((m > 127).astype(np.uint8), np.ones((2 * r + 1, 2 * r + 1), np.uint8))
    return img, grown == 0


def _to_u8(x: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(x * 255.0), 0, 255).astype(np.uint8)


def _prepare_input(job: FrameJob, cfg: RenderConfig, ws: Workspace, photos: dict | None):
    """An input view: the flare region (alpha > 0) filled by GN-FR or, in the hybrid fill,
    from the warped photos where they agree; each fill colour-matched on the ring."""
    frame = job.camera
    photo = read_rgb(ws.decoded / f"{frame.stem}.png")
    size = (photo.shape[1], photo.shape[0])
    alpha, ring = input_blend(frame, cfg, ws, size, size)
    region = alpha > 0.5 / 255
    wgt = colour = depth = None
    if photos is not None and region.any():
        colour, wgt, depth = _photo_fill(frame.K, frame.c2w, (frame.width, frame.height), job,
                                         photos, cfg, _own_clean_pixels(ws, frame))
        colour, wgt, depth = _to_decoded(frame, size, colour, wgt, depth)
        if ring is not None:
            wgt = _check_on_ring(colour, wgt, photo.astype(np.float32) / 255.0, region, ring)
    # the network renders where the photos do not cover, and on the ring (its colour match)
    net = region if wgt is None else region & ((wgt < 1) | (ring if ring is not None
                                                            else False))
    rays_o, rays_d, rows, cols = input_rays(frame, net.astype(np.float32), *size)
    guided = None
    if depth is not None:
        import torch

        d = depth[rows, cols]
        guided = (torch.from_numpy(d), torch.from_numpy((d > frame.near) & (d < frame.far)))

    def compose(rgb):
        out = photo.astype(np.float32) / 255.0
        fill = np.zeros_like(out)
        if len(rows):
            fill[rows, cols] = (match_colours(rgb, out[rows, cols], ring[rows, cols])
                                if ring is not None else rgb)
        if wgt is not None:
            pc = colour
            if ring is not None:
                pc = match_colours(colour.reshape(-1, 3), out.reshape(-1, 3),
                                   (ring & (wgt >= 1)).reshape(-1)).reshape(out.shape)
            fill = fill * (1 - wgt[..., None]) + pc * wgt[..., None]
        a = alpha[..., None]
        out = np.where(region[..., None], out * (1 - a) + fill * a, out)
        return _to_u8(out)

    if guided is None:
        return rays_o, rays_d, compose
    return rays_o, rays_d, compose, guided


RING_TOLERANCE = 0.06
"""Largest mean absolute colour difference (0..1) between the photo fill and the clean photo
on a flare region's ring at which the photo fill of that region is trusted."""


def _check_on_ring(colour: np.ndarray, wgt: np.ndarray, photo: np.ndarray, region: np.ndarray,
                   ring: np.ndarray, min_pixels: int = 20) -> np.ndarray:
    """The photo-fill weight with each connected flare region zeroed where the fill, on the
    region's ring (clean photo pixels just outside the mask), differs from the photo by more
    than RING_TOLERANCE on average: the warped photos there show another surface (a depth
    no photo confirms, or a surface the neighbours do not see), so the network fills it."""
    import cv2

    n, labels = cv2.connectedComponents(region.astype(np.uint8), connectivity=8)
    wgt = wgt.copy()
    err = np.abs(colour - photo).mean(-1)
    check = ring & (wgt >= 1)
    for k in range(1, n):
        sel = labels == k
        on = check & sel
        if on.sum() >= min_pixels and float(err[on].mean()) > RING_TOLERANCE:
            wgt[sel] = 0.0
    return wgt


def _to_decoded(frame: Frame, size: tuple[int, int], colour: np.ndarray, wgt: np.ndarray,
                depth: np.ndarray):
    """Colour, weight and depth from WS/images (pinhole) geometry into WS/decoded geometry
    (depth is z along the same rays, so it maps like the colour, without interpolation)."""
    import cv2

    cam = decoded_camera(frame, *size)
    pin = CameraModel.pinhole(frame.K, frame.width, frame.height)
    mx, my = warp_maps(pin, cam)
    colour = cv2.remap(colour, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    wgt = cv2.remap(wgt, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                    borderValue=0)
    depth = cv2.remap(depth, mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                      borderValue=0)
    return colour, wgt, depth


MATCH_MIN_PIXELS = 100
MATCH_GAIN = (0.5, 2.0)


def match_colours(rgb: np.ndarray, photo: np.ndarray, ring: np.ndarray | None) -> np.ndarray:
    """Map rendered colours ``rgb`` [R, 3] to the photo: per channel, least squares
    ``photo ~ g * rgb + b`` over the ``ring`` [R] pixels (g clipped to MATCH_GAIN, b the
    mean residual with that g). Identity with fewer than MATCH_MIN_PIXELS ring pixels or
    ``ring`` None. Values stay in the input's range convention (clipped at 0 below)."""
    if ring is None or int(ring.sum()) < MATCH_MIN_PIXELS:
        return rgb
    x, y = rgb[ring].astype(np.float64), photo[ring].astype(np.float64)
    out = np.empty_like(rgb, dtype=np.float32)
    for c in range(rgb.shape[1]):
        xc, yc = x[:, c], y[:, c]
        var = float(np.var(xc))
        g = float(np.cov(xc, yc, bias=True)[0, 1] / var) if var > 1e-8 else 1.0
        g = float(np.clip(g, *MATCH_GAIN))
        b = float(np.mean(yc - g * xc))
        out[:, c] = g * rgb[:, c] + b
    return np.maximum(out, 0.0)


def input_blend(frame: Frame, cfg: RenderConfig, ws: Workspace, size: tuple[int, int],
                decoded_size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray | None]:
    """(alpha, ring) of an input view at ``size`` = (W, H) (the decoded framing, maybe
    scaled; ``decoded_size`` is WS/decoded's), from one read of its flare mask warped
    through the camera model. alpha [H, W]: the blend weight, the mask dilated and
    feathered (1 everywhere with blend none). ring [H, W] bool: the pixels the colour match
    is fitted on, rendered at full weight (alpha >= 0.9) but outside the flare mask (the
    dilation ring); None when colour matching is off (``color_match`` false or blend none).
    """
    import cv2

    if cfg.blend == "none":
        return np.ones(size[::-1], np.float32), None
    mask = flare_mask_in(decoded_camera(frame, *decoded_size), frame, ws)
    if decoded_size != size:  # full resolution: upsample the decoded-size mask
        mask = cv2.resize(mask.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST) > 0
    alpha = blend_weights(mask, cfg.dilate, cfg.feather)
    return alpha, ((alpha >= 0.9) & ~mask) if cfg.color_match else None


def input_rays(frame: Frame, alpha: np.ndarray, width: int, height: int):
    """Rays [R, 3] (o, d) through the pixels with alpha > 0 of the view's full camera
    model at (width, height), and those pixels' rows, cols [R]."""
    import torch

    from gnfr.geometry import pixel_rays

    cam = decoded_camera(frame, width, height)
    rows, cols = np.nonzero(alpha > 0.5 / 255)
    xy = cam.pixel_to_normalized(np.stack([cols + 0.5, rows + 0.5], 1))
    rays_o, rays_d = pixel_rays(torch.eye(3), torch.tensor(frame.c2w, dtype=torch.float32),
                                torch.tensor(xy, dtype=torch.float32))
    return rays_o, rays_d, rows, cols


def decoded_camera(frame: Frame, width: int, height: int) -> CameraModel:
    """The full COLMAP camera of WS/decoded/<stem>.png (pinhole K if none is recorded)."""
    if frame.colmap_camera:
        cam = CameraModel.from_colmap(frame.colmap_camera)
    else:
        cam = CameraModel.pinhole(frame.K, frame.width, frame.height)
    if (cam.width, cam.height) != (width, height):
        cam = cam.scaled(width / cam.width, height / cam.height)
        cam.width, cam.height = width, height
    return cam


def flare_mask_in(cam: CameraModel, frame: Frame, ws: Workspace) -> np.ndarray:
    """[H, W] bool flare mask of WS/masks (WS/images geometry) warped into camera ``cam``."""
    import cv2

    path = ws.masks / f"{frame.stem}.png"
    m = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if m is None:
        raise UserError(f"{path} is missing: run `deflare-scene mask {ws.root}` first, or "
                        "render the full image with --blend none")
    pin = CameraModel.pinhole(frame.K, m.shape[1], m.shape[0])
    mx, my = warp_maps(pin, cam)
    warped = cv2.remap(m.astype(np.float32), mx, my, cv2.INTER_LINEAR,
                       borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return warped > 127


def blend_weights(mask: np.ndarray, dilate: float, feather: float) -> np.ndarray:
    """[H, W] float blend weight: 1 on the dilated mask, falling to 0 over the feather.

    Unmasked regions the mask encloses (the light source at the centre of its flare, which
    FMG and synth never mark) are kept at 0: dilation must not swallow the light.
    """
    import cv2

    long_side = max(mask.shape)
    r = max(1, round(dilate * long_side))
    grown = cv2.dilate(mask.astype(np.uint8),
                       cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
    f = max(1, round(feather * long_side))
    # distance outside the grown mask -> linear ramp, so the weight is exactly 1 inside
    dist = cv2.distanceTransform((1 - grown).astype(np.uint8), cv2.DIST_L2, 5)
    weight = np.clip(1.0 - dist / f, 0.0, 1.0).astype(np.float32)
    holes = enclosed_holes(mask)
    if holes.any():
        weight[holes] = 0.0
    return weight


def enclosed_holes(mask: np.ndarray) -> np.ndarray:
    """[H, W] bool: unmasked pixels not connected to the image border through unmasked
    pixels (4-connectivity), i.e. holes the mask surrounds."""
    import cv2

    free = (~mask.astype(bool)).astype(np.uint8)
    n, labels = cv2.connectedComponents(free, connectivity=4)
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    return (labels > 0) & ~np.isin(labels, border)


# --------------------------------------------------------------------------- bookkeeping
def _clear_frames(out_dir: Path, jobs: list[FrameJob]) -> None:
    """Remove frames of an earlier, different render of this path (not resumable)."""
    if out_dir.is_dir():
        for p in out_dir.iterdir():
            if p.is_file() and p.suffix.lower() in (".png", ".jpg", ".jpeg", ".tif", ".tiff"):
                p.unlink()


def _write_path_cameras(out_dir: Path, jobs: list[FrameJob]) -> None:
    from gnfr.paths import PathCamera, path_to_json

    cams = [PathCamera(j.out.stem, j.camera.K, j.camera.c2w, j.camera.width, j.camera.height)
            for j in jobs]
    data = path_to_json(cams)
    for f, j in zip(data["frames"], jobs, strict=True):
        f["sources"], f["near"], f["far"] = j.sources, j.near, j.far
    atomic_write_json(out_dir / "cameras.json", data)
