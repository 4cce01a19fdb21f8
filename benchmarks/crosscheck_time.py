"""Time of the mask stage with and without `--crosscheck`, per view, on a posed workspace.

    python benchmarks/crosscheck_time.py WS --work DIR [--out JSON]

WS is copied twice into DIR (nothing of it is changed); the mask stage runs in each copy
with its defaults, once without and once with `--crosscheck`, and the seconds the stage
records in its manifest are reported per view, with the share of marked pixels the
cross-check dropped. The thread count is the process's (set OMP_NUM_THREADS).
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def stage_copy(ws: Path, work: Path, name: str) -> Path:
    """A fresh copy of ``ws`` without its masks (so the stage runs in full)."""
    out = work / name
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(ws, out, symlinks=True,
                    ignore=shutil.ignore_patterns("masks", "masks_fmg", "flare.json"))
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
        for name, cc in (("fmg", False), ("crosscheck", True)):
            ws = Workspace(stage_copy(a.ws, a.work, f"{a.ws.name}.{name}"))
            mask.run(mask.MaskConfig(crosscheck=cc), ws, force=True)
            fractions = read_flare(ws).fractions()
            n, secs = len(fractions), mask.stage_seconds(ws)
            rows[name] = {"views": n, "seconds": round(secs, 2),
                          "seconds_per_view": round(secs / n, 3),
                          "marked": round(sum(fractions.values()) / n, 5)}
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    extra = rows["crosscheck"]["seconds_per_view"] - rows["fmg"]["seconds_per_view"]
    print(f"{a.ws.name}: mask stage {rows['fmg']['seconds_per_view']:.2f} s per view, with "
          f"--crosscheck {rows['crosscheck']['seconds_per_view']:.2f} (+{extra:.2f}); marked "
          f"{100 * rows['fmg']['marked']:.2f} % -> {100 * rows['crosscheck']['marked']:.2f} %")
    if a.out:
        write_result(a.out, {"workspace": str(a.ws), "rows": rows,
                             "extra_seconds_per_view": round(extra, 3)})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
