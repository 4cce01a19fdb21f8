"""Stage `finetune`: fit GN-FR to one workspace -> ``WS/model/``.

Writes ``WS/model/gnfr.safetensors`` (weights; architecture and render settings in the
metadata, so ``gnfr.checkpoint.load_model`` rebuilds the model from the file alone),
``train_state.pt`` (optimizer + RNG state + step: an interrupted run resumes exactly where
it stopped), ``metrics.jsonl`` and ``unseen.json`` (per target view, the fraction of sample
points that were on flare in every source view: regions no clean view saw).

Presets: ``paper`` (GNT-sized, 50k steps, end-to-end; default with CUDA) and ``quick`` (a
CPU-sized model; default without CUDA). See ``gnfr.train`` for what each sets. The training
loop, checkpoint files and resume are ``gnfr.fit``'s; this stage resolves options and the
start weights, and adds provenance, the unseen-region count and a progress display.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import torch

from gnfr import WEIGHTS_DIR
from gnfr.checkpoint import CheckpointError, load_weights, read_metadata
from gnfr.fit import StepInput, Trainer, checkpoint_files, has_checkpoint, render_meta
from gnfr.model import GNFR
from gnfr.ray_split import HelperDied
from gnfr.renderer import cpu_bf16, emulated_bf16
from gnfr.train import (
    PRESETS,
    Scene,
    TrainConfig,
    mirrored,
    prepare_sources,
    sample_batch,
    scene_targets,
)
from gnfr.transformer import FLARE_FALLBACKS
from pipeline.errors import UserError, shell_path
from pipeline.exposure import MODELS
from pipeline.options import option, resolve_device, validate
from pipeline.progress import info, make_progress, warn
from pipeline.workspace import UNSEEN_FILE, Workspace, atomic_write_json


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
    threads: int | None = option(None, ge=1)
    """torch threads of the fine-tune on the CPU (default ``CPU_THREADS``, 1: a step is many
    small products, which two threads share poorly; on the 2-core machine one thread trained
    the sample 1.35x faster than two, docs/performance.md, "The fine-tune on one thread").
    A speed setting: not in the stage's record. CUDA runs keep torch's."""
    workers: int | None = option(None, ge=1)
    """On the CPU: processes that share each step's rays and the encoding of its source
    views, ``threads`` threads each (default: one per thread torch would use, at most 4; 1
    trains in this process alone, with less memory). The whole batch's gradient either way,
    but for rounding (a run repeats bitwise at one count); on the 2-core machine two
    one-thread processes took a step 1.47x faster than one on the sample's small photos and
    1.48x faster at the default 1008 px (``python benchmarks/finetune_split.py``,
    docs/performance.md, "The fine-tune in two processes"). A speed setting: not in the
    stage's record (the checkpoint's provenance says it). CUDA trains in one process."""
    point_sampler: bool = True
    """GN-FR Point Sampler (False: ablation)."""
    flare_fallback: str = option("valid", choices=FLARE_FALLBACKS)
    """What a point on flare in every source that sees it attends: valid (every such view,
    the flare's light with them; GN-FR's rule) | darkest (the darker half of them: flare adds
    light, so they carry the least of it). Recorded in the model; render uses the same."""
    view_sampler: bool = True
    """GN-FR View Sampler (False: ablation)."""
    mask_loss: bool = True
    """GN-FR masking loss (False: ablation)."""
    dropout: float | None = option(None, ge=0, lt=1)
    """Dropout in the transformers while training (GNT: 0.1; default: the preset's, 0);
    holds no weights, so any value starts from the same shipped weights."""
    random_sources: bool | None = option(None, flag="--random-sources/--nearest-sources")
    """GNT's random choice of training sources inside the nearest pool, or always the
    nearest least-flared. Default: random on a scene where no view has a marked pixel (better
    novel views there), nearest otherwise (better de-flared photos); docs/presets.md."""
    edge_rays: float = option(0.0, ge=0, le=1)
    """Share of each step's rays drawn where the target photo has edges (in proportion to
    its gradient magnitude), each ray's loss weighted back so the objective is unchanged;
    0: every ray uniform (judged on the development scenes, not the default: docs/presets.md)."""
    lr_scale: float | None = option(None, gt=0)
    """Multiply both of the preset's learning rates (encoder and transformers) by this
    (default 1; docs/presets.md)."""
    holes_as_flare: bool = True
    """Train on each mask with what it encloses marked too (``ws_files.enclosed_holes``: the
    light's own core inside its flare, which a tight mask such as the full-width FMG's or
    the synth's true masks leaves unmarked): those pixels are neither targets nor source
    colours, while WS/masks (and so the render, which keeps the core as photographed) stay
    as they are. On by default since the full-width FMG shipped, whose masks leave the core
    unmarked (docs/history/fmg.md, "Twenty-sixth session"); ``--no-holes-as-flare`` for
    masks without holes (the earlier quarter-width file's, ``fmg_small.safetensors``)."""
    train_grow: float = option(0.0, ge=0, le=0.1)
    """Grow each flare mask by this fraction of the image's long side for training only (the
    masking loss and the Point Sampler; ``pipeline.training_scenes.load_workspace``): the
    faint veil just outside a mask, flare light no mask marks, is then neither learnt as the
    scene nor read from a source. The 10 % rule's fractions and the render's masks stay as
    they are. 0 (off) by default."""
    full_res_colour: bool = True
    """Sample the sources' colours (and flare masks) at the full size of WS/images while the
    encoder still sees them at the preset's ``source_scale`` (1/4 in ``quick``; the
    ``paper`` preset encodes at full size, where this changes nothing). Recorded in the
    model, so render samples colours the same way. On by default since the twenty-ninth
    session (novel views +0.11 dB, de-flared photos' flare region +0.17 dB on the development
    scenes; docs/presets.md, "Full-size colours in the fine-tune");
    ``--no-full-res-colour`` samples them at ``source_scale`` as before."""
    mirror: bool = False
    """Half the training steps (drawn at random) see the scene in a mirror: every view
    flipped left-right with its camera reflected (``gnfr.train.mirrored``), a consistent
    second copy of the scene, so a few photos give the model twice the views to learn from.
    Off by default (docs/history/gnfr.md, "Twentieth session")."""
    pad_views: bool = True
    """Views of another size than the most common one (a portrait photo among landscape
    ones) kept at their own size and padded, as the render pads its sources, instead of
    stretched to that size (``pipeline.training_scenes.load_workspace``). The default since
    the eighty-fifth session: on development builds with two photos turned to portrait,
    novel views +0.72, +0.27 and +0.25 dB over three seeds, 1.07x the fine-tune's time
    (docs/history/gnfr.md, "Views of different sizes in the fine-tune, three seeds");
    ``--no-pad-views`` stretches as before. Where every view has one size it changes
    nothing and is recorded off (``mixed_sizes``)."""
    encode_apart: bool = False
    """With views of different sizes padded (``pad_views``): each view encoded at its own
    size and its feature map padded, instead of its image padded and the padded image
    encoded (``gnfr.renderer.SourceViews.encode``, ``apart``): the encoder reads no padding,
    and a view's features are those it would have alone. Recorded in the model, so render
    encodes its sources the same way. Where nothing is padded it changes nothing and is
    recorded off. Off by default: judged in the eighty-sixth session, novel views -0.063 dB
    on the development mean for 0.981 times the fine-tune's time (docs/history/gnfr.md,
    "Views of different sizes encoded each at its own size")."""
    flare_flag: bool = False
    """Give the network, with each source's colour and features, a bit saying the point is
    on flare in that source (``GNFRConfig.flare_flag``), so a point on flare in every
    source is known to it as such; the shipped weights start it as the model without the
    flag. A new architecture, recorded in the model (render reads it). Meant with
    ``--source-flare``, which supervises such points. Off by default."""
    source_flare: float = option(0.0, ge=0, le=1)
    """Share of the training steps whose sources carry one more synthetic flare, drawn as
    ``synth`` draws it from a light placed in the scene and masked exactly, while the target
    stays as photographed (``pipeline.source_flare``): what every source shows on flare is
    then trained against a view that shows it clean. 0 (off) by default."""
    exposure_match: bool = True
    """Train on every view brought to the views' common exposure (one gain per view and
    channel from the depth maps, ``pipeline.exposure``; without the depth stage the views
    keep their own); render reads the gains from the checkpoint. On since the forty-first
    session: de-flared photos' flare region +0.106 dB, novel views +0.383 dB on the
    development scenes (two seeds; docs/history/gnfr.md, "Forty-first session")."""
    exposure_model: str = option("gain", choices=MODELS)
    """With ``exposure_match``, how the views are brought to one exposure
    (``pipeline.exposure.MODELS``): gain (one per view and channel) | view-curves (a gain
    and a slope about mid grey per view; judged and not the default, docs/history/gnfr.md,
    "Forty-second session") | camera-curve (one tone curve for the camera, a gain per
    view)."""
    exposure_reference: str = option("mean", choices=("mean", "darkest"))
    """With ``exposure_match``, the common exposure the views are brought to: mean (the
    views' mean log gain is zero, so the darker views are brightened and their highlights
    can clip in training: 7-16 % of lund's darker views, gains up to 1.76) | darkest (every
    gain scaled so the largest is 1: no view is brightened, nothing clips; the render takes
    the colours back to each frame's exposure as before)."""
    reference: bool = False
    """Plain fp32 path (no bf16 autocast, no fused attention)."""
    bf16: bool | None = option(None, flag="--bf16/--no-bf16")
    """On the CPU: the transformers' forward and backward under bf16 autocast, as CUDA always
    trains (the encoder and the weights stay fp32). Default: on where the CPU has native bf16
    (AVX512-BF16 or AMX), fp32 elsewhere, where bf16 is emulated and slower
    (``gnfr.renderer.cpu_bf16``; judged on the development scenes, docs/performance.md, "bf16
    on the CPU"). On the project's EPYC the sample's fine-tune took 192.3 s against 220.6 s
    in fp32 (two processes; the one-shot in fresh clones). Changes what is learnt beyond
    rounding: in the stage's record (a workspace moved to a CPU that decides otherwise
    fine-tunes again; ``--bf16`` / ``--no-bf16`` pin it)."""
    encoder_bf16: bool = False
    """With bf16 on (``--bf16``, the default on a CPU with native bf16): the encoder's
    forward and backward under bf16 autocast too (``TrainConfig.encoder_bf16``). Where the
    step pads a portrait photo among landscape ones the encoder is most of what padding
    costs. Recorded off where bf16 is off (it changes nothing there). Off by default:
    judged in the eighty-seventh session, novel views -0.074 dB on the development mean (lund
    -0.15 on each of three seeds) for 0.95 times the sample's training time
    (docs/history/gnfr.md, "The encoder under bf16 in the fine-tune")."""
    init: str = option("auto", choices=("auto", "scratch"), suffix=".safetensors", exists=True)
    """auto (shipped weights marked for automatic use that match, else scratch) | scratch |
    a .safetensors path (e.g. gnfr/weights/gnfr.safetensors, pretrained for quick). A copy
    of this scene's own fine-tune that stopped short (``WS/model/gnfr.safetensors`` carried
    to another machine without ``train_state.pt``; same preset and settings) goes on at its
    step count and learning rate, with a fresh optimizer state (``continuation``)."""
    seed: int = option(0, ge=0)
    """Seed of initialisation and sampling."""


CPU_THREADS = 1
"""``FinetuneConfig.threads`` when not given, on the CPU."""
MAX_AUTO_WORKERS = 4
"""Most processes ``FinetuneConfig.workers`` unset gives: each encodes the step's sources
itself, which more processes do not shorten (``gnfr.ray_split``); measured up to 2 (the
2-core machine)."""
AUTO_WORKERS = True
"""Whether ``FinetuneConfig.workers`` unset shares the CPU's threads out (True) or trains in
this process alone. The test suite sets it False (as ``pipeline.render.workers.AUTO_WORKERS``):
its counters and simulated interrupts patch this process; its tests of the split ask for it
by ``workers``."""


def fit_workers(config: FinetuneConfig, device: torch.device, cfg: TrainConfig) -> int:
    """Processes the fine-tune's steps are shared by (``gnfr.ray_split.parts``): 1 on CUDA;
    ``config.workers`` when given; else (``AUTO_WORKERS``) the threads torch would use over
    ``fit_threads``, at most ``MAX_AUTO_WORKERS``; never so many that a process gets under
    ``gnfr.ray_split.MIN_RAYS`` rays."""
    from gnfr.ray_split import parts

    if device.type == "cuda":
        return 1
    if config.workers is not None:
        want = int(config.workers)
    elif AUTO_WORKERS:
        want = min(MAX_AUTO_WORKERS, torch.get_num_threads() // fit_threads(config, device))
    else:
        want = 1
    return parts(cfg.rays, want)


def fit_threads(config: FinetuneConfig, device: torch.device) -> int | None:
    """torch threads the fine-tune runs on: ``config.threads`` or ``CPU_THREADS`` on the CPU;
    None (torch's own) on CUDA."""
    if device.type == "cuda":
        return None
    return int(config.threads or CPU_THREADS)


@contextlib.contextmanager
def torch_threads(n: int | None):
    """torch on ``n`` threads inside the block (None: unchanged), its own count restored."""
    if n is None:
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def pick_device(name: str) -> torch.device:
    """``pipeline.options.resolve_device`` as a torch.device."""
    return torch.device(resolve_device(name))


def shipped_weights(cfg: TrainConfig) -> Path | None:
    """The first shipped weight file whose architecture loads into ``cfg.model``
    (``GNFRConfig.grown_from``: the same, or without the flare flag ``cfg.model`` has) and whose
    metadata marks it for automatic use (``auto_init``; gnfr/weights/gnfr.md says when the
    shipped file earned it)."""
    for p in sorted(WEIGHTS_DIR.glob("gnfr*.safetensors")):
        try:
            cfg_p, meta = read_metadata(p)
        except CheckpointError:
            continue
        if cfg.model.grown_from(cfg_p) and meta.get("auto_init") is True:
            return p
    return None


def resolve(config: FinetuneConfig, device: torch.device) -> tuple[str, TrainConfig]:
    """The preset name and the TrainConfig after overrides."""
    name = config.preset
    if name == "auto":
        name = "paper" if device.type == "cuda" else "quick"
    cfg = PRESETS[name]
    bf16 = cpu_bf16(config.bf16, device)
    over = {k: v for k, v in (("iters", config.iters), ("rays", config.rays),
                              ("samples", config.samples)) if v is not None}
    if config.views is not None:
        over.update(n_views=(config.views, config.views), eval_views=config.views)
    cfg = replace(cfg, **over, point_sampler=config.point_sampler,
                  view_sampler=config.view_sampler, mask_loss=config.mask_loss,
                  reference=config.reference, seed=config.seed,
                  random_sources=bool(config.random_sources), mirror=config.mirror,
                  full_res_colour=config.full_res_colour, edge_rays=config.edge_rays,
                  cpu_bf16=bf16, encoder_bf16=config.encoder_bf16 and bf16,
                  flare_fallback=config.flare_fallback, source_flare=config.source_flare)
    if config.dropout is not None:
        cfg = replace(cfg, model=replace(cfg.model, dropout=config.dropout))
    if config.flare_flag:
        cfg = replace(cfg, model=replace(cfg.model, flare_flag=True))
    if config.lr_scale is not None:
        cfg = replace(cfg, lr_encoder=cfg.lr_encoder * config.lr_scale,
                      lr_transformer=cfg.lr_transformer * config.lr_scale)
    # end-to-end unless asked: the shipped weights were measured fine-tuned end-to-end
    # (gnfr/weights/gnfr.md); a frozen, cached encoder is a quarter faster per step
    cached = bool(config.cached_features)
    return name, replace(cfg, cached_features=cached)


def mixed_sizes(ws: Workspace) -> bool:
    """Whether the posed views are not all of one size (a portrait photo among landscape
    ones): where ``FinetuneConfig.pad_views`` changes what the fine-tune sees."""
    from pipeline.ws_files import read_cameras

    return len({(f.width, f.height) for f in read_cameras(ws).frames}) > 1


def run(config: FinetuneConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Fine-tune on ``ws``; returns the written paths."""
    validate(config)
    for name, value, default in (("--exposure-model", config.exposure_model, "gain"),
                                 ("--exposure-reference", config.exposure_reference, "mean")):
        if value != default and not config.exposure_match:
            raise UserError(f"{name} {value}: it says how --exposure-match evens the views "
                            f"out; drop --no-exposure-match (or {name})")
    ws.require("pose")
    device = pick_device(config.device)
    name, cfg = resolve(config, device)
    if config.random_sources is None and flare_free(ws):
        cfg = replace(cfg, random_sources=True)
        info("finetune: no view has flare marked: random sources inside the nearest pool")
    # padding changes nothing where every view has one size: recorded as off there, so the
    # flag (or its default) never reruns a finished fine-tune of such a capture
    pad = config.pad_views and mixed_sizes(ws)
    cfg = replace(cfg, encode_apart=config.encode_apart and pad)
    inputs = [ws.images, ws.cameras_json, ws.masks, ws.views_json]
    inputs += ws.depth_inputs() if config.exposure_match else []  # the gains come from the depth
    params = {"preset": name, "init": config.init, "train": asdict(cfg),
              "holes_as_flare": config.holes_as_flare, "train_grow": config.train_grow,
              "pad_views": pad,
              "exposure_match": config.exposure_match,
              "exposure_model": config.exposure_model if config.exposure_match else "gain",
              "exposure_reference": (config.exposure_reference if config.exposure_match
                                     else "mean")}
    # an option added later is absent from older records: it matches there at the value
    # those runs had (holes_as_flare was off before it existed, whatever its default now)
    stage_run = ws.begin_stage("finetune", params, inputs, force,
                               defaults={"train": asdict(TrainConfig()),
                                         "holes_as_flare": False, "train_grow": 0.0,
                                         "pad_views": False,
                                         "exposure_match": False,
                                         "exposure_model": "gain",
                                         "exposure_reference": "mean"})
    if stage_run.skip:
        info(f"finetune: up to date ({ws.model})")
        _check_init(ws, cfg, config.init)
        return stage_run.outputs
    if not ws.resumable(stage_run):  # a checkpoint of other settings or inputs (a finished
        # run's, kept while this one has not checkpointed yet) is never resumed from
        checkpoint_files(ws.model)[1].unlink(missing_ok=True)
    info(f"finetune: preset '{name}' on {device.type} ({cfg.iters} steps, {cfg.rays} rays, "
         f"{cfg.samples} samples, depth {cfg.model.depth} width {cfg.model.width}, "
         f"{'cached features' if cfg.cached_features else 'end-to-end'}"
         f"{', bf16' if cfg.cpu_bf16 else ''}{' (the encoder too)' if cfg.encoder_bf16 else ''})")
    if note := emulated_bf16("finetune", cfg.cpu_bf16):
        warn(note)
    from pipeline.training_scenes import load_workspace

    gains = (exposure_gains(ws, config.exposure_model, config.exposure_reference)
             if config.exposure_match else None)
    scene = load_workspace(ws.root, holes_as_flare=config.holes_as_flare, gains=gains,
                           grow=config.train_grow, pad=pad)
    workers, threads = fit_workers(config, device, cfg), fit_threads(config, device)
    with torch_threads(threads):
        stats = fit(scene, cfg, device, ws.model, resume=ws.resumable(stage_run),
                    init=config.init, preset=name, gains=gains, workers=workers,
                    threads=threads or 1)
    outs = [ws.model_file, ws.train_state, ws.metrics_jsonl, ws.unseen_json]
    return stage_run.finish(outs, extra=stats, versions=["torch", "safetensors"])


def exposure_gains(ws: Workspace, model: str = "gain", reference: str = "mean",
                   command: str = "finetune --exposure-match") -> dict:
    """``finetune --exposure-match``: the views' gains (or curves, by ``model``;
    ``pipeline.exposure``) to the common exposure ``reference`` names
    (``FinetuneConfig.exposure_reference``), said in one line; none, with a warning, when
    the workspace has no depth maps. ``command``: who asks, for those lines."""
    from pipeline.exposure import darkest_reference, estimate_gains, spread_ev

    if not ws.depth.is_dir():
        warn(f"{command}: no {ws.depth} (run `deflare-scene depth "
             f"{shell_path(ws.root)}`): the views are trained at their own exposures")
        return {}
    gains = estimate_gains(ws, model=model)
    if reference == "darkest":
        gains = darkest_reference(gains)
    info(f"{command.split()[0]}: {ws.root.name}'s exposures evened out ({spread_ev(gains):.2f} EV "
         "between the darkest and the brightest view)")
    return gains


def flare_free(ws: Workspace) -> bool:
    """True when no view of ``ws`` has a marked flare pixel (WS/flare.json), or when the
    workspace has no masks at all (every view is then trained on as flare-free)."""
    from pipeline.ws_files import read_flare

    if not ws.flare_json.is_file():
        return True
    return all(f == 0 for f in read_flare(ws).fractions().values())


def _check_init(ws: Workspace, cfg: TrainConfig, init: str) -> None:
    """Warn when the up-to-date model was started from other weights than ``init`` resolves
    to now (e.g. the shipped file changed): the stage params record only ``init``'s text."""
    prev = checkpoint_provenance(ws.model_file)
    if prev is None:
        return
    path = init_path(cfg, init)
    now = None if path is None or not path.is_file() else init_record(init, path)["sha256"]
    if prev.get("init", {}).get("sha256") != now:
        warn(f"finetune: {ws.model_file} was trained from "
             f"{prev.get('init', {}).get('weights')}, but --init {init} now resolves to "
             f"{path or 'scratch'}: rerun with --force to retrain from it")


# --------------------------------------------------------------------------- start weights
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
    """A fresh model (seeded), loaded from ``init``; returns it and a line saying which.
    A start file whose encoder's decoder is normalised (``GNFRConfig.dec_norm``, `pretrain
    --dec-norm`) gets a model with the norm, so such a prior fine-tunes (and its pretraining
    continues) as it was trained; a config that asks for the norm itself keeps it. The same
    for the flare flag (``GNFRConfig.flare_flag``): a start file that has it keeps it."""
    torch.manual_seed(cfg.seed)
    path = init_path(cfg, init)
    model_cfg = cfg.model
    if path is not None and path.is_file():
        with contextlib.suppress(CheckpointError):  # load_weights below says what is wrong
            start = read_metadata(path)[0]
            model_cfg = replace(model_cfg, dec_norm=model_cfg.dec_norm or start.dec_norm,
                                flare_flag=model_cfg.flare_flag or start.flare_flag)
    model = GNFR(model_cfg)
    if path is None:
        how = "from scratch (no shipped weights match this architecture)" \
            if init == "auto" else "from scratch"
    else:
        try:
            load_weights(model, path)
        except CheckpointError as e:
            raise UserError(f"--init {path}: {e}") from None
        how = f"from pretrained weights {path}"
    return model.to(device), how


def run_provenance(cfg: TrainConfig, preset: str, device: torch.device, init: dict) -> dict:
    """What trains this checkpoint, stored in its metadata (``provenance``): the start
    (``init_record``), preset and every TrainConfig number, seed, cached or end-to-end,
    device, machine and code version."""
    from pipeline.provenance import code_version, device_name, machine

    return {"init": init, "preset": preset, "train": asdict(cfg), "seed": cfg.seed,
            "cached_features": cfg.cached_features, "device": device.type,
            "device_name": device_name(device), "machine": machine(), "code": code_version(),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S")}


def scene_record(scene: Scene) -> dict:
    """What a fine-tune learns from, in short (``fit`` records it; ``continuation``
    compares it): the views' names and size (padded, ``Scene.extents``), each view's focal
    length, camera centre, mean colour (0-255) and masked fraction, of its own pixels."""
    means = [scene.own(i, img).double().mean((1, 2)) for i, img in enumerate(scene.images)]
    masks = [0.0] * len(scene.stems) if scene.masks is None else \
        [float(scene.own(i, m).double().mean()) for i, m in enumerate(scene.masks)]
    return {"stems": list(scene.stems), "size": list(scene.images.shape[-2:]),
            "focal": [round(float(f), 4) for f in scene.K[:, 0, 0]],
            "centre": [[round(float(x), 6) for x in c] for c in scene.c2w[:, :3, 3]],
            "mean": [[round(float(x), 3) for x in m] for m in means],
            "masked": [round(float(m), 6) for m in masks]}


SAME_SCENE = {"focal": 1e-3, "centre": 1e-4, "mean": 0.5, "masked": 1e-3}
"""How far two ``scene_record`` numbers may differ and still be one scene (relative for the
focal lengths, in the scene's units for the centres, in 0-255 levels for the colours): the
same photos decoded by another OpenCV or posed by LLFF's numbers on another processor."""


def same_scene(a: dict | None, b: dict) -> bool:
    """Whether two ``scene_record``s are one scene (``SAME_SCENE``)."""
    import numpy as np

    if not a or a.get("stems") != b["stems"] or a.get("size") != b["size"]:
        return False
    try:
        fa, fb = np.asarray(a["focal"], float), np.asarray(b["focal"], float)
        return bool(np.all(np.abs(fa - fb) <= SAME_SCENE["focal"] * np.abs(fb)) and all(
            np.all(np.abs(np.asarray(a[k], float) - np.asarray(b[k], float)) <= SAME_SCENE[k])
            for k in ("centre", "mean", "masked")))
    except (KeyError, ValueError):  # an older or hand-made record
        return False


BOOKKEEPING = ("iters", "log_every", "ckpt_every", "ckpt_seconds")
"""TrainConfig fields a continuation need not match: how long and how often to write, not
what is learnt."""


def _settings(train: dict) -> dict:
    """TrainConfig numbers as the metadata's JSON holds them, less ``BOOKKEEPING``."""
    import json

    return {k: v for k, v in json.loads(json.dumps(train)).items() if k not in BOOKKEEPING}


def continuation(path: Path | None, cfg: TrainConfig, preset: str, scene: dict
                 ) -> dict | None:
    """The provenance of ``path`` when it is a fine-tune of this same scene (``same_scene``
    on ``scene``, a ``scene_record``), preset and settings (every TrainConfig number but
    ``iters``) that stopped short of the steps it was asked for: a model folder's weights
    carried without their ``train_state.pt`` (another machine, a GPU lent for one session).
    ``fit`` goes on from its step count and learning-rate schedule, with a fresh optimizer
    state (Adam's moments are not in the weights). None for anything else (pretrained
    weights, another scene's model, a fine-tune that finished: ``--init`` with it starts a
    new run from its weights at step 0, as before)."""
    prov = None if path is None or not Path(path).is_file() else checkpoint_provenance(path)
    if not prov or prov.get("preset") != preset or not same_scene(prov.get("scene"), scene):
        return None
    if _settings(prov.get("train", {})) != _settings(asdict(cfg)):
        return None
    done = int(prov.get("steps_done", 0))
    return prov if 0 < done < int(prov["train"].get("iters", 0)) else None


def checkpoint_provenance(path: Path) -> dict | None:
    """The ``provenance`` metadata of a checkpoint written by ``fit`` (None when absent:
    a checkpoint of an older version or of pretraining)."""
    try:
        return read_metadata(path)[1].get("provenance")
    except CheckpointError:
        return None


def _goes_on(prov: dict, prev: dict, step: int, **how) -> None:
    """``prov`` of a run that goes on from ``prev``'s (its checkpoint's provenance): the
    start it began from (not what ``--init`` resolves to now), and this resumption listed
    after the earlier ones (``how``: what else to say of it) with the device and code; the
    start's process count (each resumption's is added by ``fit``)."""
    prov["init"] = prev.get("init", prov["init"])
    prov["started"] = prev.get("started", prov["started"])
    prov["resumed"] = [*prev.get("resumed", []), {
        "at_step": step, **how, **{k: prov[k] for k in ("device_name", "code")}}]
    prov["processes"] = prev.get("processes", 1)


# --------------------------------------------------------------------------- training
def fit(scene: Scene, cfg: TrainConfig, device: torch.device, out: Path, resume: bool = True,
        init: str = "auto", preset: str = "custom", gains: dict | None = None,
        workers: int = 1, threads: int = 1) -> dict:
    """Train on ``scene``, checkpointing into ``out``; resumes from ``out`` when allowed
    (``gnfr.fit``: weights, optimizer, RNG and step; here also the unseen counts, training
    seconds and the provenance's start). ``workers`` > 1 (on the CPU): that many processes
    share each step's rays (``gnfr.ray_split.RaySplit``; its helpers on ``threads``
    threads)."""
    from rich.progress import TextColumn

    out.mkdir(parents=True, exist_ok=True)
    gen = torch.Generator().manual_seed(cfg.seed)
    model, how = init_model(cfg, device, init)
    trainer = Trainer(model, cfg, gen=gen)
    prov = {**run_provenance(cfg, preset, device, init_record(init, init_path(cfg, init))),
            "scene": scene_record(scene)}
    if gains:  # the exposure the model was trained at: render reads its sources so
        from pipeline.exposure import gains_json

        prov["exposure_gains"] = gains_json(gains)
    unseen = _start(trainer, gen, prov, out, resume, init, how, preset, len(scene.stems))
    draws = _Draws(scene, model, cfg, device, unseen)

    def meta(step: int, seconds: float) -> dict:
        """Render settings, plus the provenance with steps done and training seconds."""
        return {**render_meta(cfg, preset, step), "provenance": {
            **prov, "steps_done": step, "train_seconds": round(seconds, 1)}}

    cols = TextColumn("{task.fields[speed]} it/s  PSNR {task.fields[psnr]}")
    with contextlib.ExitStack() as stack:
        split = None
        if workers > 1 and trainer.step < cfg.iters:
            split, workers = _ray_split(stack, model, draws.banks + draws.twins, cfg, workers,
                                        threads)
        # a speed setting, but it decides the rounding: the checkpoint says it
        (prov["resumed"][-1] if "resumed" in prov else prov)["processes"] = workers
        label = "finetune" if workers == 1 else f"finetune ({workers} processes)"
        prog = stack.enter_context(make_progress(cols))
        task = prog.add_task(label, total=cfg.iters, completed=trainer.step, speed="-",
                             psnr="-")

        def report(step: int, speed: float, line: dict | None) -> None:
            if line is not None:
                prog.update(task, psnr=f"{line['psnr']:.2f}")
            prog.update(task, completed=step, speed=f"{speed:.2f}")

        try:
            stats = trainer.run(draws, out=out, meta=meta,
                                state=lambda _, sec: {"unseen": draws.unseen,
                                                      "seconds": float(sec)},
                                after_step=draws.count_unseen, report=report, split=split)
        except HelperDied as e:
            raise UserError(f"finetune: {e}; the checkpoint of step {saved_step(out)} is kept: "
                            "rerun to resume, with `--workers 1` (`--set finetune.workers=1` "
                            "in the one-shot command) to train in one process (less memory)"
                            ) from None
    _write_unseen(out / UNSEEN_FILE, scene, draws.unseen)
    # the views a step could take as its target: the stage's record says them, so whoever
    # reports the fine-tune (eval's table) reads them rather than applying the rule again
    return {**stats, "init": prov["init"], "targets": scene_targets(scene, cfg)}


def _start(trainer: Trainer, gen: torch.Generator, prov: dict, out: Path, resume: bool,
           init: str, how: str, preset: str, n_views: int) -> torch.Tensor:
    """Where ``fit`` starts, set on ``trainer`` and ``gen`` and told in ``prov``; returns
    the unseen counts so far (per view: points on flare in every source, points drawn).
    In order: ``out``'s own checkpoint when ``resume`` (an interrupted run, exactly where it
    stopped); this scene's unfinished fine-tune carried as ``--init`` without its state
    (``continuation``: its step count and schedule, a fresh optimizer, new draws); else
    step 0 from what ``init_model`` loaded (``how`` says it)."""
    cfg = trainer.cfg
    if resume and has_checkpoint(out):
        unseen = trainer.restore(out)["unseen"]
        prev = checkpoint_provenance(checkpoint_files(out)[0])
        if prev is not None:
            _goes_on(prov, prev, trainer.step)
        info(f"finetune: resuming at step {trainer.step} of {cfg.iters}")
        return unseen
    if (prev := continuation(init_path(cfg, init), cfg, preset, prov["scene"])) is not None:
        step = int(prev["steps_done"])
        if step >= cfg.iters:
            raise UserError(f"--init {init} is this scene's fine-tune, trained to step {step}: "
                            f"give --iters above {step} to train it further")
        trainer.step, trainer.seconds = step, float(prev.get("train_seconds", 0.0))
        gen.manual_seed(cfg.seed + step)  # new draws, not the first run's again
        _goes_on(prov, prev, step, optimizer="fresh", **{"from": str(init)})
        info(f"finetune: continuing {init} at step {step} of {cfg.iters} (this scene's own "
             "fine-tune; its optimizer state is not in the weights: Adam starts afresh)")
    else:
        info(f"finetune: starting {how}")
    return torch.zeros(n_views, 2, dtype=torch.float64)


class _Draws:
    """The fine-tune's batches: each step a batch of the scene, or (``cfg.mirror``) of it or
    its mirror image at random, with that scene's encoded sources (``banks``); with
    ``cfg.source_flare`` its sources are, that often, a flared twin's (``twins``). Counts
    each target's points on flare in every source (``unseen``), the photos' own only."""

    def __init__(self, scene: Scene, model: GNFR, cfg: TrainConfig, device: torch.device,
                 unseen: torch.Tensor):
        self.cfg, self.unseen = cfg, unseen
        self.scenes = [scene, mirrored(scene)] if cfg.mirror else [scene]
        self.banks = [prepare_sources(model, sc, cfg, device) for sc in self.scenes]
        self.twins = []
        if cfg.source_flare > 0:
            from pipeline.source_flare import TWINS, flared_twins

            info(f"finetune: drawing {TWINS} flared twins of the scene's sources "
                 f"(--source-flare {cfg.source_flare:g})")
            self.twins = [prepare_sources(model, t, cfg, device)
                          for t in flared_twins(scene, cfg.seed, TWINS)]

    def __call__(self, gen: torch.Generator) -> StepInput:
        k = (int(torch.randint(len(self.scenes), (1,), generator=gen))
             if len(self.scenes) > 1 else 0)
        batch = sample_batch(self.scenes[k], self.cfg, gen)
        if (self.twins and k == 0
                and float(torch.rand((), generator=gen)) < self.cfg.source_flare):
            twin = self.twins[int(torch.randint(len(self.twins), (1,), generator=gen))]
            return StepInput(batch, *twin)
        return StepInput(batch, *self.banks[k])

    def count_unseen(self, inp: StepInput, r: dict) -> None:
        if any(inp.bank is b for b, _ in self.twins):  # unseen.json counts the photos' own
            return
        self.unseen[inp.batch.target] += torch.tensor([r["all_flared"], 1.0],
                                                      dtype=torch.float64)


def _ray_split(stack: contextlib.ExitStack, model: GNFR, banks: list, cfg: TrainConfig,
               workers: int, threads: int):
    """``workers`` processes sharing each step's rays, entered on ``stack``, and the count
    that trains: (None, 1) where the machine's shared memory has no room for them (a
    warning says what gives it room)."""
    from gnfr.ray_split import NoSharedMemory, RaySplit

    try:
        return stack.enter_context(RaySplit(model, banks, cfg, workers, threads)), workers
    except NoSharedMemory as e:
        warn(f"finetune: {e}: training in one process (more shared memory, e.g. "
             "Docker's `--shm-size 2g`, lets the processes share each step)")
        return None, 1


def saved_step(out: Path) -> int:
    """The step of the checkpoint in ``out`` (0 when there is none)."""
    if not has_checkpoint(out):
        return 0
    prov = checkpoint_provenance(checkpoint_files(out)[0]) or {}
    return int(prov.get("steps_done", 0))


def _write_unseen(path: Path, scene: Scene, unseen: torch.Tensor) -> None:
    views = {s: {"all_flared_fraction": float(unseen[i, 0] / unseen[i, 1]),
                 "steps_as_target": int(unseen[i, 1])}
             for i, s in enumerate(scene.stems) if unseen[i, 1] > 0}
    if not views:
        warn("finetune: no training step ran, unseen.json is empty")
    atomic_write_json(path, {"description": "per target view: mean fraction of sample points "
                             "that were on flare in every source view (fell back to "
                             "validity-only attention)", "views": views})
