"""The methods eval compares: GN-FR variants (fine-tune, render), inpainting, warped photos."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from pipeline.progress import info, track
from pipeline.workspace import Workspace, atomic_imwrite, read_json
from pipeline.ws_files import ViewsFile, read_cameras, read_mask, read_view_image, read_views
from workflows.research.eval.config import LABELS, NEURAL, EvalConfig
from workflows.research.eval.scene import SynthScene
from workflows.research.eval.workspaces import variant_workspace


def finetune_config(cfg: EvalConfig, name: str):
    from pipeline.finetune import FinetuneConfig

    return FinetuneConfig(preset=cfg.preset, iters=cfg.iters, rays=cfg.rays,
                          samples=cfg.samples, views=cfg.views, device=cfg.device,
                          init=cfg.init, seed=cfg.seed, **NEURAL[name], **cfg.finetune_extra)


def source_pool(name: str, n_views: int) -> dict:
    """Render options of variant ``name``'s source choice: without the View Sampler the
    nearest ``n_views`` views whatever their flare; with it the render's own choice."""
    return {} if NEURAL[name]["view_sampler"] else {"n_sources": n_views, "pool": n_views}


def heldout_render_config(path_json: Path, scale: float, **common):
    """The RenderConfig of the held-out cameras: scored one by one, so no video and nothing
    to cross-fade, each at its sources' exposure as the eval always rendered them
    (path_exposure 0). ``common``: device, samples, fill, source pool, checkpoint."""
    from pipeline.render import RenderConfig

    return RenderConfig(path=str(path_json), scale=scale, source_fade=0, path_exposure=0.0,
                        **common)


def fit_targets(record: dict, views: ViewsFile, view_sampler: bool) -> list[str]:
    """The views a variant's fine-tune took as targets, as its stage record says them
    (``pipeline.finetune.fit`` writes them since the ninety-third session). A record from
    before says nothing: there they are read as that code chose them, ``views``' (views.json)
    flagged targets with the View Sampler, every view without it."""
    if "targets" in record:
        return list(record["targets"])
    return views.targets() if view_sampler else list(views.views)


def run_neural(cfg: EvalConfig, base: Workspace, name: str, path_json: Path | None) -> dict:
    """Finetune and render one variant (each a resumable stage); paths of its outputs."""
    from pipeline import finetune, render
    from pipeline.render import RenderConfig

    variant_ws = variant_workspace(base, name)
    info(f"eval: variant {name} ({LABELS[name]}) in {variant_ws.root}")
    finetune_cfg = finetune_config(cfg, name)
    finetune.run(finetune_cfg, variant_ws, force=cfg.force)
    _, train_cfg = finetune.resolve(finetune_cfg, finetune.pick_device(cfg.device))
    n_views = train_cfg.eval_views
    common = {"device": cfg.device, "samples": cfg.samples, "fill": cfg.fill,
              **source_pool(name, n_views)}
    render.run(RenderConfig(path="inputs", color_match=cfg.color_match, **common),
               variant_ws, force=cfg.force)
    out = {"inputs": variant_ws.deflared, "workspace": variant_ws.root}
    if path_json is not None:
        render.run(heldout_render_config(path_json, cfg.render_scale, **common), variant_ws,
                   force=cfg.force)
        out["heldout"] = variant_ws.render_dir(str(path_json))
    record = variant_ws.stage_record("finetune")
    views = read_views(variant_ws)
    targets = fit_targets(record, views, NEURAL[name]["view_sampler"])
    out["train"] = {"seconds": record.get("seconds"), "steps": record.get("steps"),
                    "it_per_s": record.get("it_per_s"), "targets": len(targets),
                    "views": len(views.views),
                    "render_seconds": sum(
                        variant_ws.stage_record(stage).get("seconds") or 0
                        for stage in variant_ws.manifest()["stages"]
                        if stage.startswith("render"))}
    return out


def run_inpaint(scene: SynthScene, ws: Workspace, radius: int = 5) -> Path:
    """WS/baselines/inpaint/<stem>.png: each flared photo inpainted (Telea) in its mask."""
    out = ws.baselines / "inpaint"
    for stem in track(scene.train, "Inpainting (baseline)"):
        img = read_view_image(ws, stem, bgr=True)
        mask = cv2.dilate(read_mask(ws, stem).astype(np.uint8), np.ones((3, 3), np.uint8))
        atomic_imwrite(out / f"{stem}.png", cv2.inpaint(img, mask, radius, cv2.INPAINT_TELEA))
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
    for stem in track(scene.train, "Photo fill (baseline)"):
        frame, view = cams.by_stem()[stem], views[stem]
        flare = ~view.valid if view.valid is not None else np.zeros(view.image.shape[:2], bool)
        ref_valid = cv2.dilate(flare.astype(np.uint8), np.ones((9, 9), np.uint8)) == 0
        filled = photo_fill(frame.K, frame.c2w, view.size, [views[n] for n in near[stem]],
                            reference=view.image, ref_valid=ref_valid, near=frame.near,
                            far=frame.far)
        weight = support_weight(filled.support, 2)[..., None]
        img = (view.image * 255).astype(np.uint8)[..., ::-1]
        mask = cv2.dilate(flare.astype(np.uint8), np.ones((3, 3), np.uint8))
        inpainted = cv2.inpaint(img, mask, 5, cv2.INPAINT_TELEA).astype(np.float32) / 255
        fill = inpainted * (1 - weight) + filled.colour[..., ::-1] * weight
        blended = np.where(mask[..., None] > 0, fill, img.astype(np.float32) / 255)
        atomic_imwrite(out / f"{stem}.png",
                       np.clip(np.rint(blended * 255), 0, 255).astype(np.uint8))
    outputs = {"inputs": out}
    if path_json is not None:
        from gnfr.paths import path_from_json

        heldout_dir = ws.baselines / "photos_heldout"
        centers = np.stack([views[s].c2w[:3, 3] for s in cams.stems])
        for pc in path_from_json(read_json(path_json)):
            W, H = max(1, round(pc.width * scale)), max(1, round(pc.height * scale))
            K = np.asarray(pc.K, float).copy()
            K[0] *= W / pc.width
            K[1] *= H / pc.height
            order = np.argsort(np.linalg.norm(centers - pc.c2w[:3, 3], axis=1))
            lo = min(cams.frames[i].near for i in order[:n_sources])
            hi = max(cams.frames[i].far for i in order[:n_sources])
            filled = photo_fill(K, pc.c2w, (W, H), [views[cams.stems[i]]
                                                       for i in order[:n_sources]],
                                near=lo, far=hi)
            holes = (support_weight(filled.support, 2) < 1).astype(np.uint8)
            img = np.clip(np.rint(filled.colour[..., ::-1] * 255), 0, 255).astype(np.uint8)
            atomic_imwrite(heldout_dir / f"{pc.name}.png",
                           cv2.inpaint(img, holes, 5, cv2.INPAINT_TELEA))
        outputs["heldout"] = heldout_dir
    return outputs

