#!/bin/bash
# Work for a lent CUDA machine (the `device` tool), one phase per call, each ending inside
# the tool's 10-minute limit. Step by step, with the next session's call: docs/gpu.md.
# Run from the repo root there. Prepare here, on CPU, the data
# it carries (.carry/ is ignored by git: `echo .carry/ >> .git/info/exclude`):
#   python -m workflows.research.scene_pack SCENES... --out .carry/packs \
#       --quality 85                                                          # GN-FR, ~8 MB
#   python -m workflows.research.scene_pack --fmg-photos ../shared/data --out .carry/fmgdata \
#       --quality 60                                                          # FMG, 7.3 MB
#   bash benchmarks/build_dev_scenes.sh /work/dev      # SYNTH=/work/dev/et_synth (CPU, ~10 min)
#   mkdir -p .carry/dev/et_synth; cp -r SYNTH/{photos,clean,masks_gt,cameras_gt.json,split.json} \
#       .carry/dev/et_synth          # devab (5 MB); pip download trimesh -d .carry/whl (eval-llff)
# and call with carry naming the folders the phase reads (train: .carry/packs, .carry/fmgdata;
# devab: .carry/dev, .carry/whl; fern: .carry/fern, .carry/whl). The checkout and the carried
# folders must stay under 64 MiB (67.1 MB) together; the tracked tree alone is larger, with
# four 20-25 MB weight files (fmg, fmg_candidate_L, fmg_candidate_F26, gnfr_paper), so hold
# what the phase does not read first:
#   bash benchmarks/device_slim.sh out gnfr/weights/fmg_candidate_L.safetensors ... -- CARRY
# (it prints what would travel; `device_slim.sh back` after the calls). Older notes follow:
# carry .carry/packs in one call and .carry/fmgdata in the next
# (each training loads its data when it starts and runs on while the machine stays warm;
# the next call must come within the tool's 30 s of warmth). The sixteenth session carried
# packs at quality 90 (9.5 MB) and the FMG photos at 85 (13 MB) beside a 33 MB repo.
# Since the eighteenth session a session's device time is 15 minutes in all (a start costs 1-2
# of them): plan ONE call of `short` (the repo is 59 MB, so only one of .carry/fmgdata at
# --quality 60 or .carry/packs at a lower quality fits beside it under 67.1 MB).
# The twenty-second session carried both (.carry/packs 9.9 MB, .carry/fmgdata at --quality 60
# 7.3 MB) by moving docs/, samples/ and gnfr/weights/fmg_candidate_H.safetensors (none read
# by these phases or the gpu tests) out of the checkout for the call: 66.4 MB in all; moved
# back after (`git status` clean). Then `short 570` and, the machine still warm (30 s),
# `train 235` kept both trainings going: 13 400 FMG steps and 5 200 GN-FR steps in 13 min.
# Phases (bash benchmarks/gpu_session.sh PHASE [END_SECONDS] [ITERS]):
#   short   the trainings whose data is carried, started first, then the gpu-marked tests,
#           then the trainings go on until END and are exported (one call, e.g. END 540)
#   check   gpu-marked tests and the bench (paper / quick, 504 and 1008 px), render --compile
#   train   GN-FR `paper` pretraining and the full-width FMG training side by side on the
#           GPU (the pretraining's small batches leave it mostly idle), started in the
#           background if not running (from gnfr/weights/gnfr_paper.safetensors and
#           .carry/fmg_init.safetensors or fmg_candidate_L.safetensors), until END; then both
#           exported (fp16, split under the tool's 16 MiB per file)
#   session one call for a whole 15-minute lease (the seventy-seventh session's): the paper
#           bench alone on the GPU, then the FMG training (FMG_FROM=FILE: its start, default
#           L) beside the gpu tests and fern's `paper` fine-tune of ITERS steps; the FMG
#           exported at END, the small results in one small.tar (carry .carry/fmgdata,
#           .carry/fern, .carry/whl). On an H200: 13 119 FMG steps in 661 s over it and a
#           `train 215` on the warm machine, fern's 1 500 steps in 228 s beside them.
#   devab   the development A/B that decides `auto_init` of gnfr_paper.safetensors
#           (gnfr/weights/gnfr.md): `paper` fine-tuned ITERS steps on et's synth set from
#           scratch and from the file (resumes: run it again if a call ends first)
#   fern    fern in the LLFF protocol at `paper` from the latest paper checkpoint (ITERS steps);
#           sends back its model (fp16 parts, fern_run.part_*): carried in the next session's
#           call as .carry/fern_run, the fine-tune goes on from there (ITERS the total)
#           and its small results in small.tar. The seventy-eighth session (an H200, carry
#           .carry/{fmgdata,fern,whl,fmg_init.safetensors}, docs/, samples/ and six weight files
#           held): `fern 575 2700` ran 2 700 fern steps in 425 s beside 8 600 FMG steps,
#           then `train 230` took the FMG to 12 800 (F26); 13.2 device minutes in all.
#   loko    the full-width leave-one-kind-out table (issue 10 item 2): six FMG runs from
#           scratch on the GPU at once (without each kind, and with all), ITERS steps each or
#           until END - 200 s (then their last checkpoints), each calibrated, scored by `fmg
#           eval --per-kind --loo` on the dev and test splits there; carry .carry/fmgdata.
#           The thirtieth session's P (M + 10 000 steps at 2e-4) fell on the development
#           scenes: more steps of one recipe are no longer the plan (gnfr/weights/fmg.md).
#           Also scored on daylight composites alone (`--night 0`): the thirty-first session
#           found the thin kinds at flare IoU 0.17-0.29 on daylight, composites and photos
#           alike; FMG_NIGHT=F sets the `short`/`train` run's --night-prob (default 0.35),
#           FMG_KINDS=K=P,... its --kind-probs and FMG_CANVAS=C its --flare-canvas (the
#           thirty-second session's CPU candidates D/D2: docs/history/fmg.md), FMG_FRAMES=P
#           its --frame-prob (windows of whole photos with flare drawn as `synth` draws it;
#           the sixtieth session's CPU candidate W: photo parts up, composites and streaks
#           down; next here: FMG_FRAMES=0.5 FMG_KINDS=starburst=0.7,ghosts=0.7,streaks=0.85).
#           FMG_NIGHT_GLARE=G its --night-glare (the glare kind G times as likely on night
#           backgrounds; 0.25 for the card's next recipe, gnfr/weights/fmg.md "Next").
#           The thirty-fifth session ran all six for 1 250 steps each (`loko 555 20000`);
#           LOKO_KINDS="ghosts streaks" trains only those beside the control, for more steps.
# devab and fern stop their own job 50 s before END (it resumes in the next call), keep the
# trainings going beside them (started if their data is there) and
# export both at END, like train. Name every folder a call reads in that call's carry: in
# the sixteenth session a folder carried by the first call was gone in the second.
# Back here: `cat ptp.part_* > gnfr_paper.safetensors`, `cat fmg.part_* > fmg.safetensors`.
# The FMG comes back as its weights of best validation flare IoU (`best.safetensors`; its
# metadata says `export`, the step and the score; FMG_EXPORT=last for the latest checkpoint,
# the one the twenty-second session's K was); FMG_LR=R gives its run a lower peak rate (a
# continuation of already trained weights, whose optimizer state is never carried back), and
# PT_LR_RESTART=F the GN-FR pretraining (`pretrain --lr-restart F`: the twenty-second
# session's continuation at full rates lost 1.44 dB zero-shot on et, gnfr/weights/gnfr.md).
# The twenty-third session (FMG_LR=2e-4 PT_LR_RESTART=0.25, short 570 then train 235) made
# fmg_candidate_L (J + 10 000 steps, best validation) and a paper prior that lost 1.29 dB on
# et (not kept). The twenty-fourth session (no GPU) trained L 200-600 more steps at 2e-4 on the
# CPU: every mask score rose (fmg.md, candidates B and M), so FMG_LR=2e-4 from L stays the plan.
# The fifty-ninth session (an H200, FMG alone: FMG_WORKERS=14 FMG_LR=2e-4 with the daylight mix
# above, `short 535` then `train 200`) ran 13 700 FMG steps in 668 s, about 20.5 steps/s with
# the loaders the limit; candidates R8/R13 failed their rule (fmg.md, "Next": other data).
# On a fresh machine the packs' scenes come from the recipe in gnfr.md
# ("Exact commands": workflows.research.pretrain_scenes, then decode + pose of et,
# sceaux_castle, sacre_coeur, lund; about 5 minutes) plus maryrose and tumbler as they are.
set -u
PHASE=${1:-check}; END=${2:-560}; ITERS=${3:-2000}
T0=$(date +%s)
export PYTHONPATH=$PWD PYTHONUNBUFFERED=1
# ../shared does not travel to the device: every `fmg` command without --data (calibrate,
# eval) reads the carried photos
[ -d .carry/fmgdata ] && export DEFLARE_SHARED_DATA=${DEFLARE_SHARED_DATA:-$PWD/.carry/fmgdata}
if ls .carry/whl/*.whl > /dev/null 2>&1; then
  python3 -m pip install -q --no-index --no-deps --target /tmp/site .carry/whl/*.whl \
    && export PYTHONPATH=$PWD:/tmp/site
fi
PT=${PT:-/root/ptp}; FM=${FM:-/root/fmg}; LK=${LK:-/root}; DEV=${DEV:-cuda}   # PT, FM, LK, DEV=cpu: a dry run here
cli() { python3 -m workflows.cli "$@"; }
left() { echo $(( END - ($(date +%s) - T0) )); }
running() { pgrep -f "$1" > /dev/null; }
start_pt() {
  local init=scratch
  [ -f gnfr/weights/gnfr_paper.safetensors ] && init=gnfr/weights/gnfr_paper.safetensors
  [ -f $PT/train_state.pt ] && init=scratch   # the run folder resumes by itself
  ls .carry/packs > $PT.scenes   # the scenes it trains on, for the export's metadata
  setsid nohup python3 -m workflows.cli pretrain .carry/packs --out $PT --preset pretrain \
    --device $DEV --seed 1 --ckpt-every ${CKPT:-500} --iters 500000 --init $init \
    ${PT_LR_RESTART:+--lr-restart $PT_LR_RESTART} \
    >> $PT.log 2>&1 < /dev/null &
  echo "GN-FR pretraining started (init $init)"
}
start_fmg() {
  local init=() from=${FMG_FROM:-gnfr/weights/fmg_candidate_L.safetensors}   # L: 26 200 GPU steps
  [ -f .carry/fmg_init.safetensors ] && from=.carry/fmg_init.safetensors
  [ -f $from ] && [ ! -f $FM/checkpoint.safetensors ] && init=(--init $from)
  setsid nohup python3 -m workflows.cli fmg train --out $FM --data .carry/fmgdata \
    --device $DEV --iters 20000 --batch ${FMG_BATCH:-16} --size 256 --widths 64,128,256,512 \
    --depths 2,2,2,2 --skip-width 32 --ckpt-every ${CKPT:-200} --eval-every 2000 \
    --night-prob ${FMG_NIGHT:-0.35} --flare-canvas ${FMG_CANVAS:-1} --frame-prob ${FMG_FRAMES:-0} \
    --kind-probs ${FMG_KINDS:-starburst=0.7,ghosts=0.7,streaks=0.7} --dice 0.5 "${init[@]}" \
    --workers ${FMG_WORKERS:-10} ${FMG_LR:+--lr $FMG_LR} ${FMG_NIGHT_GLARE:+--night-glare $FMG_NIGHT_GLARE} \
    >> $FM.log 2>&1 < /dev/null &
  echo "FMG training started (${init[*]:-scratch})"
}
export_pt() {
  [ -f $PT/gnfr.safetensors ] || { echo "no GN-FR checkpoint yet"; return; }
  python3 -c "from pathlib import Path; from workflows.research.pretrain import export_fp16; \
export_fp16(Path('$PT/gnfr.safetensors'), Path('${PT}16.safetensors'), \
{'pretrain_scenes': sorted(Path('$PT.scenes').read_text().split()), \
 'synthetic_flare': True, 'auto_init': False})" && \
    split -b 15000000 ${PT}16.safetensors $OUT/ptp.part_
  cp $PT/metrics.jsonl $OUT/ptp_metrics.jsonl 2>/dev/null
}
export_fmg() {   # the weights of best validation (FMG_EXPORT=last: the latest checkpoint)
  [ -f $FM/checkpoint.safetensors ] || { echo "no FMG checkpoint yet"; return; }
  local best=True; [ "${FMG_EXPORT:-best}" = last ] || [ ! -f $FM/best.safetensors ] && best=False
  python3 -c "from pathlib import Path; from workflows.research.fmg_train import \
export_checkpoint; export_checkpoint(Path('$FM'), Path('${FM}16.safetensors'), best=$best, \
extra={'export': 'best validation' if $best else 'last checkpoint'})" && \
    split -b 15000000 ${FM}16.safetensors $OUT/fmg.part_
  cp $FM/log.jsonl $OUT/fmg_log.jsonl 2>/dev/null
}
train_on() {   # both trainings run on in the background across calls (setsid)
  [ -d .carry/packs ] && { running "pretrain .carry/packs" || start_pt; }
  [ -d .carry/fmgdata ] && { running "fmg train --out $FM" || start_fmg; }
  return 0
}
until_end_then_export() {
  while [ "$(left)" -gt 40 ]; do sleep 10; done
  tail -2 $PT.log; tail -2 $FM.log; export_pt; export_fmg
  # at most 8 files come back: the two weight files' parts (4), their logs (3) and the
  # phase's own result (the FMG's text log is not kept: its log.jsonl holds the same)
  tail -c 4000 $PT.log > $OUT/ptp_log.txt; ls -la $OUT
}
gpu_tests() {   # the gpu-marked tests, their log written to $1, its end printed
  python3 -m pytest -q -m gpu tests/gnfr/test_gpu.py -p no:cacheprovider -rA > "$1" 2>&1
  tail -6 "$1"
}
fern_llff() {   # fern in the LLFF protocol at `paper` from $2 for ITERS steps into /root/fern,
                # stopped $1 s before END; its output in /root/fern_log.txt, the end printed
  timeout $(( $(left) - $1 )) python3 -m workflows.cli eval-llff .carry/fern --out /root/fern \
    --preset paper --init "$2" --iters $ITERS --device cuda > /root/fern_log.txt 2>&1
  tail -15 /root/fern_log.txt
}
case $PHASE in
check)
  nvidia-smi -L; python3 -c "import torch; print(torch.__version__, torch.cuda.get_device_name())"
  gpu_tests $OUT/gpu_tests.log
  for p in paper quick; do
    cli bench --preset $p --device cuda --out $OUT/bench_${p}_cuda.json 2>&1 | tail -2; done
  cli bench --preset paper --device cuda --train-size 1008x756 \
    --out $OUT/bench_paper_cuda_1008.json 2>&1 | tail -2
  python3 benchmarks/render_compile.py --preset paper --device cuda \
    --out $OUT/render_compile_cuda_paper.json 2>&1 | tail -2
  exit 0 ;;
train)
  train_on
  until_end_then_export
  exit 0 ;;
short)
  train_on
  gpu_tests $OUT/gpu_tests.log
  until_end_then_export
  exit 0 ;;
devab)
  train_on   # the A/B shares the GPU with the trainings: its scores, not its speed, count
  timeout $(( $(left) - 50 )) python3 benchmarks/finetune_ab.py .carry/dev/et_synth --preset paper --iters $ITERS \
    --set init=gnfr/weights/gnfr_paper.safetensors --work /root/ab \
    --out $OUT/finetune_ab_paper_init_dev_et.json 2>&1 | tail -5
  until_end_then_export
  exit 0 ;;
fern)
  init=gnfr/weights/gnfr_paper.safetensors
  [ -f $PT/gnfr.safetensors ] && export_pt && cp ${PT}16.safetensors /root/fern_init.safetensors \
    && init=/root/fern_init.safetensors
  # across sessions: the fern fine-tune an earlier session sent back (fern_run.part_*, put in
  # .carry/fern_run) goes on at its step count and rate (finetune's continuation of a model
  # carried without its optimizer state); ITERS is then the total, e.g. 50000
  if ls .carry/fern_run/fern_run.part_* > /dev/null 2>&1; then
    cat .carry/fern_run/fern_run.part_* > /root/fern_run.safetensors; init=/root/fern_run.safetensors
  fi
  train_on
  fern_llff 50 $init
  # the small results in one tar: with the two models' parts and the trainings' logs they
  # stay inside the tool's 8 files
  mkdir -p /root/small; cp /root/fern_log.txt /root/small/
  cp /root/fern/results.json /root/small/fern_paper_results.json 2>/dev/null
  cp /root/fern/table.md /root/small/fern_table.md 2>/dev/null
  FR=/root/fern/clean.ws/variants/gnfr/model   # its last checkpoint, fp16, for the next session
  cp $FR/metrics.jsonl /root/small/fern_metrics.jsonl 2>/dev/null
  [ -f $FR/gnfr.safetensors ] && python3 -c "from pathlib import Path; \
from workflows.research.pretrain import export_fp16; \
export_fp16(Path('$FR/gnfr.safetensors'), Path('/root/fern_run16.safetensors'))" \
    && split -b 15000000 /root/fern_run16.safetensors $OUT/fern_run.part_
  tar -C /root/small -cf $OUT/small.tar .
  until_end_then_export
  exit 0 ;;
loko)   # issue 10 item 2 at full width: six runs from scratch side by side, one without each
        # kind and one with every kind (the fair column beside them: same steps, same recipe)
  KINDS=${LOKO_KINDS:-starburst ghosts streaks glare scatter}   # fewer runs: more steps each
  mkdir -p $LK $OUT
  for k in all $KINDS; do
    w=(); [ $k = all ] || w=(--without $k)
    setsid nohup python3 -m workflows.cli fmg train --out $LK/loko_$k --data .carry/fmgdata \
      --device $DEV --iters $ITERS --batch ${LOKO_BATCH:-16} --size 256 --widths 64,128,256,512 \
      --depths 2,2,2,2 --skip-width 32 --ckpt-every 250 --eval-every 1000000 --night-prob 0.35 \
      --kind-probs starburst=0.7,ghosts=0.7,streaks=0.7 --dice 0.5 "${w[@]}" \
      --workers ${LOKO_WORKERS:-2} > $LK/loko_$k.log 2>&1 < /dev/null &
  done
  [ $DEV = cuda ] && gpu_tests $OUT/gpu_tests.log   # the CUDA tests beside the six runs (20 s)
  while pgrep -f "fmg train --out $LK/loko_" > /dev/null && [ "$(left)" -gt 200 ]; do sleep 10; done
  pkill -f "fmg train --out $LK/loko_"; sleep 5
  for k in all $KINDS; do   # a run cut short by the clock: its last checkpoint, kind recorded
    tail -1 $LK/loko_$k.log
    [ -f $LK/loko_$k/fmg.safetensors ] || python3 -c "from pathlib import Path; \
from workflows.research.fmg_train import export_checkpoint; export_checkpoint(Path('$LK/loko_$k'), \
Path('$LK/loko_$k/fmg.safetensors'), extra={'without': '${k/all/}', 'export': 'cut short'})"
    cli fmg calibrate --weights $LK/loko_$k/fmg.safetensors --write > /dev/null 2>&1 &
  done
  wait   # the six calibrations side by side, then the three tables side by side
  loo=(); for k in $KINDS; do loo+=(--loo $LK/loko_$k/fmg.safetensors); done
  for split in dev test; do
    cli fmg eval --weights $LK/loko_all/fmg.safetensors --per-kind --split $split \
      --count ${LOKO_COUNT:-48} --rays "${loo[@]}" --out $OUT/fmg_loko_full_width_$split.json \
      > $LK/eval_$split.log 2>&1 &
  done
  cli fmg eval --weights $LK/loko_all/fmg.safetensors --per-kind --split dev --night 0 \
    --count ${LOKO_COUNT:-48} --rays "${loo[@]}" --out $OUT/fmg_loko_full_width_dev_day.json \
    > $LK/eval_dev_day.log 2>&1 &
  wait; tail -n 8 $LK/eval_*.log
  for k in all $KINDS; do echo "== $k"; grep -v '^|' $LK/loko_$k.log | tail -n 3; done \
    > $OUT/loko_train_tails.txt
  exit 0 ;;
session)   # one call for a whole 15-minute lease (a start costs 1-2 of them): the paper bench
           # alone on the GPU, then the FMG training (.carry/fmgdata) beside the CUDA tests and
           # fern's `paper` fine-tune of ITERS steps (.carry/fern, .carry/whl), the FMG
           # exported at END; the small results come back in one tar (the tool returns 8 files)
  mkdir -p /root/small; nvidia-smi -L
  cli bench --preset paper --device cuda --rays ${BENCH_RAYS:-65536} \
    --out /root/small/bench_paper_cuda.json 2>&1 | tail -3
  train_on
  gpu_tests /root/small/gpu_tests.log
  if [ -d .carry/fern ]; then
    fern_llff 60 gnfr/weights/gnfr_paper.safetensors
    cp /root/fern_log.txt /root/small/fern_log.txt
    cp /root/fern/results.json /root/small/fern_paper_results.json 2>/dev/null
    cp /root/fern/table.md /root/small/fern_table.md 2>/dev/null
    cp /root/fern/clean.ws/variants/gnfr/model/metrics.jsonl /root/small/fern_metrics.jsonl 2>/dev/null
  fi
  while [ "$(left)" -gt 40 ]; do sleep 5; done
  tail -2 $FM.log; export_fmg; tail -c 6000 $FM.log > /root/small/fmg_log_tail.txt
  tar -C /root/small -cf $OUT/small.tar . ; ls -la $OUT
  exit 0 ;;
*) echo "unknown phase $PHASE (short, check, train, devab, fern, loko, session)"; exit 2 ;;
esac
