"""`deflare-scene eval SCENE`: GN-FR against its ablations and baselines on a synth scene.

SCENE is a folder written by ``deflare-scene synth`` (``photos/`` flared training views,
``clean/`` ground truth of every view, ``masks_gt/``, ``cameras_gt.json``, ``split.json``).
The evaluation workspace (``--out``, default ``SCENE/eval.ws``) is laid out as
```
WS/images, decoded, cameras.json     the flared training photos with their GROUND-TRUTH
                                     cameras (no pose noise; pinhole, decoded = images)
WS/masks, flare.json, views.json     mask (FMG, or masks_gt with --masks gt) and select
WS/variants/<name>/                  one workspace per neural variant (inputs hard-linked
                                     from WS): model/, deflared/, renders/heldout_cameras/
WS/baselines/inpaint/<stem>.png      single-image inpainting of the masked region
WS/baselines/photos[_heldout]/       neighbours warped by plane-sweep depth (no network)
WS/eval/heldout_cameras.json         the held-out cameras as a JSON camera path
WS/eval/table.md, results.json, grid.jpg
```
Every neural variant trains with the same budget (preset, steps, rays, samples, seed) and is
rendered twice: the held-out cameras (novel views, full renders at ``render_scale``) and the
input views (``render --path inputs``: the product's de-flared photos, flare region
re-rendered and blended). Each variant's finetune and renders are workspace stages, so an
interrupted evaluation resumes per variant; the scores are recomputed every run (seconds).

Scenes: evaluate only scenes of ``pipeline.datasets.TEST_SCENES`` (fern, kermit, cyprus), which
no training run uses; another scene is evaluated with a warning recorded in the results.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from pipeline import metrics
from pipeline.cameras import Cameras, Frame, load_cameras
from pipeline.datasets import HELDOUT_SCENES
from pipeline.errors import UserError
from pipeline.images import PHOTO_EXTS, read_image
from pipeline.progress import info, track, warn
from pipeline.workspace import Workspace, atomic_imwrite, atomic_write_json, read_json
from pipeline.ws_files import (
    read_cameras,
    read_flare,
    read_mask,
    read_mask_file,
    read_view_image,
    write_cameras,
)

NEURAL = {
    "gnfr": {"point_sampler": True, "view_sampler": True, "mask_loss": True},
    "gnt": {"point_sampler": False, "view_sampler": False, "mask_loss": False},
    "no_ps": {"point_sampler": False, "view_sampler": True, "mask_loss": True},
    "no_vs": {"point_sampler": True, "view_sampler": False, "mask_loss": True},
    "no_ml": {"point_sampler": True, "view_sampler": True, "mask_loss": False},
}
"""Neural variants: which of GN-FR's three parts each keeps."""
BASELINES = ("input", "inpaint", "photos")
ALL_VARIANTS = (*NEURAL, *BASELINES)
LABELS = {"gnfr": "GN-FR", "gnt": "GNT (all GN-FR parts off)",
          "no_ps": "GN-FR w/o Point Sampler", "no_vs": "GN-FR w/o View Sampler",
          "no_ml": "GN-FR w/o masking loss", "input": "flared input (no removal)",
          "inpaint": "inpainting of the mask (OpenCV Telea)",
          "photos": "photos warped by plane-sweep depth, no network (Telea where none agree)"}
SHARED_STAGES = ("decode", "pose", "mask", "depth", "select")
"""Stages whose outputs a variant workspace shares with the evaluation workspace."""


def linked_paths(ws: Workspace) -> list[Path]:
    """What a variant workspace shares with the evaluation workspace (hard links): the
    outputs of ``SHARED_STAGES`` that the variant's finetune and render read."""
    return [ws.images, ws.decoded, ws.masks, ws.cameras_json, ws.views_json, ws.flare_json,
            ws.depth]


@dataclass
class EvalConfig:
    """Options of `deflare-scene eval`."""

    scene: Path
    """Folder written by `deflare-scene synth`."""
    out: Path | None = None
    """Evaluation workspace (default SCENE/eval.ws)."""
    variants: tuple[str, ...] = ALL_VARIANTS
    """Methods to score: gnfr, gnt, no_ps, no_vs, no_ml, input, inpaint, photos."""
    masks: str = "fmg"
    """fmg (shipped FMG weights, or ``fmg_weights``) | gt (SCENE/masks_gt)."""
    fmg_weights: Path | None = None
    """FMG weights for --masks fmg (default: the shipped ones)."""
    preset: str = "auto"
    """Training preset of every neural variant (auto: paper on CUDA, quick on CPU)."""
    iters: int | None = None
    """Override the preset's steps (the same for every variant)."""
    rays: int | None = None
    """Override rays per step."""
    samples: int | None = None
    """Override samples per ray (training and rendering)."""
    views: int | None = None
    """Override the number of source views."""
    init: str = "auto"
    """Weights to start from: auto | scratch | FILE.safetensors (as finetune --init)."""
    render_scale: float = 0.5
    """Held-out views are rendered (and scored) at this fraction of their size."""
    device: str = "auto"
    """auto | cpu | cuda."""
    seed: int = 0
    """Seed of every variant's training."""
    color_match: bool = True
    """De-flared inputs with the render stage's colour match of the fill (as the product
    writes them); false scores the raw fill blended in."""
    fill: str = "hybrid"
    """Render fill of the neural variants (render --fill): hybrid (photos warped by depth
    where they agree, the network elsewhere) | network (the network everywhere)."""
    grid_rows: int = 4
    """Views (rows) in grid.jpg: held-out views first, then the most flared inputs."""
    force: bool = False
    """Redo every stage."""
    finetune_extra: dict = field(default_factory=dict)
    """Extra FinetuneConfig fields (tests, experiments)."""


# --------------------------------------------------------------------------- the scene
@dataclass
class SynthScene:
    root: Path
    cams: Cameras
    """Ground-truth cameras of every view."""
    train: list[str]
    heldout: list[str]
    origin: str
    """Name of the photo folder the clean scene came from (e.g. kermit)."""


def load_synth(root: Path) -> SynthScene:
    """Read and check a synth output folder."""
    root = Path(root).resolve()
    for name in ("photos", "clean", "masks_gt", "cameras_gt.json", "split.json"):
        if not (root / name).exists():
            raise UserError(f"{root / name} is missing: SCENE must be a folder written by "
                            "`deflare-scene synth WS --out SCENE`")
    split = read_json(root / "split.json")
    cams = load_cameras(root / "cameras_gt.json")
    train, held = list(split.get("train", [])), list(split.get("heldout", []))
    for s in train:
        if photo_path(root, s) is None:
            raise UserError(f"{root / 'photos' / (s + '.png')} is missing: rerun "
                            f"`deflare-scene synth ... --out {root} --force`")
    for s in train + held:
        if not (root / "clean" / f"{s}.png").is_file() or s not in cams.by_stem():
            raise UserError(f"{root}: view {s} has no clean image or camera: rerun synth")
    return SynthScene(root, cams, train, held, _origin(root))


def _origin(root: Path) -> str:
    """The photo folder name of the clean scene synth read (``origin`` in split.json, else
    the synth manifest, else the folder's own name)."""
    origin = read_json(root / "split.json").get("origin")
    if origin:
        return str(origin)
    try:
        ws = Path(Workspace(root).stage_record("synth")["params"]["workspace"])
        return Workspace(ws).scene_name if ws.exists() else ws.name
    except (KeyError, TypeError, UserError):
        return root.name


# --------------------------------------------------------------------------- workspaces
def photo_path(root: Path, stem: str) -> Path | None:
    """The flared photo of ``stem`` in ``root/photos`` (synth writes PNG; the shipped sample
    keeps its photos as JPEG), or None."""
    for ext in PHOTO_EXTS:
        if (root / "photos" / f"{stem}{ext}").is_file():
            return root / "photos" / f"{stem}{ext}"
    return None


def place_photo(src: Path, dst: Path) -> None:
    """``dst`` (a .png) holds the image of ``src``: a hard link when ``src`` is a PNG, else
    a lossless PNG re-encoding."""
    if src.suffix.lower() == ".png":
        link_file(src, dst)
    elif not dst.exists():
        atomic_imwrite(dst, read_image(src, bgr=True))


def link_file(src: Path, dst: Path) -> None:
    """Make ``dst`` a hard link of ``src`` (a copy across devices), atomically."""
    if dst.exists() and os.path.samefile(src, dst):
        return
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = dst.with_name(f".{dst.name}.link{os.getpid()}")
    tmp.unlink(missing_ok=True)
    try:
        os.link(src, tmp)
    except OSError:
        shutil.copy2(src, tmp)
    os.replace(tmp, dst)


def sync_tree(src: Path, dst: Path) -> None:
    """Mirror folder or file ``src`` at ``dst`` with hard links (extra files removed)."""
    if src.is_file():
        link_file(src, dst)
        return
    dst.mkdir(parents=True, exist_ok=True)
    names = {p.name for p in src.iterdir() if p.is_file() and not p.name.startswith(".")}
    for name in names:
        link_file(src / name, dst / name)
    for p in dst.iterdir():
        if p.is_file() and p.name not in names:
            p.unlink()


def pinhole_frame(f: Frame) -> Frame:
    """``f`` with its COLMAP camera replaced by the pinhole of its image (decoded = images)."""
    K = f.K
    cam = {"model": "PINHOLE", "width": f.width, "height": f.height,
           "params": [float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])]}
    return Frame(f.name, f.stem, K, f.width, f.height, f.c2w, f.near, f.far, cam)


def build_workspace(scene: SynthScene, out: Path, force: bool = False) -> Workspace:
    """The posed evaluation workspace: training photos + ground-truth cameras."""
    ws = Workspace.create(out, scene.root / "photos")
    run_ = ws.begin_stage("pose", {"cameras": "ground truth (synth cameras_gt.json)",
                                   "scene": str(scene.root)},
                          [scene.root / "photos", scene.root / "cameras_gt.json"], force)
    if run_.skip:
        return ws
    by = scene.cams.by_stem()
    frames = [pinhole_frame(by[s]) for s in scene.train]
    for s in scene.train:
        src = photo_path(scene.root, s)
        place_photo(src, ws.image_path(s))
        place_photo(src, ws.decoded_path(s))
    write_cameras(ws, Cameras(frames, scene.cams.colmap_to_world))
    ws.record_stage("decode", {"linked_from": str(scene.root / "photos")}, [ws.decoded])
    run_.finish([ws.images, ws.cameras_json])
    return ws


def variant_workspace(base: Workspace, name: str) -> Workspace:
    """WS/variants/<name>: a workspace sharing base's inputs and stage records."""
    vws = Workspace.create(base.variants / name, base.photos_dir)
    for path in linked_paths(base):
        sync_tree(path, vws.root / path.relative_to(base.root))
    vws.copy_stage_records(base, SHARED_STAGES)
    return vws


def heldout_path_json(scene: SynthScene, ws: Workspace) -> Path:
    """WS/eval/heldout_cameras.json: the held-out cameras as a JSON camera path."""
    from gnfr.paths import PathCamera, path_to_json

    by = scene.cams.by_stem()
    cams = [PathCamera(s, by[s].K, by[s].c2w, by[s].width, by[s].height)
            for s in scene.heldout]
    path = ws.eval / "heldout_cameras.json"
    data = path_to_json(cams)
    if not path.exists() or read_json(path) != _roundtrip(data):
        atomic_write_json(path, data)
    return path


def _roundtrip(obj):
    return json.loads(json.dumps(obj))


# --------------------------------------------------------------------------- methods
def finetune_config(cfg: EvalConfig, name: str):
    from pipeline.finetune import FinetuneConfig

    return FinetuneConfig(preset=cfg.preset, iters=cfg.iters, rays=cfg.rays,
                          samples=cfg.samples, views=cfg.views, device=cfg.device,
                          init=cfg.init, seed=cfg.seed, **NEURAL[name], **cfg.finetune_extra)


def run_neural(cfg: EvalConfig, base: Workspace, name: str, path_json: Path | None) -> dict:
    """Finetune and render one variant (each a resumable stage); paths of its outputs."""
    from pipeline import finetune, render
    from pipeline.render import RenderConfig

    vws = variant_workspace(base, name)
    info(f"eval: variant {name} ({LABELS[name]}) in {vws.root}")
    fcfg = finetune_config(cfg, name)
    finetune.run(fcfg, vws, force=cfg.force)
    _, tcfg = finetune.resolve(fcfg, finetune.pick_device(cfg.device))
    n = tcfg.eval_views
    # without the View Sampler, render from the nearest n views whatever their flare
    pool = {} if NEURAL[name]["view_sampler"] else {"n_sources": n, "pool": n}
    common = {"device": cfg.device, "samples": cfg.samples, "fill": cfg.fill, **pool}
    render.run(RenderConfig(path="inputs", color_match=cfg.color_match, **common), vws,
               force=cfg.force)
    out = {"inputs": vws.deflared, "workspace": vws.root}
    if path_json is not None:
        render.run(RenderConfig(path=str(path_json), scale=cfg.render_scale, **common), vws,
                   force=cfg.force)
        out["heldout"] = vws.render_dir(str(path_json))
    rec = vws.stage_record("finetune")
    out["train"] = {"seconds": rec.get("seconds"), "steps": rec.get("steps"),
                    "it_per_s": rec.get("it_per_s"),
                    "render_seconds": sum(vws.stage_record(k).get("seconds") or 0 for k in
                                          vws.manifest()["stages"] if k.startswith("render"))}
    return out


def run_inpaint(scene: SynthScene, ws: Workspace, radius: int = 5) -> Path:
    """WS/baselines/inpaint/<stem>.png: each flared photo inpainted (Telea) in its mask."""
    out = ws.baselines / "inpaint"
    for s in track(scene.train, "Inpainting (baseline)"):
        img = read_view_image(ws, s, bgr=True)
        m = cv2.dilate(read_mask(ws, s).astype(np.uint8), np.ones((3, 3), np.uint8))
        atomic_imwrite(out / f"{s}.png", cv2.inpaint(img, m, radius, cv2.INPAINT_TELEA))
    return out


def run_photos(scene: SynthScene, ws: Workspace, path_json: Path | None,
               scale: float = 1.0, n_sources: int = 4) -> dict:
    """The no-network baseline: WS/baselines/photos/<stem>.png, each flared photo's mask
    region filled from its ``n_sources`` nearest photos warped by WS/depth where at least
    two agree (pipeline/photo_fill.py), OpenCV Telea inpainting elsewhere; and with held-out
    cameras, WS/baselines/photos_heldout/<stem>.png rendered the same way at ``scale`` (holes
    inpainted).
    """
    from pipeline.depth import load_views, nearest_views
    from pipeline.photo_fill import photo_fill, support_weight

    cams = read_cameras(ws)
    views = load_views(ws, cams, cams.stems, with_depth=True)
    near = nearest_views(cams, n_sources)
    out = ws.baselines / "photos"
    for s in track(scene.train, "Photo fill (baseline)"):
        f, v = cams.by_stem()[s], views[s]
        flare = ~v.valid if v.valid is not None else np.zeros(v.image.shape[:2], bool)
        ref_valid = cv2.dilate(flare.astype(np.uint8), np.ones((9, 9), np.uint8)) == 0
        pf = photo_fill(f.K, f.c2w, v.size, [views[n] for n in near[s]],
                        reference=v.image, ref_valid=ref_valid, near=f.near, far=f.far)
        wgt = support_weight(pf.support, 2)[..., None]
        img = (v.image * 255).astype(np.uint8)[..., ::-1]
        m = cv2.dilate(flare.astype(np.uint8), np.ones((3, 3), np.uint8))
        base = cv2.inpaint(img, m, 5, cv2.INPAINT_TELEA).astype(np.float32) / 255
        fill = base * (1 - wgt) + pf.colour[..., ::-1] * wgt
        res = np.where(m[..., None] > 0, fill, img.astype(np.float32) / 255)
        atomic_imwrite(out / f"{s}.png", np.clip(np.rint(res * 255), 0, 255).astype(np.uint8))
    rec = {"inputs": out}
    if path_json is not None:
        from gnfr.paths import path_from_json

        hout = ws.baselines / "photos_heldout"
        centers = np.stack([views[s].c2w[:3, 3] for s in cams.stems])
        for pc in path_from_json(read_json(path_json)):
            W, H = max(1, round(pc.width * scale)), max(1, round(pc.height * scale))
            K = np.asarray(pc.K, float).copy()
            K[0] *= W / pc.width
            K[1] *= H / pc.height
            order = np.argsort(np.linalg.norm(centers - pc.c2w[:3, 3], axis=1))
            lo = min(cams.frames[i].near for i in order[:n_sources])
            hi = max(cams.frames[i].far for i in order[:n_sources])
            pf = photo_fill(K, pc.c2w, (W, H), [views[cams.stems[i]]
                                                   for i in order[:n_sources]], near=lo, far=hi)
            ok = (support_weight(pf.support, 2) < 1).astype(np.uint8)
            img = np.clip(np.rint(pf.colour[..., ::-1] * 255), 0, 255).astype(np.uint8)
            atomic_imwrite(hout / f"{pc.name}.png", cv2.inpaint(img, ok, 5, cv2.INPAINT_TELEA))
        rec["heldout"] = hout
    return rec


# --------------------------------------------------------------------------- scoring
def _read(path: Path, shape: tuple[int, int] | None = None) -> np.ndarray:
    """[H, W, 3] uint8 BGR, area-resized to ``shape`` (h, w) when given."""
    return read_image(path, bgr=True, size=None if shape is None else (shape[1], shape[0]),
                      fix="rerun `deflare-scene eval`")


def _truth_mask(scene: SynthScene, stem: str) -> np.ndarray:
    """[H, W] bool ground-truth flare mask SCENE/masks_gt/<stem>.png."""
    return read_mask_file(scene.root / "masks_gt" / f"{stem}.png",
                          f"rerun `deflare-scene synth ... --out {scene.root} --force`")


def score_views(scene: SynthScene, folder: Path, stems: list[str],
                with_region: bool) -> dict:
    """PSNR / SSIM of ``folder/<stem>.png`` against SCENE/clean (resized to the
    prediction's size), and with ``with_region`` the PSNR inside the true flare mask."""
    per = {}
    for s in stems:
        pred = _read(folder / f"{s}.png")
        gt = _read(scene.root / "clean" / f"{s}.png", pred.shape[:2])
        rec = {"psnr": metrics.psnr(pred, gt), "ssim": metrics.ssim(pred, gt)}
        if with_region:
            rec["psnr_flare"] = metrics.masked_psnr(pred, gt, _truth_mask(scene, s))
        per[s] = rec
    return {**summarise(per), "views": per}


def summarise(per: dict) -> dict:
    """Means over views of every score (views where a score is None are skipped)."""
    keys = sorted({k for r in per.values() for k in r})
    out = {}
    for k in keys:
        vals = [r[k] for r in per.values() if r.get(k) is not None]
        out[k] = float(np.mean(vals)) if vals else None
    return out


def flared_views(scene: SynthScene) -> list[str]:
    """Training views with flare in masks_gt (a clean view's input is its ground truth:
    scoring it would only add capped PSNRs)."""
    return [s for s in scene.train if _truth_mask(scene, s).any()]


def fmg_scores(scene: SynthScene, ws: Workspace) -> dict:
    """The workspace masks against masks_gt on the training views (mIoU etc.)."""
    per = {}
    for s in scene.train:
        per[s] = metrics.mask_scores(read_mask(ws, s), _truth_mask(scene, s))
    return {**summarise(per), "views": per}


# --------------------------------------------------------------------------- entry point
def parse_variants(text: str) -> tuple[str, ...]:
    names = tuple(v.strip() for v in text.split(",") if v.strip())
    bad = [v for v in names if v not in ALL_VARIANTS]
    if bad or not names:
        raise UserError(f"--variants {text!r}: unknown {', '.join(bad) or '(empty)'}; choose "
                        f"from {','.join(ALL_VARIANTS)}")
    return names


def run(cfg: EvalConfig) -> Path:
    """Evaluate; returns WS/eval (table.md, results.json, grid.jpg)."""
    from pipeline import depth, mask, select

    if cfg.masks not in ("fmg", "gt"):
        raise UserError(f"--masks {cfg.masks!r}: use fmg (the FMG network) or gt")
    if not 0 < cfg.render_scale <= 1:
        raise UserError(f"--render-scale {cfg.render_scale} must be in (0, 1]")
    scene = load_synth(cfg.scene)
    if scene.origin not in HELDOUT_SCENES:
        warn(f"eval: {scene.root} was made from '{scene.origin}', not one of the held-out "
             f"scenes {', '.join(HELDOUT_SCENES)}: a trained model may have seen it")
    if not scene.heldout:
        warn("eval: the scene has no held-out views (synth --heldout N): novel-view scores "
             "are skipped")
    base = build_workspace(scene, Path(cfg.out or scene.root / "eval.ws"), cfg.force)
    mcfg = mask.MaskConfig(masks_dir=scene.root / "masks_gt" if cfg.masks == "gt" else None,
                           weights=cfg.fmg_weights, device=cfg.device)
    try:
        mask.run(mcfg, base, force=cfg.force)
    except UserError as e:
        if cfg.masks != "fmg":
            raise
        raise UserError(f"{e}; or evaluate with the true masks: --masks gt") from None
    depth.run(depth.DepthConfig(), base, force=cfg.force)
    if any(v in NEURAL for v in cfg.variants):  # baselines need no View Sampler
        select.run(select.SelectConfig(), base, force=cfg.force)
    path_json = heldout_path_json(scene, base) if scene.heldout else None
    methods = {}
    for name in cfg.variants:
        if name in NEURAL:
            methods[name] = run_neural(cfg, base, name, path_json)
        elif name == "input":
            methods[name] = {"inputs": base.images}
        elif name == "photos":
            methods[name] = run_photos(scene, base, path_json, cfg.render_scale)
        else:
            methods[name] = {"inputs": run_inpaint(scene, base)}
    results = score_all(cfg, scene, base, methods)
    write_outputs(cfg, scene, base, methods, results)
    return base.eval


def score_all(cfg: EvalConfig, scene: SynthScene, base: Workspace, methods: dict) -> dict:
    info("eval: scoring")
    res = {"scene": str(scene.root), "origin": scene.origin,
           "origin_is_heldout_scene": scene.origin in HELDOUT_SCENES,
           "train_views": scene.train, "heldout_views": scene.heldout,
           "cameras": "ground truth (no pose noise)", "masks": cfg.masks,
           "budget": budget(cfg), "provenance": run_provenance(base), "methods": {}}
    res["mask_scores"] = fmg_scores(scene, base)
    res["mask_threshold"] = read_flare(base).threshold
    flared = flared_views(scene) or scene.train
    res["scored_input_views"] = flared
    for name, m in methods.items():
        r = {"label": LABELS[name],
             "inputs": score_views(scene, m["inputs"], flared, with_region=True)}
        if "heldout" in m:
            r["heldout"] = score_views(scene, m["heldout"], scene.heldout, with_region=False)
        if "train" in m:
            r["train"] = m["train"]
        r["provenance"] = method_provenance(name, m, base)
        res["methods"][name] = r
    return res


# --------------------------------------------------------------------------- provenance
def run_provenance(ws: Workspace) -> dict:
    """What scored this results file: code version, machine, the command, and the
    workspace's shared stage records (cameras, masks with their source and cut, depth,
    View Sampler), read from WS, not from the code's defaults."""
    from pipeline.provenance import code_version, command_line, machine

    def params(stage: str) -> dict | None:
        rec = ws.stage_record(stage)
        return None if not rec else {"params": rec.get("params"), "status": rec.get("status"),
                                     "started": rec.get("started"),
                                     "seconds": rec.get("seconds")}

    masks = {"source": None, "threshold": None, "weights": None}
    if ws.flare_json.exists():
        flare = read_flare(ws)
        masks = {"source": flare.source, "threshold": flare.threshold,
                 "weights": flare.weights}
    return {"code": code_version(), "machine": machine(), "command": command_line(),
            "scored": time.strftime("%Y-%m-%dT%H:%M:%S"), "workspace": str(ws.root),
            "cameras": params("pose"), "masks": {**masks, "stage": params("mask")},
            "depth": params("depth"), "select": params("select")}


def method_provenance(name: str, m: dict, base: Workspace) -> dict:
    """What trained and rendered one method, read from its workspace: for a neural variant
    the checkpoint's metadata (``provenance`` written by finetune: start weights and their
    sha256, preset numbers, seed, steps done, device, training seconds, code), the
    checkpoint's own sha256 and the finetune / render stage records (colour match, fill,
    render size, sources)."""
    if name not in NEURAL:
        used = {"input": [], "inpaint": ["masks"], "photos": ["masks", "depth"]}[name]
        return {"kind": "baseline", "uses": used}
    from gnfr.checkpoint import read_metadata
    from pipeline.provenance import sha256

    vws = Workspace(m["workspace"])
    ckpt = vws.model_file
    _, meta = read_metadata(ckpt)
    prov = meta.pop("provenance", None)
    fin = vws.stage_record("finetune")
    renders = {k: {"params": r.get("params"), "seconds": r.get("seconds"),
                   "started": r.get("started"), "frames": r.get("frames")}
               for k, r in vws.manifest()["stages"].items() if k.startswith("render:")}
    out = {"kind": "neural", "parts": NEURAL[name], "checkpoint": str(ckpt),
           "checkpoint_sha256": sha256(ckpt), "checkpoint_meta": meta,
           "trained": prov, "finetune_stage": {k: fin.get(k) for k in (
               "params", "started", "seconds", "steps", "it_per_s", "train_seconds", "init",
               "versions")}, "renders": renders}
    out["summary"] = provenance_summary(prov, fin, renders)
    return out


def provenance_summary(prov: dict | None, fin: dict, renders: dict) -> dict:
    """The few facts a table prints, from the checkpoint (None where it does not say)."""
    inputs = (renders.get("render:inputs") or {}).get("params") or {}
    held = [r["params"] for k, r in renders.items() if k != "render:inputs" and r["params"]]
    if prov is None:  # a checkpoint written before finetune recorded its provenance
        return {"from_checkpoint": False, "trained_from": None, "init_sha256": None,
                "cached_features": None, "steps_done": fin.get("steps"), "seed": None,
                "preset": (fin.get("params") or {}).get("preset"), "device": None,
                "train_seconds": fin.get("seconds"), "color_match": inputs.get("color_match"),
                "fill": inputs.get("fill"), "heldout_fill": [h.get("fill") for h in held]}
    init = prov.get("init") or {}
    return {"from_checkpoint": True,
            "trained_from": Path(init["weights"]).name if init.get("sha256") else "scratch",
            "init_sha256": init.get("sha256"), "cached_features": prov.get("cached_features"),
            "steps_done": prov.get("steps_done"), "seed": prov.get("seed"),
            "preset": prov.get("preset"), "device": prov.get("device_name"),
            "train_seconds": prov.get("train_seconds"),
            "color_match": inputs.get("color_match"), "fill": inputs.get("fill"),
            "heldout_fill": [h.get("fill") for h in held]}


def budget(cfg: EvalConfig) -> dict:
    """What every neural variant was asked to run with (the options, resolved by the code
    that scores), beside the paper's setting. What actually trained each model is in its
    ``provenance`` (read from the checkpoint); the table reports that."""
    from pipeline.finetune import FinetuneConfig, pick_device, resolve, shipped_weights

    fc = FinetuneConfig(preset=cfg.preset, iters=cfg.iters, rays=cfg.rays,
                        samples=cfg.samples, views=cfg.views, device=cfg.device,
                        init=cfg.init, **cfg.finetune_extra)
    dev = pick_device(cfg.device)
    preset, t = resolve(fc, dev)
    return {"preset": preset, "device": dev.type, "iters": t.iters, "rays": t.rays,
            "samples": t.samples, "depth": t.model.depth, "width": t.model.width,
            "source_scale": t.source_scale, "eval_views": t.eval_views,
            "cached_features": t.cached_features, "init": cfg.init,
            "init_weights": _init_weights(cfg.init, shipped_weights(t)),
            "render_scale": cfg.render_scale, "seed": cfg.seed,
            "color_match": cfg.color_match, "fill": cfg.fill}


def _init_weights(init: str, shipped: Path | None) -> str:
    """What ``init`` resolved to: 'scratch' or a weight file's name."""
    if init == "auto":
        return shipped.name if shipped is not None else "scratch"
    return init if init == "scratch" else Path(init).name


# --------------------------------------------------------------------------- outputs
def write_outputs(cfg: EvalConfig, scene: SynthScene, base: Workspace, methods: dict,
                  results: dict) -> None:
    atomic_write_json(base.eval / "results.json", results)
    (base.eval / "table.md").parent.mkdir(parents=True, exist_ok=True)
    from pipeline.workspace import atomic_write_text

    atomic_write_text(base.eval / "table.md", table_markdown(results))
    atomic_imwrite(base.eval / "grid.jpg", image_grid(cfg, scene, base, methods, results),
                   [cv2.IMWRITE_JPEG_QUALITY, 90])
    info(f"eval: wrote {base.eval / 'table.md'}, results.json and grid.jpg")


def _f(v, fmt: str = "{:.2f}") -> str:
    return "—" if v is None else fmt.format(v)


def table_markdown(res: dict) -> str:
    b, ms = res["budget"], res["mask_scores"]
    origin = res["origin"]
    where = ("one of the held-out scenes (pipeline.datasets.HELDOUT_SCENES), never used for "
             "training" if res["origin_is_heldout_scene"] else
             "NOT one of pipeline.datasets.HELDOUT_SCENES: a trained model may have seen it")
    if res["masks"] == "gt":
        masks = "ground truth masks_gt (`--masks gt`), so no FMG mIoU is measured"
    else:
        cut = res.get("mask_threshold")
        masks = (f"FMG network (shipped weights unless --fmg-weights), probability cut "
                 f"{_f(cut, '{:g}')}; against masks_gt on "
                 f"the training views: mIoU {_f(ms.get('miou'), '{:.3f}')}, flare IoU "
                 f"{_f(ms.get('iou_flare'), '{:.3f}')}")
    lines = [
        f"# deflare-scene eval: {origin} with synthetic flare", "",
        f"- Scene: `{res['scene']}`, made from `{origin}`: {where}.",
        f"- Views: {len(res['train_views'])} training views (photos with flare; inputs are "
        f"scored on the {len(res['scored_input_views'])} with flare in masks_gt), "
        f"{len(res['heldout_views'])} held-out views. Cameras: ground truth for every view "
        "(no pose noise; COLMAP was not run on the flared photos).",
        f"- Masks: {masks}.",
        f"- Budget, the same for every neural variant: preset `{b['preset']}` on "
        f"{b['device']}, {b['iters']} steps (paper: 50,000 fine-tuning steps after 500k "
        f"pretraining), {b['rays']} rays x {b['samples']} samples, model depth {b['depth']} "
        f"width {b['width']} (paper: GNT, depth 8 width 64), sources at "
        f"{b['source_scale']:g} resolution, {b['eval_views']} render views, `--init "
        f"{b['init']}` asked (what each model started from: below, from its checkpoint).",
        f"- Held-out views rendered and scored at {b['render_scale']:g} of full size"
        f"{'' if b['render_scale'] == 1 else ' (cut for time)'}; de-flared inputs at full "
        f"size, {'with' if b.get('color_match', False) else 'without'} the render stage's "
        f"colour match of the fill; render fill: {b.get('fill', 'network')}.",
        *provenance_lines(res), "",
        "| method | held-out PSNR | held-out SSIM | inputs PSNR | inputs SSIM | "
        "flare-region PSNR | train s |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in res["methods"].values():
        h, i, t = r.get("heldout", {}), r["inputs"], r.get("train", {})
        lines.append(f"| {r['label']} | {_f(h.get('psnr'))} | {_f(h.get('ssim'), '{:.4f}')} "
                     f"| {_f(i.get('psnr'))} | {_f(i.get('ssim'), '{:.4f}')} | "
                     f"{_f(i.get('psnr_flare'))} | {_f(t.get('seconds'), '{:.0f}')} |")
    lines += ["", "PSNR in dB, SSIM (Gaussian window, Wang et al. 2004) on [0, 1] RGB against "
              "SCENE/clean. Held-out: full renders of the held-out cameras (novel views). "
              "Inputs: the de-flared training photos as `render --path inputs` writes them "
              "(the masked region re-rendered and blended; baselines: the photo itself, or "
              "inpainted). Flare-region PSNR: only the pixels of masks_gt. Baselines have no "
              "held-out views (—). Paper (Table 1, full budget, real-scene synthetic "
              "flare): GNT 22.44 dB, GN-FR 26.18 dB / SSIM 0.8815 on held-out views.", ""]
    return "\n".join(lines)


def provenance_lines(res: dict) -> list[str]:
    """Markdown bullets: the code and machine that scored, and per neural method what its
    checkpoint says trained it."""
    p = res.get("provenance")
    if not p:
        return ["- Provenance: not recorded (results written before eval recorded it)."]
    code, mach = p.get("code") or {}, p.get("machine") or {}
    commit = (code.get("commit") or "unknown")[:12]
    n_dirty = len(code.get("dirty_files") or [])
    dirty = f" with uncommitted changes to {n_dirty} files" if code.get("dirty") else ""
    lines = [f"- Scored by commit `{commit}`{dirty}"
             f" on {mach.get('cpu')} ({mach.get('torch_threads')} torch threads, torch "
             f"{mach.get('torch')}, GPU: {(mach.get('cuda') or {}).get('name', 'none')}); "
             f"command `{p.get('command')}`."]
    groups: dict[str, list[str]] = {}  # methods that share one model print one line
    for r in res["methods"].values():
        sm = (r.get("provenance") or {}).get("summary")
        if sm is not None:
            groups.setdefault(json.dumps(sm, sort_keys=True), []).append(r["label"])
    for key, labels in groups.items():
        sm, label = json.loads(key), " and ".join(labels)
        if not sm["from_checkpoint"]:
            lines.append(f"- {label}: its checkpoint records no provenance (written "
                         f"before finetune recorded it): start weights unknown, "
                         f"{sm['steps_done']} steps.")
            continue
        start = (f"`{sm['trained_from']}` (sha256 {sm['init_sha256'][:12]})"
                 if sm["init_sha256"] else "scratch")
        lines.append(
            f"- {label}: trained from {start}, {sm['steps_done']} steps of preset "
            f"`{sm['preset']}`, seed {sm['seed']}, "
            f"{'cached features' if sm['cached_features'] else 'end-to-end'}, on "
            f"{sm['device']}, {_f(sm['train_seconds'], '{:.0f}')} s"
            + ("" if sm["fill"] is None else f"; inputs rendered "
               f"{'with' if sm['color_match'] else 'without'} colour match, fill {sm['fill']}")
            + f"; held-out fill {', '.join(map(str, sm['heldout_fill'])) or '—'}.")
    return lines


def _tile(img: np.ndarray | None, size: tuple[int, int], text: str) -> np.ndarray:
    """[h, w, 3] uint8 BGR thumbnail with a caption (grey when there is no image)."""
    w, h = size
    t = np.full((h, w, 3), 64, np.uint8) if img is None else \
        cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
    cv2.rectangle(t, (0, 0), (w, 16), (0, 0, 0), -1)
    cv2.putText(t, text[: w // 7], (3, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1,
                cv2.LINE_AA)
    return t


def image_grid(cfg: EvalConfig, scene: SynthScene, base: Workspace, methods: dict,
               res: dict, height: int = 180) -> np.ndarray:
    """Rows: held-out views, then the most flared inputs; columns: input, every method
    (except the input baseline), ground truth."""
    flare = {s: float(_truth_mask(scene, s).mean()) for s in scene.train}
    train = sorted(flared_views(scene) or scene.train, key=lambda s: -flare[s])
    n_held = min(len(scene.heldout), max(1, cfg.grid_rows // 2))
    rows = scene.heldout[:n_held] + train[: max(0, cfg.grid_rows - n_held)]
    gt0 = _read(scene.root / "clean" / f"{rows[0]}.png")
    size = (max(16, round(height * gt0.shape[1] / gt0.shape[0])), height)
    cols = [m for m in methods if m != "input"]
    out = []
    for s in rows:
        held = s in scene.heldout
        photo = None if held else _read(base.image_path(s))
        tiles = [_tile(photo, size, f"{s} held-out" if held else f"{s} input")]
        for m in cols:
            key = "heldout" if held else "inputs"
            folder = methods[m].get(key)
            score = res["methods"][m].get(key, {}).get("views", {}).get(s, {})
            img = _read(folder / f"{s}.png") if folder is not None else None
            tiles.append(_tile(img, size, f"{m} {_f(score.get('psnr'), '{:.1f}')}dB"))
        tiles.append(_tile(_read(scene.root / "clean" / f"{s}.png"), size, "ground truth"))
        out.append(np.concatenate(tiles, 1))
    return np.concatenate(out, 0)
