#!/bin/bash
# Packed vs padded, seed 1, same CPU, same data (fresh46's run folder), code at 39ac1c8 (worktree .).
set -e
cd .
export PYTHONPATH=src
TR=.venv/bin/tacreasoner
W=runs/quickstart
for v in packed padded; do
  O=runs/pair1/$v
  extra=""
  [ $v = padded ] && extra="--set runtime.pack_sequences=false --set model.attn_implementation=sdpa"
  for st in 1 2; do
    [ -f $O/stage$st/run.done ] && continue
    /usr/bin/time -f "stage$st $v %e s" $TR train --stage $st --resume --config quickstart-smollm2-cpu --set seed=1 --set output_dir=$O \
      --set model.llm=$W/llm --set model.appearance=$W/encoder --set data.bench=$W/bench \
      --set data.video_cache=$W/video_cache --set runtime.progress=false --set runtime.log_with=none $extra
    touch $O/stage$st/run.done
  done
  [ -f runs/pair1/eval_val_$v/report.json ] || $TR evaluate --model $O/stage2/model --bench $W/bench --split val --out runs/pair1/eval_val_$v \
    --batch-size 48 --max-new-tokens 64 --video-cache $W/video_cache
done
echo CHAIN DONE
