"""`deflare-scene pretrain`: a generalizable GN-FR model trained across many scenes.

Scenes: deflare-scene workspaces, LLFF folders (``poses_bounds.npy``) and COLMAP workspaces
(``sparse/`` + ``images/``), or folders holding such scenes. The held-out evaluation scenes
(``pipeline.scene_splits.HELDOUT_SCENES``) are always left out. Optional synthetic flare
(``pipeline.flare``) is imposed once per view at load time with its ground-truth mask, so the
masking loss, Point Sampler and View Sampler train as in the paper.

Several processes: ``torchrun --nproc_per_node K -m workflows.research.pretrain ...`` (or
``python -m torch.distributed.run``); each rank draws its own batches, gradients are
averaged with an all-reduce (NCCL on CUDA, gloo on CPU), rank 0 writes checkpoints.
A run resumes from ``OUT/train_state.pt`` (weights, optimizer, step); on resume each rank's
sampler is re-seeded from (seed, rank, step), so a resumed run is statistically, not
bitwise, the same as an uninterrupted one. The loop itself, its files and resume are
``gnfr.fit``'s (the same as fine-tuning's); a metrics line here is the logged step's own
values and its scene.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import torch

from gnfr.checkpoint import CheckpointError
from gnfr.fit import MODEL_FILE, StepInput, Trainer, has_checkpoint, last_record, render_meta
from gnfr.train import PRESETS, Scene, TrainConfig, mirrored, prepare_sources, sample_batch
from pipeline.errors import UserError
from pipeline.finetune import exposure_gains, init_model, init_path
from pipeline.options import option, resolve_device, validate
from pipeline.progress import info, make_progress, warn
from pipeline.scene_splits import HELDOUT_SCENES
from pipeline.training_scenes import detect_and_load, load_workspace, scene_layout
from pipeline.workspace import Workspace
from workflows.research.run_settings import record_settings, refuse_other_settings


@dataclass
class PretrainConfig:
    """Options of `deflare-scene pretrain`."""

    scenes: list[Path] = field(default_factory=list)
    """Scene folders, or folders whose sub-folders are scenes."""
    out: Path = Path("gnfr_pretrain")
    """Output folder: gnfr.safetensors, train_state.pt, metrics.jsonl."""
    preset: str = option("pretrain", choices=tuple(PRESETS))
    """pretrain (the paper's: GNT-sized) | pretrain-quick | tiny (tests) | any finetune
    preset (docs/presets.md)."""
    iters: int | None = option(None, ge=1)
    """Override the preset's number of steps."""
    ckpt_every: int | None = option(None, ge=1)
    """Override the preset's steps between checkpoints (a lent GPU that may go away: often)."""
    full_res_colour: bool = False
    """Sample the sources' colours at their full resolution while the encoder sees them at
    the preset's ``source_scale`` (``TrainConfig.full_res_colour``; recorded in the weights,
    and render follows it)."""
    dropout: float | None = option(None, ge=0, lt=1)
    """Dropout in the view and ray transformers while pretraining (GNT's 0.1; holds no
    weights, so it needs no new architecture and renders ignore it)."""
    dec_norm: bool = False
    """GNT's InstanceNorm after the encoder decoder's skip-merging convolutions
    (``GNFRConfig.dec_norm``): a new architecture, so only from scratch or from weights
    that have it; recorded in the weights' config."""
    random_sources: bool = False
    """GNT's draw of the N sources in a random order of the round(k N) nearest pool instead of
    the nearest first (``TrainConfig.random_sources``; the View Sampler's flare rule kept)."""
    lr_restart: float | None = option(None, gt=0, le=1)
    """Warm restart: from the step the run starts at (``--init``'s recorded step; kept when
    the run resumes) the rates start again at this fraction of the preset's and halve on the
    preset's schedule (for continuing a run whose rates have decayed to nothing)."""
    mirror: bool = False
    """Train on each scene's mirror image too (every view flipped left-right, its camera
    reflected: a consistent second scene with its own synthetic flare draw), doubling the
    scenes the prior sees. Recorded in the weights' metadata (``pretrain_mirror``)."""
    layered: int = option(0, ge=0)
    """Add this many synthetic layered scenes (``workflows.research.layered_scenes``:
    textured planes cut from the training scenes' photos, rendered exactly), each with its
    own synthetic flare draw; recorded in the weights' metadata (``pretrain_layered``). Off
    by default: 40 of them made the ``quick`` prior worse on the development scenes
    (docs/history/gnfr.md, "Twenty-first session")."""
    layered_share: float = option(0.3, gt=0, lt=1)
    """With ``layered``: the fraction of steps that draw a layered scene (the rest draw a
    real scene, uniformly)."""
    exposure_match: bool = False
    """Bring each workspace scene's views to their common exposure before training (one gain
    per view and channel from its depth maps, ``pipeline.exposure``, as ``finetune
    --exposure-match`` does on by default), so the prior learns from sources exposed as its
    targets are. Scenes without depth maps (LLFF, COLMAP, scene packs, workspaces before
    ``deflare-scene depth``) keep their own exposures, each with a warning. Recorded in the
    weights' metadata (``pretrain_exposure_match``: the scenes evened out). Off by default:
    it did not pass its rule on the development scenes (docs/history/gnfr.md, "Sixty-ninth
    session")."""
    source_flare: float = option(0.0, ge=0, le=1)
    """The share of steps (drawn at random) whose sources are read from a flared twin of
    their scene (``pipeline.source_flare``: one more synthetic flare on every view, drawn as
    ``synth`` draws it, one lens and light per twin, masked; ``TWINS`` per scene, drawn once
    from the seed) while the target stays as loaded, so points every source shows on flare
    are supervised across scenes (``finetune --source-flare`` does it for one scene).
    Recorded in the weights' metadata (``pretrain_source_flare``). 0 (the default): never.
    With ``flare_flag`` it raised the development scenes' novel views but not their
    de-flared photos, so it is off (docs/history/gnfr.md, "Seventy-first session")."""
    flare_flag: bool = False
    """Give each source's colour and features one more input, 1 where the point is on flare
    in that source (``GNFRConfig.flare_flag``; weights without it load with the flag's input
    at zero), so the prior learns across scenes what the flag means; recorded in the
    weights' config, and a fine-tune from them keeps it."""
    flare: bool = True
    """Impose synthetic flare (pipeline.flare) with ground-truth masks."""
    flare_prob: float = option(0.5, ge=0, le=1)
    """Fraction of views that get flare."""
    max_size: int = option(504, ge=64)
    """Long side of the images scenes are loaded at."""
    device: str = option("auto", device=True)
    """auto | cpu | cuda (with torchrun: cuda:LOCAL_RANK) | cuda:N."""
    seed: int = option(0, ge=0)
    """Seed of initialisation and sampling."""
    init: str = option("scratch", choices=("scratch", "auto"), suffix=".safetensors")
    """scratch | auto (shipped weights) | path to a .safetensors checkpoint."""


FREE_ON_RESUME = frozenset({"scenes", "out", "iters", "ckpt_every", "device", "init"})
"""Options a resumed run may change (``workflows.research.run_settings``): more steps,
checkpoint spacing, the device, and ``init`` (read only at a fresh start); the scenes are
compared by folder name, so the same scenes at another path resume. Any other change is
refused."""


def find_scenes(paths: list[Path]) -> list[Path]:
    """Scene folders among ``paths`` and their sub-folders, held-out scenes removed."""
    found = []
    for p in paths:
        cands = [p] if scene_layout(p) else sorted(
            q for q in p.iterdir() if q.is_dir() and scene_layout(q)) if p.is_dir() else []
        if not cands:
            raise UserError(f"{p} holds no scene (workspace, LLFF or COLMAP folder, scene pack)")
        found += cands
    kept = [p for p in found if p.name.removesuffix(".deflare") not in HELDOUT_SCENES]
    for p in sorted(set(found) - set(kept)):
        warn(f"pretrain: leaving out held-out evaluation scene {p}")
    if not kept:
        raise UserError("pretrain: no training scene left after removing held-out scenes")
    return kept


def impose_flare(scene: Scene, prob: float, rng: np.random.Generator) -> Scene:
    """Synthetic flare on a random ``prob`` of the views, with their masks and fractions."""
    from pipeline.flare import FlareConfig, synthesize

    cfg = FlareConfig()
    imgs = scene.images.clone()
    masks = torch.zeros(imgs.shape[0], 1, *imgs.shape[-2:], dtype=torch.uint8)
    for i in range(imgs.shape[0]):
        if rng.random() >= prob:
            continue
        view = scene.own(i, imgs[i])  # the view itself, its padding (Scene.extents) left out
        flared, layers = synthesize(view.permute(1, 2, 0).numpy(), cfg, rng)
        view[:] = torch.from_numpy(np.round(flared * 255).astype(np.uint8)).permute(2, 0, 1)
        scene.own(i, masks[i, 0])[:] = torch.from_numpy(layers.mask.astype(np.uint8))
    flare = {s: float(scene.own(i, masks[i]).float().mean()) for i, s in enumerate(scene.stems)}
    # the synthetic flare changes which views may be targets: the rule decides again
    return replace(scene, images=imgs, masks=masks, flare=flare, targets=None)


def load_evened(folder: Path, max_size: int) -> tuple[Scene, bool]:
    """``--exposure-match``: a scene with its views at their common exposure when it is a
    workspace with depth maps (``pipeline.finetune.exposure_gains``), else as it is, with a
    warning; and whether it was evened out."""
    if scene_layout(folder) == "workspace":
        gains = exposure_gains(Workspace(folder), command="pretrain --exposure-match")
        if gains:
            return load_workspace(folder, gains=gains), True
    else:
        warn(f"pretrain --exposure-match: {folder} is not a deflare-scene workspace (no depth "
             "maps to even its exposures out): its views are trained at their own exposures")
    return detect_and_load(folder, max_size), False


def load_scenes(config: PretrainConfig, folders: list[Path] | None = None,
                evened: list[str] | None = None) -> list[Scene]:
    """Every training scene of ``config.scenes`` (or the ``folders`` already found in
    them), and its mirror image with ``config.mirror``, each with its own synthetic flare
    when asked; then ``config.layered`` layered scenes (last in the list). With
    ``config.exposure_match`` each workspace with depth maps at its common exposure, its
    name appended to ``evened``."""
    from pipeline.progress import track

    rng = np.random.default_rng(config.seed)
    scenes, photos = [], []
    for folder in track(folders or find_scenes(config.scenes), "loading scenes"):
        if config.exposure_match:
            loaded, even = load_evened(folder, config.max_size)
            if even and evened is not None:
                evened.append(loaded.name)
        else:
            loaded = detect_and_load(folder, config.max_size)
        photos += [v.permute(1, 2, 0).numpy() for v in loaded.images]  # views, not copies
        for scene in (loaded, mirrored(loaded)) if config.mirror else (loaded,):
            if config.flare:
                scene = impose_flare(scene, config.flare_prob, rng)
            scenes.append(scene)
    if config.layered:
        from workflows.research.layered_scenes import LayeredConfig, layered_scenes

        info(f"pretrain: drawing {config.layered} layered scenes from {len(photos)} photos")
        size = (config.max_size, round(config.max_size * 0.75))  # 4:3 at the load size
        for scene in layered_scenes(config.layered, photos, config.seed, LayeredConfig(
                size=size)):
            scenes.append(impose_flare(scene, config.flare_prob, rng) if config.flare
                          else scene)
    return scenes


def start_step(cfg: TrainConfig, init: str, preset: str) -> int:
    """The step a run started from pretrained weights continues at: the ``step`` recorded in
    the weights' metadata when they come from the same preset (so the learning-rate schedule
    and step count go on where that run stopped; its optimizer state is not shipped), else 0.
    ``run`` refuses an ``iters`` that is not above it."""
    from gnfr.checkpoint import read_metadata

    path = init_path(cfg, init)
    if path is None or not Path(path).is_file():
        return 0
    try:
        _, meta = read_metadata(path)
    except CheckpointError as e:
        raise UserError(f"--init {path}: {e}: pass GN-FR weights (a .safetensors file that "
                        "pretrain or finetune wrote)") from None
    if meta.get("preset") != preset:
        return 0
    return int(meta.get("step", 0))


# --------------------------------------------------------------------------- distributed
def setup_distributed(device_name: str) -> tuple[int, int, torch.device]:
    """(rank, world size, device); initialises the process group under torchrun."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    rank = int(os.environ.get("RANK", "0"))
    name = resolve_device(device_name)
    if name == "cuda":  # auto on a GPU machine, or cuda: this rank's GPU
        device = torch.device("cuda", int(os.environ.get("LOCAL_RANK", "0")))
        torch.cuda.set_device(device)
    else:
        device = torch.device(name)
    if world > 1 and not torch.distributed.is_initialized():
        torch.distributed.init_process_group("nccl" if device.type == "cuda" else "gloo")
    return rank, world, device


def allreduce_grads(model: torch.nn.Module) -> None:
    """Average gradients over ranks in one flat buffer (params without grad count as 0)."""
    params = [p for p in model.parameters() if p.requires_grad]
    flat = torch.cat([(p.grad if p.grad is not None else torch.zeros_like(p)).reshape(-1)
                      for p in params])
    torch.distributed.all_reduce(flat)
    flat /= torch.distributed.get_world_size()
    i = 0
    for p in params:
        n = p.numel()
        p.grad = flat[i:i + n].view_as(p).clone()
        i += n


def broadcast_params(model: torch.nn.Module) -> None:
    for t in model.state_dict().values():
        torch.distributed.broadcast(t, 0)


# --------------------------------------------------------------------------- training
def train_config(config: PretrainConfig, train: TrainConfig | None = None) -> TrainConfig:
    """The preset's TrainConfig (or ``train``, which replaces it entirely) with the options
    ``config`` sets: steps, checkpoint interval, full-resolution colour, dropout, the decoder's
    InstanceNorm, random sources, the flare flag and the seed."""
    cfg = train or PRESETS[config.preset]
    over = {k: v for k, v in (("iters", config.iters), ("ckpt_every", config.ckpt_every))
            if v is not None}
    over |= {k: True for k in ("full_res_colour", "random_sources") if getattr(config, k)}
    model = {k: True for k in ("dec_norm", "flare_flag") if getattr(config, k)}
    if config.dropout is not None:
        model["dropout"] = config.dropout
    return replace(cfg, **over, model=replace(cfg.model, **model), seed=config.seed)


def scene_draws(scenes: list[Scene], banks: list, twins: list[list], config: PretrainConfig,
                train_cfg: TrainConfig):
    """The pretraining's batches: a random scene (a layered one, the last
    ``config.layered`` of ``scenes``, at ``layered_share`` of the steps when there are any),
    then a batch of it with its sources (``banks``); with ``source_flare`` its sources are,
    that often, one of its flared ``twins``' (none for the layered scenes)."""
    real = len(scenes) - config.layered

    def draw(gen: torch.Generator) -> StepInput:
        if config.layered and float(torch.rand((), generator=gen)) < config.layered_share:
            k = real + int(torch.randint(config.layered, (1,), generator=gen))
        else:
            k = int(torch.randint(real, (1,), generator=gen))
        batch = sample_batch(scenes[k], train_cfg, gen)
        if k < real and twins and float(torch.rand((), generator=gen)) < config.source_flare:
            j = int(torch.randint(len(twins[k]), (1,), generator=gen))
            return StepInput(batch, *twins[k][j], fields={"scene": scenes[k].name, "twin": j})
        return StepInput(batch, *banks[k], fields={"scene": scenes[k].name})

    return draw


def data_meta(config: PretrainConfig, evened: list[str]) -> dict:
    """What the pretraining's data was, for the weights' metadata: mirrored, layered scenes
    and their share, the scenes brought to one exposure (``evened``), source flare."""
    return ({"pretrain_mirror": True} if config.mirror else {}) | (
        {"pretrain_layered": config.layered, "pretrain_layered_share": config.layered_share}
        if config.layered else {}) | (
        {"pretrain_exposure_match": evened} if config.exposure_match else {}) | (
        {"pretrain_source_flare": config.source_flare} if config.source_flare else {})


def run(config: PretrainConfig, train: TrainConfig | None = None) -> Path:
    """Pretrain; returns the weight file. ``train`` overrides the preset entirely."""
    validate(config)
    rank, world, device = setup_distributed(config.device)
    train_cfg = train_config(config, train)
    folders = find_scenes(config.scenes)  # a bad scene path fails before OUT is made
    out = Path(config.out)
    step = start_step(train_cfg, config.init, config.preset)
    resume = has_checkpoint(out)
    settings = {**{k: v for k, v in asdict(config).items() if k not in FREE_ON_RESUME},
                "scenes": [f.name for f in folders]}  # by name: paths differ by machine
    if resume:  # a run of other settings is never resumed from
        refuse_other_settings(out, settings, "pretrain")
    if config.lr_restart is not None:
        train_cfg = replace(train_cfg, lr_restart=config.lr_restart, lr_restart_step=step)
    if step and not resume and step >= train_cfg.iters:
        raise UserError(f"--init {config.init} was trained to step {step} with preset "
                        f"{config.preset}: give --iters above {step} to train it further")
    evened: list[str] = []
    scenes = load_scenes(config, folders, evened)  # an unreadable scene fails before OUT is made
    model, how = init_model(train_cfg, device, config.init)  # so does an --init that misfits
    out.mkdir(parents=True, exist_ok=True)
    if rank == 0:
        record_settings(out, settings)
    trainer = Trainer(model, train_cfg, step=step)
    if step:
        how += f", continuing its step count at {step} (fresh optimizer state)"
    if resume:  # weights, optimizer, step; the sampler is re-seeded below, not restored
        try:
            trainer.restore(out, rng=False)
        except CheckpointError as e:
            raise UserError(f"{e}: resume {out} with the options it was started with "
                            "(e.g. --dec-norm, --preset), or give another --out") from None
        how = f"resuming at step {trainer.step}"
    if world > 1:
        broadcast_params(model)
    if rank == 0:
        info(f"pretrain: {len(scenes)} scenes, {world} process(es) on {device.type}, "
             f"{train_cfg.iters} steps, {how}")
    trainer.gen = torch.Generator().manual_seed(train_cfg.seed * 1_000_003 + rank * 7919
                                                + trainer.step)
    banks = [prepare_sources(model, scene, train_cfg, device) for scene in scenes]
    twins = source_twins(model, scenes[:len(scenes) - config.layered], config, train_cfg, device)
    draw = scene_draws(scenes, banks, twins, config, train_cfg)
    data = data_meta(config, evened)
    with make_progress() as prog:
        task = prog.add_task("pretrain", total=train_cfg.iters, completed=trainer.step)
        trainer.run(draw, out=out,
                    meta=lambda at_step, _: {**render_meta(train_cfg, config.preset, at_step),
                                             **data},
                    record=last_record, grad_hook=allreduce_grads if world > 1 else None,
                    writer=rank == 0,
                    report=lambda at_step, _, __: prog.update(task, completed=at_step))
    if world > 1:
        torch.distributed.barrier()
    return out / MODEL_FILE


def source_twins(model, scenes: list[Scene], config: PretrainConfig, train_cfg: TrainConfig,
                 device) -> list[list]:
    """``--source-flare``: for each scene its ``TWINS`` flared twins' sources (bank, cache),
    drawn once from the run's seed, the scene's index in the list and the twin's; [] when
    the option is off."""
    if config.source_flare <= 0:
        return []
    from pipeline.progress import track
    from pipeline.source_flare import TWINS, flared_twins

    return [[prepare_sources(model, t, train_cfg, device)
             for t in flared_twins(scene, config.seed * 1000 + k, TWINS)]
            for k, scene in enumerate(track(scenes, f"drawing {TWINS} flared twins a scene"))]


def export_fp16(run_weights: Path, dest: Path, extra: dict | None = None) -> Path:
    """Ship a pretraining checkpoint: fp16 weights with its metadata (plus ``extra``)."""
    from gnfr.checkpoint import load_model, read_metadata, save_model

    _, meta = read_metadata(run_weights)
    model = load_model(run_weights)
    return save_model(dest, model, {**meta, **(extra or {})}, dtype=torch.float16)


def main(argv: list[str] | None = None) -> int:
    """Entry for torchrun: ``python -m workflows.research.pretrain [options]`` (same as the CLI)."""
    from workflows.cli import main as cli_main

    return cli_main(["pretrain", *(argv if argv is not None else __import__("sys").argv[1:])])


if __name__ == "__main__":
    raise SystemExit(main())
