"""Held-out views with two eval variants' models and render settings swapped (a diagnosis).

    python benchmarks/heldout_swap.py SYNTH EVAL_WS --work DIR [--a gnfr] [--b gnt]
        [--fills hybrid,network] [--device cpu] --out JSON

`deflare-scene eval` scores each neural variant's renders of the held-out cameras; two
variants differ in the model their fine-tune made and in how their renders choose sources
(a variant without the View Sampler takes the nearest ``eval_views`` views, whatever their
flare). This renders the held-out cameras of ``EVAL_WS`` (``eval/heldout_cameras.json``) for
each model (``--a``, ``--b``: ``EVAL_WS/variants/<name>/model/gnfr.safetensors``) with each
variant's source choice, in copies of the variant workspaces under ``DIR`` (nothing in
``EVAL_WS`` is written), with the eval's render settings (its ``results.json``: render
scale, source count, fill), and scores them against ``SYNTH/clean``. The Point Sampler
goes with the model (its checkpoint's metadata, as the render stage reads it). Where a
model gap stays whatever the sources, the fine-tune made it; where it moves with the
sources, the render's choice did (docs/eval.md, "Why GN-FR trails vanilla GNT on novel
views").
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def render_arm(eval_ws: Path, work: Path, model: str, sources: str, fill: str,
               budget: dict, device: str = "cpu") -> Path:
    """The held-out renders of ``model``'s checkpoint with ``sources``' workspace and source
    rule, in ``work/<model>_with_<sources>``: the folder of PNGs."""
    from pipeline import render
    from pipeline.workspace import Workspace
    from workflows.research.eval.methods import heldout_render_config, source_pool

    ws_dir = work / f"{model}_with_{sources}"
    if not ws_dir.exists():
        shutil.copytree(eval_ws / "variants" / sources, ws_dir)
    ws = Workspace(ws_dir)
    path = ws_dir / f"heldout_{fill}.json"
    shutil.copy(eval_ws / "eval" / "heldout_cameras.json", path)
    ckpt = eval_ws / "variants" / model / "model" / "gnfr.safetensors"
    render.run(heldout_render_config(path, float(budget["render_scale"]), device=device,
                                     fill=fill, checkpoint=str(ckpt),
                                     **source_pool(sources, int(budget["eval_views"]))), ws)
    return ws.render_dir(str(path))


def main(argv: list[str] | None = None) -> int:
    from pipeline.errors import UserError
    from pipeline.provenance import sha256, write_result
    from pipeline.workspace import read_json
    from workflows.research.eval.scene import load_synth
    from workflows.research.eval.scoring import score_views

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("synth", type=Path)
    ap.add_argument("eval_ws", type=Path)
    ap.add_argument("--work", type=Path, required=True,
                    help="folder for the copies of the variant workspaces")
    ap.add_argument("--a", default="gnfr")
    ap.add_argument("--b", default="gnt")
    ap.add_argument("--fills", default="hybrid", help="comma-separated: hybrid, network")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    try:
        results = args.eval_ws / "eval" / "results.json"
        if not results.is_file():
            raise UserError(f"{results} is missing: run `deflare-scene eval {args.synth} "
                            f"--out {args.eval_ws} --variants {args.a},{args.b}` first")
        res = read_json(results)
        budget = res["budget"]
        scene = load_synth(args.synth)
        if not scene.heldout:
            raise UserError(f"{args.synth} has no held-out views: build it with "
                            "`deflare-scene synth --heldout N`")
        if res.get("heldout_views") != scene.heldout:
            raise UserError(f"{args.eval_ws} was not evaluated on {args.synth} (its held-out "
                            f"views differ): give the SYNTH folder its eval ran on")
        missing = [m for m in (args.a, args.b)
                   if not (args.eval_ws / "variants" / m / "model").is_dir()]
        if missing:
            raise UserError(f"{args.eval_ws}/variants/{missing[0]} has no model: run eval with "
                            f"--variants {args.a},{args.b}")
        fills = args.fills.split(",")
        if bad := [f for f in fills if f not in ("hybrid", "network")]:
            raise UserError(f"--fills {args.fills}: {', '.join(bad)} is no fill; give hybrid "
                            "and/or network")
        arms = {}
        for fill in fills:
            for model in (args.a, args.b):
                for sources in (args.a, args.b):
                    folder = render_arm(args.eval_ws, args.work, model, sources, fill,
                                        budget, args.device)
                    scores = score_views(scene, folder, scene.heldout, with_region=False)
                    key = f"{model}_model_{sources}_sources_{fill}"
                    arms[key] = {"model": model, "sources": sources, "fill": fill,
                                 **scores}
                    eval_row = res["methods"].get(model, {}).get("heldout", {})
                    same = model == sources and fill == budget.get("fill")
                    print(f"{key}: {scores['psnr']:.3f} dB"
                          + (f" (eval: {eval_row.get('psnr', float('nan')):.3f})"
                             if same else ""), flush=True)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    models = {m: sha256(args.eval_ws / "variants" / m / "model" / "gnfr.safetensors")
              for m in (args.a, args.b)}
    write_result(args.out, {"synth": str(args.synth), "eval_ws": str(args.eval_ws),
                            "eval_results": {m: res["methods"][m].get("heldout", {}).get("psnr")
                                             for m in (args.a, args.b)},
                            "eval_provenance": res.get("provenance"), "budget": budget,
                            "models_sha256": models, "heldout_views": scene.heldout,
                            "arms": arms})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
