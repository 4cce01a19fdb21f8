"""Whose masks cost the novel views: each arm's model renders with the other arm's masks.

docs/history/fmg.md, "Twenty-fifth session".

    python benchmarks/mask_cross_render.py SYNTH --arm NAME=WS --arm NAME=WS --out JSON
        [--cameras JSON] [--work DIR] [--variants own,other,othermasks,nearest]

Two workspaces of the same synth scene, each fine-tuned with one arm's masks (e.g. the
runs of `benchmarks/fmg_photo_ab.py run`). For each arm's model, in a copy of its workspace
(never the workspace itself), the held-out cameras are rendered as the photo rule renders
them (`render --path EVAL_WS/eval/heldout_cameras.json --scale 0.5`; ``--cameras``,
by default SYNTH/eval.ws/eval/heldout_cameras.json) with:

- ``own``: its own WS/masks and views.json (reproduces the arm's committed score);
- ``other``: the other arm's WS/masks and views.json (the attention masks and the flare
  fractions that choose the sources);
- ``othermasks``: the other arm's WS/masks, its own views.json (the sources kept);
- ``nearest``: its own masks, rendered with ``--sources-equal-below 1`` (every view counts
  as unflared), so each camera renders from its nearest views.

and scored against the synth's clean held-out views as `eval` scores them. Every render
passes ``--sources-equal-below`` (``--equal-below``, default 0: how the twenty-third and
twenty-fourth sessions' runs rendered), so ``own`` reproduces those runs whatever the
render's default, and ``--path-exposure 0`` (each camera at its sources' exposure, as
`eval` renders its held-out cameras).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

VARIANTS = ("own", "other", "othermasks", "nearest")


def prepare(src: Path, other: Path, variant: str, dst: Path) -> Path:
    """A copy of workspace ``src`` (no renders) set up for ``variant``."""
    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(src, dst, symlinks=True, ignore=shutil.ignore_patterns("renders"))
    if variant in ("other", "othermasks"):
        shutil.rmtree(dst / "masks")
        shutil.copytree(other / "masks", dst / "masks")
    if variant == "other":
        shutil.copy2(other / "views.json", dst / "views.json")
    return dst


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("synth", type=Path, help="a `deflare-scene synth` folder")
    ap.add_argument("--arm", action="append", required=True, metavar="NAME=WS",
                    help="an arm's fine-tuned workspace (exactly two)")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--equal-below", type=float, default=0.0,
                    help="the renders' --sources-equal-below (default 0)")
    ap.add_argument("--cameras", type=Path, default=None,
                    help="the held-out cameras (default: SYNTH/eval.ws/eval/"
                         "heldout_cameras.json, where `eval --out SYNTH/eval.ws` wrote them)")
    ap.add_argument("--work", type=Path, default=None,
                    help="where the copies go (default: a folder beside --out, removed)")
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError

    try:
        arms = dict(x.split("=", 1) for x in a.arm)
    except ValueError:
        print(f"error: --arm takes NAME=WS, got {a.arm}", file=sys.stderr)
        return 2
    variants = [v for v in a.variants.split(",") if v]
    bad = [v for v in variants if v not in VARIANTS]
    cams = a.cameras or a.synth / "eval.ws" / "eval" / "heldout_cameras.json"
    problems = ([f"--arm given {len(arms)} times: give exactly two arms"] if len(arms) != 2
                else [])
    problems += [f"unknown variant {v!r}: choose from {', '.join(VARIANTS)}" for v in bad]
    problems += [f"{ws} is not a fine-tuned workspace (no views.json, masks/ or model/)"
                 for ws in arms.values()
                 if not all((Path(ws) / p).exists() for p in ("views.json", "masks", "model"))]
    if not cams.is_file():
        problems.append(f"{cams} does not exist: give a `deflare-scene synth` folder that "
                        "`deflare-scene eval` has run on")
    if problems:
        print(f"error: {problems[0]}", file=sys.stderr)
        return 2
    from pipeline.provenance import write_result
    from workflows.research.eval.scene import load_synth
    from workflows.research.eval.scoring import score_views

    scene = load_synth(a.synth)
    work = a.work or a.out.with_suffix(".work")
    names = list(arms)
    cli = [sys.executable, "-m", "workflows.cli"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    rows = []
    try:
        for model in names:
            other = names[1 - names.index(model)]
            for variant in variants:
                ws = prepare(Path(arms[model]), Path(arms[other]), variant,
                             work / f"{model}_{variant}.ws")
                line = 1.0 if variant == "nearest" else a.equal_below  # 1: every view clean
                subprocess.run(cli + ["render", str(ws), "--path", str(cams), "--scale", "0.5",
                                      "--sources-equal-below", str(line),
                                      "--path-exposure", "0"],
                               check=True, env=env, cwd=ROOT, stdout=subprocess.DEVNULL)
                held = score_views(scene, ws / "renders" / "heldout_cameras", scene.heldout,
                                   with_region=False)
                rows.append({"model": model, "render": variant, "heldout": held})
                print(f"model {model}, render {variant}: held-out PSNR {held['psnr']:.2f}, "
                      f"SSIM {held['ssim']:.4f}")
    except (subprocess.CalledProcessError, UserError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    finally:
        if a.work is None:
            shutil.rmtree(work, ignore_errors=True)
    write_result(a.out, {"scene": str(a.synth), "arms": arms, "equal_below": a.equal_below,
                         "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
