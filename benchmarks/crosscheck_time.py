"""Time of the mask stage per view, alone and with the other photos' checks, on a posed WS.

    python benchmarks/crosscheck_time.py WS --work DIR [--out JSON]

WS is copied into DIR once per setting (nothing of it is changed); the mask stage runs in
each copy with its defaults, alone, with `--crosscheck` and with `--ghost-lines
--ghost-views`, and the seconds the stage records in its manifest are reported per view,
with the share of pixels each marks. The thread count is the process's (set
OMP_NUM_THREADS).
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SETTINGS = {"fmg": {"ghost_lines": False, "ghost_views": False},
            "crosscheck": {"crosscheck": True, "ghost_lines": False, "ghost_views": False},
            "ghost_views": {"ghost_lines": True, "ghost_views": True}}
"""The mask settings timed (MaskConfig fields over its defaults)."""


def stage_copy(ws: Path, work: Path, name: str) -> Path:
    """A fresh copy of ``ws`` without its masks (so the stage runs in full)."""
    out = work / name
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(ws, out, symlinks=True,
                    ignore=shutil.ignore_patterns("masks", "masks_fmg", "masks_ghosts",
                                                  "flare.json"))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", type=Path)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from pipeline import mask
    from pipeline.errors import UserError
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_flare

    if not (a.ws / "cameras.json").is_file():
        print(f"error: {a.ws} is not a posed workspace (no cameras.json): run "
              f"`deflare-scene pose` first", file=sys.stderr)
        return 2
    a.work.mkdir(parents=True, exist_ok=True)
    rows = {}
    try:
        for name, over in SETTINGS.items():
            ws = Workspace(stage_copy(a.ws, a.work, f"{a.ws.name}.{name}"))
            mask.run(mask.MaskConfig(**over), ws, force=True)
            fractions = read_flare(ws).fractions()
            n, secs = len(fractions), mask.stage_seconds(ws)
            rows[name] = {"views": n, "seconds": round(secs, 2),
                          "seconds_per_view": round(secs / n, 3),
                          "marked": round(sum(fractions.values()) / n, 5)}
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    extra = {n: round(r["seconds_per_view"] - rows["fmg"]["seconds_per_view"], 3)
             for n, r in rows.items() if n != "fmg"}
    print(f"{a.ws.name}: mask stage {rows['fmg']['seconds_per_view']:.2f} s per view "
          f"(marked {100 * rows['fmg']['marked']:.2f} %); " + "; ".join(
              f"{n} {extra[n]:+.2f} s (marked {100 * rows[n]['marked']:.2f} %)" for n in extra))
    if a.out:
        write_result(a.out, {"workspace": str(a.ws), "rows": rows,
                             "extra_seconds_per_view": extra["crosscheck"],
                             "extra_seconds_per_view_by_setting": extra})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
