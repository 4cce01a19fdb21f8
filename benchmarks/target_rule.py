"""Which views the 10 % target rule lets train, against the truth, on synthetic-flare workspaces.

The select stage flags a view as a training target when its mask marks at most 10 % of it
(`WS/views.json`). This reads, for each workspace given as SYNTH=WS (a `deflare-scene synth`
folder with `masks_gt/`, and a workspace made from it, e.g. an arm of
`benchmarks/fmg_photo_ab.py`), per view: the share its mask marks (`flare_fraction`), the
true share of flare (`masks_gt/<stem>.png`) and the target flag; and per workspace how many
targets the truth puts over the rule (`targets_over_truth`) and how many views the truth
puts under it that are not targets (`kept_out_under_truth`). No network runs: it reads files
(docs/history/fmg.md, "Seventy-fourth session").

    python benchmarks/target_rule.py /work/dev/sceaux_synth=/work/s70/ab/sceaux_s72_pad_s2.ws \
        ... --out docs/results/target_rule_s74.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def rule_rows(synth: Path, root: Path) -> dict:
    """The per-view rows and the counts of one workspace ``root`` made from ``synth``."""
    from gnfr.view_sampler import is_target
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_mask_file, read_views

    ws = Workspace(root)
    views = read_views(ws)
    limit = views.max_flare  # select's --max-flare, as recorded
    rows = {}
    for s, v in views.views.items():
        truth = read_mask_file(synth / "masks_gt" / f"{s}.png",
                               f"give a synth folder whose masks_gt/ has view {s}")
        rows[s] = {"marked": v.flare_fraction, "true": round(float(truth.mean()), 6),
                   "target": v.target}
    return {"synth": str(synth), "workspace": str(root), "max_flare": limit, "views": rows,
            "targets": sum(r["target"] for r in rows.values()),
            "targets_over_truth": sum(r["target"] and not is_target(r["true"], limit)
                                      for r in rows.values()),
            "kept_out_under_truth": sum(not r["target"] and is_target(r["true"], limit)
                                        for r in rows.values())}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pairs", nargs="+", metavar="SYNTH=WS",
                    help="a synth folder and a workspace made from it")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError
    from pipeline.provenance import write_result

    rows = []
    for pair in a.pairs:
        synth, sep, ws = pair.partition("=")
        if not sep:
            ap.error(f"{pair}: give SYNTH=WS")
        try:
            got = rule_rows(Path(synth).resolve(), Path(ws).resolve())
        except UserError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        rows.append(got)
        print(f"{Path(ws).name}: {got['targets']} targets of {len(got['views'])}, "
              f"{got['targets_over_truth']} over the rule by the truth, "
              f"{got['kept_out_under_truth']} kept out under it", flush=True)
    write_result(a.out, {"workspaces": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
