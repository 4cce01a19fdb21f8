"""Fine-tuning speed with full-size against quarter-size source colours, one workspace twice.

Two copies of one workspace fine-tuned side by side (the same load):

    cp -r WS WS_q
    OMP_NUM_THREADS=1 deflare-scene finetune WS --iters 300 --preset quick &
    OMP_NUM_THREADS=1 deflare-scene finetune WS_q --iters 300 --preset quick --no-full-res-colour
    python benchmarks/full_res_colour_speed.py WS WS_q --out JSON

(``--other-code``: both copies with full-size colours, the second fine-tuned by other code,
e.g. ``PYTHONPATH=WORKTREE python -m workflows.cli finetune ...`` from an earlier commit.)

Reads each workspace's last training metrics line (steps/s) and the finetune stage's seconds,
and the size of the workspace's images (docs/presets.md, "Full-size colours in the
fine-tune").
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def arm(ws: Path) -> dict:
    """Steps/s, steps, stage seconds, the full_res_colour setting and the image size of one
    fine-tuned workspace."""
    from pipeline.errors import UserError
    from pipeline.images import image_size
    from pipeline.workspace import Workspace

    w = Workspace(ws)
    if not w.metrics_jsonl.is_file():
        raise UserError(f"{ws}: no fine-tune metrics ({w.metrics_jsonl}); run "
                        "`deflare-scene finetune WS` first")
    last = json.loads(w.metrics_jsonl.read_text().splitlines()[-1])
    rec = w.stage_record("finetune")  # one read of the manifest
    if rec.get("status") != "complete":
        raise UserError(f"{ws}: its fine-tune has not finished; wait for it (or rerun "
                        "`deflare-scene finetune WS`)")
    h, wd = image_size(min(w.images.glob("*.png")))
    return {"workspace": str(ws), "it_s": last["it_s"], "steps": last["step"],
            "stage_seconds": rec["seconds"],
            "full_res_colour": rec["params"]["train"]["full_res_colour"],
            "image_size": [int(wd), int(h)]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("full", type=Path, help="workspace fine-tuned with full-size colours")
    ap.add_argument("quarter", type=Path, help="its copy fine-tuned with --no-full-res-colour")
    ap.add_argument("--other-code", action="store_true",
                    help="the second workspace is fine-tuned with full-size colours too, by "
                         "other code (e.g. a worktree of an earlier commit): report the "
                         "first's speed against it")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError

    try:
        first, second = arm(a.full), arm(a.quarter)
        if a.other_code:
            if not (first["full_res_colour"] and second["full_res_colour"]):
                raise UserError("with --other-code both workspaces must be fine-tuned with "
                                "full-size colours")
        elif not first["full_res_colour"] or second["full_res_colour"]:
            raise UserError("the first workspace must be fine-tuned with full-size colours, "
                            "the second with --no-full-res-colour")
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if a.other_code:
        res = {"full": first, "full_other_code": second,
               "faster": first["it_s"] / second["it_s"] - 1}
        print(f"full {first['it_s']:.2f} steps/s, the other code's {second['it_s']:.2f}: "
              f"{100 * res['faster']:+.0f} % at {first['image_size']}")
    else:
        res = {"full": first, "quarter": second, "slower": 1 - first["it_s"] / second["it_s"]}
        print(f"full {first['it_s']:.2f} steps/s, quarter {second['it_s']:.2f}: "
              f"{100 * res['slower']:.0f} % slower at {first['image_size']}")
    if a.out:
        from pipeline.provenance import write_result
        write_result(a.out, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
