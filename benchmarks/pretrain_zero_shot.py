"""Benchmark of the zero-shot quality of pretrained GN-FR weights (no fine-tuning).

Render the held-out cameras of an evaluation workspace (`deflare-scene eval` builds one)
with NO fine-tuning, network fill, and score them against the clean ground truth. A
pretrained prior that generalizes better scores higher here; it is the cheapest honest
comparison of two pretraining checkpoints.

    python benchmarks/pretrain_zero_shot.py SCENE_SYNTH WEIGHTS [WEIGHTS ...] \
        --scale 0.5 --out docs/results/pretrain_zero_shot.json

SCENE_SYNTH is a `deflare-scene synth` folder whose `eval.ws` exists (run `eval` once).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("weights", type=Path, nargs="+")
    ap.add_argument("--scale", type=float, default=0.5)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from gnfr.checkpoint import read_metadata
    from pipeline import render
    from pipeline.provenance import sha256 as file_sha256
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from workflows.research.eval.scene import load_synth
    from workflows.research.eval.scoring import score_views

    scene = load_synth(a.scene)
    base = Workspace(a.scene / "eval.ws")
    path_json = base.eval / "heldout_cameras.json"
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for w in a.weights:
            ws_dir = Path(tmp) / w.stem
            shutil.copytree(base.root, ws_dir, ignore=shutil.ignore_patterns(
                base.variants.name, base.baselines.name))
            ws = Workspace(ws_dir)
            t0 = time.perf_counter()
            render.run(render.RenderConfig(path=str(path_json), checkpoint=str(w),
                                           fill="network", scale=a.scale), ws, force=True)
            res = score_views(scene, ws.render_dir(str(path_json)), scene.heldout, False)
            _, meta = read_metadata(w)
            rows.append({"weights": str(w), "sha256": file_sha256(w),
                         "step": meta.get("step"), "scenes": meta.get("pretrain_scenes"),
                         "psnr": round(res["psnr"], 3), "ssim": round(res["ssim"], 4),
                         "render_s": round(time.perf_counter() - t0, 1)})
            print(json.dumps(rows[-1]), flush=True)
    rec = {"scene": str(a.scene), "origin": scene.origin, "heldout": scene.heldout,
           "scale": a.scale, "fine_tuning": "none (zero-shot)", "rows": rows}
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
