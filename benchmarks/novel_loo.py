"""Leave-one-out novel views of an evaluated synth scene, for comparing render settings.

    python benchmarks/novel_loo.py SCENE_SYNTH [--variant gnfr] [--scale 0.5] \
        [--set render.FIELD=VALUE ...] [--eval-ws DIR | --ws DIR] [--heldout] [--frames DIR] \
        --out JSON

`deflare-scene eval` holds out few cameras (2 per development scene): too few to choose a
render setting. This renders every training camera of the eval's variant as a novel frame
(the render stage, a JSON camera path) in a scratch workspace whose views.json lacks that
view, so neither GN-FR's sources nor the photo fill see its photo, and scores it against
the clean photo (PSNR, SSIM). Bias: the fine-tuned model trained on that view as a target,
so the network's part is optimistic: settings that let GN-FR draw more look better than
they are (docs/depth.md, "Leave-one-out views"). Use it for settings that leave the
network's share alone, on one model; not to compare the network with the photos, nor models.

``--heldout`` renders the eval's held-out cameras instead, from the whole workspace (no view
removed): unbiased (the model never saw them), but only as many views as the split holds.
``--non-targets`` leaves out, in turn, only the training cameras that were never a
fine-tuning target (views.json: flared over the 10 % rule): the network never learned to
draw them, so, like ``--heldout``, it is unbiased, and it has more cameras on a heavily
flared scene.
``--deflared`` renders the de-flared photos (``render --path inputs``, the defaults) in each
scratch workspace before its frame, from the views that workspace keeps, so a left-out
photo reaches no other photo's de-flared fill: for ``--set render.from_deflared=true``,
whose frames read them.
``--eval-ws`` names the evaluation workspace (default SCENE/eval.ws; finetune_ab.py writes
DIR/base.ws). ``--ws`` names a fine-tuned workspace itself instead (an arm of
``fmg_photo_ab.py``: DIR/<scene>_<arm>_s<seed>.ws).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--variant", default="gnfr")
    ap.add_argument("--scale", type=float, default=0.5)
    ap.add_argument("--set", dest="sets", action="append", default=[],
                    help="render.FIELD=VALUE, as the one-shot's --set")
    ap.add_argument("--eval-ws", type=Path, default=None,
                    help="evaluation workspace (default SCENE/eval.ws)")
    ap.add_argument("--ws", type=Path, default=None,
                    help="a fine-tuned workspace itself (not an eval's variant)")
    ap.add_argument("--heldout", action="store_true",
                    help="render the held-out cameras from the whole workspace instead")
    ap.add_argument("--non-targets", action="store_true",
                    help="leave out only the training cameras that were never a target")
    ap.add_argument("--deflared", action="store_true",
                    help="render the de-flared photos in each scratch workspace first")
    ap.add_argument("--frames", type=Path, default=None,
                    help="also keep the rendered frames in this folder")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from dataclasses import asdict, replace

    from gnfr.paths import PathCamera, path_to_json
    from pipeline import render
    from pipeline.cameras import Cameras, load_cameras, save_cameras
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace, atomic_write_json
    from pipeline.ws_files import ViewsFile, read_views, write_views
    from workflows.oneshot import apply_overrides
    from workflows.research.eval.scene import load_synth
    from workflows.research.eval.scoring import score_views
    from workflows.research.eval.workspaces import shared_workspace

    cfg = apply_overrides({"render": render.RenderConfig(scale=a.scale)}, a.sets)["render"]
    scene = load_synth(a.scene)
    if a.ws is not None and a.eval_ws is not None:
        raise SystemExit("novel_loo: --ws and --eval-ws exclude each other")
    base = Workspace(a.ws) if a.ws is not None else Workspace(
        Workspace(a.eval_ws or a.scene / "eval.ws").variants / a.variant)
    ckpt = render.find_checkpoint(base, cfg.checkpoint)
    views = read_views(base)
    scene_cams = load_cameras(base.cameras_json)
    by_stem = scene.cams.by_stem()
    with tempfile.TemporaryDirectory(prefix="deflare-loo-") as tmp:
        frames = Path(tmp) / "frames"
        frames.mkdir()
        stems = scene.heldout if a.heldout else scene.train
        if a.non_targets:
            if a.heldout:
                raise SystemExit("novel_loo: --heldout and --non-targets exclude each other")
            stems = [s for s in stems if s in views.views and not views.views[s].target]
            if not stems:
                raise SystemExit(f"novel_loo: every training camera of {a.scene} was a target")
        for stem in stems:
            ws = shared_workspace(base, Path(tmp) / f"ws_{stem}")
            if not a.heldout:  # leave this view out of the sources and the photo fill
                ws.views_json.unlink()  # a hard link: write a new file, not into base's
                write_views(ws, ViewsFile(views.max_flare, {
                    s: v for s, v in views.views.items() if s != stem}))
            f = by_stem[stem]
            pj = Path(tmp) / f"{stem}.json"
            atomic_write_json(pj, path_to_json([PathCamera(stem, f.K, f.c2w, f.width,
                                                           f.height)]))
            if a.deflared:  # the left-out view is no photo here: it gets no de-flared one
                if not a.heldout:  # (atomic writes: new files, not into base's link)
                    save_cameras(ws.cameras_json, Cameras(
                        [c for c in scene_cams.frames if c.stem != stem],
                        scene_cams.colmap_to_world))
                render.run(render.RenderConfig(checkpoint=str(ckpt), workers=cfg.workers),
                           ws, force=True)
                if not a.heldout:
                    save_cameras(ws.cameras_json, scene_cams)
            render.run(replace(cfg, path=str(pj), checkpoint=str(ckpt)), ws, force=True)
            shutil.copy(ws.renders / stem / f"{stem}.png", frames / f"{stem}.png")
        r = score_views(scene, frames, stems, with_region=False)
        if a.frames is not None:
            shutil.copytree(frames, a.frames, dirs_exist_ok=True)
    rec = {"scene": str(a.scene), "variant": a.variant, "checkpoint": str(ckpt),
           "render": {k: v for k, v in asdict(cfg).items() if k != "path"},
           "sets": a.sets, "heldout": a.heldout, "non_targets": a.non_targets,
           "deflared": a.deflared,
           "views": stems,
           "psnr": r["psnr"], "ssim": r["ssim"],
           "per_view": {k: {m: round(v[m], 4) for m in ("psnr", "ssim")}
                        for k, v in r["views"].items()}}
    print(json.dumps({k: rec[k] for k in ("sets", "psnr", "ssim")}), flush=True)
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
