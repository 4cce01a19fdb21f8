"""Stage `finetune`: fit GN-FR to one workspace -> ``WS/model/``.

Writes ``WS/model/gnfr.safetensors`` (weights; architecture and render settings in the
metadata, so ``gnfr.checkpoint.load_model`` rebuilds the model from the file alone),
``train_state.pt`` (optimizer + RNG state + step: an interrupted run resumes exactly where
it stopped), ``metrics.jsonl`` and ``unseen.json`` (per target view, the fraction of sample
points that were on flare in every source view: regions no clean view saw).

Presets: ``paper`` (GNT-sized, 50k steps, end-to-end; default with CUDA) and ``quick`` (a
CPU-sized model; default without CUDA). See ``gnfr.train`` for what each sets.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import torch

from gnfr.checkpoint import (
    CheckpointError,
    load_train_state,
    load_weights,
    read_metadata,
    save_model,
    save_train_state,
)
from gnfr.model import GNFR
from gnfr.renderer import SourceViews
from gnfr.train import (
    PRESETS,
    Scene,
    TrainConfig,
    downscale,
    make_optimizer,
    sample_batch,
    train_step,
)
from pipeline.progress import info, make_progress, warn
from pipeline.workspace import Workspace, atomic_write_json

WEIGHTS_DIR = Path(__file__).resolve().parents[1] / "gnfr" / "weights"
MODEL_FILE, STATE_FILE = "gnfr.safetensors", "train_state.pt"


@dataclass
class FinetuneConfig:
    """Options of `deflare-scene finetune`."""

    preset: str = "auto"
    """paper | quick | auto (paper with CUDA, quick otherwise)."""
    iters: int | None = None
    """Override the preset's number of steps."""
    rays: int | None = None
    """Override rays per step."""
    samples: int | None = None
    """Override samples per ray."""
    views: int | None = None
    """Override the number of source views (training and rendering)."""
    cached_features: bool | None = None
    """Frozen encoder, every source encoded once (default: off, the encoder is fine-tuned)."""
    device: str = "auto"
    """auto | cpu | cuda | mps."""
    point_sampler: bool = True
    """GN-FR Point Sampler (False: ablation)."""
    view_sampler: bool = True
    """GN-FR View Sampler (False: ablation)."""
    mask_loss: bool = True
    """GN-FR masking loss (False: ablation)."""
    reference: bool = False
    """Plain fp32 path (no bf16 autocast, no fused attention)."""
    init: str = "auto"
    """auto (shipped weights marked for automatic use that match, else scratch) | scratch |
    a .safetensors path (e.g. gnfr/weights/gnfr.safetensors, pretrained for quick)."""
    seed: int = 0
    """Seed of initialisation and sampling."""


def pick_device(name: str) -> torch.device:
    if name == "auto":
        if torch.cuda.is_available():
            return torch.device("cuda")
        return torch.device("cpu")
    if name == "cuda" and not torch.cuda.is_available():
        from pipeline.errors import UserError
        raise UserError("--device cuda: no CUDA device is visible; use --device cpu")
    return torch.device(name)


def shipped_weights(cfg: TrainConfig) -> Path | None:
    """The first shipped weight file whose architecture matches ``cfg.model`` and whose
    metadata marks it for automatic use (``auto_init``; gnfr/weights/gnfr.md says when the
    shipped file earned it)."""
    for p in sorted(WEIGHTS_DIR.glob("gnfr*.safetensors")):
        try:
            cfg_p, meta = read_metadata(p)
        except CheckpointError:
            continue
        if cfg_p == cfg.model and meta.get("auto_init") is True:
            return p
    return None


def resolve(config: FinetuneConfig, device: torch.device) -> tuple[str, TrainConfig]:
    """The preset name and the TrainConfig after overrides."""
    name = config.preset
    if name == "auto":
        name = "paper" if device.type == "cuda" else "quick"
    cfg = PRESETS[name]
    over = {k: v for k, v in (("iters", config.iters), ("rays", config.rays),
                              ("samples", config.samples)) if v is not None}
    if config.views is not None:
        over.update(n_views=(config.views, config.views), eval_views=config.views)
    cfg = replace(cfg, **over, point_sampler=config.point_sampler,
                  view_sampler=config.view_sampler, mask_loss=config.mask_loss,
                  reference=config.reference, seed=config.seed)
    # end-to-end unless asked: the shipped weights were measured fine-tuned end-to-end
    # (gnfr/weights/gnfr.md); a frozen, cached encoder is a quarter faster per step
    cached = bool(config.cached_features)
    return name, replace(cfg, cached_features=cached)


def run(config: FinetuneConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Fine-tune on ``ws``; returns the written paths."""
    ws.require("pose")
    device = pick_device(config.device)
    name, cfg = resolve(config, device)
    inputs = [ws.images, ws.cameras_json, ws.masks, ws.views_json]
    params = {"preset": name, "init": config.init, "train": asdict(cfg)}
    run_ = ws.begin_stage("finetune", params, inputs, force)
    if run_.skip:
        info(f"finetune: up to date ({ws.model})")
        return run_.outputs
    info(f"finetune: preset '{name}' on {device.type} ({cfg.iters} steps, {cfg.rays} rays, "
         f"{cfg.samples} samples, depth {cfg.model.depth} width {cfg.model.width}, "
         f"{'cached features' if cfg.cached_features else 'end-to-end'})")
    from pipeline.scene_data import load_workspace

    scene = load_workspace(ws.root)
    stats = fit(scene, cfg, device, ws.model, resume=ws.resumable(run_), init=config.init,
                preset=name)
    outs = [ws.model / MODEL_FILE, ws.model / STATE_FILE, ws.model / "metrics.jsonl",
            ws.model / "unseen.json"]
    return run_.finish(outs, extra=stats, versions=["torch", "safetensors"])


# --------------------------------------------------------------------------- training loop
def rng_state(gen: torch.Generator) -> dict:
    st = {"gen": gen.get_state(), "torch": torch.get_rng_state()}
    if torch.cuda.is_available():
        st["cuda"] = torch.cuda.get_rng_state_all()
    return st


def set_rng_state(gen: torch.Generator, st: dict) -> None:
    gen.set_state(st["gen"])
    torch.set_rng_state(st["torch"])
    if "cuda" in st and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(st["cuda"])


def init_model(cfg: TrainConfig, device: torch.device, init: str) -> tuple[GNFR, str]:
    """A fresh model (seeded), loaded from ``init``; returns it and a line saying which."""
    torch.manual_seed(cfg.seed)
    model = GNFR(cfg.model)
    path = shipped_weights(cfg) if init == "auto" else (None if init == "scratch"
                                                        else Path(init))
    if path is None:
        how = "from scratch (no shipped weights match this architecture)" \
            if init == "auto" else "from scratch"
    else:
        try:
            load_weights(model, path)
        except CheckpointError as e:
            from pipeline.errors import UserError
            raise UserError(f"--init {path}: {e}") from None
        how = f"from pretrained weights {path}"
    return model.to(device), how


def render_meta(cfg: TrainConfig, preset: str, step: int) -> dict:
    """Settings render needs besides the architecture (stored in the safetensors)."""
    return {"step": step, "preset": preset, "samples": cfg.samples,
            "eval_views": cfg.eval_views, "point_sampler": cfg.point_sampler,
            "view_sampler": cfg.view_sampler, "mask_loss": cfg.mask_loss,
            "source_scale": cfg.source_scale}


def save_all(out: Path, model, opt, gen, step: int, cfg: TrainConfig, preset: str,
             unseen: torch.Tensor) -> None:
    save_model(out / MODEL_FILE, model, render_meta(cfg, preset, step))
    save_train_state(out / STATE_FILE, {"step": step, "optimizer": opt.state_dict(),
                                        "rng": rng_state(gen), "unseen": unseen})


def prepare_sources(model: GNFR, scene: Scene, cfg: TrainConfig, device: torch.device):
    """(bank, cache): all views at source scale on ``device``, and in cached-feature mode
    their features encoded once with the frozen encoder."""
    imgs, K, masks = downscale(scene, cfg.source_scale)
    c2w = scene.c2w.float()
    bank = (imgs.to(device), K.to(device), None if masks is None else masks.to(device),
            c2w.to(device))
    cache = None
    if cfg.cached_features:
        model.encoder.requires_grad_(False)
        cache = SourceViews.encode(model, *bank[:2], bank[3], bank[2], device)
    return bank, cache


def fit(scene: Scene, cfg: TrainConfig, device: torch.device, out: Path, resume: bool = True,
        init: str = "auto", preset: str = "custom") -> dict:
    """Train on ``scene``, checkpointing into ``out``; resumes from ``out`` when allowed."""
    out.mkdir(parents=True, exist_ok=True)
    gen = torch.Generator().manual_seed(cfg.seed)
    model, how = init_model(cfg, device, init)
    opt = make_optimizer(model, cfg)
    step, unseen = 0, torch.zeros(len(scene.stems), 2, dtype=torch.float64)
    state_path = out / STATE_FILE
    if resume and state_path.exists() and (out / MODEL_FILE).exists():
        load_weights(model, out / MODEL_FILE)
        st = load_train_state(state_path)
        opt.load_state_dict(st["optimizer"])
        set_rng_state(gen, st["rng"])
        step, unseen = int(st["step"]), st["unseen"]
        info(f"finetune: resuming at step {step} of {cfg.iters}")
    else:
        info(f"finetune: starting {how}")
    trim_metrics(out / "metrics.jsonl", step)
    bank, cache = prepare_sources(model, scene, cfg, device)
    stats = _loop(model, opt, gen, scene, cfg, bank, cache, step, unseen, out, preset)
    _write_unseen(out / "unseen.json", scene, unseen)
    return stats


def _loop(model, opt, gen, scene, cfg, bank, cache, step, unseen, out, preset) -> dict:
    from rich.progress import TextColumn

    window, t0, done0 = [], time.time(), step
    cols = TextColumn("{task.fields[speed]} it/s  PSNR {task.fields[psnr]}")
    with open(out / "metrics.jsonl", "a") as metrics, make_progress(cols) as prog:
        task = prog.add_task("finetune", total=cfg.iters, completed=step, speed="-",
                             psnr="-")
        while step < cfg.iters:
            batch = sample_batch(scene, cfg, gen)
            r = train_step(model, opt, batch, bank, cache, cfg, step)
            unseen[batch.target] += torch.tensor([r["all_flared"], 1.0], dtype=torch.float64)
            step += 1
            window.append(r)
            speed = (step - done0) / max(time.time() - t0, 1e-9)
            if step % cfg.log_every == 0 or step == cfg.iters:
                psnr = sum(x["psnr"] for x in window) / len(window)
                rec = {"step": step, "loss": sum(x["loss"] for x in window) / len(window),
                       "psnr": psnr, "all_flared": sum(x["all_flared"] for x in window)
                       / len(window), "lr_factor": r["lr_factor"], "it_s": speed}
                metrics.write(json.dumps(rec) + "\n")
                metrics.flush()
                window = []
                prog.update(task, psnr=f"{psnr:.2f}")
            if step % cfg.ckpt_every == 0 or step == cfg.iters:
                save_all(out, model, opt, gen, step, cfg, preset, unseen)
            prog.update(task, completed=step, speed=f"{speed:.2f}")
    return {"steps": step, "it_per_s": round((step - done0) / max(time.time() - t0, 1e-9), 3)}


def trim_metrics(path: Path, step: int) -> None:
    """Drop metric lines past the checkpoint a run resumes from (all on a fresh start)."""
    if not path.exists():
        return
    keep = [ln for ln in path.read_text().splitlines()
            if ln.strip() and json.loads(ln)["step"] <= step]
    path.write_text("".join(ln + "\n" for ln in keep))


def _write_unseen(path: Path, scene: Scene, unseen: torch.Tensor) -> None:
    views = {s: {"all_flared_fraction": float(unseen[i, 0] / unseen[i, 1]),
                 "steps_as_target": int(unseen[i, 1])}
             for i, s in enumerate(scene.stems) if unseen[i, 1] > 0}
    if not views:
        warn("finetune: no training step ran, unseen.json is empty")
    atomic_write_json(path, {"description": "per target view: mean fraction of sample points "
                             "that were on flare in every source view (fell back to "
                             "validity-only attention)", "views": views})
