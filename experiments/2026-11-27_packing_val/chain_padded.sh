#!/bin/bash
# The quickstart recipe, seed 0, as trained before packing (padded batches, sdpa), on fresh46's data; then val.
set -e
cd .
TR=.venv/bin/tacreasoner
W=runs/quickstart
O=runs/padded/seed0
for st in 1 2; do
  [ -f $O/stage$st/run.done ] && continue
  $TR train --stage $st --resume --config quickstart-smollm2-cpu --set seed=0 --set output_dir=$O \
    --set model.llm=$W/llm --set model.appearance=$W/encoder --set data.bench=$W/bench \
    --set data.video_cache=$W/video_cache --set runtime.progress=false --set runtime.log_with=none \
    --set runtime.pack_sequences=false --set model.attn_implementation=sdpa
  touch $O/stage$st/run.done
done
$TR evaluate --model $O/stage2/model --bench $W/bench --split val --out runs/padded/eval_val \
  --batch-size 48 --max-new-tokens 64 --video-cache $W/video_cache
