"""Training, scoring and calibration of the FMG (flare mask PSPNet) on synthetic composites.

``train(cfg)`` owns the loop: AdamW with poly learning-rate decay, the 5:1 weighted BCE,
a checkpoint every ``ckpt_every`` steps in ``out`` (``checkpoint.safetensors`` with fp32
weights + ``optimizer.pt`` with optimizer state and step, read back with
``torch.load(weights_only=True)``), so a rerun with the same ``out`` resumes. It ends by
writing ``out/fmg.safetensors`` (fp16, config in the metadata) and ``out/metrics.json``.
``evaluate(weights, ...)`` scores mIoU / mAcc on held-out composites, with the default flare
settings and with ``FlareConfig.unseen()``. The options of each `deflare-scene fmg` command
are a dataclass here (FMGTrainConfig, FMGEvalConfig, FMGCalibrateConfig, FMGOverlayConfig).
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from pipeline.errors import UserError
from pipeline.images import list_photos, read_image
from pipeline.options import option, resolve_device, validate
from pipeline.progress import info
from pipeline.workspace import atomic_imwrite, atomic_path, atomic_write_json

REPO = Path(__file__).resolve().parents[2]


def default_data() -> Path:
    """The shared photo folder: $DEFLARE_SHARED_DATA or ../shared/data beside the repo."""
    return Path(os.environ.get("DEFLARE_SHARED_DATA", REPO.parent / "shared" / "data"))


@dataclass
class FMGTrainConfig:
    """Options of `deflare-scene fmg train`."""

    out: Path
    """Run folder (resumes if it has a checkpoint): checkpoints, log.jsonl, metrics.json; the
    result is OUT/fmg.safetensors."""
    data: Path = field(default_factory=default_data)
    """Folder with backgrounds/ and scenes/, images found recursively (default
    $DEFLARE_SHARED_DATA or ../shared/data)."""
    iters: int = option(3000, ge=1)
    """Optimizer steps."""
    batch: int = option(8, ge=1)
    """Composites per step."""
    size: int = option(256, ge=32)
    """Composite side in pixels."""
    widths: tuple[int, ...] = option((32, 64, 128, 256), ge=1)
    """Backbone stage widths (ResNet-18: 64,128,256,512)."""
    depths: tuple[int, ...] = option((2, 2, 2, 2), ge=1)
    """BasicBlocks per stage (ResNet-18: 2,2,2,2; ResNet-34: 3,4,6,3)."""
    head_width: int = option(128, ge=1)
    """Head channels (the conv after pyramid pooling)."""
    skip_width: int = option(0, ge=0)
    """Channels of the fine decoder (stride 4, then input size; 0: none). ``init`` from a
    file without one starts the decoder at zero, i.e. at that file's predictions."""
    lr: float = option(2e-3, gt=0)
    """Peak learning rate (AdamW, poly decay with power 0.9 after a short warm-up)."""
    weight_decay: float = option(1e-4, ge=0)
    """AdamW weight decay (Python API)."""
    ckpt_every: int = option(100, ge=1)
    """Steps between checkpoints."""
    eval_every: int = option(500, ge=1)
    """Steps between validation scores (on ``val_count`` held-out composites)."""
    val_count: int = option(32, ge=1)
    """Held-out composites scored during training (twice as many at the end)."""
    night_prob: float = option(0.0, ge=0, le=1)
    """Probability of a night-darkened training background (``CompositeConfig``)."""
    flare_prob: float = option(0.8, ge=0, le=1)
    """Probability that a training composite has flare; the rest are clean photos (with hard
    negatives at ``CompositeConfig.clean_negative_prob``) that teach 'nothing here'."""
    flare_canvas: float = option(1.0, ge=1, le=4)
    """Draw each composite's flare for a frame this many times its side and keep a window of
    it around the light (``CompositeConfig.flare_canvas``; 2: flare at the scale the mask
    stage meets it on a 512 px photo). Validation composites are drawn the same way."""
    without: tuple[str, ...] = option(
        (), choices=("starburst", "ghosts", "streaks", "glare", "scatter"))
    """Kinds of flare to leave out of training (comma-separated, of
    starburst,ghosts,streaks,glare,scatter): a leave-one-kind-out model; recorded in the
    weights' metadata."""
    negatives: tuple[str, ...] = option(
        ("lamp", "specular", "sky", "wall", "foliage", "neon", "reflection"),
        choices=("lamp", "specular", "sky", "clouds", "wall", "foliage", "backlit", "neon",
                 "reflection"))
    """Kinds of hard negatives (bright non-flare content, ``pipeline.fmg_data.HARD_NEGATIVES``)
    painted onto training composites (comma-separated); recorded in the weights' metadata.
    ``clouds`` (fair-weather cumulus on blue sky) and ``backlit`` (a dark tree crown at night
    in front of a lamp's glow) are drawn only when named here."""
    kind_probs: tuple[str, ...] = ()
    """KIND=P pairs (comma-separated, e.g. streaks=0.7,ghosts=0.7): draw these kinds of flare
    with probability P instead of their ``FlareConfig`` default; recorded in the weights'
    metadata."""
    dice: float = option(0.0, ge=0)
    """Weight of a soft-Dice term on the flare class added to the weighted BCE (0: BCE
    only). Dice scores each composite's flare as a whole, so thin flare counts as much as
    large flare."""
    init: Path | None = None
    """FMG weights to start from (same widths, depths and head width) when OUT has no
    checkpoint; the step count starts at 0 (the card adds the init's steps)."""
    seed: int = option(0, ge=0)
    """Seed of initialisation and composites (Python API)."""
    device: str = option("auto", device=True)
    """auto, cpu, cuda or cuda:N."""
    workers: int = option(0, ge=0)
    """Processes that draw the training composites ahead of the optimizer (0: drawn in this
    process, one random stream; N: step s's composites from a generator seeded by (seed, s),
    so the draw does not depend on N and a resumed run goes on with the same composites).
    Use most of a GPU machine's cores: drawing composites is what limits a GPU run."""


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
    ghost_lines: bool = False
    """With ``per_kind`` or ``clean``: add the ghost-line regions to every model's mask (as
    `mask --ghost-lines`)."""
    ghost_chain: int | None = option(None, ge=1)
    """With ``ghost_lines``: the rule's chain (as `mask --ghost-chain`)."""
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
    work_size: int = option(512, ge=32)
    """The network's working size (long side)."""
    rays: bool = False
    """Add the flare rays to each model's mask (as the mask stage does unless --no-rays)."""
    ray_min: int | None = option(None, ge=1)
    """With ``rays``: the ray rule's fewest rays per light (as `mask --ray-min`)."""
    ray_opposite: float | None = option(None, ge=0, le=90)
    """With ``rays``: the ray rule's opposite-streak tolerance (as `mask --ray-opposite`)."""
    ghost_lines: bool = False
    """Add the ghost-line regions to each model's mask (as `mask --ghost-lines`)."""
    ghost_chain: int | None = option(None, ge=1)
    """With ``ghost_lines``: the rule's chain (as `mask --ghost-chain`)."""


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
    if sum((cfg.per_kind, bool(cfg.work_sizes), cfg.clean, bool(cfg.negatives))) > 1:
        raise UserError("give one of --per-kind, --work-sizes, --clean, --negatives")
    return cfg


def check_ray_rule(cfg) -> None:
    """A one-line UserError when ``ray_min`` or ``ray_opposite`` is given without ``rays``
    (they would silently change nothing)."""
    if not cfg.rays and (cfg.ray_min is not None or cfg.ray_opposite is not None):
        raise UserError("--ray-min and --ray-opposite set the flare rays' rule: add --rays")


def _sources(data: Path, size: int, night_prob: float = 0.0, without: tuple[str, ...] = (),
             negatives: tuple[str, ...] | None = None,
             kind_probs: dict[str, float] | None = None, flare_prob: float = 0.8,
             flare_canvas: float = 1.0):
    from pipeline.fmg_data import (
        CompositeConfig,
        CompositeSource,
        load_backgrounds,
        split_backgrounds,
        training_flare,
    )

    parts = split_backgrounds(data)
    comp = CompositeConfig(size=size, night_prob=night_prob, flare_prob=flare_prob,
                           flare_canvas=flare_canvas)
    if negatives is not None:
        comp = replace(comp, negatives=tuple(negatives))
    tr = CompositeSource(load_backgrounds(parts.train, comp.preload_side),
                         training_flare(without, kind_probs), comp)
    va = _part_backgrounds(data, size, "dev")  # validation: the development part
    return tr, va, comp, (len(parts.train), len(parts.dev), len(parts.test))


def score(model, images, masks, batch: int = 8, refine: bool = False,
          cut: float = 0.5, also=None, confirm=None,
          scales: tuple[float, ...] = (1.0,), ghosts=None) -> dict[str, float]:
    """mIoU / mAcc of ``model`` on images [N, 3, S, S] with masks [N, 1, S, S] (pooled),
    flare where the probability exceeds ``cut`` or where ``also`` [N, 1, S, S] bool (e.g.
    the images' flare rays, ``ray_batch``) is set. With ``confirm`` = (second model, its
    cut, keep) the masks are those of `mask --confirm` (``pipeline.mask.confirmed_marks``,
    ``also`` as the rays). ``scales``: each network's probabilities averaged over these
    fractions of the composites' side (``gnfr.fmg.predict_probs``). ``ghosts`` (a
    ``pipeline.flare_ghosts.GhostConfig``): the ghost-line regions of the probabilities
    added, as `mask --ghost-lines` adds them (before the confirmation)."""
    import torch

    from gnfr.fmg import confusion, predict_probs, seg_metrics
    from pipeline.mask import confirmed_marks

    def confirmed(marked, second, extra):
        return torch.from_numpy(np.stack([[confirmed_marks(
            marked[i, 0].numpy(), second[i, 0].numpy(), confirm[2],
            None if extra is None else extra[i, 0].numpy())] for i in range(len(marked))]))

    conf = torch.zeros(2, 2, dtype=torch.long)
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
            conf += confusion(marked, masks[i:i + batch] > 0.5)
    return seg_metrics(conf)


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


# --------------------------------------------------------------------------- checkpoints
BEST_FILE = "best.safetensors"
"""The run's weights at its best validation flare IoU so far (``_fit``; fp32, like the
checkpoint, with the step and the score in its metadata)."""


def _save_weights(path: Path, model, meta: dict[str, str]) -> None:
    """``gnfr.fmg.save_fmg`` in fp32 (a run's own files keep full precision), atomically."""
    import torch

    from gnfr.fmg import save_fmg

    with atomic_path(path) as tmp:
        save_fmg(tmp, model, extra=meta, dtype=torch.float32)


def save_checkpoint(out: Path, model, opt, step: int, init_steps: int = 0) -> None:
    """Weights (with the step, and ``init_iters``: the steps of the run's ``--init`` file)
    and optimizer state, each written atomically."""
    import torch

    _save_weights(out / "checkpoint.safetensors", model,
                  {"step": str(step), "init_iters": str(init_steps)})
    with atomic_path(out / "optimizer.pt") as tmp:
        torch.save({"optimizer": opt.state_dict(), "step": step}, tmp)


def best_score(out: Path) -> float:
    """The validation flare IoU of ``out``'s best weights so far (-1 when there are none)."""
    from gnfr.fmg import read_fmg_metadata

    path = out / BEST_FILE
    return float(read_fmg_metadata(path).get("val_IoU_flare", -1)) if path.is_file() else -1.0


def export_checkpoint(out: Path, dest: Path, init_steps: int | None = None,
                      extra: dict[str, str] | None = None, best: bool = False) -> Path:
    """A run's latest checkpoint (``out/checkpoint.safetensors``, fp32), or with ``best``
    its weights of best validation (``out/best.safetensors``), as fp16 FMG weights at
    ``dest`` (as ``fmg.safetensors`` at the end of a run, with ``iters`` and
    ``total_iters`` = the file's step plus ``init_steps``, the steps of the run's ``--init``
    file; by default what the checkpoint recorded): a run cut short, e.g. on a lent GPU,
    still leaves weights that ``--init`` continues and ``fmg eval`` scores."""
    from gnfr.fmg import load_fmg, read_fmg_metadata, save_fmg

    ck = out / (BEST_FILE if best else "checkpoint.safetensors")
    if not ck.is_file():
        raise UserError(f"{out} has no {ck.name}: nothing to export")
    model = load_fmg(ck)  # the checkpoint carries the config in its metadata too
    meta = read_fmg_metadata(ck)
    step = int(meta.get("step", "0"))
    if init_steps is None:
        init_steps = int(meta.get("init_iters", "0"))
    kept = {k: meta[k] for k in ("val_IoU_flare", "val_mIoU") if k in meta}
    return save_fmg(dest, model, extra={"iters": str(step), "total_iters": str(step + init_steps),
                                        **kept, **(extra or {})})


def has_checkpoint(out: Path) -> bool:
    """Whether ``out`` holds a run to resume (its weights and optimizer state)."""
    return (out / "checkpoint.safetensors").is_file() and (out / "optimizer.pt").is_file()


def load_checkpoint(out: Path, model, opt) -> int:
    """Restore weights and optimizer from ``out``; returns the step (0 when none)."""
    import torch
    from safetensors.torch import load_file

    if not has_checkpoint(out):
        return 0
    ck, op = out / "checkpoint.safetensors", out / "optimizer.pt"
    try:
        model.load_state_dict(load_file(str(ck)))
        state = torch.load(op, map_location="cpu", weights_only=True)
        opt.load_state_dict(state["optimizer"])
    except (RuntimeError, KeyError, ValueError) as e:
        raise UserError(f"checkpoint in {out} does not match this configuration ({e!r:.120}):"
                        " use another --out or the same options as the first run") from None
    return int(state["step"])


def _load_init(model, path: Path) -> None:
    """Copy the weights of an FMG file into ``model``; a one-line UserError when its shape
    differs."""
    from pipeline.mask import load_fmg_weights

    src = load_fmg_weights(path)
    if src.cfg.widths != model.cfg.widths or src.cfg.depths != model.cfg.depths or \
            src.cfg.head_width != model.cfg.head_width:
        raise UserError(f"--init {path}: widths {src.cfg.widths}, depths {src.cfg.depths}, "
                        f"head width {src.cfg.head_width} differ from this run's; pass the "
                        "same --widths/--depths/--head-width")
    missing, unexpected = model.load_state_dict(src.state_dict(), strict=False)
    if unexpected or any(not k.startswith("decoder.") for k in missing):
        raise UserError(f"--init {path}: its weights do not fit this run's network "
                        f"(missing {missing[:3]}, unexpected {unexpected[:3]})")


def _lr(cfg: FMGTrainConfig, step: int) -> float:
    warm = min(1.0, (step + 1) / 50)
    return cfg.lr * warm * max(0.0, 1 - step / max(cfg.iters, 1)) ** 0.9


# --------------------------------------------------------------------------- train
_POOL_SOURCE = None
"""The training composites' source, sent once to each batch worker when it starts."""

_WORKER_WAIT_S = 600.0
"""How long the training loop waits for one step's composites before it gives up."""


def _pool_init(src) -> None:
    global _POOL_SOURCE
    import cv2

    cv2.setNumThreads(1)  # a fresh process (spawned): its thread pool is its own
    _POOL_SOURCE = src


def _pool_batch(job: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Step ``job[2]``'s composites as numpy arrays (the worker does no torch work)."""
    n, seed, step = job
    rng = np.random.default_rng([seed, step, 1])
    pairs = [_POOL_SOURCE.sample(rng) for _ in range(n)]
    return np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])


class TrainBatches:
    """One batch of training composites per step, from ``begin``'s step on. With ``workers`` > 0 a
    pool of worker processes draws ``2 x workers`` steps ahead; step s's batch comes from a
    generator seeded by (seed, s) whatever the number of workers.

    The workers are spawned, not forked: a child forked from a process whose OpenCV or torch
    thread pools have run can deadlock in them (it did, in CI, inside ``cv2.setNumThreads``),
    so each worker is a fresh interpreter that receives the source once, pickled."""

    def __init__(self, src, n: int, seed: int, workers: int = 0):
        self.src, self.n, self.seed, self.workers = src, n, seed, workers
        self.pool, self.ahead = None, []
        self.begin(0)
        if workers:
            import multiprocessing as mp

            self.pool = mp.get_context("spawn").Pool(workers, initializer=_pool_init,
                                                     initargs=(src,))

    def begin(self, start: int) -> None:
        """Draw from step ``start`` on (a resumed run's step)."""
        self.rng = np.random.default_rng([self.seed, start])
        self.queued = start

    def next(self):
        if self.pool is None:
            return self.src.batch(self.n, self.rng)
        while len(self.ahead) < 2 * self.workers:
            self.ahead.append(self.pool.apply_async(_pool_batch,
                                                    ((self.n, self.seed, self.queued),)))
            self.queued += 1
        from multiprocessing import TimeoutError as mp_TimeoutError

        import torch

        try:
            x, y = self.ahead.pop(0).get(timeout=_WORKER_WAIT_S)
        except mp_TimeoutError:
            self.close(wait=False)
            raise UserError(f"fmg train: no composites from the {self.workers} batch workers in "
                            f"{_WORKER_WAIT_S:.0f} s; rerun with --workers 0") from None
        return (torch.from_numpy(x).permute(0, 3, 1, 2).contiguous(),
                torch.from_numpy(y)[:, None].float())

    def close(self, wait: bool = True) -> None:
        """Stop the workers. With ``wait`` (the normal end) the batches drawn ahead are
        received first and the pool is closed, not terminated: ``Pool.terminate`` while a
        worker is sending a result can leave the pool's result thread reading half a message
        forever (a test hung so, on a loaded machine); workers that send nothing for
        ``_WORKER_WAIT_S`` are terminated all the same."""
        if self.pool is None:
            return
        pool, self.pool, ahead, self.ahead = self.pool, None, self.ahead, []
        if wait:
            for r in ahead:
                r.wait(_WORKER_WAIT_S)
            if all(r.ready() for r in ahead):
                pool.close()
                pool.join()
                return
        pool.terminate()
        pool.join()


def _fit(cfg: FMGTrainConfig, model, opt, batches: TrainBatches, step: int, val, dev,
         out: Path, init_steps: int = 0) -> None:
    """The optimizer loop from ``step`` to ``cfg.iters``: log, validation (keeping the
    weights of best validation flare IoU in ``best.safetensors``), checkpoints."""
    from gnfr.fmg import fmg_loss

    t0, log, best = time.time(), out / "log.jsonl", best_score(out)
    while step < cfg.iters:
        model.train()
        x, y = batches.next()
        for g in opt.param_groups:
            g["lr"] = _lr(cfg, step)
        loss = fmg_loss(model(x.to(dev)), y.to(dev), dice=cfg.dice)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        step += 1
        rec = {"step": step, "loss": round(float(loss.detach()), 5),
               "s": round(time.time() - t0, 1)}
        if step % cfg.eval_every == 0 or step == cfg.iters:
            rec.update({f"val_{k}": round(v, 4) for k, v in score(model, *val).items()})
            info(f"step {step}: loss {rec['loss']:.4f} val mIoU {rec['val_mIoU']:.3f} "
                 f"mAcc {rec['val_mAcc']:.3f}")
            if rec["val_IoU_flare"] > best:
                best = rec["val_IoU_flare"]
                _save_weights(out / BEST_FILE, model, {
                    "step": str(step), "init_iters": str(init_steps),
                    **{k: str(v) for k, v in rec.items() if k.startswith("val_")}})
        with open(log, "a") as f:
            f.write(json.dumps(rec) + "\n")
        if step % cfg.ckpt_every == 0 or step == cfg.iters:
            save_checkpoint(out, model, opt, step, init_steps)


def train(cfg: FMGTrainConfig) -> dict:
    """Train (or resume) an FMG; returns the final metrics."""
    import torch

    from gnfr.fmg import FMGConfig, build_fmg, save_fmg
    from pipeline.flare import check_kinds, parse_kind_probs
    from pipeline.fmg_data import fixed_set

    validate(cfg)
    kind_probs = parse_kind_probs(cfg.kind_probs)
    if cfg.without:  # each kind once, in the order given
        cfg = replace(cfg, without=check_kinds(cfg.without, "--without"))
    out = Path(cfg.out)
    dev = resolve_device(cfg.device)
    torch.manual_seed(cfg.seed)
    src, val_bgs, comp, counts = _sources(Path(cfg.data), cfg.size, cfg.night_prob,
                                          tuple(cfg.without), tuple(cfg.negatives),
                                          kind_probs, cfg.flare_prob, cfg.flare_canvas)
    info(f"fmg train: {counts[0]} training photos, {counts[1]} development (validation), "
         f"{counts[2]} test (never seen), device {dev}, "
         f"kinds {','.join(src.flare_cfg.kinds)}")
    model = build_fmg(FMGConfig(widths=tuple(cfg.widths), depths=tuple(cfg.depths),
                                head_width=cfg.head_width, skip_width=cfg.skip_width))
    if cfg.init and not has_checkpoint(out):  # a bad --init stops before workers or OUT
        _load_init(model, Path(cfg.init))
    batches = TrainBatches(src, cfg.batch, cfg.seed, cfg.workers)  # workers start before CUDA
    model = model.to(dev)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    step = load_checkpoint(out, model, opt)
    if step:
        info(f"fmg train: resuming at step {step}")
    elif cfg.init:
        info(f"fmg train: starting from {cfg.init}")
    out.mkdir(parents=True, exist_ok=True)
    from pipeline.fmg_data import CompositeSource

    val = fixed_set(CompositeSource(val_bgs, src.flare_cfg, comp), cfg.val_count, 12345)
    if cfg.init:
        init_steps = weights_info(Path(cfg.init))["steps"]
    else:  # a run resumed without its --init: the steps its checkpoint recorded
        from gnfr.fmg import read_fmg_metadata

        ck = out / "checkpoint.safetensors"
        init_steps = int(read_fmg_metadata(ck).get("init_iters", "0")) if step else 0
    batches.begin(step)
    try:
        _fit(cfg, model, opt, batches, step, val, dev, out, init_steps)
    finally:
        batches.close()
    meta = {"iters": str(cfg.iters), "train": json.dumps(asdict(cfg), default=str),
            "without": ",".join(cfg.without), "kinds": ",".join(src.flare_cfg.kinds),
            "kind_probs": json.dumps({k: src.flare_cfg.kind_prob(k)
                                      for k in src.flare_cfg.kinds})}
    if cfg.init:
        meta.update({"init": str(cfg.init), "init_iters": str(init_steps)})
    meta["total_iters"] = str(cfg.iters + init_steps)  # steps from scratch, init included
    with atomic_path(out / "fmg.safetensors") as tmp:
        save_fmg(tmp, model.cpu(), extra=meta)
    metrics = evaluate(out / "fmg.safetensors", Path(cfg.data), count=cfg.val_count * 2,
                       size=cfg.size, split="dev")
    atomic_write_json(out / "metrics.json", metrics)
    return metrics


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
        imgs, masks = fixed_set(CompositeSource(bgs, fcfg, c), count, seed, extras)
        frac = {"flare_pixels": round(float(masks.mean()), 4)}
        res[name] = {**score(model, imgs, masks, cut=cut), **frac}
        if refine:
            res[name + "_refined"] = {**score(model, imgs, masks, refine=True, cut=cut),
                                      **frac}
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
    from dataclasses import asdict

    from pipeline.flare_rays import RayConfig

    return asdict(ray_cfg or RayConfig()) if rays else None


def _ghost_rule(ghosts) -> dict | None:
    """The ghost-line rule a result used (GhostConfig's fields), None without it."""
    from dataclasses import asdict

    return asdict(ghosts) if ghosts is not None else None


def evaluate_kinds(weights: Path, data: Path, loo: tuple[Path, ...] = (), count: int = 48,
                   seed: int = 2025, size: int = 256,
                   kinds: tuple[str, ...] | None = None, split: str = "test",
                   rays: bool = False, ray_cfg=None, confirm: Path | None = None,
                   confirm_keep: str = "both", scales: tuple[float, ...] = (1.0,),
                   flare_canvas: float = 1.0, night: float | None = None,
                   ghosts=None) -> dict:
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
    regions (``score``)."""
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
           "weights": {k: v for k, v in main.items() if k != "model"},
           "confirm": None if confirm is None else {**weights_info(Path(confirm)),
                                                     "keep": confirm_keep},
           "loo": [{k: v for k, v in h.items() if k != "model"} for h in held], "kinds": {}}
    for i, kind in enumerate(kinds):
        src = CompositeSource(bgs, fl.FlareConfig(kinds=(kind,)), comp)
        imgs, masks = fixed_set(src, count, seed + i, extras=True)
        ray = ray_batch(imgs, ray_cfg) if rays else None  # the same for every model: once
        row = {"flare_pixels": round(float(masks.mean()), 4),
               "weights": score(main["model"], imgs, masks, cut=main["cut"], also=ray,
                                confirm=second, scales=scales, ghosts=ghosts)}
        for h in held:
            if kind in h["without"]:
                row["without"] = {**score(h["model"], imgs, masks, cut=h["cut"], also=ray,
                                          scales=scales, ghosts=ghosts),
                                  "weights": h["weights"], "steps": h["steps"]}
        res["kinds"][kind] = row
    return res


def format_kinds(res: dict) -> str:
    """The per-kind table: trained without the kind, and ``weights``."""
    w, c = res["weights"], res.get("confirm")
    also = f", confirmed by {Path(c['weights']).name}" if c else ""
    rows = [f"{res['count']} held-out composites per kind ({res['size']} px, night "
            f"{res['night']:g}); flare IoU / mIoU / mAcc",
            f"| kind | flare pixels | trained without it (steps) | {Path(w['weights']).name} "
            f"({w['steps']} steps{also}) |", "|---|---|---|---|"]

    def cell(m: dict) -> str:
        return f"{m['IoU_flare']:.3f} / {m['mIoU']:.3f} / {m['mAcc']:.3f}"

    for kind, r in res["kinds"].items():
        loo = f"{cell(r['without'])} ({r['without']['steps']})" if "without" in r else "-"
        rows.append(f"| {kind} | {r['flare_pixels']:.3f} | {loo} | {cell(r['weights'])} |")
    return "\n".join(rows)


def format_metrics(m: dict) -> str:
    rows = ["| flare settings | mIoU | mAcc | IoU flare | flare pixels |", "|---|---|---|---|---|"]
    for k, v in m.items():
        if isinstance(v, dict):
            rows.append(f"| {k} | {v['mIoU']:.3f} | {v['mAcc']:.3f} | {v['IoU_flare']:.3f} | "
                        f"{v.get('flare_pixels', math.nan):.3f} |")
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
                    ghosts=None) -> dict:
    """Fraction of pixels marked (at the weights' cut, network at ``work_size``, flare rays
    added with ``rays`` by rule ``ray_cfg``, with ``confirm`` (weights) the second network of
    `mask --confirm`: as in the mask stage, the networks at ``scales`` of ``work_size`` as
    `mask --scales`, the ghost-line regions added with ``ghosts`` as `mask --ghost-lines`)
    on every clean photo of ``scenes`` at full size: mean and max per scene."""
    from pipeline.mask import flare_marks, load_fmg_weights

    cut = weights_info(Path(weights))["cut"]
    model = load_fmg_weights(Path(weights))
    second = (None if confirm is None else (load_fmg_weights(Path(confirm)),
                                            weights_info(Path(confirm))["cut"], confirm_keep))
    res = {"weights": str(weights), "cut": cut, "work_size": work_size, "split": split,
           "rays": rays, "ray_rule": _ray_rule(rays, ray_cfg), "scales": list(scales),
           "ghost_lines": _ghost_rule(ghosts),
           "confirm": None if confirm is None else {**weights_info(Path(confirm)),
                                                     "keep": confirm_keep}, "scenes": {}}
    for scene in scenes or CLEAN_SCENES[split]:
        marked = {name: float(flare_marks(model, im, cut, work_size, rays, ray_cfg=ray_cfg,
                                          confirm=second, scales=scales,
                                          ghosts=ghosts).mean())
                  for name, im in _photos(Path(data) / scene)}
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


def real_flare_overview(weights: tuple[Path, ...], photos: tuple[Path, ...], out: Path,
                        work_size: int = 512, width: int = 480, rays: bool = False,
                        ray_cfg=None, ghosts=None) -> dict:
    """One JPEG: a row per photo, the photo then each model's mask (at its cut; with the flare
    rays of rule ``ray_cfg`` if ``rays``, the ghost-line regions of rule ``ghosts`` if given)
    outlined and tinted red; returns the fraction of each photo each model marks."""
    import cv2

    from pipeline.mask import flare_marks, load_fmg_weights, ray_marks

    models = [(weights_info(Path(w))["cut"], load_fmg_weights(Path(w))) for w in weights]
    rows, fracs = [], {}
    for photo in photos:
        img = read_image(photo, bgr=True)
        scale = width / img.shape[1]
        tiles = [cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)]
        ray = ray_marks(img, work_size, ray_cfg) if rays else False  # the same for every model
        for (cut, model), w in zip(models, weights, strict=True):
            marked = flare_marks(model, img, cut, work_size, ghosts=ghosts) | ray
            fracs[f"{photo.name} {w}"] = float(marked.mean())
            small = cv2.resize(marked.astype(np.uint8), (tiles[0].shape[1], tiles[0].shape[0]),
                               interpolation=cv2.INTER_NEAREST)
            tile = tiles[0].copy()
            tile[small > 0] = (0.55 * tile[small > 0]
                               + 0.45 * np.array([0, 0, 255])).astype(np.uint8)
            contours, _ = cv2.findContours(small, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
            cv2.drawContours(tile, contours, -1, (0, 255, 255), 1)
            cv2.putText(tile,
                        f"{weights_label(Path(w))}{' + rays' if rays else ''}"
                        f"{' + ghost lines' if ghosts is not None else ''}: "
                        f"{100 * marked.mean():.1f} %",
                        (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2)
            tiles.append(tile)
        rows.append(np.hstack(tiles))
    atomic_imwrite(out, np.vstack(rows), [cv2.IMWRITE_JPEG_QUALITY, 80])
    return fracs


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
