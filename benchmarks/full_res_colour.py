"""Full-size source colours (`render --full-res-colour`) against colours at source scale.

With one trained checkpoint and no retraining: held-out novel views and de-flared inputs of
a `deflare-scene synth` scene whose `eval.ws` exists, for each fill.

    python benchmarks/full_res_colour.py SCENE_SYNTH CHECKPOINT --fills network,hybrid \
        --out docs/results/full_res_colour_dev_sceaux.json
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
    ap.add_argument("checkpoint", type=Path)
    ap.add_argument("--fills", default="network,hybrid")
    ap.add_argument("--scale", type=float, default=0.5, help="held-out render scale")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)

    from pipeline import render
    from pipeline.provenance import sha256, write_result
    from pipeline.workspace import Workspace
    from workflows.research.eval.scene import flared_views, load_synth
    from workflows.research.eval.scoring import score_views

    scene = load_synth(a.scene)
    base = a.scene / "eval.ws"
    path_json = base / "eval" / "heldout_cameras.json"
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        ws_dir = Path(tmp) / "ws"
        shutil.copytree(base, ws_dir, ignore=shutil.ignore_patterns(
            "variants", "baselines", "renders", "deflared"))
        ws = Workspace(ws_dir)
        for fill in a.fills.split(","):
            for frc in (False, True):
                t0 = time.perf_counter()
                render.run(render.RenderConfig(path=str(path_json), checkpoint=str(a.checkpoint),
                                               fill=fill, scale=a.scale, full_res_colour=frc),
                           ws, force=True)
                t1 = time.perf_counter()
                held = score_views(scene, ws.renders / path_json.stem, scene.heldout, False)
                render.run(render.RenderConfig(path="inputs", checkpoint=str(a.checkpoint),
                                               fill=fill, full_res_colour=frc), ws, force=True)
                t2 = time.perf_counter()
                inp = score_views(scene, ws.deflared, flared_views(scene), True)
                rows.append({"fill": fill, "full_res_colour": frc,
                             "heldout_psnr": round(held["psnr"], 3),
                             "heldout_ssim": round(held["ssim"], 4),
                             "inputs_psnr_flare": round(inp["psnr_flare"], 3),
                             "inputs_psnr": round(inp["psnr"], 3),
                             "inputs_ssim": round(inp["ssim"], 4),
                             "heldout_s": round(t1 - t0, 1), "inputs_s": round(t2 - t1, 1)})
                print(json.dumps(rows[-1]), flush=True)
    write_result(a.out, {"scene": str(a.scene), "heldout": scene.heldout,
                         "checkpoint": str(a.checkpoint), "checkpoint_sha256": sha256(a.checkpoint),
                         "heldout_scale": a.scale, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
