#!/bin/bash
# Work for a lent CUDA machine (the `device` tool), one phase per call, each ending inside
# the tool's 10-minute limit. Run from the repo root there, with the training data carried:
#   python -m workflows.research.scene_pack SCENES... --out .carry/packs   # here, on CPU
#   cp -r ../shared/data/scenes/fern .carry/fern; pip download trimesh -d .carry/whl
# phases:
#   check     gpu-marked tests, bench (paper/quick, 504 and 1008 px), render --compile,
#             then paper pretraining started in the background until the call's end
#   continue  keeps the pretraining going (resumes from .carry/ptp.safetensors on a fresh
#             machine), exports its weights at the end
#   fern      stops the pretraining, exports, then fern in the LLFF protocol at `paper`
#             from the exported weights (ITERS steps)
#   devab     the development A/B that decides `auto_init` of gnfr_paper.safetensors
#             (gnfr/weights/gnfr.md): `paper` fine-tuned ITERS steps on et's synth set
#             (copy its photos/ clean/ masks_gt/ cameras_gt.json split.json to
#             .carry/dev/et_synth) from scratch and from the file
# Weights come back as $OUT/ptp.part_* (fp16, split under the tool's 16 MiB per file):
# `cat ptp.part_* > ptp.safetensors` here.
set -u
PHASE=${1:-check}; END=${2:-560}; ITERS=${3:-3000}
T0=$(date +%s)
export PYTHONPATH=$PWD PYTHONUNBUFFERED=1
python3 -m pip install -q --no-index --no-deps --target /tmp/site .carry/whl/*.whl 2>/dev/null \
  && export PYTHONPATH=$PWD:/tmp/site
RUN=/root/ptp
cli() { python3 -m workflows.cli "$@"; }
left() { echo $(( END - ($(date +%s) - T0) )); }
export_w() {  # fp16 weights of the run's last checkpoint, split for the trip back
  [ -f $RUN/gnfr.safetensors ] || { echo "no checkpoint yet"; return; }
  python3 -c "from pathlib import Path; from workflows.research.pretrain import export_fp16; \
export_fp16(Path('$RUN/gnfr.safetensors'), Path('/root/ptp16.safetensors'), \
{'pretrain_scenes': sorted(p.name for p in Path('.carry/packs').iterdir()), \
 'synthetic_flare': True, 'auto_init': False})" && \
  split -b 15000000 /root/ptp16.safetensors $OUT/ptp.part_
  cp $RUN/metrics.jsonl $OUT/ptp_metrics.jsonl 2>/dev/null; tail -c 20000 /root/ptp.log > $OUT/ptp_log.txt
}
start_pt() {
  local init=scratch
  [ -d $RUN ] || { [ -f .carry/ptp.safetensors ] && init=.carry/ptp.safetensors; }
  setsid nohup python3 -m workflows.cli pretrain .carry/packs --out $RUN --preset pretrain \
    --device cuda --seed 1 --ckpt-every 500 --init $init >> /root/ptp.log 2>&1 < /dev/null &
  echo "pretraining started (init $init)"
}
running() { pgrep -f "pretrain .carry/packs" > /dev/null; }
case $PHASE in
check)
  nvidia-smi -L; python3 -c "import torch; print(torch.__version__, torch.cuda.get_device_name())"
  python3 -m pytest -q -m gpu tests/gnfr/test_gpu.py -p no:cacheprovider 2>&1 | tee $OUT/gpu_tests.log | tail -5
  for p in paper quick; do
    cli bench --preset $p --device cuda --out $OUT/bench_${p}_cuda.json 2>&1 | tail -4; done
  cli bench --preset paper --device cuda --train-size 1008x756 \
    --out $OUT/bench_paper_cuda_1008.json 2>&1 | tail -4
  python3 benchmarks/render_compile.py --preset paper --device cuda \
    --out $OUT/render_compile_cuda_paper.json 2>&1 | tail -4
  start_pt ;;
continue)
  running || start_pt ;;
fern)
  pkill -f "pretrain .carry/packs"; sleep 5
  [ -f $RUN/gnfr.safetensors ] || { mkdir -p $RUN; cp .carry/ptp.safetensors $RUN/gnfr.safetensors; }
  export_w
  cli eval-llff .carry/fern --out /root/fern --preset paper --init /root/ptp16.safetensors \
    --iters $ITERS --device cuda 2>&1 | tail -15
  cp /root/fern/results.json $OUT/fern_paper_results.json; cp /root/fern/table.md $OUT/fern_table.md
  exit 0 ;;
devab)
  pkill -f "pretrain .carry/packs"
  python3 benchmarks/finetune_ab.py .carry/dev/et_synth --preset paper --iters $ITERS \
    --set init=gnfr/weights/gnfr_paper.safetensors --work /root/ab \
    --out $OUT/finetune_ab_paper_init_dev_et.json 2>&1 | tail -5
  exit 0 ;;
esac
while [ "$(left)" -gt 15 ] && running; do sleep 10; done
tail -3 /root/ptp.log; export_w; ls -la $OUT
