#!/usr/bin/env bash
# SmolLM2-135M-Instruct with and without the read-out heads, seed by seed on this machine's CPU (2 cores), behind
# benchmarks/results/smollm2_heads*.md. For each seed the core (configs/smollm2-135m-cpu.yaml: the paper's modules
# only) and the heads model (configs/smollm2-135m-heads-cpu.yaml: the same recipe with the cross-fitted comparator,
# name matcher and clip reader) train both stages, then answer val and test. Nothing is chosen from these runs'
# test answers: the recipe was chosen on val before (smollm2_recipe.md) and the two configs differ only in the
# heads. Then the removed-touch control on val for both seed-0 models, and the paired tables (paired_seeds.py).
# Run after `tacreasoner quickstart --no-train`, `tacreasoner pretrain-encoder --out runs/quickstart/encoder
# --data runs/quickstart/sim --steps 400` and `tacreasoner llm get smollm2 --out runs/smollm2`:
#   bash benchmarks/smollm2_heads.sh [SEEDS...]        # default 0 1 2; resumable: finished steps are skipped
set -u
export PYTHONUNBUFFERED=1
W=${W:-runs/smollm2_heads}
BENCH=${BENCH:-runs/quickstart/bench}
TR=${TR:-.venv/bin/python -m tacreasoner}
PY=${PY:-.venv/bin/python}
SEEDS=("$@")
[ $# -eq 0 ] && SEEDS=(0 1 2)
declare -A CONFIG=([core]=configs/smollm2-135m-cpu.yaml [heads]=configs/smollm2-135m-heads-cpu.yaml)
mkdir -p "$W/logs"
el() { echo "[$(date +%H:%M:%S)] $*"; }

train() {  # train VARIANT SEED: both stages (each skipped once its run.json says it finished)
    local v=$1 s=$2 st out="$W/runs/$1.seed$2"
    for st in 1 2; do
        if grep -qs steps_done "$out/stage$st/run.json"; then continue; fi
        $TR train --stage "$st" --config "${CONFIG[$v]}" --set seed="$s" --set output_dir="$out" \
            --set runtime.progress=false > "$W/logs/$v.seed$s.stage$st.log" 2>&1 || { el "$v seed $s stage $st FAILED"; return 1; }
        el "$v seed $s stage $st done: $(tail -1 "$W/logs/$v.seed$s.stage$st.log")"
    done
}
answer() {  # answer VARIANT SEED SPLIT: evaluate (its predictions resume)
    local v=$1 s=$2 split=$3
    [ -f "$W/eval/$v.seed$s/$split/report.json" ] && return 0
    $TR evaluate --model "$W/runs/$v.seed$s/stage2/model" --bench "$BENCH" --split "$split" \
        --out "$W/eval/$v.seed$s/$split" > "$W/logs/$v.seed$s.eval_$split.log" 2>&1 || { el "$v seed $s $split FAILED"; return 1; }
    el "$v seed $s $split: $(grep -m1 'Average' "$W/eval/$v.seed$s/$split/report.md")"
}

for s in "${SEEDS[@]}"; do
    for v in core heads; do
        train "$v" "$s" && answer "$v" "$s" val && answer "$v" "$s" test
    done
done
for v in core heads; do
    [ -f "$W/touch/$v.seed0/done" ] && continue
    $PY benchmarks/touch_control.py --model "$W/runs/$v.seed0/stage2/model" --bench "$BENCH" --split val \
        --out "$W/touch/$v.seed0" --name "smollm2_heads_touch_$v" > "$W/logs/touch_$v.log" 2>&1 \
        && touch "$W/touch/$v.seed0/done" && el "touch control $v done"
done
for split in val test; do
    core=() heads=()
    for s in "${SEEDS[@]}"; do core+=("$W/eval/core.seed$s/$split") heads+=("$W/eval/heads.seed$s/$split"); done
    $PY benchmarks/paired_seeds.py --split "$split" --name "smollm2_heads_$split" \
        --title "SmolLM2-135M-Instruct: the paper's core against the core with the read-out heads ($split)" \
        --a "core (smollm2-135m-cpu.yaml)" "${core[@]}" \
        --b "with heads (smollm2-135m-heads-cpu.yaml)" "${heads[@]}" \
        --notes "Both trained on 2 CPU cores (this machine), Stage I 300 + Stage II 600 steps on plain answers, LoRA r16, bf16 autocast; the heads model differs only in encoder.cross_video 3 + clip_reader (cross-fitted, data.head_folds 5). Each seed's two models have their own Stage I (the cross-video layer trains in Stage I). The LLM's weights came through 4-bit (Q4_1) GGUF quantisation. DynTAC-Sim-Bench, held-out objects; val and test were each answered once per model; nothing was chosen from them. Command: bash benchmarks/smollm2_heads.sh" \
        > "$W/logs/paired_$split.log" 2>&1 && el "paired $split written"
done
el "all done"
