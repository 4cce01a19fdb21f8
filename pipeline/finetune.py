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
from pipeline.options import option, resolve_device, validate
from pipeline.progress import info, make_progress, warn
from pipeline.workspace import Workspace, atomic_write_json

WEIGHTS_DIR = Path(__file__).resolve().parents[1] / "gnfr" / "weights"
MODEL_FILE, STATE_FILE = "gnfr.safetensors", "train_state.pt"


@dataclass
class FinetuneConfig:
    """Options of `deflare-scene finetune`."""

    preset: str = option("auto", choices=("auto", "paper", "quick", "tiny"))
    """paper (the paper's GNT-sized model) | quick (CPU-sized; steps, rays and sizes in
    docs/presets.md) | auto (paper with CUDA, quick otherwise) | tiny (smoke tests only)."""
    iters: int | None = option(None, ge=1)
    """Override the preset's number of steps."""
    rays: int | None = option(None, ge=1)
    """Override rays per step."""
    samples: int | None = option(None, ge=1)
    """Override samples per ray."""
    views: int | None = option(None, ge=1)
    """Override the number of source views (training and rendering)."""
    cached_features: bool | None = option(None, flag="--cached-features/--end-to-end")
    """Frozen encoder, every source encoded once (default: off, the encoder is fine-tuned)."""
    device: str = option("auto", device=True)
    """auto (CUDA when present) | cpu | cuda | cuda:N."""
    point_sampler: bool = True
    """GN-FR Point Sampler (False: ablation)."""
    view_sampler: bool = True
    """GN-FR View Sampler (False: ablation)."""
    mask_loss: bool = True
    """GN-FR masking loss (False: ablation)."""
    reference: bool = False
    """Plain fp32 path (no bf16 autocast, no fused attention)."""
    init: str = option("auto", choices=("auto", "scratch"), suffix=".safetensors")
    """auto (shipped weights marked for automatic use that match, else scratch) | scratch |
    a .safetensors path (e.g. gnfr/weights/gnfr.safetensors, pretrained for quick)."""
    seed: int = option(0, ge=0)
    """Seed of initialisation and sampling."""


def pick_device(name: str) -> torch.device:
    """``pipeline.options.resolve_device`` as a torch.device."""
    return torch.device(resolve_device(name))


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
    validate(config)
    ws.require("pose")
    device = pick_device(config.device)
    name, cfg = resolve(config, device)
    inputs = [ws.images, ws.cameras_json, ws.masks, ws.views_json]
    params = {"preset": name, "init": config.init, "train": asdict(cfg)}
    run_ = ws.begin_stage("finetune", params, inputs, force)
    if run_.skip:
        info(f"finetune: up to date ({ws.model})")
        _check_init(ws, cfg, config.init)
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


def _check_init(ws: Workspace, cfg: TrainConfig, init: str) -> None:
    """Warn when the up-to-date model was started from other weights than ``init`` resolves
    to now (e.g. the shipped file changed): the stage params record only ``init``'s text."""
    prev = checkpoint_provenance(ws.model / MODEL_FILE)
    if prev is None:
        return
    path = init_path(cfg, init)
    now = None if path is None or not path.is_file() else init_record(init, path)["sha256"]
    if prev.get("init", {}).get("sha256") != now:
        warn(f"finetune: {ws.model / MODEL_FILE} was trained from "
             f"{prev.get('init', {}).get('weights')}, but --init {init} now resolves to "
             f"{path or 'scratch'}: rerun with --force to retrain from it")


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


def init_path(cfg: TrainConfig, init: str) -> Path | None:
    """The weight file ``init`` (auto | scratch | a path) resolves to; None = scratch."""
    if init == "auto":
        return shipped_weights(cfg)
    return None if init == "scratch" else Path(init)


def init_record(init: str, path: Path | None) -> dict:
    """What a model started from: the ``--init`` value, the file it resolved to with its
    sha256, and the step / pretraining facts that file's metadata carries."""
    if path is None:
        return {"init": init, "weights": "scratch", "sha256": None}
    from pipeline.provenance import sha256

    rec = {"init": init, "weights": str(Path(path).resolve()), "sha256": sha256(path)}
    try:
        meta = read_metadata(path)[1]
    except CheckpointError:
        return rec
    keys = ("step", "preset", "pretrain_steps", "pretrain_scenes", "auto_init", "card")
    rec["metadata"] = {k: meta[k] for k in keys if k in meta}
    return rec


def init_model(cfg: TrainConfig, device: torch.device, init: str) -> tuple[GNFR, str]:
    """A fresh model (seeded), loaded from ``init``; returns it and a line saying which."""
    torch.manual_seed(cfg.seed)
    model = GNFR(cfg.model)
    path = init_path(cfg, init)
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
             unseen: torch.Tensor, prov: dict | None = None, seconds: float = 0.0) -> None:
    """Weights (with ``prov``, the run's provenance, plus steps done and training seconds
    so far in the metadata) and the training state."""
    meta = render_meta(cfg, preset, step)
    if prov is not None:
        meta["provenance"] = {**prov, "steps_done": step, "train_seconds": round(seconds, 1)}
    save_model(out / MODEL_FILE, model, meta)
    save_train_state(out / STATE_FILE, {"step": step, "optimizer": opt.state_dict(),
                                        "rng": rng_state(gen), "unseen": unseen,
                                        "seconds": float(seconds)})


def run_provenance(cfg: TrainConfig, preset: str, device: torch.device, init: dict) -> dict:
    """What trains this checkpoint, stored in its metadata (``provenance``): the start
    (``init_record``), preset and every TrainConfig number, seed, cached or end-to-end,
    device, machine and code version."""
    from pipeline.provenance import code_version, device_name, machine

    return {"init": init, "preset": preset, "train": asdict(cfg), "seed": cfg.seed,
            "cached_features": cfg.cached_features, "device": device.type,
            "device_name": device_name(device), "machine": machine(), "code": code_version(),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S")}


def checkpoint_provenance(path: Path) -> dict | None:
    """The ``provenance`` metadata of a checkpoint written by ``fit`` (None when absent:
    a checkpoint of an older version or of pretraining)."""
    try:
        return read_metadata(path)[1].get("provenance")
    except CheckpointError:
        return None


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
    prov = run_provenance(cfg, preset, device, init_record(init, init_path(cfg, init)))
    seconds = 0.0
    if resume and state_path.exists() and (out / MODEL_FILE).exists():
        load_weights(model, out / MODEL_FILE)
        st = load_train_state(state_path)
        opt.load_state_dict(st["optimizer"])
        set_rng_state(gen, st["rng"])
        step, unseen = int(st["step"]), st["unseen"]
        seconds = float(st.get("seconds", 0.0))
        # the start is what the interrupted run began from, not what init resolves to now
        prev = checkpoint_provenance(out / MODEL_FILE)
        if prev is not None:
            prov["init"] = prev.get("init", prov["init"])
            prov["started"] = prev.get("started", prov["started"])
            prov["resumed"] = [*prev.get("resumed", []), {"at_step": step, **{
                k: prov[k] for k in ("device_name", "code")}}]
        info(f"finetune: resuming at step {step} of {cfg.iters}")
    else:
        info(f"finetune: starting {how}")
    trim_metrics(out / "metrics.jsonl", step)
    bank, cache = prepare_sources(model, scene, cfg, device)
    stats = _loop(model, opt, gen, scene, cfg, bank, cache, step, unseen, out, preset, prov,
                  seconds)
    _write_unseen(out / "unseen.json", scene, unseen)
    return {**stats, "init": prov["init"]}


def _loop(model, opt, gen, scene, cfg, bank, cache, step, unseen, out, preset, prov=None,
          seconds0: float = 0.0) -> dict:
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
                save_all(out, model, opt, gen, step, cfg, preset, unseen, prov,
                         seconds0 + time.time() - t0)
            prog.update(task, completed=step, speed=f"{speed:.2f}")
    return {"steps": step, "it_per_s": round((step - done0) / max(time.time() - t0, 1e-9), 3),
            "train_seconds": round(seconds0 + time.time() - t0, 1)}


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
