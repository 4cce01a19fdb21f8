#!/usr/bin/env bash
# Build the development scenes the render/fill/mask rules of docs/history/fill.md and
# gnfr/weights/fmg.md are scored on: sceaux_castle and et (and lund, the thirteenth session's
# confirmation scene; 15 of its 29 photos pose) from ../shared/data/scenes, decoded
# at 504 px, posed, given synthetic flare of every kind (2 views held out; sceaux_castle
# seed 0: 2 of its 9 training views under 10 % flare, et seed 3: all 7, lund seed 0: 12 of
# 13) and evaluated
# (GN-FR fine-tuned with the true masks, quick preset, CPU). About 10 minutes a scene on one
# core.
#   bash benchmarks/build_dev_scenes.sh [OUT=/work/dev] [DATA=../shared/data/scenes]
# Writes OUT/{sceaux,et,lund}_ws (posed workspaces) and OUT/{sceaux,et,lund}_synth (with
# eval.ws/variants/gnfr/model/gnfr.safetensors). Safe to rerun: every stage resumes.
# COLMAP poses with one thread: with all threads sceaux_castle's solve differed from run to
# run and machine to machine (the twenty-third session's rebuild: true flare on 9.5 % of the
# pixels against 12.8 % in the committed runs), so a rule comparing against committed
# numbers compared different scenes; with one thread and a fixed seed two solves are
# byte-identical (et and sceaux_castle checked). et and lund rebuilt with all threads matched
# the committed scenes (the shipped masks scored as before). Older builds may differ.
set -euo pipefail
OUT=${1:-/work/dev}
DATA=${2:-$(cd "$(dirname "$0")/../.." && pwd)/shared/data/scenes}
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
# seeds of the flare draw: et's seed 0 flares every view above the 10 % rule (no target)
SPECS="sceaux:sceaux_castle:0 et:et:3 lund:lund/images:0"
for spec in $SPECS; do  # every scene present before anything is written
  IFS=: read -r _ name _ <<< "$spec"
  [ -d "$DATA/$name" ] || { echo "no $DATA/$name: pass the scenes folder as the second argument" >&2; exit 2; }
done
mkdir -p "$OUT"
for spec in $SPECS; do
  IFS=: read -r short name seed <<< "$spec"
  deflare-scene decode "$DATA/$name" --out "$OUT/${short}_ws" --max-size 504
  deflare-scene pose "$OUT/${short}_ws" --threads 1 --seed 0 --no-loose-pass   # repeatable (below); the passes of the committed builds
  deflare-scene synth "$OUT/${short}_ws" --out "$OUT/${short}_synth" --heldout 2 --seed "$seed"
  deflare-scene eval "$OUT/${short}_synth" --variants gnfr,input --masks gt \
      --render-scale 0.5 --device cpu
done
