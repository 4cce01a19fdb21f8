"""Training of the FMG (flare mask PSPNet) on synthetic composites, resumable.

``train(cfg)`` owns the loop: AdamW with poly learning-rate decay, the 5:1 weighted BCE,
a checkpoint every ``ckpt_every`` steps in ``out`` (``checkpoint.safetensors`` with fp32
weights + ``optimizer.pt`` with optimizer state and step, read back with
``torch.load(weights_only=True)``), so a rerun with the same ``out`` resumes. It ends by
writing ``out/fmg.safetensors`` (fp16, config in the metadata) and ``out/metrics.json``
(scored by workflows/research/fmg_eval.py). The options of `deflare-scene fmg train` are
FMGTrainConfig.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pipeline.errors import UserError
from pipeline.options import option, resolve_device, validate
from pipeline.progress import info
from pipeline.workspace import atomic_path, atomic_write_json
from workflows.research.fmg_eval import (
    _part_backgrounds,
    default_data,
    evaluate,
    score,
    weights_info,
)
from workflows.research.run_settings import record_settings, refuse_other_settings

if TYPE_CHECKING:
    from pipeline.flare import FlareConfig


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
    night_glare: float = option(1.0, ge=0)
    """The ``glare`` kind's probability on a night-darkened background, as a multiple of its
    probability by day (``CompositeConfig.night_glare``; 1: the same, 0: none at night).
    Recorded in the run's settings only when not 1 (runs started before it resume)."""
    flare_prob: float = option(0.8, ge=0, le=1)
    """Probability that a training composite has flare; the rest are clean photos (with hard
    negatives at ``CompositeConfig.clean_negative_prob``) that teach 'nothing here'."""
    flare_canvas: float = option(1.0, ge=1, le=4)
    """Draw each composite's flare for a frame this many times its side and keep a window of
    it around the light (``CompositeConfig.flare_canvas``; 2: flare at the scale the mask
    stage meets it on a 512 px photo). Validation composites are drawn the same way."""
    frame_prob: float = option(0.0, ge=0, le=1)
    """Probability that a training composite is a window of its photo at the photo's own
    scale with the flare drawn for the whole photo, as the mask stage meets flare
    (``CompositeConfig.frame_prob``; no random affine). Validation composites stay as they
    are, so runs with and without it score on the same set."""
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


def _sources(data: Path, size: int, night_prob: float = 0.0, without: tuple[str, ...] = (),
             negatives: tuple[str, ...] | None = None,
             kind_probs: dict[str, float] | None = None, flare_prob: float = 0.8,
             flare_canvas: float = 1.0, frame_prob: float = 0.0, night_glare: float = 1.0):
    from pipeline.fmg_data import (
        CompositeConfig,
        CompositeSource,
        load_backgrounds,
        split_backgrounds,
        training_flare,
    )

    parts = split_backgrounds(data)
    comp = CompositeConfig(size=size, night_prob=night_prob, flare_prob=flare_prob,
                           flare_canvas=flare_canvas, frame_prob=frame_prob,
                           night_glare=night_glare)
    if negatives is not None:
        comp = replace(comp, negatives=tuple(negatives))
    tr = CompositeSource(load_backgrounds(parts.train, comp.preload_side),
                         training_flare(without, kind_probs), comp)
    va = _part_backgrounds(data, size, "dev")  # validation: the development part
    return tr, va, comp, (len(parts.train), len(parts.dev), len(parts.test))


# --------------------------------------------------------------------------- checkpoints
BEST_FILE = "best.safetensors"
"""The run's weights at its best validation flare IoU so far (``_fit``; fp32, like the
checkpoint, with the step and the score in its metadata)."""


FREE_ON_RESUME = frozenset({"out", "data", "iters", "ckpt_every", "eval_every", "val_count",
                            "device", "workers", "init"})
"""Options a resumed run may change (``workflows.research.run_settings``): more steps,
checkpoint and validation spacing, the data's path (another machine), the device and
workers; ``init`` is read only at a fresh start. Any other change is refused."""


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


def _init_steps(cfg: FMGTrainConfig, out: Path, step: int) -> int:
    """The steps the weights a run starts from had: on resuming, those its checkpoint
    recorded for the --init it started from; on a fresh start (or a checkpoint written
    before it recorded them), --init's own (0 without one)."""
    recorded = None
    if step:
        from gnfr.fmg import read_fmg_metadata

        recorded = read_fmg_metadata(out / "checkpoint.safetensors").get("init_iters")
    if recorded is not None:
        return int(recorded)
    return weights_info(Path(cfg.init))["steps"] if cfg.init else 0


def _final_meta(cfg: FMGTrainConfig, flare_cfg: FlareConfig, init_steps: int) -> dict[str, str]:
    """The metadata of a finished run's OUT/fmg.safetensors."""
    meta = {"iters": str(cfg.iters), "train": json.dumps(asdict(cfg), default=str),
            "without": ",".join(cfg.without), "kinds": ",".join(flare_cfg.kinds),
            "kind_probs": json.dumps({k: flare_cfg.kind_prob(k) for k in flare_cfg.kinds}),
            "night_glare": str(cfg.night_glare)}
    if cfg.init:
        meta.update({"init": str(cfg.init), "init_iters": str(init_steps)})
    meta["total_iters"] = str(cfg.iters + init_steps)  # steps from scratch, init included
    return meta


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
    settings = {k: v for k, v in asdict(cfg).items() if k not in FREE_ON_RESUME}
    if cfg.night_glare == 1.0:  # as before the option existed: earlier runs still resume
        settings.pop("night_glare")
    if has_checkpoint(out):  # a run of other settings is never resumed from
        refuse_other_settings(out, settings, "fmg train")
    dev = resolve_device(cfg.device)
    torch.manual_seed(cfg.seed)
    src, val_bgs, comp, counts = _sources(Path(cfg.data), cfg.size, cfg.night_prob,
                                          tuple(cfg.without), tuple(cfg.negatives),
                                          kind_probs, cfg.flare_prob, cfg.flare_canvas,
                                          cfg.frame_prob, cfg.night_glare)
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
    record_settings(out, settings)
    from pipeline.fmg_data import CompositeSource

    val = fixed_set(CompositeSource(val_bgs, src.flare_cfg, comp), cfg.val_count, 12345)
    init_steps = _init_steps(cfg, out, step)
    batches.begin(step)
    try:
        _fit(cfg, model, opt, batches, step, val, dev, out, init_steps)
    finally:
        batches.close()
    with atomic_path(out / "fmg.safetensors") as tmp:
        save_fmg(tmp, model.cpu(), extra=_final_meta(cfg, src.flare_cfg, init_steps))
    metrics = evaluate(out / "fmg.safetensors", Path(cfg.data), count=cfg.val_count * 2,
                       size=cfg.size, split="dev")
    atomic_write_json(out / "metrics.json", metrics)
    return metrics
