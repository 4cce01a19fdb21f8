#!/bin/bash
# Fit the checkout into the device tool's 64 MiB: hold tracked files a phase does not read.
# The tracked tree is larger than the tool's limit (four 20-25 MB weight files: fmg,
# fmg_candidate_L, fmg_candidate_F26, gnfr_paper), so a call to the lent GPU must leave some
# behind.
# Run from the repo root here:
#   bash benchmarks/device_slim.sh size [CARRY...]   # MB that would travel, and the limit
#   bash benchmarks/device_slim.sh out PATH... [-- CARRY...]   # move PATHs to $HELD, then size
#   bash benchmarks/device_slim.sh back              # every held path restored, git clean
# What each phase of benchmarks/gpu_session.sh can leave behind: `loko`, `check` and the
# bench read neither gnfr/weights/gnfr_paper.safetensors nor fmg_candidate_L.safetensors
# (the thirty-fifth session held both: 57 MB with .carry/fmgdata); `fern`, `devab` and the
# GN-FR pretraining read gnfr_paper; the FMG training of `short`/`train` starts from
# .carry/fmg_init.safetensors or fmg_candidate_L. docs/ and samples/ are read by none.
# $HELD (default ../device_held, outside the checkout) keeps each path under its repo path.
set -eu
HELD=${HELD:-$(cd .. && pwd)/device_held}
LIMIT=67108864   # 64 MiB: the tool's limit on what travels (tracked, untracked not ignored, carry)
travel_bytes() {
  { git ls-files -z --cached --others --exclude-standard | while IFS= read -r -d '' f; do
      [ -f "$f" ] && printf '%s\0' "$f"; done
    for c in "$@"; do [ -e "$c" ] && find "$c" -type f -print0; done
  } | du -cb --files0-from=- 2>/dev/null | tail -1 | cut -f1
}
size() {
  local b; b=$(travel_bytes "$@")
  echo "would travel: $((b / 1000000)) MB of the limit's $((LIMIT / 1000000)) MB"
  [ "$b" -le "$LIMIT" ] || { echo "error: over the device tool's 64 MiB: hold more" \
    "(bash benchmarks/device_slim.sh out PATH)" >&2; return 2; }
}
case ${1:-size} in
size) shift || true; size "$@" ;;
out)
  shift; paths=()
  while [ $# -gt 0 ] && [ "$1" != -- ]; do paths+=("$1"); shift; done
  [ $# -gt 0 ] && shift   # what follows -- is the call's carry
  for p in "${paths[@]}"; do
    [ -e "$p" ] || { echo "error: $p: no such path in the checkout" >&2; exit 2; }
    git ls-files --error-unmatch "$p" > /dev/null 2>&1 \
      || { echo "error: $p: not tracked by git (hold tracked files only)" >&2; exit 2; }
    mkdir -p "$HELD/$(dirname "$p")" && mv "$p" "$HELD/$p" && echo "held: $p"
  done
  size "$@" ;;
back)
  [ -d "$HELD" ] || { echo "nothing held ($HELD)"; exit 0; }
  # files and symbolic links (samples/cyprus_truth/photos is a tracked link)
  (cd "$HELD" && find . \( -type f -o -type l \) -print0) | while IFS= read -r -d '' f; do
    mkdir -p "$(dirname "$f")" && mv "$HELD/$f" "$f" && echo "restored: ${f#./}"
  done
  find "$HELD" -depth -type d -empty -delete
  git status --short | grep '^ D' && { echo "error: tracked files still missing" >&2; exit 2; }
  echo "checkout whole again" ;;
*) echo "error: unknown command $1 (size, out, back)" >&2; exit 2 ;;
esac
