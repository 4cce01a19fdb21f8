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

Scenes: evaluate only scenes of ``pipeline.scene_splits.TEST_SCENES`` (fern, kermit, cyprus), which
no training run uses; another scene is evaluated with a warning recorded in the results.

The package: ``config`` (EvalConfig, the variants), ``scene`` (reading SCENE), ``workspaces``
(WS and the variant workspaces), ``methods`` (training, rendering, baselines), ``scoring``,
``provenance`` and ``report`` (results.json, table.md, grid.jpg); ``run`` here ties them.
"""

from __future__ import annotations

from pathlib import Path

from workflows.research.eval.config import ALL_VARIANTS, NEURAL, EvalConfig

__all__ = ["ALL_VARIANTS", "NEURAL", "EvalConfig", "run"]


def run(cfg: EvalConfig) -> Path:
    """Evaluate; returns WS/eval (table.md, results.json, grid.jpg)."""
    from pipeline import depth, mask, select
    from pipeline.errors import UserError
    from pipeline.options import validate
    from pipeline.progress import warn
    from pipeline.scene_splits import HELDOUT_SCENES
    from workflows.research.eval.methods import run_inpaint, run_neural, run_photos
    from workflows.research.eval.report import write_outputs
    from workflows.research.eval.scene import load_synth
    from workflows.research.eval.scoring import score_all
    from workflows.research.eval.workspaces import build_workspace, heldout_path_json

    validate(cfg)
    if not cfg.variants:
        raise UserError(f"--variants is empty: give one or more of {', '.join(ALL_VARIANTS)}")
    scene = load_synth(cfg.scene)
    if scene.origin not in HELDOUT_SCENES:
        warn(f"eval: {scene.root} was made from '{scene.origin}', not one of the held-out "
             f"scenes {', '.join(HELDOUT_SCENES)}: a trained model may have seen it")
    if not scene.heldout:
        warn("eval: the scene has no held-out views (synth --heldout N): novel-view scores "
             "are skipped")
    base = build_workspace(scene, Path(cfg.out or scene.root / "eval.ws"), cfg.force)
    mask_cfg = mask.MaskConfig(
        masks_dir=scene.root / "masks_gt" if cfg.masks == "gt" else None,
        weights=cfg.fmg_weights, device=cfg.device)
    try:
        mask.run(mask_cfg, base, force=cfg.force)
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

