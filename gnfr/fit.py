"""The one GN-FR training loop: steps, metrics.jsonl lines, periodic checkpoints, resume.

A run folder holds ``gnfr.safetensors`` (weights; ``meta`` from the caller in the
metadata), ``train_state.pt`` (``{"step", "optimizer", "rng", **extra}``: the optimizer's
state_dict, the sampling generator's and torch's RNG states, the step count, and what the
caller adds, e.g. fine-tuning's ``unseen`` and ``seconds``) and ``metrics.jsonl`` (one JSON
line every ``cfg.log_every`` steps and at the last step). ``Trainer.run`` trains to
``cfg.iters`` from ``Trainer.step``, checkpointing every ``cfg.ckpt_every`` steps and at the
last one; ``Trainer.restore`` resumes from a folder's checkpoint. The learning-rate schedule
is applied per step by ``gnfr.train.train_step`` (``set_learning_rates``).

What differs between callers comes in as callables: ``draw(generator) -> StepInput`` (the
batch and the source bank it reads: one scene for fine-tuning, a random scene for
pretraining), the checkpoint metadata and extra state, what a metrics line holds, a
per-step hook, a gradient hook (a DDP all-reduce), a progress report and the processes
that share each step's rays (``gnfr.ray_split``). Nothing here knows
workspaces or the CLI.
"""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import torch

from gnfr.checkpoint import load_train_state, load_weights, save_model, save_train_state
from gnfr.model import GNFR
from gnfr.renderer import SourceViews
from gnfr.train import Batch, SourceBank, TrainConfig, make_optimizer, train_step

MODEL_FILE = "gnfr.safetensors"
"""Weights of a run folder (``gnfr.checkpoint.load_model`` rebuilds the model from it)."""
STATE_FILE = "train_state.pt"
"""Training state of a run folder (``load_train_state``)."""
METRICS_FILE = "metrics.jsonl"
"""Metric lines of a run folder."""


def checkpoint_files(out: str | Path) -> tuple[Path, Path]:
    """(weights, training state) of the run folder ``out``."""
    out = Path(out)
    return out / MODEL_FILE, out / STATE_FILE


def has_checkpoint(out: str | Path) -> bool:
    """Whether ``out`` holds both files a run resumes from."""
    return all(p.exists() for p in checkpoint_files(out))


def rng_state(gen: torch.Generator) -> dict:
    """The sampling generator's and torch's (CPU, and CUDA when present) RNG states."""
    st = {"gen": gen.get_state(), "torch": torch.get_rng_state()}
    if torch.cuda.is_available():
        st["cuda"] = torch.cuda.get_rng_state_all()
    return st


def set_rng_state(gen: torch.Generator, st: dict) -> None:
    """Restore what ``rng_state`` saved."""
    gen.set_state(st["gen"])
    torch.set_rng_state(st["torch"])
    if "cuda" in st and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(st["cuda"])


def render_meta(cfg: TrainConfig, preset: str, step: int) -> dict:
    """Checkpoint metadata render needs besides the architecture (stored by save_model),
    with the step count and preset name."""
    meta = {"step": step, "preset": preset, "samples": cfg.samples,
            "eval_views": cfg.eval_views, "point_sampler": cfg.point_sampler,
            "view_sampler": cfg.view_sampler, "mask_loss": cfg.mask_loss,
            "source_scale": cfg.source_scale, "full_res_colour": cfg.full_res_colour}
    if cfg.encode_apart:  # absent: padded views encoded together, as earlier models were
        meta["encode_apart"] = True
    if cfg.flare_fallback != "valid":  # absent: the validity fallback of earlier models
        meta["flare_fallback"] = cfg.flare_fallback
    if cfg.lr_restart > 0:  # how the rates went (provenance; render does not read it)
        meta.update(lr_restart=cfg.lr_restart, lr_restart_step=cfg.lr_restart_step)
    return meta


def trim_metrics(path: str | Path, step: int) -> None:
    """Drop metric lines past the checkpoint a run resumes from (all on a fresh start)."""
    path = Path(path)
    if not path.exists():
        return
    keep = [ln for ln in path.read_text().splitlines()
            if ln.strip() and json.loads(ln)["step"] <= step]
    path.write_text("".join(ln + "\n" for ln in keep))


@dataclass
class StepInput:
    """What one training step reads (what a ``draw`` callable returns)."""

    batch: Batch
    bank: SourceBank
    """All views of the batch's scene at source scale."""
    cache: SourceViews | None = None
    """``bank`` encoded once, in cached-feature mode."""
    fields: dict = field(default_factory=dict)
    """Extra fields of this step for its metrics line (e.g. ``{"scene": name}``)."""


Draw = Callable[[torch.Generator], StepInput]
Record = Callable[[int, list[dict], float], dict]


def mean_record(step: int, window: list[dict], it_s: float) -> dict:
    """A metrics line averaging loss, PSNR and all_flared over the steps since the last
    line (fine-tuning's)."""
    n = len(window)
    return {"step": step, "loss": sum(x["loss"] for x in window) / n,
            "psnr": sum(x["psnr"] for x in window) / n,
            "all_flared": sum(x["all_flared"] for x in window) / n,
            "lr_factor": window[-1]["lr_factor"], "it_s": it_s}


def last_record(step: int, window: list[dict], it_s: float) -> dict:
    """A metrics line of the last step alone, with its extra fields (pretraining's)."""
    return {"step": step, **window[-1], "it_s": it_s}


@dataclass
class Trainer:
    """One training run's state: model, optimizer, sampling generator, steps done and
    training seconds before this process. ``opt`` defaults to ``make_optimizer`` and
    ``gen`` to a generator seeded with ``cfg.seed``."""

    model: GNFR
    cfg: TrainConfig
    opt: torch.optim.Optimizer | None = None
    gen: torch.Generator | None = None
    step: int = 0
    seconds: float = 0.0

    def __post_init__(self) -> None:
        if self.opt is None:
            self.opt = make_optimizer(self.model, self.cfg)
        if self.gen is None:
            self.gen = torch.Generator().manual_seed(self.cfg.seed)

    def train_one(self, inp: StepInput, grad_hook: Callable | None = None,
                  split=None) -> dict:
        """One optimizer step at ``self.step`` (``gnfr.train.train_step``, ``split`` a
        started ``gnfr.ray_split.RaySplit`` or None); counts it. Returns loss, psnr,
        all_flared and lr_factor."""
        r = train_step(self.model, self.opt, inp.batch, inp.bank, inp.cache, self.cfg,
                       self.step, grad_hook, split)
        self.step += 1
        return r

    def save(self, out: str | Path, meta: dict, extra: dict | None = None) -> None:
        """Checkpoint into ``out``: the weights with ``meta`` in their metadata, then the
        training state (step, optimizer, RNG, and ``extra``)."""
        weights, state = checkpoint_files(out)
        save_model(weights, self.model, meta)
        save_train_state(state, {"step": self.step, "optimizer": self.opt.state_dict(),
                                 "rng": rng_state(self.gen), **(extra or {})})

    def restore(self, out: str | Path, rng: bool = True) -> dict:
        """Resume from the checkpoint in ``out`` (see ``has_checkpoint``): weights,
        optimizer state, step count, training seconds (when saved) and, with ``rng``, the
        RNG states. Returns the whole training state (for the caller's extra keys)."""
        weights, state = checkpoint_files(out)
        load_weights(self.model, weights)
        st = load_train_state(state)
        self.opt.load_state_dict(st["optimizer"])
        if rng:
            set_rng_state(self.gen, st["rng"])
        self.step = int(st["step"])
        self.seconds = float(st.get("seconds", 0.0))
        return st

    def run(self, draw: Draw, *, out: str | Path | None,
            meta: Callable[[int, float], dict],
            state: Callable[[int, float], dict] | None = None,
            record: Record = mean_record,
            after_step: Callable[[StepInput, dict], None] | None = None,
            grad_hook: Callable | None = None, writer: bool = True,
            report: Callable[[int, float, dict | None], None] | None = None,
            split=None) -> dict:
        """Train from ``self.step`` to ``cfg.iters``.

        Each step trains on ``draw(self.gen)``, then calls ``after_step(input, result)``.
        When ``writer`` (False on DDP ranks other than 0) and ``out`` is given, metric lines
        past ``self.step`` are dropped first; every ``log_every`` steps and at the last a
        line ``record(step, window, it_s)`` is appended (``window``: each step's result
        since the last line with its input's ``fields``); every ``ckpt_every`` steps and at
        the last (and ``cfg.ckpt_seconds`` after the last save) the weights are saved with
        ``meta(step, seconds)`` and the state with
        ``state(step, seconds)``'s extra keys. ``report(step, it_s, line or None)`` follows
        every step (progress display). ``split``: a started ``gnfr.ray_split.RaySplit``
        whose processes take a share of each step's rays. Returns steps, it_per_s and
        train_seconds (seconds of all runs so far)."""
        cfg = self.cfg
        write = writer and out is not None
        if write:
            out = Path(out)
            out.mkdir(parents=True, exist_ok=True)
            trim_metrics(out / METRICS_FILE, self.step)
        seconds0, t0, done0, window = self.seconds, time.time(), self.step, []
        saved = t0  # when the last checkpoint was written (``cfg.ckpt_seconds``)
        with contextlib.ExitStack() as files:
            metrics = files.enter_context(open(out / METRICS_FILE, "a")) if write else None
            while self.step < cfg.iters:
                inp = draw(self.gen)
                r = self.train_one(inp, grad_hook, split)
                if after_step is not None:
                    after_step(inp, r)
                step = self.step
                window.append({**inp.fields, **r})
                speed = (step - done0) / max(time.time() - t0, 1e-9)
                line = None
                if step % cfg.log_every == 0 or step == cfg.iters:
                    if write:
                        line = record(step, window, speed)
                        metrics.write(json.dumps(line) + "\n")
                        metrics.flush()
                    window = []
                due = cfg.ckpt_seconds > 0 and time.time() - saved >= cfg.ckpt_seconds
                if write and (step % cfg.ckpt_every == 0 or step == cfg.iters or due):
                    self.seconds = seconds0 + time.time() - t0
                    self.save(out, meta(step, self.seconds),
                              None if state is None else state(step, self.seconds))
                    saved = time.time()
                if report is not None:
                    report(step, speed, line)
        elapsed = time.time() - t0
        self.seconds = seconds0 + elapsed
        return {"steps": self.step,
                "it_per_s": round((self.step - done0) / max(elapsed, 1e-9), 3),
                "train_seconds": round(self.seconds, 1)}
