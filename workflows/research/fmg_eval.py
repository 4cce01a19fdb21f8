"""Scoring and calibration of the FMG (flare mask PSPNet): composites, photos, cuts.

``evaluate(weights, ...)`` scores mIoU / mAcc on held-out composites, with the default flare
settings and with ``FlareConfig.unseen()``; ``evaluate_kinds`` per kind of flare (and
leave-one-kind-out models); ``clean_fractions``, ``negative_fractions`` and
``work_size_sweep`` what it marks on clean photos, hard negatives and at other working
sizes; ``real_flare_overview`` draws its masks on real photos; ``calibrate`` picks the cut
written into the weights. The options of the `deflare-scene fmg eval|calibrate|overlay`
commands are dataclasses here (FMGEvalConfig, FMGCalibrateConfig, FMGOverlayConfig);
training is workflows/research/fmg_train.py.
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from pipeline.errors import UserError
from pipeline.images import list_photos, read_image
from pipeline.options import option
from pipeline.workspace import atomic_imwrite

REPO = Path(__file__).resolve().parents[2]


def default_data() -> Path:
    """The shared photo folder: $DEFLARE_SHARED_DATA or ../shared/data beside the repo."""
    return Path(os.environ.get("DEFLARE_SHARED_DATA", REPO.parent / "shared" / "data"))


@dataclass
class FMGEvalConfig:
    """Options of `deflare-scene fmg eval`: one of four scores of FMG weights."""

    weights: Path | None = None
    """FMG weights (default: the shipped ones)."""
    data: Path = field(default_factory=default_data)
    """Folder with backgrounds/ and scenes/."""
    count: int = option(64, ge=1)
    """Held-out composites per flare setting (per kind with ``per_kind``)."""
    size: int = option(256, ge=32)
    """Composite side in pixels."""
    refine: bool = False
    """Also score guided-filter refined masks."""
    per_kind: bool = False
    """Score each kind of flare alone (leave-one-kind-out table)."""
    loo: tuple[Path, ...] = ()
    """With ``per_kind``: weights trained with `fmg train --without KIND`, scored on that kind
    (repeat for several)."""
    work_sizes: tuple[int, ...] = option((), ge=32)
    """Instead: flare IoU of thin streaks and starbursts on held-out photos against the
    working size, e.g. 384,512,768."""
    clean: bool = False
    """Instead: share of pixels marked on clean photos (of the test scenes, or with ``--split
    dev`` of the FMG's development scene)."""
    work_size: int = option(512, ge=32)
    """With ``clean``: the network's working size (long side), as the mask stage's
    --work-size."""
    split: str = option("test", choices=("dev", "test"))
    """Which held-out photos the composites use: dev (the FMG's development photos: make
    choices here) or test (the test scenes and backgrounds: report only)."""
    rays: bool = False
    """Score the FMG's masks with the flare rays added (as the mask stage does unless
    --no-rays), with --per-kind or --clean."""
    scales: tuple[float, ...] = option((1.0,), gt=0, le=2, metavar="S1,S2")
    """With ``per_kind`` or ``clean``: the network run at these fractions of the working size
    (of the composite's side with ``per_kind``), its probabilities averaged, as `mask
    --scales` (every network scored, the second of ``confirm`` too)."""
    night: float | None = option(None, ge=0, le=1)
    """With ``per_kind``: the share of the composites on night-darkened backgrounds (default
    ``PER_KIND_NIGHT``, 0.3; 0 scores daylight alone, as the development scenes are)."""
    flare_canvas: float = option(1.0, ge=1, le=4)
    """With ``per_kind``: the composites' flare drawn for a frame this many times their side,
    a window around the light kept (`fmg train --flare-canvas`; 2: at the scale the mask
    stage meets flare on a 512 px photo)."""
    ray_min: int | None = option(None, ge=1)
    """With ``rays``: the ray rule's fewest rays per light (as `mask --ray-min`)."""
    ray_opposite: float | None = option(None, ge=0, le=90)
    """With ``rays``: the ray rule's opposite-streak tolerance (as `mask --ray-opposite`)."""
    streak_lines: bool | None = option(None, flag="--streak-lines/--no-streak-lines")
    """With ``rays``: also the streak lines through a light (as `mask --streak-lines`)."""
    streak_scales: tuple[float, ...] | None = option(None, gt=0, le=1, metavar="S1,S2")
    """With ``streak_lines``: where the streak lines are looked for (as `mask
    --streak-scales`)."""
    light_cores: bool | None = option(None, flag="--light-cores/--no-light-cores")
    """With ``rays``: also lamps found by their saturated region's core (as `mask
    --light-cores`)."""
    ghost_lines: bool = False
    """With ``per_kind`` or ``clean``: add the ghost-line regions to every model's mask (as
    `mask --ghost-lines`)."""
    ghost_chain: int | None = option(None, ge=1)
    """With ``ghost_lines``: the rule's chain (as `mask --ghost-chain`)."""
    fill_holes: bool = False
    """With ``per_kind``: every model's mask with the unmarked pixels it encloses marked (as
    `mask --fill-holes`); the IoUs and the fill ceiling are scored on those masks."""
    pads: tuple[str, ...] = option((), choices=("reflect", "replicate", "constant"))
    """With ``clean``: also run the network on each photo padded these ways and keep what
    the runs agree on, as the mask stage does by default (`mask --pads
    reflect,replicate,constant`); none: the plain run alone."""
    pads_keep: str = option("pixels", choices=("pixels", "regions"))
    """With ``pads``: what the runs' agreement keeps, as `mask --pads-keep`."""
    negatives: tuple[str, ...] = option(
        (), choices=("lamp", "specular", "sky", "clouds", "wall", "foliage", "backlit", "neon",
                     "reflection"))
    """Instead: share of pixels marked on ``count`` flare-free composites of the ``split``
    part per kind of hard negative named here (comma-separated, e.g. backlit,clouds; each
    painted alone, as `fmg train --negatives` paints it): what a model marks of bright
    things that are not flare."""
    confirm: Path | None = None
    """With ``per_kind`` or ``clean``: score the masks of `mask --confirm` with these weights
    as the second network (each network at its own cut; e.g.
    gnfr/weights/fmg_candidate_L.safetensors)."""
    confirm_keep: str | None = option(None, choices=("both", "first"))
    """With ``confirm``: as `mask --confirm-keep` (default both)."""
    out: Path | None = None
    """Write the metrics here (JSON)."""


@dataclass
class FMGCalibrateConfig:
    """Options of `deflare-scene fmg calibrate` (composites of the development photos)."""

    weights: Path | None = None
    """FMG weights (default: the shipped ones)."""
    data: Path = field(default_factory=default_data)
    """Folder with backgrounds/ and scenes/."""
    count: int = option(96, ge=1)
    """Development composites to score."""
    seed: int = option(7, ge=0)
    """Seed of the composites."""
    write: bool = False
    """Store the best cut in the weights' metadata (the mask stage's default)."""
    out: Path | None = None
    """Write the sweep here (JSON)."""


@dataclass(kw_only=True)
class FMGOverlayConfig:
    """Options of `deflare-scene fmg overlay`."""

    photos: tuple[Path, ...]
    """Photos to mask (e.g. real flare)."""
    weights: tuple[Path, ...] = ()
    """FMG weights, one column each (default: the shipped ones)."""
    out: Path
    """The overview JPEG to write."""
    json: Path | None = None
    """Also write each photo's marked share per model here (JSON, with the command and code)."""
    fill_holes: bool = False
    """Mark the unmarked pixels each mask encloses too, as `mask --fill-holes` does (last)."""
    work_size: int = option(512, ge=32)
    """The network's working size (long side)."""
    rays: bool = False
    """Add the flare rays to each model's mask (as the mask stage does unless --no-rays)."""
    ray_min: int | None = option(None, ge=1)
    """With ``rays``: the ray rule's fewest rays per light (as `mask --ray-min`)."""
    ray_opposite: float | None = option(None, ge=0, le=90)
    """With ``rays``: the ray rule's opposite-streak tolerance (as `mask --ray-opposite`)."""
    streak_lines: bool | None = option(None, flag="--streak-lines/--no-streak-lines")
    """With ``rays``: also the streak lines through a light (as `mask --streak-lines`)."""
    streak_scales: tuple[float, ...] | None = option(None, gt=0, le=1, metavar="S1,S2")
    """With ``streak_lines``: where the streak lines are looked for (as `mask
    --streak-scales`)."""
    light_cores: bool | None = option(None, flag="--light-cores/--no-light-cores")
    """With ``rays``: also lamps found by their saturated region's core (as `mask
    --light-cores`)."""
    ghost_lines: bool = False
    """Add the ghost-line regions to each model's mask (as `mask --ghost-lines`)."""
    ghost_chain: int | None = option(None, ge=1)
    """With ``ghost_lines``: the rule's chain (as `mask --ghost-chain`)."""
    pads: tuple[str, ...] = option((), choices=("reflect", "replicate", "constant"))
    """Also run each network on the photo padded these ways and keep what the runs agree on,
    as the mask stage does by default (`mask --pads reflect,replicate,constant`); none: the
    network's plain run alone."""
    pads_keep: str = option("pixels", choices=("pixels", "regions"))
    """With ``pads``: what the runs' agreement keeps, as `mask --pads-keep` (pixels: each
    pixel every run marks; regions: the plain run's regions they agree on a pixel of)."""


def check_pads(cfg) -> None:
    """A one-line UserError when ``cfg`` (`fmg eval` or `fmg overlay`) sets --pads-keep
    without --pads."""
    if cfg.pads_keep != "pixels" and not cfg.pads:
        raise UserError("--pads-keep says what the padded runs of --pads keep: add --pads")


def check_modes(cfg: FMGEvalConfig) -> FMGEvalConfig:
    """``cfg`` when it asks for one score (the composites, ``per_kind``, ``work_sizes``,
    ``clean`` or ``negatives``); else a one-line UserError."""
    if cfg.loo and not cfg.per_kind:
        raise UserError("--loo needs --per-kind")
    if cfg.rays and not (cfg.per_kind or cfg.clean or cfg.negatives):
        raise UserError("--rays needs --per-kind, --clean or --negatives")
    if cfg.confirm is not None and not (cfg.per_kind or cfg.clean):
        raise UserError("--confirm needs --per-kind or --clean")
    if cfg.confirm_keep is not None and cfg.confirm is None:
        raise UserError("--confirm-keep says which regions --confirm keeps: add --confirm "
                        "WEIGHTS, or leave --confirm-keep out")
    check_ray_rule(cfg)
    if tuple(cfg.scales) != (1.0,) and not (cfg.per_kind or cfg.clean):
        raise UserError("--scales needs --per-kind or --clean")
    if cfg.flare_canvas != 1.0 and not cfg.per_kind:
        raise UserError("--flare-canvas needs --per-kind")
    if cfg.night is not None and not cfg.per_kind:
        raise UserError("--night needs --per-kind")
    if cfg.ghost_lines and not (cfg.per_kind or cfg.clean):
        raise UserError("--ghost-lines needs --per-kind or --clean")
    if cfg.fill_holes and not cfg.per_kind:
        raise UserError("--fill-holes needs --per-kind")
    if cfg.pads and not cfg.clean:
        raise UserError("--pads needs --clean")
    check_pads(cfg)
    if sum((cfg.per_kind, bool(cfg.work_sizes), cfg.clean, bool(cfg.negatives))) > 1:
        raise UserError("give one of --per-kind, --work-sizes, --clean, --negatives")
    return cfg


def check_ray_rule(cfg) -> None:
    """A one-line UserError when ``ray_min``, ``ray_opposite``, ``streak_lines`` or
    ``light_cores`` is given without ``rays``, or ``streak_scales`` without
    ``streak_lines`` (they would silently change nothing)."""
    if not cfg.rays and (cfg.ray_min is not None or cfg.ray_opposite is not None
                         or cfg.streak_lines is not None or cfg.light_cores is not None):
        raise UserError("--ray-min, --ray-opposite, --streak-lines and --light-cores set the "
                        "flare rays' rule: add --rays")
    from pipeline.mask import check_streak_scales

    check_streak_scales(cfg)


def run_eval(cfg: FMGEvalConfig) -> tuple[dict, str, Path]:
    """`fmg eval`: the one score ``cfg`` asks for (``check_modes``), as (metrics, the table
    printed, the weights scored). Every weights file is opened first, so a missing or foreign
    one stops the run with one clear line before any scoring."""
    from pipeline.mask import DEFAULT_WEIGHTS, ghost_config, load_fmg_weights, ray_config

    check_modes(cfg)
    rule, ghosts = ray_config(cfg), ghost_config(cfg)
    weights = cfg.weights or DEFAULT_WEIGHTS
    for path in (weights, *cfg.loo):
        load_fmg_weights(path)
    keep = cfg.confirm_keep or "both"
    if cfg.confirm:
        load_fmg_weights(cfg.confirm, flag="--confirm")
    if cfg.work_sizes:
        metrics = work_size_sweep(weights, cfg.data, cfg.work_sizes, split=cfg.split)
        return metrics, format_work_sizes(metrics), weights
    if cfg.clean:
        metrics = clean_fractions(weights, cfg.data, cfg.work_size, split=cfg.split,
                                  rays=cfg.rays, ray_cfg=rule, confirm=cfg.confirm,
                                  confirm_keep=keep, scales=cfg.scales, ghosts=ghosts,
                                  pads=cfg.pads, pads_keep=cfg.pads_keep)
        return metrics, format_clean(metrics), weights
    if cfg.negatives:
        metrics = negative_fractions(weights, cfg.data, cfg.negatives, cfg.count,
                                     size=cfg.size, split=cfg.split, rays=cfg.rays,
                                     ray_cfg=rule)
        return metrics, format_negatives(metrics), weights
    if cfg.per_kind:
        metrics = evaluate_kinds(weights, cfg.data, cfg.loo, cfg.count, size=cfg.size,
                                 split=cfg.split, rays=cfg.rays, ray_cfg=rule,
                                 confirm=cfg.confirm, confirm_keep=keep, scales=cfg.scales,
                                 flare_canvas=cfg.flare_canvas, night=cfg.night,
                                 ghosts=ghosts, fill_holes=cfg.fill_holes)
        return metrics, format_kinds(metrics), weights
    metrics = evaluate(weights, cfg.data, cfg.count, refine=cfg.refine, size=cfg.size,
                       split=cfg.split)
    return metrics, format_metrics(metrics), weights


# --------------------------------------------------------------------------- scoring a batch
def score(model, images, masks, batch: int = 8, refine: bool = False,
          cut: float = 0.5, also=None, confirm=None,
          scales: tuple[float, ...] = (1.0,), ghosts=None, clean=None,
          fill_holes: bool = False) -> dict[str, float]:
    """mIoU / mAcc of ``model`` on images [N, 3, S, S] with masks [N, 1, S, S] (pooled),
    flare where the probability exceeds ``cut`` or where ``also`` [N, 1, S, S] bool (e.g.
    the images' flare rays, ``ray_batch``) is set. With ``confirm`` = (second model, its
    cut, keep) the masks are those of `mask --confirm` (``pipeline.mask.confirmed_marks``,
    ``also`` as the rays). ``scales``: each network's probabilities averaged over these
    fractions of the composites' side (``gnfr.fmg.predict_probs``). ``ghosts`` (a
    ``pipeline.flare_ghosts.GhostConfig``): the ghost-line regions of the probabilities
    added, as `mask --ghost-lines` adds them (before the confirmation). ``fill_holes``: the
    unmarked pixels a mask encloses marked too, as `mask --fill-holes` does (last).
    ``clean``: the images without their flare [N, 3, S, S]; adds ``flare_psnr_ceiling``
    (:func:`fill_ceiling`)."""
    import torch

    from gnfr.fmg import confusion, predict_probs, seg_metrics
    from pipeline.mask import confirmed_marks

    def confirmed(marked, second, extra):
        return torch.from_numpy(np.stack([[confirmed_marks(
            marked[i, 0].numpy(), second[i, 0].numpy(), confirm[2],
            None if extra is None else extra[i, 0].numpy())] for i in range(len(marked))]))

    conf = torch.zeros(2, 2, dtype=torch.long)
    err = np.zeros(2)  # squared error the marks leave in the true flare, its pixels
    model.eval()
    dev = next(model.parameters()).device
    with torch.no_grad():
        for i in range(0, len(images), batch):
            x = images[i:i + batch].to(dev)
            side = max(x.shape[-2:])
            p = predict_probs(model, x, side, scales).cpu()
            if refine:
                p = _refine_batch(x.cpu(), p)
            marked = p > cut
            if ghosts is not None:
                marked |= ghost_batch(x.cpu(), p, ghosts)
            extra = also[i:i + batch] if also is not None else None
            if confirm is not None:
                q = predict_probs(confirm[0], x, side, scales).cpu()
                if refine:  # both networks refined, as in the mask stage
                    q = _refine_batch(x.cpu(), q)
                marked = confirmed(marked, q > confirm[1], extra)
            elif extra is not None:
                marked |= extra
            if fill_holes:
                marked = holes_filled(marked)
            true = masks[i:i + batch] > 0.5
            conf += confusion(marked, true)
            if clean is not None:
                err += fill_error(images[i:i + batch], clean[i:i + batch], marked, true)
    out = seg_metrics(conf)
    if clean is not None:
        out["flare_psnr_ceiling"] = fill_ceiling(*err)
    return out


def holes_filled(marked):
    """[N, 1, S, S] bool masks with the unmarked pixels each encloses marked
    (``pipeline.ws_files.enclosed_holes``, as `mask --fill-holes`)."""
    import torch

    from pipeline.ws_files import enclosed_holes

    return torch.stack([m | torch.from_numpy(enclosed_holes(m[0].numpy()))[None]
                        for m in marked])


def fill_error(images, clean, marked, true) -> np.ndarray:
    """(squared error, channel values) in the true flare ``true`` [N, 1, S, S] of ``images``
    [N, 3, S, S] (sRGB 0..1) with every ``marked`` pixel made ``clean``: both quantised to 8
    bits as photos are (:func:`squared_error`)."""
    def u8(x):
        return np.round(np.clip(x.permute(0, 2, 3, 1).numpy().astype(np.float64), 0, 1) * 255)

    left = (true & ~marked).numpy()[:, 0]
    return np.array([squared_error(u8(images), u8(clean))[left].sum(), 3 * true.sum().item()])


def squared_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Each pixel's squared error [..., H, W] of two 8-bit images [..., H, W, 3] (uint8 or
    0-255 values) on the 0-1 scale, summed over the channels: what a photo's PSNR counts."""
    return (((a.astype(np.float64) - b.astype(np.float64)) / 255.0) ** 2).sum(-1)


def fill_ceiling(err: float, count: float) -> float | None:
    """The flare-region PSNR (dB) of a perfect fill of the marked pixels from the squared
    error the marks leave and the channel values it is over (``pipeline.metrics.mse_to_psnr``,
    capped alike; None without true flare): `fmg eval`'s and ``benchmarks/mask_shape.py``'s."""
    from pipeline.metrics import mse_to_psnr

    return None if count <= 0 else mse_to_psnr(err / count)


def ray_batch(x, ray_cfg=None):
    """[N, 1, S, S] bool flare rays (rule ``ray_cfg``, default RayConfig's) of images
    [N, 3, S, S] (sRGB 0..1)."""
    import torch

    from pipeline.flare_rays import ray_mask

    return torch.stack([torch.from_numpy(ray_mask(np.ascontiguousarray(
        xi.permute(1, 2, 0).numpy()), ray_cfg))[None] for xi in x])


def ghost_batch(x, p, ghost_cfg):
    """[N, 1, S, S] bool ghost-line regions (``pipeline.mask.ghost_marks``, rule
    ``ghost_cfg``) of images [N, 3, S, S] (sRGB 0..1) with FMG probabilities ``p``
    [N, 1, S, S]."""
    import torch

    from pipeline.mask import ghost_marks

    out = []
    for xi, pi in zip(x, p, strict=True):
        bgr = _bgr_uint8(xi)
        out.append(torch.from_numpy(ghost_marks(bgr, pi[0].numpy(), max(bgr.shape[:2]),
                                                ghost_cfg))[None])
    return torch.stack(out)


def _bgr_uint8(x) -> np.ndarray:
    """A BGR uint8 image [S, S, 3] (the mask stage's input) of an image tensor [3, S, S]
    (sRGB 0..1)."""
    return (x.permute(1, 2, 0).numpy()[..., ::-1] * 255).astype(np.uint8)


def _refine_batch(x, p):
    import torch

    from pipeline.mask import refine_probs

    out = []
    for xi, pi in zip(x, p, strict=True):
        out.append(torch.from_numpy(refine_probs(_bgr_uint8(xi), pi[0].numpy()))[None])
    return torch.stack(out)


# --------------------------------------------------------------------------- evaluate
def _part_backgrounds(data: Path, size: int, split: str) -> list:
    """The ``split`` part's photos (``dev`` or ``test``; ``pipeline.fmg_data.PhotoSplit``)."""
    from pipeline.fmg_data import CompositeConfig, load_backgrounds, split_backgrounds

    if split not in ("dev", "test"):
        raise UserError(f"--split {split}: give dev (choices) or test (reports)")
    photos = load_backgrounds(getattr(split_backgrounds(Path(data)), split),
                              CompositeConfig(size=size).preload_side)
    if not photos:
        raise UserError(f"{data}: no readable {split} photos (see pipeline.fmg_data."
                        "split_backgrounds for which scenes and backgrounds they are)")
    return photos


def evaluate(weights: Path, data: Path, count: int = 64, seed: int = 2024,
             refine: bool = False, size: int = 256, split: str = "test") -> dict:
    """mIoU / mAcc on ``count`` composites of the ``split`` part (``test``: scenes in
    HELDOUT_SCENES + held-out backgrounds; ``dev``: the FMG's development photos) at the cut
    the mask stage uses (the weights' calibrated one, else 0.5),
    for the default flare settings (every kind), ``FlareConfig.unseen()`` and the default
    settings with night backgrounds on half of them (``night``)."""
    from pipeline import flare as fl
    from pipeline.fmg_data import CompositeConfig, CompositeSource, fixed_set
    from pipeline.mask import MaskConfig, load_fmg_weights, resolve_threshold

    model = load_fmg_weights(Path(weights))
    cut = resolve_threshold(MaskConfig(), Path(weights))  # the mask stage's default cut
    comp = CompositeConfig(size=size)
    bgs = _part_backgrounds(data, size, split)
    res = {"weights": str(weights), "count": count, "size": size, "seed": seed, "cut": cut,
           "split": split}
    rows = (("default", fl.FlareConfig(), comp, False),
            ("unseen", fl.FlareConfig.unseen(), comp, False),
            ("night", fl.FlareConfig(), CompositeConfig(size=size, night_prob=0.5), True))
    for name, fcfg, c, extras in rows:
        imgs, masks, clean = fixed_set(CompositeSource(bgs, fcfg, c), count, seed, extras,
                                       with_clean=True)
        frac = {"flare_pixels": round(float(masks.mean()), 4)}
        res[name] = {**score(model, imgs, masks, cut=cut, clean=clean), **frac}
        if refine:
            res[name + "_refined"] = {**score(model, imgs, masks, refine=True, cut=cut,
                                              clean=clean), **frac}
    return res


PER_KIND_NIGHT = 0.3
"""Share of night backgrounds in the per-kind evaluation composites."""


def weights_info(path: Path) -> dict:
    """What a weights file says about its training: steps, kinds left out, cut."""
    from gnfr.fmg import read_fmg_metadata
    from pipeline.mask import MaskConfig, resolve_threshold

    meta = read_fmg_metadata(path)
    without = tuple(k for k in meta.get("without", "").split(",") if k)
    return {"weights": str(path), "without": without,
            "steps": int(meta.get("total_iters", meta.get("iters", "0")) or 0),
            "cut": resolve_threshold(MaskConfig(), Path(path))}


def _ray_rule(rays: bool, ray_cfg) -> dict | None:
    """The ray rule a result used (RayConfig's fields), None without rays."""

    from pipeline.flare_rays import RayConfig

    return asdict(ray_cfg or RayConfig()) if rays else None


def _ghost_rule(ghosts) -> dict | None:
    """The ghost-line rule a result used (GhostConfig's fields), None without it."""

    return asdict(ghosts) if ghosts is not None else None


def evaluate_kinds(weights: Path, data: Path, loo: tuple[Path, ...] = (), count: int = 48,
                   seed: int = 2025, size: int = 256,
                   kinds: tuple[str, ...] | None = None, split: str = "test",
                   rays: bool = False, ray_cfg=None, confirm: Path | None = None,
                   confirm_keep: str = "both", scales: tuple[float, ...] = (1.0,),
                   flare_canvas: float = 1.0, night: float | None = None,
                   ghosts=None, fill_holes: bool = False) -> dict:
    """Per kind of flare: flare IoU, mIoU and mAcc on ``count`` composites of the ``split``
    part flared with that kind alone (``FlareConfig(kinds=(kind,))``; test or development
    scenes and backgrounds, night backgrounds on ``night`` of them, default
    ``PER_KIND_NIGHT``), of ``weights`` (e.g. the shipped model) and of each
    leave-one-kind-out model in ``loo`` on the kind it was trained without (its
    metadata ``without``). Each model is cut at its own calibrated threshold; with ``rays``
    the flare rays (rule ``ray_cfg``) are added to every model's mask; with ``confirm``
    (weights) ``weights``' masks are those of `mask --confirm` with that second network;
    ``scales``: every network at these fractions of the composites' side (``score``);
    ``flare_canvas``: the flare drawn for a frame that many times the composites' side
    (``CompositeConfig.flare_canvas``); ``ghosts``: every model's mask with the ghost-line
    regions (``score``); ``fill_holes``: every model's mask with its enclosed holes marked
    (`mask --fill-holes`). Each score has the fill ceiling (``flare_psnr_ceiling``)."""
    from pipeline import flare as fl
    from pipeline.fmg_data import CompositeConfig, CompositeSource, fixed_set
    from pipeline.mask import load_fmg_weights

    main = {**weights_info(Path(weights)), "model": load_fmg_weights(Path(weights))}
    second = (None if confirm is None else (load_fmg_weights(Path(confirm)),
                                            weights_info(Path(confirm))["cut"], confirm_keep))
    held = []
    for w in loo:
        info_w = weights_info(Path(w))
        if not info_w["without"]:
            raise UserError(f"--loo {w}: these weights were trained on every kind (no "
                            "'without' in their metadata); train with --without KIND")
        held.append({**info_w, "model": load_fmg_weights(Path(w))})
    kinds = tuple(kinds or fl.KINDS)
    bgs = _part_backgrounds(data, size, split)
    night = PER_KIND_NIGHT if night is None else night
    comp = CompositeConfig(size=size, night_prob=night, flare_canvas=flare_canvas)
    res = {"count": count, "seed": seed, "size": size, "night": night, "split": split,
           "rays": rays, "ray_rule": _ray_rule(rays, ray_cfg), "scales": list(scales),
           "flare_canvas": flare_canvas, "ghost_lines": _ghost_rule(ghosts),
           "fill_holes": fill_holes,
           "weights": {k: v for k, v in main.items() if k != "model"},
           "confirm": None if confirm is None else {**weights_info(Path(confirm)),
                                                     "keep": confirm_keep},
           "loo": [{k: v for k, v in h.items() if k != "model"} for h in held], "kinds": {}}
    for i, kind in enumerate(kinds):
        src = CompositeSource(bgs, fl.FlareConfig(kinds=(kind,)), comp)
        imgs, masks, clean = fixed_set(src, count, seed + i, extras=True, with_clean=True)
        ray = ray_batch(imgs, ray_cfg) if rays else None  # the same for every model: once
        row = {"flare_pixels": round(float(masks.mean()), 4),
               "weights": score(main["model"], imgs, masks, cut=main["cut"], also=ray,
                                confirm=second, scales=scales, ghosts=ghosts, clean=clean,
                                fill_holes=fill_holes)}
        for h in held:
            if kind in h["without"]:
                row["without"] = {**score(h["model"], imgs, masks, cut=h["cut"], also=ray,
                                          scales=scales, ghosts=ghosts, clean=clean,
                                          fill_holes=fill_holes),
                                  "weights": h["weights"], "steps": h["steps"]}
        res["kinds"][kind] = row
    return res


def format_kinds(res: dict) -> str:
    """The per-kind table: trained without the kind, and ``weights``."""
    w, c = res["weights"], res.get("confirm")
    also = f", confirmed by {Path(c['weights']).name}" if c else ""
    rows = [f"{res['count']} held-out composites per kind ({res['size']} px, night "
            f"{res['night']:g}{', holes filled' if res.get('fill_holes') else ''}); flare "
            "IoU / mIoU / mAcc / fill ceiling (flare-region PSNR of a perfect fill of the "
            "marks)",
            f"| kind | flare pixels | trained without it (steps) | {Path(w['weights']).name} "
            f"({w['steps']} steps{also}) |", "|---|---|---|---|"]

    def cell(m: dict) -> str:
        fill = m.get("flare_psnr_ceiling")
        return (f"{m['IoU_flare']:.3f} / {m['mIoU']:.3f} / {m['mAcc']:.3f}"
                + ("" if fill is None else f" / {fill:.2f} dB"))

    for kind, r in res["kinds"].items():
        loo = f"{cell(r['without'])} ({r['without']['steps']})" if "without" in r else "-"
        rows.append(f"| {kind} | {r['flare_pixels']:.3f} | {loo} | {cell(r['weights'])} |")
    return "\n".join(rows)


def format_metrics(m: dict) -> str:
    """The metrics table; the fill ceiling's column where a row has one (`fmg eval`)."""
    fills = any(isinstance(v, dict) and "flare_psnr_ceiling" in v for v in m.values())
    rows = ["| flare settings | mIoU | mAcc | IoU flare | flare pixels |"
            + (" fill ceiling (dB) |" if fills else ""), "|---|---|---|---|---|"
            + ("---|" if fills else "")]
    for k, v in m.items():
        if isinstance(v, dict):
            fill = v.get("flare_psnr_ceiling")
            rows.append(f"| {k} | {v['mIoU']:.3f} | {v['mAcc']:.3f} | {v['IoU_flare']:.3f} | "
                        f"{v.get('flare_pixels', math.nan):.3f} |"
                        + ((" - |" if fill is None else f" {fill:.2f} |") if fills else ""))
    if "cut" in m:
        rows.append(f"(flare where the probability exceeds {m['cut']:g})")
    return "\n".join(rows)


# --------------------------------------------------------------------------- photo-size checks
WORK_SIZE_PHOTOS = {"test": ("scenes/cyprus",), "dev": ("scenes/lund/images",)}
"""Per part, held-out photos large enough (1500x1000 and more) to flare at photo size for the
working-size sweep."""


CLEAN_SCENES = {"test": ("scenes/fern/images_8", "scenes/kermit", "scenes/cyprus"),
                "dev": ("scenes/lund/images",)}
"""Per part, the clean photos ``clean_fractions`` scores (test scenes; the FMG's dev scene)."""


def _photos(folder: Path, long_side: int | None = None) -> list:
    """BGR uint8 photos of ``folder`` (not recursive), downscaled to ``long_side``; a
    one-line UserError when the folder is missing (``--data`` not the shared data)."""
    import cv2

    if not folder.is_dir():
        raise UserError(f"{folder}: no such folder; pass --data pointing at the shared data "
                        "(a folder with scenes/ and backgrounds/), or set DEFLARE_SHARED_DATA")
    out = []
    for p in list_photos(folder):
        try:
            img = read_image(p, bgr=True)
        except UserError:  # an unreadable file is left out
            continue
        if long_side and max(img.shape[:2]) > long_side:
            s = long_side / max(img.shape[:2])
            img = cv2.resize(img, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        out.append((p.name, img))
    return out


def work_size_sweep(weights: Path, data: Path, work_sizes: tuple[int, ...] = (384, 512, 768),
                    kinds: tuple[str, ...] = ("streaks", "starburst"), photo_side: int = 1008,
                    per_photo: int = 2, seed: int = 31, split: str = "test") -> dict:
    """Flare IoU (at the weights' cut) against the network's working size (long side given
    to ``predict_probs``), on held-out photos (``WORK_SIZE_PHOTOS``) at long side
    ``photo_side`` flared at that size with one kind alone (thin streaks and spikes), a third
    of them darkened to night. Scored at photo size."""
    import torch

    from gnfr.fmg import confusion, seg_metrics
    from pipeline import flare as fl
    from pipeline.fmg_data import CompositeConfig, darken_night
    from pipeline.mask import fmg_probs, load_fmg_weights

    info_w = weights_info(Path(weights))
    model = load_fmg_weights(Path(weights))
    photos = [im for f in WORK_SIZE_PHOTOS[split]
              for _, im in _photos(Path(data) / f, photo_side)]
    res = {"weights": str(weights), "cut": info_w["cut"], "photo_side": photo_side, "split": split,
           "photos": len(photos) * per_photo, "kinds": {}}
    for kind in kinds:
        rng = np.random.default_rng(seed)
        cfg = fl.FlareConfig(kinds=(kind,))
        conf = {w: torch.zeros(2, 2, dtype=torch.long) for w in work_sizes}
        for bgr in photos:
            for _ in range(per_photo):
                img = bgr[..., ::-1].astype(np.float32) / 255
                if rng.random() < 1 / 3:
                    img = darken_night(img, CompositeConfig(), rng)
                flared, layers = fl.synthesize(img, cfg, rng)
                im8 = np.clip(flared * 255 + 0.5, 0, 255).astype(np.uint8)[..., ::-1]
                truth = torch.from_numpy(layers.mask)
                for w in work_sizes:
                    p = torch.from_numpy(fmg_probs(model, [np.ascontiguousarray(im8)], w)[0])
                    conf[w] += confusion(p > info_w["cut"], truth)
        res["kinds"][kind] = {str(w): seg_metrics(c) for w, c in conf.items()}
    return res


def format_work_sizes(res: dict) -> str:
    sizes = list(next(iter(res["kinds"].values())))
    rows = [f"flare IoU / mIoU against working size ({res['photos']} held-out photos at long "
            f"side {res['photo_side']}, cut {res['cut']:g})",
            "| kind | " + " | ".join(sizes) + " |", "|---" * (len(sizes) + 1) + "|"]
    for kind, r in res["kinds"].items():
        rows.append(f"| {kind} | " + " | ".join(
            f"{r[w]['IoU_flare']:.3f} / {r[w]['mIoU']:.3f}" for w in sizes) + " |")
    return "\n".join(rows)


def clean_fractions(weights: Path, data: Path, work_size: int = 512,
                    scenes: tuple[str, ...] | None = None, split: str = "test",
                    rays: bool = False, ray_cfg=None, confirm: Path | None = None,
                    confirm_keep: str = "both", scales: tuple[float, ...] = (1.0,),
                    ghosts=None, pads: tuple[str, ...] = (),
                    pads_keep: str = "pixels") -> dict:
    """Fraction of pixels marked (at the weights' cut, network at ``work_size``, flare rays
    added with ``rays`` by rule ``ray_cfg``, with ``confirm`` (weights) the second network of
    `mask --confirm`: as in the mask stage, the networks at ``scales`` of ``work_size`` as
    `mask --scales`, the ghost-line regions added with ``ghosts`` as `mask --ghost-lines`,
    with ``pads`` what the padded runs agree on, as `mask --pads --pads-keep` keeps it) on
    every clean photo of ``scenes`` at full size: mean and max per scene."""
    from pipeline.mask import flare_marks, load_fmg_weights

    def marks(im):
        return flare_marks(model, im, cut, work_size, rays, ray_cfg=ray_cfg, confirm=second,
                           scales=scales, ghosts=ghosts, pads=tuple(pads), pads_keep=pads_keep)

    cut = weights_info(Path(weights))["cut"]
    model = load_fmg_weights(Path(weights))
    second = (None if confirm is None else (load_fmg_weights(Path(confirm)),
                                            weights_info(Path(confirm))["cut"], confirm_keep))
    res = {"weights": str(weights), "cut": cut, "work_size": work_size, "split": split,
           "rays": rays, "ray_rule": _ray_rule(rays, ray_cfg), "scales": list(scales),
           "ghost_lines": _ghost_rule(ghosts), "pads": list(pads),
           "pads_keep": pads_keep if pads else None,
           "confirm": None if confirm is None else {**weights_info(Path(confirm)),
                                                     "keep": confirm_keep}, "scenes": {}}
    for scene in scenes or CLEAN_SCENES[split]:
        marked = {name: float(marks(im).mean()) for name, im in _photos(Path(data) / scene)}
        fractions = list(marked.values())
        res["scenes"][scene] = {"views": len(fractions), "mean": float(np.mean(fractions)),
                                "max": float(max(fractions)),
                                "over_10pct": int(sum(x > 0.10 for x in fractions)),
                                "per_view": marked}
    return res


def negative_fractions(weights: Path, data: Path, kinds: tuple[str, ...], count: int = 48,
                       seed: int = 2026, size: int = 256, split: str = "dev",
                       rays: bool = False, ray_cfg=None) -> dict:
    """Per kind of hard negative (``pipeline.fmg_data.HARD_NEGATIVES``): the share of pixels
    ``weights`` marks (at its cut; flare rays added with ``rays``) on ``count`` flare-free
    composites of the ``split`` part, each a random crop (night on ``PER_KIND_NIGHT`` of
    them) with that negative alone painted on it: mean, max, and how many composites have
    more than 1 % marked. Nothing in them is flare, so every mark is a false one."""
    import torch

    from pipeline.fmg_data import (
        CompositeConfig,
        add_hard_negatives,
        darken_night,
        random_crop,
    )
    from pipeline.mask import load_fmg_weights

    info_w = weights_info(Path(weights))
    model = load_fmg_weights(Path(weights))
    dev = next(model.parameters()).device
    bgs = _part_backgrounds(data, size, split)
    comp = CompositeConfig(size=size, night_prob=PER_KIND_NIGHT)
    res = {"weights": str(weights), "cut": info_w["cut"], "count": count, "seed": seed,
           "size": size, "night": PER_KIND_NIGHT, "split": split, "rays": rays,
           "ray_rule": _ray_rule(rays, ray_cfg), "negatives": {}}
    model.eval()
    for i, kind in enumerate(kinds):
        rng = np.random.default_rng(seed + i)
        imgs = []
        for _ in range(count):
            img = random_crop(bgs[int(rng.integers(len(bgs)))], size, comp.crop_scale, rng)
            if rng.random() < comp.night_prob:
                img = darken_night(img, comp, rng)
            imgs.append(add_hard_negatives(img, rng, (kind,)))
        x = torch.from_numpy(np.stack(imgs)).permute(0, 3, 1, 2).contiguous()
        marked = []
        with torch.no_grad():
            for j in range(0, count, 8):
                p = torch.sigmoid(model(x[j:j + 8].to(dev))).cpu()[:, 0] > info_w["cut"]
                if rays:
                    p |= ray_batch(x[j:j + 8], ray_cfg)[:, 0]
                marked += [float(m.float().mean()) for m in p]
        res["negatives"][kind] = {"mean": float(np.mean(marked)), "max": float(max(marked)),
                                  "over_1pct": int(sum(m > 0.01 for m in marked))}
    return res


def format_negatives(res: dict) -> str:
    rows = [f"flare-free composites with one hard negative ({res['split']}), pixels marked at "
            f"cut {res['cut']:g}" + (", rays on" if res["rays"] else ""),
            "| negative | composites | mean | max | over 1 % |", "|---|---|---|---|---|"]
    for kind, r in res["negatives"].items():
        rows.append(f"| {kind} | {res['count']} | {100 * r['mean']:.2f} % | "
                    f"{100 * r['max']:.2f} % | {r['over_1pct']} |")
    return "\n".join(rows)


def format_clean(res: dict) -> str:
    also = (f", confirmed by {Path(res['confirm']['weights']).name}" if res.get("confirm")
            else "")
    rows = [f"clean photos, pixels marked at cut {res['cut']:g}, network at {res['work_size']}"
            f"{also}",
            "| scene | views | mean | max | views over 10 % |", "|---|---|---|---|---|"]
    for scene, r in res["scenes"].items():
        rows.append(f"| {scene} | {r['views']} | {100 * r['mean']:.2f} % | {100 * r['max']:.2f} % "
                    f"| {r['over_10pct']} |")
    return "\n".join(rows)


def overlay_label(weights: Path, marked: float, rays: bool, ray_cfg, ghost_lines: bool,
                  pads: bool, holes: bool = False) -> str:
    """An overlay tile's label: the weights, each option that added marks, the share marked."""
    lines = rays and ray_cfg is not None and ray_cfg.lines
    cores = rays and ray_cfg is not None and ray_cfg.cores
    if lines and tuple(ray_cfg.line_scales) != (1.0,):
        lines = " + streak lines at " + ",".join(f"{s:g}" for s in ray_cfg.line_scales)
    elif lines:
        lines = " + streak lines"
    return (f"{weights_label(weights)}{' + rays' if rays else ''}"
            f"{lines or ''}{' + light cores' if cores else ''}"
            f"{' + ghost lines' if ghost_lines else ''}{' + pads' if pads else ''}"
            f"{' + holes filled' if holes else ''}: "
            f"{100 * marked:.1f} %")


def real_flare_overview(weights: tuple[Path, ...], photos: tuple[Path, ...], out: Path,
                        work_size: int = 512, width: int = 480, rays: bool = False,
                        ray_cfg=None, ghosts=None, pads: tuple[str, ...] = (),
                        pads_keep: str = "pixels", fill_holes: bool = False) -> dict:
    """One JPEG: a row per photo, the photo then each model's mask (at its cut; with the flare
    rays of rule ``ray_cfg`` if ``rays``, the ghost-line regions of rule ``ghosts`` if given,
    with ``pads`` what the padded runs agree on, as `mask --pads --pads-keep` keeps it; with
    ``fill_holes`` the unmarked pixels each mask encloses marked last, as `mask --fill-holes`)
    outlined and tinted red; returns the fraction of each photo each model marks."""
    import cv2

    from pipeline.images import put_label
    from pipeline.mask import flare_marks, load_fmg_weights, ray_marks
    from pipeline.ws_files import enclosed_holes

    loaded = [load_fmg_weights(Path(w)) for w in weights]  # a bad file: one line, before work
    models = [(weights_info(Path(w))["cut"], m) for w, m in zip(weights, loaded, strict=True)]
    rows, fracs = [], {}
    for photo in photos:
        img = read_image(photo, bgr=True)
        scale = width / img.shape[1]
        tiles = [cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)]
        ray = ray_marks(img, work_size, ray_cfg) if rays else False  # the same for every model
        for (cut, model), w in zip(models, weights, strict=True):
            marked = flare_marks(model, img, cut, work_size, ghosts=ghosts, pads=tuple(pads),
                                 pads_keep=pads_keep) | ray
            if fill_holes:
                marked |= enclosed_holes(marked)
            fracs[f"{photo.name} {w}"] = float(marked.mean())
            small = cv2.resize(marked.astype(np.uint8), (tiles[0].shape[1], tiles[0].shape[0]),
                               interpolation=cv2.INTER_NEAREST)
            tile = tiles[0].copy()
            tile[small > 0] = (0.55 * tile[small > 0]
                               + 0.45 * np.array([0, 0, 255])).astype(np.uint8)
            contours, _ = cv2.findContours(small, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
            cv2.drawContours(tile, contours, -1, (0, 255, 255), 1)
            label = overlay_label(Path(w), float(marked.mean()), rays, ray_cfg,
                                  ghosts is not None, bool(pads), fill_holes)
            put_label(tile, label, scale=0.7)
            tiles.append(tile)
        rows.append(np.hstack(tiles))
    atomic_imwrite(out, np.vstack(rows), [cv2.IMWRITE_JPEG_QUALITY, 80])
    return fracs


def run_overlay(cfg: FMGOverlayConfig) -> dict[str, float]:
    """`fmg overlay`: check ``cfg``, write the overview (``real_flare_overview``, which opens
    every weights file before any photo: one clear line for a bad one) and, with
    ``cfg.json``, its record; returns the fraction of each photo each model marks."""
    from pipeline.mask import DEFAULT_WEIGHTS, ghost_config, ray_config

    check_ray_rule(cfg)
    check_pads(cfg)
    weights = cfg.weights or (DEFAULT_WEIGHTS,)
    marked = real_flare_overview(weights, cfg.photos, cfg.out, cfg.work_size, rays=cfg.rays,
                                 ray_cfg=ray_config(cfg), ghosts=ghost_config(cfg),
                                 pads=cfg.pads, pads_keep=cfg.pads_keep,
                                 fill_holes=cfg.fill_holes)
    if cfg.json is not None:
        from pipeline.provenance import write_result

        write_result(cfg.json, {"overview": str(cfg.out), "marked": marked,
                                "weights": [str(w) for w in weights],
                                "work_size": cfg.work_size, "rays": cfg.rays,
                                "pads": list(cfg.pads), "fill_holes": cfg.fill_holes})
    return marked


def weights_label(path: Path) -> str:
    """A column's name: the file's stem, with its folder where the stem alone says nothing
    (a run's ``fmg``, ``checkpoint`` or ``best``, the shipped ``gnfr/weights/fmg``)."""
    generic = path.stem in ("fmg", "checkpoint", "best") and path.parent.name
    return f"{path.parent.name}/{path.stem}" if generic else path.stem


# --------------------------------------------------------------------------- calibrate
CALIBRATION_CUTS = tuple(round(0.3 + 0.05 * i, 2) for i in range(14))  # 0.30 .. 0.95


CALIBRATION_TIE = 0.002
"""Flare-IoU differences this small are sampling noise of a 96-composite set."""


def calibrate(weights: Path, data: Path, count: int = 96, seed: int = 7, size: int = 256,
              cuts: tuple[float, ...] = CALIBRATION_CUTS) -> dict:
    """Sweep the probability cut on fresh composites drawn from the FMG's *development*
    photos (``pipeline.fmg_data.PhotoSplit.dev``: never trained on, never reported; the test
    scenes and backgrounds stay out, so the cut is not tuned on anything an evaluation
    scores), with night backgrounds on a share of them.

    Per cut: flare IoU, mIoU and the ratio of marked to true flare pixels. ``best`` is the
    cut of highest flare IoU; cuts within ``CALIBRATION_TIE`` of it count as tied and the
    one marking closest to the true flare area wins (the 10 % rule counts area).
    The weighted BCE (flare 5:1) makes the network over-mark at 0.5, and the View
    Sampler's 10 % rule counts mask pixels, so an uncalibrated cut drops views whose true
    flare is under 10 %."""
    import torch

    from pipeline import flare as fl
    from pipeline.fmg_data import (
        CompositeConfig,
        CompositeSource,
        fixed_set,
    )
    from pipeline.mask import load_fmg_weights

    model = load_fmg_weights(Path(weights)).eval()
    comp = CompositeConfig(size=size, night_prob=0.25)
    src = CompositeSource(_part_backgrounds(Path(data), size, "dev"),
                          fl.FlareConfig(), comp)
    imgs, masks = fixed_set(src, count, seed, extras=True)
    with torch.no_grad():
        probs = torch.cat([torch.sigmoid(model(imgs[i:i + 8])) for i in range(0, count, 8)])
    from gnfr.fmg import confusion

    truth = masks > 0.5
    rows = []
    for c in cuts:
        (tn, fp), (fn, tp) = confusion(probs > c, truth).tolist()
        iou_f, iou_c = tp / max(tp + fp + fn, 1), tn / max(tn + fp + fn, 1)
        rows.append({"cut": c, "iou_flare": round(iou_f, 4),
                     "miou": round((iou_f + iou_c) / 2, 4),
                     "marked_over_true": round((tp + fp) / max(tp + fn, 1), 3)})
    top = max(r["iou_flare"] for r in rows)
    near = [r for r in rows if r["iou_flare"] >= top - CALIBRATION_TIE]
    best = min(near, key=lambda r: abs(r["marked_over_true"] - 1.0))["cut"]
    return {"weights": str(weights), "count": count, "seed": seed, "size": size, "split": "dev",
            "true_flare_fraction": round(float(truth.float().mean()), 4), "rows": rows,
            "best": best}


def format_calibration(res: dict) -> str:
    lines = [f"{res['count']} development composites, true flare fraction "
             f"{res['true_flare_fraction']}",
             "| cut | flare IoU | mIoU | marked / true |", "|---|---|---|---|"]
    for r in res["rows"]:
        mark = " (best)" if r["cut"] == res["best"] else ""
        lines.append(f"| {r['cut']:.2f}{mark} | {r['iou_flare']:.3f} | {r['miou']:.3f} | "
                     f"{r['marked_over_true']:.2f} |")
    return "\n".join(lines)


def write_threshold(weights: Path, cut: float) -> None:
    """Store ``cut`` as the weights' calibrated ``threshold`` metadata (tensors unchanged;
    the file is replaced atomically)."""
    from gnfr.checkpoint import replace_metadata

    replace_metadata(weights, {"threshold": f"{cut:g}"})
