"""One table of many render settings' held-out frames, each against a base arm.

An exploration of render options (not a rule) renders each setting with ``novel_loo.py
--heldout`` on several fine-tuned workspaces, writing ``DIR/ARM_SCENE_sSEED.json``; this
reads them all and writes, per arm, each draw's PSNR / SSIM and the seed means' and scene
means' differences from ``--base``:

    python benchmarks/novel_loo_table.py DIR --base base [--scenes sceaux,et,lund] \
        [--seeds 6,7] [--arms a,b] --out JSON

Arms default to every ``ARM`` with a file for each scene and seed.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def table(work: Path, base: str, scenes: list[str], seeds: list[int],
          arms: list[str] | None = None) -> dict:
    """{arm: {"sets": its render options, "draws": {SCENE_sSEED: [psnr, ssim]}, "scenes":
    {SCENE: [dpsnr, dssim]}, "mean": [dpsnr, dssim]}}: differences from ``base``, seed
    means then scene means."""
    from pipeline.errors import UserError

    def name(arm: str, sc: str, s: int) -> Path:
        return work / f"{arm}_{sc}_s{s}.json"

    if arms is None:
        found = {p.name.split(f"_{scenes[0]}_s{seeds[0]}.json")[0]
                 for p in work.glob(f"*_{scenes[0]}_s{seeds[0]}.json")}
        arms = sorted(a for a in found
                      if all(name(a, sc, s).is_file() for sc in scenes for s in seeds))
    out = {}
    for arm in [base, *[a for a in arms if a != base]]:
        draws, sets = {}, None
        for sc in scenes:
            for s in seeds:
                f = name(arm, sc, s)
                if not f.is_file():
                    raise UserError(f"{f}: no such result; render it with novel_loo.py first")
                r = json.loads(f.read_text())
                draws[f"{sc}_s{s}"] = [r["psnr"], r["ssim"]]
                sets = r.get("sets", sets)
        out[arm] = {"sets": sets, "draws": draws}
    for v in out.values():
        per = {sc: [sum(v["draws"][f"{sc}_s{s}"][i] - out[base]["draws"][f"{sc}_s{s}"][i]
                        for s in seeds) / len(seeds) for i in (0, 1)] for sc in scenes}
        v["scenes"] = per
        v["mean"] = [sum(p[i] for p in per.values()) / len(per) for i in (0, 1)]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("work", type=Path)
    ap.add_argument("--base", default="base")
    ap.add_argument("--scenes", default="sceaux,et,lund")
    ap.add_argument("--seeds", default="6,7")
    ap.add_argument("--arms", default=None, help="arms separated by commas (default: all)")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError

    try:
        seeds = [int(s) for s in a.seeds.split(",")]
    except ValueError:
        print(f"error: --seeds takes integers separated by commas, got {a.seeds!r}",
              file=sys.stderr)
        return 2
    try:
        res = table(a.work, a.base, a.scenes.split(","), seeds,
                    a.arms.split(",") if a.arms else None)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for arm, v in sorted(res.items(), key=lambda kv: -kv[1]["mean"][0]):
        cells = "  ".join(f"{sc} {d[0]:+.3f}/{d[1]:+.4f}" for sc, d in v["scenes"].items())
        print(f"{arm:14s} {cells}  mean {v['mean'][0]:+.3f} / {v['mean'][1]:+.4f}")
    if a.out:
        from pipeline.provenance import write_result

        write_result(a.out, {"base": a.base, "seeds": seeds, "arms": res})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
