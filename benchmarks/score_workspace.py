"""Score one workspace's de-flared inputs (and held-out renders) on a synth scene, as `eval` does.

    python benchmarks/score_workspace.py SYNTH WS [--heldout RENDER_DIR] [--out JSON]

For workspaces built by hand from an evaluated variant (a stage rerun with another option,
e.g. `deflare-scene mask WS --fill-holes` then select, finetune and render), scored exactly
as `deflare-scene eval` scores its methods: PSNR / SSIM of WS/deflared over SYNTH's flared
training views and PSNR inside the true flare (workflows.research.eval.scoring.score_views),
and with ``--heldout`` the renders of SYNTH's held-out cameras in RENDER_DIR (e.g.
WS/renders/heldout_cameras after `render WS --path EVAL_WS/eval/heldout_cameras.json`), and
with ``--keys`` the training views' cameras rendered as novel frames (whole and inside the
true flare).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path, help="a `deflare-scene synth` folder")
    ap.add_argument("workspace", type=Path, help="a workspace with WS/deflared")
    ap.add_argument("--heldout", type=Path, default=None,
                    help="folder of the held-out cameras' renders")
    ap.add_argument("--keys", type=Path, default=None,
                    help="folder of the training views' cameras rendered as novel frames "
                         "(benchmarks/fmg_photo_ab.py --keys)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_views
    from workflows.research.eval.scene import flared_views, load_synth
    from workflows.research.eval.scoring import score_views

    scene = load_synth(a.scene)
    ws = Workspace(a.workspace)
    stems = flared_views(scene) or scene.train
    rec = {"scene": str(a.scene), "workspace": str(a.workspace),
           "stages": {k: v.get("params") for k, v in ws.manifest()["stages"].items()},
           "inputs": score_views(scene, ws.deflared, stems, with_region=True)}
    line = (f"inputs PSNR {rec['inputs']['psnr']:.2f}, flare region "
            f"{rec['inputs']['psnr_flare']:.2f}, SSIM {rec['inputs']['ssim']:.4f}")
    if ws.views_json.exists():  # which views the fine-tune could train on (the 10 % rule)
        views = read_views(ws)
        rec["targets"] = {"targets": len(views.targets()), "views": len(views.views)}
        line += f"; {rec['targets']['targets']} of {rec['targets']['views']} views targets"
    if a.heldout is not None:
        rec["heldout"] = score_views(scene, a.heldout, scene.heldout, with_region=False)
        line += (f"; held-out PSNR {rec['heldout']['psnr']:.2f}, "
                 f"SSIM {rec['heldout']['ssim']:.4f}")
    if a.keys is not None:
        rec["keys"] = score_views(scene, a.keys, scene.train, with_region=True)
        line += (f"; at the photos' cameras PSNR {rec['keys']['psnr']:.2f}, flare region "
                 f"{rec['keys']['psnr_flare']:.2f}")
    print(f"{a.workspace}: {line}")
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
