#!/usr/bin/env bash
# The PhysiCLeAR recipe and the paper's directions on one lent GPU, inside a fixed time budget (issue 37, points 5
# and 6). Same config and steps as benchmarks/physiclear_recipe.sh, which it calls; what differs on a GPU is only
# that Accelerate picks bf16 mixed precision there (runtime.mixed_precision: auto).
#   A. `tacreasoner recipe physiclear` (seed 0, no evaluation) ALONE: its recipe.json holds the GPU recipe's cost
#      (ALONE=0: its Stage I only, which decodes the clips once for all; measured once, 2026-11-26, 113 + 87 s);
#   B. every other (variant, seed) trained in parallel on the same GPU (PARALLEL processes), stopped EVAL_SECONDS
#      before DEADLINE;
#   C. each variant's finished seeds answered on val (benchmark and held-out wordings), variants in parallel;
#   D. the table: benchmarks/results/$NAME.{md,json}.
# Needs runs/smollm2 (tacreasoner llm get smollm2) and runs/effnet (tacreasoner encoder get efficientnet-lite0).
#   W=runs/physiclear_gpu DATA=../shared/data/physiclear DEADLINE=$(( $(date +%s) + 540 )) bash benchmarks/physiclear_gpu.sh
set -u
export PYTHONUNBUFFERED=1 W=${W:-runs/physiclear_gpu} DATA=${DATA:-../shared/data/physiclear}
export TR=${TR:-python3 -m tacreasoner} PY=${PY:-python3} TACREASONER_VIDEO_WORKERS=${TACREASONER_VIDEO_WORKERS:-12}
export MACHINE=${MACHINE:-one $(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1) GPU}
read -r -a VARIANTS <<< "${VARIANTS:-rec long no_dyn no_stage1}"
PARALLEL=${PARALLEL:-12}                   # all of B at once: each process keeps the GPU only a little busy
DEADLINE=${DEADLINE:-$(( $(date +%s) + 540 ))}  # epoch seconds by which D must have run
EVAL_SECONDS=${EVAL_SECONDS:-200}          # what C is given
NAME=${NAME:-physiclear_val_gpu}
here=$(dirname "$0")
say() { echo "[$(date +%H:%M:%S)] $*"; }

say "A: the one-command recipe, seed 0, trained alone (its recipe.json holds the GPU's wall times)"
mkdir -p "$W/recipe" "$W/runs"
[ -e "$W/recipe/encoder" ] || cp -r runs/effnet "$W/recipe/encoder"
# ALONE=0: only Stage I of it alone (it decodes the clips for everyone); its Stage II joins the parallel trainings
skip_stage2=(); [ "${ALONE:-1}" = 0 ] && skip_stage2=(--set stage2.skip=true)
$TR recipe physiclear --data "$DATA" --out "$W/recipe" --llm runs/smollm2 --no-evaluate "${skip_stage2[@]}" || exit 1
# the recipe's parts become the variants' shared parts (same config, bench and clip cache)
for part in bench video_cache; do [ -e "$W/$part" ] || ln -s "recipe/$part" "$W/$part"; done
[ -e "$W/runs/rec.seed0" ] || ln -s ../recipe/train/seed0 "$W/runs/rec.seed0"
VARIANTS=rec TRAIN_ONLY=1 bash "$here/physiclear_recipe.sh" 0 || exit 1

B_SECONDS=${B_SECONDS:-$(( DEADLINE - $(date +%s) - EVAL_SECONDS ))}
say "B: the other trainings, $PARALLEL at a time, for at most $B_SECONDS s"
jobs=()
for v in "${VARIANTS[@]}"; do for s in 0 1 2; do [ "$v.$s.${ALONE:-1}" = rec.0.1 ] || jobs+=("$v $s"); done; done
printf '%s\n' "${jobs[@]}" | timeout "$B_SECONDS" xargs -P "$PARALLEL" -L 1 bash -c \
    'OMP_NUM_THREADS=1 VARIANTS=$0 TRAIN_ONLY=1 bash '"$here"'/physiclear_recipe.sh $1 > /dev/null'
pkill -f physiclear_recipe.sh 2>/dev/null
pkill -f "tacreasoner train" 2>/dev/null
sleep 2
say "B: $(ls -d "$W"/runs/*/stage2/model/config.json 2>/dev/null | wc -l) models trained"

say "C: evaluations"
done_variants=()
for v in "${VARIANTS[@]}"; do
    seeds=()
    for s in 0 1 2; do [ -e "$W/runs/$v.seed$s/stage2/model/config.json" ] && seeds+=("$s"); done
    [ ${#seeds[@]} -eq 0 ] && continue
    done_variants+=("$v")
    export "SEEDS_$v=${seeds[*]}"
    OMP_NUM_THREADS=3 VARIANTS=$v TABLE=0 timeout $(( DEADLINE - $(date +%s) - 20 )) \
        bash "$here/physiclear_recipe.sh" "${seeds[@]}" &
done
wait
pkill -f "tacreasoner evaluate-physiclear" 2>/dev/null
say "D: table"
VARIANTS="${done_variants[*]}" NAME=$NAME EVAL=0 bash "$here/physiclear_recipe.sh"
