#!/usr/bin/env bash
# The README's main job at one commit, as a new user runs it, timed and scored:
#   bash benchmarks/oneshot_at.sh NAME COMMIT [REPO]
# clones REPO (default: this checkout) at COMMIT into /tmp/NAME, makes a fresh virtual
# environment with the README's set-up command, runs `/usr/bin/time -v deflare-scene
# samples/cyprus` (log: /tmp/NAME/oneshot.log, with the wall time and peak memory) and scores
# the de-flared photos into /tmp/NAME/scores.json (benchmarks/sample_scores.py). Run two
# commits one after the other on an otherwise idle machine to compare them.
set -euo pipefail
NAME=$1; COMMIT=$2; REPO=${3:-$(cd "$(dirname "$0")/.." && pwd)}
cd /tmp && rm -rf "$NAME" && git clone -q "$REPO" "$NAME" && cd "$NAME" && git checkout -q "$COMMIT"
python3 -m venv .venv && source .venv/bin/activate && python -m pip install -q --upgrade pip
pip install -q torch==2.13.0 -e ".[test]" > /dev/null 2>&1
/usr/bin/time -v deflare-scene samples/cyprus > oneshot.log 2>&1
grep -E "Elapsed|Maximum resident" oneshot.log
python benchmarks/sample_scores.py samples/cyprus.deflare --out scores.json > /dev/null
