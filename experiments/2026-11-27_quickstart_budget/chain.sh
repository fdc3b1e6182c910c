#!/bin/bash
# chain NAME SEED SPLITS... ; env SETS holds --set options
set -e
cd .
N=$1; S=$2; shift 2
TR=.venv/bin/tacreasoner
W=runs/qs
O=runs/short/$N.seed$S
for st in 1 2; do
  [ -f $O/stage$st/run.done ] && continue
  $TR train --stage $st --resume --config quickstart-smollm2-cpu --set seed=$S --set output_dir=$O \
    --set model.llm=$W/llm --set model.appearance=$W/encoder --set data.bench=$W/bench \
    --set data.video_cache=$W/video_cache --set runtime.progress=false --set runtime.log_with=none $SETS
  touch $O/stage$st/run.done
done
for sp in "$@"; do
  [ -f runs/short/eval/$N.seed$S/$sp/report.md ] && continue
  $TR evaluate --model $O/stage2/model --bench $W/bench --split $sp --out runs/short/eval/$N.seed$S/$sp \
    --batch-size 48 --max-new-tokens 64 --video-cache $W/video_cache
done
