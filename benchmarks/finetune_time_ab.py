"""How long the fine-tune takes under two settings or two versions, in alternating runs.

    python benchmarks/finetune_time_ab.py WS --work DIR --arm pad= \
        --arm stretch=--no-pad-views [--exe old=/tmp/old/.venv/bin/deflare-scene] \
        [--iters 900] [--rounds 3] [--out JSON]

Each ``--arm NAME=ARGS`` is a copy of the workspace WS in DIR/NAME (WS itself is only read)
fine-tuned with ``deflare-scene finetune DIR/NAME --iters N --force ARGS``, by the
``deflare-scene`` beside this Python unless ``--exe NAME=PATH`` names another (a clone at
another commit, as ``benchmarks/oneshot_at.sh`` makes them). The arms take turns, round
after round, so that a shared machine's drift in speed (several per cent within minutes
on this one) falls on every arm alike; one arm run after the other compares the machine's
moods as much as the arms. Reports each run's wall time and the stage's own training
seconds and speed (``WS/manifest.json``), and each arm's mean and its ratio to the first
arm's. Run it on an otherwise idle machine.
"""

from __future__ import annotations

import argparse
import json
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path


def parse_pairs(items: list[str], what: str) -> dict[str, str]:
    """{name: value} of ``NAME=VALUE`` items, in their order."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise SystemExit(f"{what} {item}: give NAME=VALUE")
        out[name] = value
    return out


def stage_record(ws: Path) -> dict:
    """The finetune stage's seconds, train_seconds and it_per_s from ``ws``'s manifest."""
    stage = json.loads((ws / "manifest.json").read_text())["stages"]["finetune"]
    return {k: stage.get(k) for k in ("seconds", "train_seconds", "it_per_s", "steps")}


def commit_of(exe: str) -> str | None:
    """The commit of the checkout a ``deflare-scene`` executable runs (its virtual
    environment's parent folder, as ``benchmarks/oneshot_at.sh`` lays it out, or this
    checkout), None where that is not a git checkout."""
    root = Path(exe).resolve().parents[2]
    if not (root / ".git").exists():
        root = Path(__file__).resolve().parents[1]
    r = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                       text=True)
    return r.stdout.strip() or None


def summary(runs: list[dict], arms: list[str]) -> dict:
    """Each arm's mean wall and training seconds and its ratio to the first arm's."""
    out = {}
    for arm in arms:
        mine = [r for r in runs if r["arm"] == arm]
        out[arm] = {"runs": len(mine),
                    "wall_s": sum(r["wall_s"] for r in mine) / len(mine),
                    "train_s": sum(r["train_seconds"] for r in mine) / len(mine)}
    first = out[arms[0]]
    for arm in arms:
        out[arm]["wall_ratio"] = out[arm]["wall_s"] / first["wall_s"]
        out[arm]["train_ratio"] = out[arm]["train_s"] / first["train_s"]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("ws", type=Path)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--arm", action="append", required=True, help="NAME=ARGS")
    ap.add_argument("--exe", action="append", default=[], help="NAME=PATH")
    ap.add_argument("--iters", type=int, default=900)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    arms = parse_pairs(a.arm, "--arm")
    exes = parse_pairs(a.exe, "--exe")
    if unknown := set(exes) - set(arms):
        raise SystemExit(f"--exe {sorted(unknown)[0]}: no --arm of that name")
    if not (a.ws / "manifest.json").is_file():
        raise SystemExit(f"{a.ws}: not a workspace (no manifest.json)")
    here = str(Path(sys.executable).with_name("deflare-scene"))
    exes = {name: exes.get(name, here) for name in arms}
    a.work.mkdir(parents=True, exist_ok=True)
    for name in arms:
        shutil.rmtree(a.work / name, ignore_errors=True)
        shutil.copytree(a.ws, a.work / name)
    runs = []
    for r in range(a.rounds):
        for name, extra in arms.items():
            cmd = [exes[name], "finetune", str(a.work / name), "--iters",
                   str(a.iters), "--force", *shlex.split(extra)]
            log = a.work / f"{name}_{r}.log"
            t0 = time.perf_counter()
            with log.open("w") as f:
                rc = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode
            wall = time.perf_counter() - t0
            if rc != 0:
                raise SystemExit(f"{shlex.join(cmd)} failed ({rc}): see {log}")
            run = {"arm": name, "round": r, "wall_s": round(wall, 2), **stage_record(a.work / name)}
            runs.append(run)
            print(json.dumps(run), flush=True)
    res = {"ws": str(a.ws), "iters": a.iters, "rounds": a.rounds,
           "arms": {n: {"args": arms[n], "exe": exes[n], "commit": commit_of(exes[n])}
                    for n in arms},
           "runs": runs, "summary": summary(runs, list(arms))}
    print(json.dumps(res["summary"], indent=1))
    if a.out:
        a.out.write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
