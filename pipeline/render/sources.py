"""Source views: choosing them per frame, the checkpoint and model, encoding them once."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from pipeline.cameras import Cameras, Frame
from pipeline.errors import UserError, shell_path
from pipeline.progress import warn
from pipeline.render.config import RenderConfig
from pipeline.workspace import Workspace
from pipeline.ws_files import (
    MASK_THRESHOLD,
    ViewsFile,
    grow_mask,
    has_masks,
    read_mask,
    read_view_image,
)


def _eval_sources(ranked: list[str], fractions: list[float], cfg: RenderConfig,
                  novel: bool) -> list[str]:
    """The least flared ``cfg.n_sources`` of the nearest ``cfg.pool`` of ``ranked``, every
    fraction up to ``cfg.equal_below(novel)`` counted as none (gnfr.view_sampler)."""
    from gnfr.view_sampler import eval_sources

    return list(eval_sources(ranked, fractions, n=cfg.n_sources, pool=cfg.pool,
                             equal_below=cfg.equal_below(novel)))


def _views_file(views: ViewsFile | Mapping) -> ViewsFile:
    """``views`` as a ViewsFile; also accepts views.json's ``"views"`` mapping, the form
    benchmarks/flare_coverage.py still passes."""
    if isinstance(views, ViewsFile):
        return views
    return ViewsFile.from_json({"max_flare": None, "views": views})


def input_sources(stem: str, views: ViewsFile | Mapping, cfg: RenderConfig,
                  among: Iterable[str] | None = None) -> list[str]:
    """Sources of an input view: its ranked pool in views.json (``ViewsFile.sources``:
    itself excluded, only views in ``among`` when given)."""
    views = _views_file(views)
    pool = views.sources(stem, among)
    if not pool:
        raise UserError(f"{stem} has no source views in views.json: rerun "
                        "`deflare-scene select WS`")
    fractions = views.fractions(pool)
    return _eval_sources(pool, [fractions[s] for s in pool], cfg, novel=False)


def novel_sources(center: np.ndarray, cams: Cameras, views: ViewsFile | Mapping,
                  cfg: RenderConfig) -> list[str]:
    """Sources of a novel camera: the input views views.json lists, ranked by distance to
    ``center``; with ``cfg.keeps_nearest()`` the ``cfg.nearest_n()`` nearest of them are
    always sources (each in place of the farthest chosen), however flared. Nearest first."""
    views = _views_file(views)
    d = np.linalg.norm(cams.centers() - center, axis=1)
    ranked = [cams.frames[i].stem for i in np.argsort(d, kind="stable")]
    ranked = [s for s in ranked if s in views]
    fractions = views.fractions(ranked)
    chosen = _eval_sources(ranked, [fractions[s] for s in ranked], cfg, novel=True)
    if ranked and cfg.keeps_nearest():
        missing = [s for s in ranked[:cfg.nearest_n()] if s not in chosen]
        if missing:  # chosen come nearest first, all n of them: the farthest give way
            rank = {s: i for i, s in enumerate(ranked)}
            kept = chosen[:max(0, len(chosen) - len(missing))]
            chosen = sorted([*missing, *kept], key=rank.__getitem__)[:len(chosen)]
    return chosen


# --------------------------------------------------------------------------- model, cache
def find_checkpoint(ws: Workspace, path: str | None) -> Path:
    """The weights to render with: ``path``, else WS/model/gnfr.safetensors
    (``Workspace.model_file``), else the newest ``.safetensors`` in WS/model/."""
    if path:
        p = Path(path)
        if not p.is_file():
            raise UserError(f"checkpoint {p} does not exist")
        return p
    found = ws.model_file
    if not found.is_file():
        cands = sorted(ws.model.glob("*.safetensors"), key=lambda p: p.stat().st_mtime)
        found = cands[-1] if cands else None
    if not found:
        raise UserError(f"no model checkpoint in {ws.model}: run `deflare-scene finetune "
                        f"{shell_path(ws.root)}` first (or pass --checkpoint FILE.safetensors)")
    return Path(found)


def train_meta(ckpt: Path) -> dict:
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


def load_model(ckpt: Path, device: str):
    """The GN-FR model of ``ckpt`` on ``device``; a UserError for an unusable checkpoint."""
    from gnfr.checkpoint import CheckpointError
    from gnfr.renderer import load_model as load_gnfr

    try:
        return load_gnfr(ckpt, device)
    except CheckpointError as e:
        raise UserError(f"{e}: retrain with `deflare-scene finetune WS --force`") from None


def _source_images(ws: Workspace, cams: Cameras, stems: list[str], scale: float,
                   gains: dict | None, deflared: tuple[float, float] | None
                   ) -> list[np.ndarray]:
    """The views ``stems`` as :func:`encode_sources` encodes them: [h, w, 3] uint8 RGB, each
    flare region from its de-flared photo with ``deflared``, resized by ``scale``, brought to
    the model's exposure by ``gains``."""
    by = cams.by_stem()
    imgs = [read_view_image(ws, s) for s in stems]
    if deflared is not None:
        imgs = [with_deflared(ws, by[s], i, *deflared) for s, i in zip(stems, imgs, strict=True)]
    imgs = [_resize_img(i, scale) for i in imgs]
    if gains:
        from pipeline.exposure import apply_gain

        imgs = [apply_gain(i, gains[s]) if s in gains else i
                for s, i in zip(stems, imgs, strict=True)]
    return imgs


def _source_mask(ws: Workspace, cam: Frame, img: np.ndarray, scale: float,
                 grow: float) -> np.ndarray:
    """[h, w] float32 1/0: the view ``cam``'s flare mask, grown by ``grow``, at the size of
    its resized image ``img``."""
    flare = grow_mask(read_mask(ws, cam.stem), grow)
    if flare.shape != (cam.height, cam.width):
        raise UserError(f"{ws.mask_path(cam.stem)} is not the size of its image: "
                        f"{ws.rerun('mask')}")
    # area-resized as 0/255 grey, then cut: flare where more than half is
    grey = flare.astype(np.uint8) * 255
    return (_resize_img(grey, scale, like=img) > MASK_THRESHOLD).astype(np.float32)


def encode_sources(model, ws: Workspace, cams: Cameras, stems: list[str], device: str,
                   scale: float = 1.0, full_res_colour: bool = False,
                   gains: dict | None = None, apart: bool = False,
                   deflared: tuple[float, float] | None = None, grow: float = 0.0):
    """Encode the views ``stems`` once, at ``scale`` of WS/images: (SourceViews, {stem: i});
    with ``full_res_colour`` only the encoder sees them at ``scale``, colours and masks are
    sampled at the full size. ``gains``: {stem: [3] linear gain} the model was trained at
    (``finetune --exposure-match``), applied to the views. ``deflared`` = (dilate, feather)
    of the de-flared photos' blend: each view's flare region read from its de-flared photo
    (:func:`with_deflared`, ``RenderConfig.from_deflared``), its flare mask kept. ``grow``:
    the flare masks grown by that fraction of each view's long side
    (``RenderConfig.source_grow``).

    Images of different sizes (a portrait photo among landscape ones) are padded to the
    largest; the padding lies outside its view (``SourceViews.extents``: no point in it is
    sampled, as no point past a photo's edge is) and is marked as flare; with ``apart`` (a
    model fine-tuned so, ``FinetuneConfig.encode_apart``) each is encoded at its own size
    and its feature map padded. Without masks (no WS/masks) the Point Sampler is off.
    """
    import torch

    from gnfr.renderer import SourceViews

    by = cams.by_stem()
    feature_scale, scale = (scale, 1.0) if full_res_colour else (1.0, scale)
    imgs = _source_images(ws, cams, stems, scale, gains, deflared)
    H, W = max(i.shape[0] for i in imgs), max(i.shape[1] for i in imgs)
    have_masks = has_masks(ws, stems)
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
            m = (_source_mask(ws, by[s], img, scale, grow) if have_masks
                 else np.zeros((h, w), np.float32))
            masks[v, 0, :h, :w] = torch.from_numpy(m)
    K = np.stack([by[s].K for s in stems])
    for v, (s, img) in enumerate(zip(stems, imgs, strict=True)):  # exact K of resized images
        K[v, 0] *= img.shape[1] / by[s].width
        K[v, 1] *= img.shape[0] / by[s].height
    K = torch.tensor(K, dtype=torch.float32)
    c2w = torch.tensor(np.stack([by[s].c2w for s in stems]), dtype=torch.float32)
    extents = (torch.tensor([[i.shape[1], i.shape[0]] for i in imgs], dtype=torch.float32)
               if padded else None)
    src = SourceViews.encode(model, images, K, c2w, masks, device,
                             feature_scale=feature_scale, extents=extents, apart=apart)
    return src, {s: i for i, s in enumerate(stems)}


def require_deflared(ws: Workspace, views: ViewsFile | Mapping,
                     cfg: RenderConfig | None = None) -> tuple[float, float]:
    """The de-flared photos' blend (dilate, feather) from their stage's record, for
    ``RenderConfig.from_deflared`` and ``lean_deflared`` (the option ``cfg`` asks for, named
    in the error); a one-line error when that stage has not finished or a view's de-flared
    photo is missing."""
    flag = ("--lean-deflared" if cfg is not None and cfg.lean_deflared and not cfg.from_deflared
            else "--from-deflared")
    rec = ws.stage_record("render:inputs")
    fix = f"run `deflare-scene render {shell_path(ws.root)}` (--path inputs) first"
    if rec.get("status") != "complete":
        raise UserError(f"render {flag} reads the de-flared photos in {ws.deflared}, "
                        f"which are not rendered: {fix}, or drop {flag}")
    for stem in _views_file(views).views:
        if not ws.deflared_path(stem).is_file():
            raise UserError(f"{ws.deflared_path(stem)} is missing (render {flag} "
                            f"reads it): {fix}, or drop {flag}")
    params = rec.get("params", {})
    return float(params.get("dilate", 0.0)), float(params.get("feather", 0.01))


def with_deflared(ws: Workspace, frame, img: np.ndarray, dilate: float,
                  feather: float) -> np.ndarray:
    """``img`` (WS/images/<stem>, uint8 RGB) with its flare region taken from the view's
    de-flared photo (WS/deflared, in the decoded photo's camera, warped into WS/images'
    pinhole one): blended in by the rule that blended the de-flared photo's fill into the
    photo (``pipeline.render.inputs.blend_weights``, ``dilate``, ``feather``), applied to
    the WS/masks mask in WS/images' geometry, so outside it the photo's own pixels stay,
    unresampled."""
    import cv2

    from pipeline.camera_models import CameraModel, warp_maps
    from pipeline.images import read_image
    from pipeline.render.inputs import blend_weights, decoded_camera

    path = ws.deflared_path(frame.stem)
    fix = f"run `deflare-scene render {shell_path(ws.root)}` (--path inputs) again"
    fill = read_image(path, fix=fix)
    H, W = img.shape[:2]
    pin = CameraModel.pinhole(frame.K, W, H)
    mx, my = warp_maps(decoded_camera(frame, fill.shape[1], fill.shape[0]), pin)
    fill = cv2.remap(fill, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    alpha = blend_weights(read_mask(ws, frame.stem), dilate, feather)[..., None]
    out = alpha * fill.astype(np.float32) + (1.0 - alpha) * img.astype(np.float32)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


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
