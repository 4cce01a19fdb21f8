"""One training detail, on and off: GN-FR fine-tuned twice on a synth scene, same budget.

    python benchmarks/finetune_ab.py SCENE --set random_sources=true --work DIR \
        [--preset quick] [--iters N] [--seed S] [--out JSON]

A ``--set`` of an `eval` option (``init=FILE.safetensors``, ``iters=N``) sets that option of
the second run; any other names a FinetuneConfig field.

Runs `deflare-scene eval SCENE --variants gnfr` twice, in DIR/base.ws (the defaults) and
DIR/<name>.ws (the defaults plus the ``--set`` FinetuneConfig fields), with the same preset,
steps, seed, masks and fill, and reports both rows (held-out novel views, de-flared inputs
and their flare region, training speed). Each run resumes, so a base run is reused by a
second experiment with the same budget. Make choices with it on development scenes only
(pipeline.scene_splits.DEV_SCENES).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path


def parse_sets(items: list[str]) -> dict:
    """{field: value} of ``field=value`` items (values read as JSON, else as text)."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--set {item}: give FIELD=VALUE")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


def arm_label(value) -> str:
    """A value as it names the second arm: a weight file by its stem, anything else as
    written (``0.5`` stays ``0.5``; before the ninth session it became ``0``)."""
    text = str(value)
    return Path(text).stem if text.endswith(".safetensors") else text


def row(results: Path) -> dict:
    """The gnfr row of an eval's results.json, without the per-view detail."""
    g = json.loads(results.read_text())["methods"]["gnfr"]
    return {"heldout_psnr": g["heldout"]["psnr"], "heldout_ssim": g["heldout"]["ssim"],
            "inputs_psnr": g["inputs"]["psnr"], "inputs_ssim": g["inputs"]["ssim"],
            "flare_region_psnr": g["inputs"]["psnr_flare"], "train": g["train"],
            "provenance": g.get("provenance")}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--set", dest="sets", action="append", required=True)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--preset", default="quick")
    ap.add_argument("--masks", default="fmg", choices=("fmg", "gt"),
                    help="both arms' masks: the FMG's (default) or the synth folder's true "
                         "ones (e.g. a flare-free scene, where they are empty)")
    ap.add_argument("--iters", type=int)
    ap.add_argument("--seed", type=int, default=0,
                    help="training seed of both arms (eval's --seed)")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from pipeline.errors import UserError
    from pipeline.provenance import write_result
    from workflows.research.eval import EvalConfig, run

    extra = parse_sets(a.sets)
    name = "_".join(f"{k}-{arm_label(v)}" for k, v in extra.items()).lower()
    res = {"scene": str(a.scene), "preset": a.preset, "iters": a.iters, "masks": a.masks,
           "seed": a.seed, "set": extra}
    own = {f.name for f in dataclasses.fields(EvalConfig)}  # e.g. init: eval's own option
    for label, fields in (("base", {}), (name, extra)):
        top = {k: v for k, v in fields.items() if k in own}
        rest = {k: v for k, v in fields.items() if k not in own}
        opts = {"preset": a.preset, "iters": a.iters, "masks": a.masks, "seed": a.seed,
                **top}  # --set wins
        try:
            out = run(EvalConfig(scene=a.scene, out=a.work / f"{label}.ws", variants=("gnfr",),
                                 finetune_extra=rest, **opts))
        except UserError as e:  # a bad scene, option or value: one line, as the CLI says it
            print(f"error: {e}", file=sys.stderr)
            return 2
        res[label] = row(out / "results.json")
        r = res[label]
        region = r["flare_region_psnr"]
        print(f"{label}: held-out {r['heldout_psnr']:.2f} / {r['heldout_ssim']:.3f}, inputs "
              f"{r['inputs_psnr']:.2f}, flare region "
              f"{'-' if region is None else f'{region:.2f}'}, "
              f"{r['train']['it_per_s']:.2f} it/s")
    write_result(a.out, res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
