"""Benchmark of the render fill's settings on an evaluated scene (quality and time).

Re-render the de-flared inputs of a trained `eval` variant with each render setting and
score them against the clean truth (whole image, flare region, SSIM), with the render time.
Only the render changes; the model is the variant's.

    python benchmarks/fill_ablation.py SCENE_SYNTH --out docs/results/fill_ablation_X.json
    python benchmarks/fill_ablation.py SCENE_SYNTH --ws ARM_WS --work DIR --settings a,b
        # a fine-tuned workspace of its own (e.g. an arm of benchmarks/fmg_photo_ab.py),
        # copied into DIR first so the arm's own renders stay as they were

Settings: network (GN-FR everywhere), hybrid without depth-guided samples, hybrid with
guided samples where >= 1 / >= 2 photos agree on the depth (the default is 2), the
default without guided samples where the ring check turns the photos down
(``hybrid_band_checked``), the default hybrid and the network fill without the flare
layer (``--flare-layer 0``: the region replaced by the fill). ``--settings a,b`` runs only
those.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SETTINGS = {
    "network": {"fill": "network"},
    "hybrid_unguided": {"fill": "hybrid", "depth_samples": 0},
    "hybrid_guided_support1": {"fill": "hybrid", "depth_support": 1},
    "hybrid_guided_support2": {"fill": "hybrid", "depth_support": 2},
    "hybrid_band_checked": {"fill": "hybrid", "band_rejected": False},
    "hybrid_no_flare_layer": {"fill": "hybrid", "flare_layer": 0.0},
    "network_no_flare_layer": {"fill": "network", "flare_layer": 0.0},
    "hybrid_beyond_4": {"fill": "hybrid", "beyond_planes": 4},
    **{f"hybrid_layer_local_{v}": {"fill": "hybrid", "flare_layer_local": v}
       for v in (0.005, 0.01, 0.02)},
    "hybrid_clipped_all": {"fill": "hybrid", "clipped": "all"},
    **{f"hybrid_layer_adapt_{v}": {"fill": "hybrid", "flare_layer_adapt": v} for v in (0.5, 1.0)},
    **{f"hybrid_depth_min_blob_{v}": {"fill": "hybrid", "depth_min_blob": v}
       for v in (0, 0.0005, 0.002)},  # 0: every island (the inputs' default before f408c72)
    **{f"hybrid_photo_fallback_{n}": {"fill": "hybrid", "photo_fallback": n} for n in (0, 2)},
    **{f"hybrid_photo_sources_{n}": {"fill": "hybrid", "photo_sources": n} for n in (4, 6, 8)},
    **{f"hybrid_dilate_{v}": {"fill": "hybrid", "dilate": v} for v in (0.0, 0.005, 0.01)},
    **{f"hybrid_feather_{v}": {"fill": "hybrid", "feather": v} for v in (0.005, 0.01, 0.02)},
    **{f"hybrid_agree_window_{n}": {"fill": "hybrid", "agree_window": n} for n in (1, 3, 5)},
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--variant", default="gnfr")
    ap.add_argument("--eval-ws", type=Path, default=None,
                    help="the eval workspace (default SCENE/eval.ws; e.g. an arm of "
                         "benchmarks/finetune_ab.py, WORK/<arm>.ws)")
    ap.add_argument("--ws", type=Path, default=None,
                    help="a fine-tuned workspace of the scene to render instead of an eval "
                         "variant (copied into --work first)")
    ap.add_argument("--work", type=Path, default=None, help="where --ws is copied")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--settings", default=",".join(SETTINGS),
                    help="comma-separated names of SETTINGS to run (default: all)")
    a = ap.parse_args(argv)
    names = [n for n in a.settings.split(",") if n]
    unknown = sorted(set(names) - set(SETTINGS))
    if unknown:
        ap.error(f"unknown settings {unknown}; known: {', '.join(SETTINGS)}")
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from gnfr.checkpoint import read_metadata
    from pipeline import render
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from workflows.research.eval.scene import flared_views, load_synth
    from workflows.research.eval.scoring import score_views

    scene = load_synth(a.scene)
    if a.ws is not None:
        if a.work is None:
            ap.error("--ws needs --work (the arm's workspace is rendered in a copy)")
        if not (a.ws / "cameras.json").is_file():
            ap.error(f"{a.ws} is not a workspace (no cameras.json): pass a fine-tuned "
                     "workspace of the scene")
        copy = a.work / a.ws.name
        if not copy.is_dir():
            shutil.copytree(a.ws, copy, symlinks=True)
        ws = Workspace(copy)
    else:
        ws = Workspace(Workspace(a.eval_ws or a.scene / "eval.ws").variants / a.variant)
    stems = flared_views(scene)
    rows = {}
    for name in names:
        over = SETTINGS[name]
        t0 = time.perf_counter()
        render.run(render.RenderConfig(path="inputs", **over), ws, force=True)
        dt = time.perf_counter() - t0
        r = score_views(scene, ws.deflared, stems, with_region=True)
        rows[name] = {"settings": over, "psnr": round(r["psnr"], 3),
                      "psnr_flare": round(r["psnr_flare"], 3), "ssim": round(r["ssim"], 4),
                      "render_s": round(dt, 1)}
        print(name, json.dumps(rows[name]), flush=True)
    _, meta = read_metadata(ws.model_file)
    rec = {"scene": str(a.scene), "origin": scene.origin, "variant": a.variant,
           "eval_ws": str(a.eval_ws or a.scene / "eval.ws"),
           "ws": str(a.ws) if a.ws is not None else None,
           "scored_views": stems, "model": {k: meta.get(k) for k in
                                             ("step", "preset", "init", "init_sha256")},
           "finetune_record": {k: ws.stage_record("finetune").get(k)
                               for k in ("steps", "seconds", "params")},
           "rows": rows}
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
