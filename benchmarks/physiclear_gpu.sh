#!/usr/bin/env bash
# The recommended PhysiCLeAR recipe (3 seeds) and the paper's directions on it (3 seeds each) on one lent GPU, inside
# a fixed time budget (issue 37, points 5 and 6). Same config and steps as benchmarks/physiclear_recipe.sh, whose
# steps it runs; what differs on a GPU is only that Accelerate picks bf16 mixed precision (runtime.mixed_precision:
# auto). The 135M model leaves an H100 mostly idle, so every (variant, seed) runs at once as its own chain:
#   1. shared parts: bench, baselines, TouchCoT (rules teacher), and the clip cache, filled once by a 1-step Stage I
#      (so the chains do not all decode the same clips);
#   2. one chain per (variant, seed): [Stage I] -> Stage II -> `evaluate-physiclear` on val into eval_seed/V.seedS;
#      rec's chains then answer the held-out wordings and run the removed-touch control (blank, shuffled clips).
#      `cot` differs from `rec` only in Stage II, so it starts from rec's Stage I of the same seed;
#   3. at DEADLINE whatever has not finished is stopped; what finished stays (each step is skipped when redone).
# Per-seed folders are joined into 3-seed rows and paired tests by benchmarks/physiclear_directions.sh (any machine).
# Needs runs/smollm2 (tacreasoner llm get smollm2) and runs/effnet (tacreasoner encoder get efficientnet-lite0).
#   W=runs/physiclear_gpu DATA=../shared/data/physiclear DEADLINE=$(( $(date +%s) + 500 )) bash benchmarks/physiclear_gpu.sh
set -u
export PYTHONUNBUFFERED=1 W=${W:-runs/physiclear_gpu} DATA=${DATA:-../shared/data/physiclear}
export TR=${TR:-python3 -m tacreasoner} PY=${PY:-python3} TACREASONER_VIDEO_WORKERS=${TACREASONER_VIDEO_WORKERS:-12}
export CONFIG=${CONFIG:-physiclear-smollm2-cpu}
read -r -a VARIANTS <<< "${VARIANTS:-rec no_dyn cot no_stage1}"
read -r -a SEEDS <<< "${SEEDS:-0 1 2}"
DEADLINE=${DEADLINE:-$(( $(date +%s) + 500 ))}  # epoch seconds by which everything stops
here=$(dirname "$0")
# shellcheck source=benchmarks/_gpu_lib.sh
source "$here/_gpu_lib.sh"  # say, step, wait_for_jobs_until
mkdir -p "$W/logs" "$W/eval_seed" "$W/touch"

say "1: shared parts"
step bench "$W/bench/bench.json" $TR build-bench --source physiclear --data "$DATA" --out "$W/bench" || exit 1
# TouchCoT's cue extraction decodes clips too: beside the clip cache, in the background (only cot's Stage II needs it)
(step touchcot "$W/touchcot/touchcot/touchcot_train.jsonl" $TR build-cot --bench "$W/bench" --out "$W/touchcot" \
    --teacher rules --workers "$TACREASONER_VIDEO_WORKERS" || touch "$W/logs/touchcot.failed") &
for kind in random majority; do
    step "baseline_$kind" "$W/baselines/$kind/report.json" bash -c \
        "$TR baseline --bench $W/bench --kind $kind --split val --out $W/baselines/$kind/preds/$kind.jsonl && \
         $TR score $W/baselines/$kind/preds/$kind.jsonl --bench $W/bench --split val --out $W/baselines/$kind"
done
step clip_cache "$W/warm/stage1/model/config.json" $TR train --stage 1 --config "$CONFIG" --set stage1.steps=1 \
    --set output_dir="$W/warm" --set model.llm=runs/smollm2 --set model.appearance=runs/effnet \
    --set data.bench="$W/bench" --set data.video_cache="$W/video_cache" --set runtime.progress=false || exit 1

chain() {  # chain VARIANT SEED
    local v=$1 s=$2 model="$W/runs/$1.seed$2/stage2/model"
    if [ "$v" = cot ]; then
        until [ -e "$W/runs/rec.seed$s/stage1/model/config.json" ] && [ -e "$W/touchcot/touchcot/touchcot_train.jsonl" ]
        do [ -e "$W/logs/touchcot.failed" ] && return 1; sleep 5; done
        mkdir -p "$W/runs/cot.seed$s"
        [ -e "$W/runs/cot.seed$s/stage1" ] || ln -s "../rec.seed$s/stage1" "$W/runs/cot.seed$s/stage1"
    fi
    OMP_NUM_THREADS=1 VARIANTS=$v TRAIN_ONLY=1 bash "$here/physiclear_recipe.sh" "$s" > /dev/null || return 1
    OMP_NUM_THREADS=1 step "$v.seed$s.eval_val" "$W/eval_seed/$v.seed$s/octopi.json" $TR evaluate-physiclear \
        --model "$model" --data "$DATA" --split val --out "$W/eval_seed/$v.seed$s" || return 1
    [ "$v" = rec ] || return 0
    OMP_NUM_THREADS=1 step "$v.seed$s.eval_val_heldout" "$W/eval_seed_heldout/$v.seed$s/octopi.json" \
        $TR evaluate-physiclear --model "$model" --data "$DATA" --split val --wording heldout \
        --out "$W/eval_seed_heldout/$v.seed$s"
    OMP_NUM_THREADS=1 step "$v.seed$s.touch" "$W/touch/physiclear_touch_$v.seed$s.md" $PY \
        "$here/touch_control.py" --model "$model" --bench "$W/bench" --split val --out "$W/touch/$v.seed$s" \
        --video-cache "$W/video_cache" --results-dir "$W/touch" --name "physiclear_touch_$v.seed$s"
}
export -f chain step say
export here

say "2: ${#VARIANTS[@]} variants x ${#SEEDS[@]} seeds, all at once, until $(date -d "@$DEADLINE" +%H:%M:%S)"
pids=()
for v in "${VARIANTS[@]}"; do for s in "${SEEDS[@]}"; do
    W=$W chain "$v" "$s" & pids+=($!)
done; done
if ! wait_for_jobs_until "$DEADLINE"; then
    say "3: deadline: stopping what is unfinished"
    pkill -P $$ 2>/dev/null; pkill -f "physiclear_recipe.sh" 2>/dev/null
    pkill -f "tacreasoner (train|evaluate-physiclear|build-cot)" 2>/dev/null; pkill -f touch_control.py 2>/dev/null
fi
wait 2>/dev/null
say "models: $(ls -d "$W"/runs/*/stage2/model/config.json 2>/dev/null | wc -l); evaluated: $(ls "$W"/eval_seed/*/octopi.json 2>/dev/null | wc -l)"
