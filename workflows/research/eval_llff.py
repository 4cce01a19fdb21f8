"""`deflare-scene eval-llff SCENE`: GN-FR on an LLFF scene in the field's standard protocol.

The field's yardstick: every 8th view held out, train on the rest, score renders of the
held-out views.

SCENE is an LLFF folder (``poses_bounds.npy`` + ``images/`` or ``images_<factor>/``), read
with ``pipeline.training_scenes.load_llff`` (its image folder choice, resize to ``max_size``,
intrinsics and the normalised world frame). ``OUT`` (``--out``) holds
```
OUT/posed/                  workspace of EVERY view with the ground-truth LLFF cameras
                            (images, decoded, cameras.json as pinhole; no COLMAP)
OUT/clean_scene/            synth-style folder of the clean protocol: photos/ (training
                            views), clean/ (all), masks_gt/ (all empty), cameras_gt.json,
                            split.json (the LLFF split)
OUT/clean.ws/               its evaluation workspace: mask (the empty masks), depth, select,
                            variants/gnfr/ (finetune, renders/heldout_<fill>/ per fill)
OUT/flare_scene/, flare.ws/ with --flare: synthetic flare on the TRAINING views only
                            (`deflare-scene synth`, held-out views stay clean), then
                            `deflare-scene eval` with the true masks (GN-FR vs vanilla GNT)
OUT/results.json, table.md  scores with provenance, beside published per-scene numbers
```
Clean protocol: every view is flare-free, so GN-FR's flare parts have nothing to act on and
the numbers measure novel-view synthesis of the fine-tuned model (the hybrid fill also
warps photos by depth where they agree). The held-out cameras are rendered at full size
(504x378 for LLFF images_8) through a JSON camera path, once per ``--fill``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pipeline.cameras import Cameras, Frame
from pipeline.errors import UserError
from pipeline.images import image_size, list_photos
from pipeline.options import option, validate
from pipeline.progress import info
from pipeline.workspace import (
    Workspace,
    atomic_imwrite,
    atomic_write_json,
    atomic_write_text,
    read_json,
)
from pipeline.ws_files import read_cameras, write_cameras

PUBLISHED = {
    "fern": [
        {"method": "NeRF (Mildenhall et al., ECCV 2020)", "psnr": 25.17, "ssim": 0.792,
         "setting": "per-scene optimisation, 1008x756, LLFF per-scene table"},
        {"method": "IBRNet, fine-tuned (Wang et al., CVPR 2021)", "psnr": None, "ssim": None,
         "setting": "to be cited: the per-scene fern numbers were not found by this "
                    "project's search; not filled in from memory"},
        {"method": "GNT, single-scene (Varma et al., ICLR 2023)", "psnr": None, "ssim": None,
         "setting": "to be cited: the per-scene fern numbers were not found by this "
                    "project's search; not filled in from memory"},
    ],
}
"""Published per-scene numbers of the held-out views (PSNR dB, SSIM); None = to be cited."""


@dataclass
class LlffEvalConfig:
    """Options of `deflare-scene eval-llff`."""

    scene: Path
    """LLFF folder (poses_bounds.npy + images/ or images_<factor>/), e.g.
    ../shared/data/scenes/fern."""
    out: Path | None = None
    """Output folder (default ./<scene name>.llff_eval); results in OUT/results.json,
    OUT/table.md."""
    every: int = option(8, ge=2)
    """Hold out every K-th view (index % K == 0; the LLFF protocol is 8)."""
    max_size: int = option(504, ge=32)
    """Long side of the images (load_llff picks images_<factor> and resizes; LLFF: 504)."""
    preset: str = option("auto", choices=("auto", "paper", "quick", "tiny"))
    """Training preset: auto (paper on CUDA, quick on CPU) | quick | paper | tiny (smoke tests
    only)."""
    iters: int | None = option(None, ge=1)
    """Override the preset's steps."""
    rays: int | None = option(None, ge=1)
    """Override rays per step."""
    samples: int | None = option(None, ge=1)
    """Override samples per ray (training and rendering)."""
    views: int | None = option(None, ge=1)
    """Override the number of source views."""
    init: str = option("auto", choices=("auto", "scratch"), suffix=".safetensors")
    """Weights to start from: auto | scratch | FILE.safetensors (as finetune --init)."""
    device: str = option("auto", device=True)
    """auto | cpu | cuda | cuda:N."""
    seed: int = option(0, ge=0)
    """Training seed."""
    fills: tuple[str, ...] = option(("hybrid", "network"), flag="--fill",
                                    choices=("hybrid", "network"))
    """Render fills of the held-out views, comma-separated (render --fill), each rendered and
    scored; the flare protocol uses the first."""
    flare: bool = False
    """Also impose synthetic flare on the training views and compare GN-FR with vanilla GNT
    (`eval` with the true masks)."""
    variants: tuple[str, ...] = option(
        ("gnfr", "gnt", "input"),
        choices=("gnfr", "gnt", "no_ps", "no_vs", "no_ml", "input", "inpaint", "photos"))
    """Methods of the flare protocol (as `eval --variants`)."""
    flare_seed: int = option(0, ge=0)
    """Seed of the synthetic flare (synth --seed)."""
    force: bool = False
    """Redo every stage."""
    finetune_extra: dict = field(default_factory=dict)
    """Extra FinetuneConfig fields (Python API: tests)."""


# --------------------------------------------------------------------------- the scene
def llff_split(stems: list[str], every: int) -> tuple[list[str], list[str]]:
    """(train, heldout): index % every == 0 is held out (the LLFF protocol, every=8)."""
    if every < 2:
        raise UserError(f"--every {every}: hold out every K-th view with K >= 2 (LLFF: 8)")
    held = [s for i, s in enumerate(stems) if i % every == 0]
    train = [s for s in stems if s not in held]
    if len(train) < 3:
        raise UserError(f"{len(stems)} views leave {len(train)} for training with --every "
                        f"{every}: need at least 3")
    return train, held


def pinhole(K: np.ndarray, W: int, H: int) -> dict:
    """The COLMAP PINHOLE camera of ``K`` at W x H."""
    return {"model": "PINHOLE", "width": int(W), "height": int(H),
            "params": [float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])]}


def llff_cameras(llff, names: dict[str, str]) -> Cameras:
    """The cameras of a loaded LLFF scene (``gnfr.train.Scene``) as cameras.json frames."""
    H, W = llff.images.shape[-2:]
    frames = []
    for i, stem in enumerate(llff.stems):
        K = llff.K[i].numpy()
        frames.append(Frame(names[stem], stem, K, int(W), int(H), llff.c2w[i].numpy(),
                            float(llff.near[i]), float(llff.far[i]), pinhole(K, W, H)))
    return Cameras(frames, np.eye(4))


def posed_workspace(folder: Path, out: Path, max_size: int, force: bool = False) -> Workspace:
    """OUT/posed: every view of the LLFF scene with its ground-truth camera (pose stage
    recorded as ground truth; images = decoded, pinhole)."""
    from pipeline.training_scenes import _llff_image_dir, load_llff

    folder = Path(folder).resolve()
    if not (folder / "poses_bounds.npy").is_file():
        raise UserError(f"{folder / 'poses_bounds.npy'} is missing: SCENE must be an LLFF "
                        "folder (poses_bounds.npy + images/ or images_<factor>/)")
    img_dir = _llff_image_dir(folder, max_size)
    ws = Workspace.create(out, folder)
    params = {"cameras": "ground truth (LLFF poses_bounds.npy, pipeline.training_scenes.load_llff)",
              "scene": str(folder), "image_dir": img_dir.name, "max_size": max_size}
    stage = ws.begin_stage("pose", params, [folder / "poses_bounds.npy", img_dir], force)
    if stage.skip:
        return ws
    llff = load_llff(folder, max_size)
    names = {p.stem: p.name for p in list_photos(img_dir)}  # the files load_llff read
    for i, stem in enumerate(llff.stems):
        bgr = np.ascontiguousarray(llff.images[i].permute(1, 2, 0).numpy()[..., ::-1])
        atomic_imwrite(ws.image_path(stem), bgr)
        atomic_imwrite(ws.decoded_path(stem), bgr)
    write_cameras(ws, llff_cameras(llff, names))
    ws.record_stage("decode", {"from": str(img_dir), "max_size": max_size}, [ws.decoded])
    stage.finish([ws.images, ws.cameras_json], extra={"views": len(llff.stems)})
    return ws


def write_clean_scene(posed: Workspace, out: Path, train: list[str], held: list[str],
                      origin: str, every: int) -> Path:
    """A synth-style folder of the clean scene (no flare anywhere) for `eval`'s loaders."""
    from workflows.research.eval.workspaces import link_file

    for stem in read_cameras(posed).stems:
        src = posed.image_path(stem)
        link_file(src, out / "clean" / f"{stem}.png")
        if stem in train:
            link_file(src, out / "photos" / f"{stem}.png")
        mask_path = out / "masks_gt" / f"{stem}.png"
        if not mask_path.exists():
            h, w = image_size(src, fix="rerun `deflare-scene eval-llff` with --force")
            atomic_imwrite(mask_path, np.zeros((h, w), np.uint8))
    for photo in (out / "photos").glob("*.png"):  # a changed split
        if photo.stem not in train:
            photo.unlink()
    split = {"train": train, "heldout": held, "origin": origin, "protocol":
             f"LLFF: every {every}th view held out (index % {every} == 0), no flare"}
    if not (out / "split.json").exists() or read_json(out / "split.json") != split:
        atomic_write_json(out / "split.json", split)
    link_file(posed.cameras_json, out / "cameras_gt.json")
    return out


# --------------------------------------------------------------------------- protocols
def eval_config(cfg: LlffEvalConfig, scene: Path, out: Path, fill: str):
    """The EvalConfig of a protocol: true masks, held-out views at full size."""
    from workflows.research.eval.config import EvalConfig

    return EvalConfig(scene=scene, out=out, masks="gt", preset=cfg.preset, iters=cfg.iters,
                      rays=cfg.rays, samples=cfg.samples, views=cfg.views, init=cfg.init,
                      render_scale=1.0, device=cfg.device, seed=cfg.seed, fill=fill,
                      force=cfg.force, finetune_extra=cfg.finetune_extra,
                      variants=cfg.variants)


def run_clean(cfg: LlffEvalConfig, root: Path, posed: Workspace, train: list[str],
              held: list[str], origin: str) -> dict:
    """The clean protocol: GN-FR fine-tuned on the training views, held-out views rendered
    with each fill at full size and scored."""
    from pipeline import depth, finetune, mask, render, select
    from pipeline.render import RenderConfig
    from workflows.research.eval.methods import finetune_config
    from workflows.research.eval.provenance import budget, method_provenance, run_provenance
    from workflows.research.eval.scene import load_synth
    from workflows.research.eval.scoring import score_views
    from workflows.research.eval.workspaces import (
        build_workspace,
        heldout_path_json,
        variant_workspace,
    )

    folder = write_clean_scene(posed, root / "clean_scene", train, held, origin, cfg.every)
    scene = load_synth(folder)
    eval_cfg = eval_config(cfg, folder, root / "clean.ws", cfg.fills[0])
    base = build_workspace(scene, root / "clean.ws", cfg.force)
    mask.run(mask.MaskConfig(masks_dir=folder / "masks_gt", device=cfg.device), base,
             force=cfg.force)
    depth.run(depth.DepthConfig(), base, force=cfg.force)
    select.run(select.SelectConfig(), base, force=cfg.force)
    path_json = heldout_path_json(scene, base)
    variant_ws = variant_workspace(base, "gnfr")
    info(f"eval-llff: fine-tuning GN-FR on {len(train)} views in {variant_ws.root}")
    finetune.run(finetune_config(eval_cfg, "gnfr"), variant_ws, force=cfg.force)
    methods = {}
    for fill in cfg.fills:
        fill_path = base.eval / f"heldout_{fill}.json"  # one camera path (render) per fill
        if not fill_path.exists() or read_json(fill_path) != read_json(path_json):
            atomic_write_json(fill_path, read_json(path_json))
        render.run(RenderConfig(path=str(fill_path), scale=1.0, fill=fill, device=cfg.device,
                                samples=cfg.samples, source_fade=0,  # cameras, no video
                                path_exposure=0.0),
                   variant_ws, force=cfg.force)
        renders = variant_ws.render_dir(str(fill_path))
        methods[f"gnfr_{fill}"] = {
            "label": f"GN-FR, fill {fill}", "fill": fill,
            "heldout": score_views(scene, renders, held, with_region=False),
            "renders": str(renders),
            "render_seconds": variant_ws.stage_record(f"render:{fill_path.stem}").get("seconds")}
    prov = method_provenance("gnfr", {"workspace": variant_ws.root}, base)  # after renders
    for method in methods.values():
        method["provenance"] = prov
    return {"scene": str(folder), "workspace": str(base.root),
            "budget": budget(eval_cfg), "provenance": run_provenance(base),
            "methods": methods}


def run_flare(cfg: LlffEvalConfig, root: Path, posed: Workspace, held: list[str]) -> dict:
    """The flare protocol: `synth` (flare on the training views; the LLFF split) and `eval`
    with the true masks; returns eval's results."""
    from pipeline.synth import SynthConfig
    from pipeline.synth import run as synth_run
    from workflows.research.eval import run as run_eval

    out = root / "flare_scene"
    synth_run(SynthConfig(out=out, seed=cfg.flare_seed, heldout_every=cfg.every), posed,
              force=cfg.force)
    got = read_json(out / "split.json")["heldout"]
    if got != held:
        raise UserError(f"{out}/split.json holds out {got}, not the LLFF views {held}: "
                        "rerun with --force")
    folder = run_eval(eval_config(cfg, out, root / "flare.ws", cfg.fills[0]))
    return read_json(folder / "results.json")


def run(cfg: LlffEvalConfig) -> Path:
    """Run the protocol(s); returns OUT/results.json (and writes OUT/table.md)."""
    from pipeline.training_scenes import load_llff

    t0 = time.time()
    validate(cfg)
    if not cfg.fills:
        raise UserError("--fill is empty: give hybrid, network or both (comma-separated)")
    folder = Path(cfg.scene).resolve()
    root = Path(cfg.out or Path.cwd() / f"{folder.name}.llff_eval").resolve()
    posed = posed_workspace(folder, root / "posed", cfg.max_size, cfg.force)
    stems = read_cameras(posed).stems
    train, held = llff_split(stems, cfg.every)
    info(f"eval-llff: {folder.name}: {len(train)} training views, held out {', '.join(held)}")
    H, W = load_llff(folder, cfg.max_size).images.shape[-2:]
    res = {"protocol": f"LLFF: every {cfg.every}th view held out (index % {cfg.every} == 0), "
                       "train on the rest, held-out renders at full size against the photos",
           "scene": str(folder), "origin": folder.name, "size": [int(W), int(H)],
           "train_views": train, "heldout_views": held,
           "published": PUBLISHED.get(folder.name, []),
           "clean": run_clean(cfg, root, posed, train, held, folder.name)}
    if cfg.flare:
        res["flare"] = run_flare(cfg, root, posed, held)
    res["seconds"] = round(time.time() - t0, 1)
    atomic_write_json(root / "results.json", res)
    atomic_write_text(root / "table.md", table_markdown(res))
    info(f"eval-llff: wrote {root / 'results.json'} and table.md")
    return root / "results.json"


# --------------------------------------------------------------------------- table
def table_markdown(res: dict) -> str:
    """OUT/table.md: the clean protocol's scores beside published ones (and the flare
    protocol's table)."""
    from workflows.research.eval.report import format_or_dash, provenance_lines
    from workflows.research.eval.report import table_markdown as eval_table

    clean = res["clean"]
    budget = clean["budget"]
    lines = [f"# deflare-scene eval-llff: {res['origin']}", "",
             f"- Protocol: {res['protocol']}; {len(res['train_views'])} training views, "
             f"held out {', '.join(res['heldout_views'])}; {res['size'][0]}x{res['size'][1]}; "
             "ground-truth LLFF cameras.",
             f"- Asked: preset `{budget['preset']}` on {budget['device']}, "
             f"{budget['iters']} steps, {budget['rays']} rays x {budget['samples']} samples, "
             f"depth {budget['depth']} width {budget['width']}, `--init {budget['init']}`.",
             *provenance_lines(clean), "",
             "| method | held-out PSNR | held-out SSIM | setting |", "|---|---:|---:|---|"]
    for method in clean["methods"].values():
        summary = method["provenance"].get("summary") or {}
        heldout = method["heldout"]
        lines.append(f"| {method['label']} (this project) | "
                     f"{format_or_dash(heldout.get('psnr'))} | "
                     f"{format_or_dash(heldout.get('ssim'), '{:.3f}')} | preset "
                     f"{summary.get('preset')}, {summary.get('steps_done')} steps from "
                     f"{summary.get('trained_from')}, {summary.get('device')} |")
    for published in res["published"]:
        lines.append(f"| {published['method']} (published) | "
                     f"{format_or_dash(published['psnr'])} | "
                     f"{format_or_dash(published['ssim'], '{:.3f}')} | "
                     f"{published['setting']} |")
    lines += ["", "PSNR in dB and SSIM (pipeline/metrics.py) of the held-out photos; "
              "published numbers are at the paper's full budget (GPU, 1008x756 for NeRF).", ""]
    if "flare" in res:
        lines += ["## With synthetic flare on the training views", "",
                  eval_table(res["flare"])]
    lines.append(f"Wall time of this command: {res['seconds']:.0f} s.")
    return "\n".join(lines) + "\n"
