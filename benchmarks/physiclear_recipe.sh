#!/usr/bin/env bash
# The recommended real-data recipe on PhysiCLeAR and the paper's directions on it, every step a `tacreasoner`
# command, behind benchmarks/results/physiclear_val.md (issue 37). Shared parts: SmolLM2 (llm get), the
# EfficientNet-Lite0 appearance encoder (encoder get: chosen by train-object CV, encoder_candidates.md), the
# PhysiCLeAR benchmark (Octopi's task set), the random and majority baselines; then per variant and seed Stage I and
# II of the shipped config physiclear-smollm2-cpu and `evaluate-physiclear` on val (the test objects are not in
# this copy), in the benchmark's wordings and in held-out wordings (val_heldout):
#   rec        the recommended recipe (the config as shipped)
#   no_dyn     without the temporal branch (appearance only, VTV-LLM-like)
#   cot        Stage II on TouchCoT reasoning (offline rules teacher) instead of plain answers
#   no_stage1  without Stage I (Stage II from the untrained projector)
#   heads      with the cross-fitted read-out heads (clip reader, comparator, name matcher): a plug-in, beside
#   long       the recipe trained longer: Stage I 300 + Stage II 600 steps (the first recipe's length)
#   compact    Stage II on the compact describe-then-conclude reasoning (cot/compact.py) instead of plain answers;
#              its Stage I is rec's of the same seed (copied when rec trained it first: the settings are the same)
#   know       compact + text-only knowledge: everyday objects (data.knowledge all) and training scenarios
#              (data.scenario_knowledge); Stage I rec's
#   know_noname  the same with every entry sharing a word with a val/test object's name left out
#              (data.knowledge without_eval_names): what carries over to names never seen
#   plain_know plain answers (as rec) + the same name-removed object knowledge and scenario knowledge as text: the
#              model the stepwise answering mode (evaluate --answer-mode stepwise) asks what named objects feel like
#              and what a scenario needs; Stage I rec's
# STEPWISE=1 also answers val with --answers stepwise (each video read in a pass of its own, the conclusion by the
# rule: evaluate/stepwise.py) into $W/eval_val_stepwise/<variant>.seeds…, a row of its own in the table.
# TRAIN_ONLY=1 stops after training (to train variants and seeds in parallel, then evaluate); TABLE=0 skips the
# table; EVAL=0 tables what was evaluated before without evaluating; NAME names the result
# files (default physiclear_val); MACHINE says where it ran (default: 2 CPU cores, this machine).
# Each step is skipped when its output exists; its wall time goes to $W/times.tsv when it runs.
#   SEEDS_rec="0 1 2" VARIANTS="rec no_dyn" bash benchmarks/physiclear_recipe.sh [SEED...]   # default: rec, seed 0
set -u
export PYTHONUNBUFFERED=1
W=${W:-runs/physiclear}
DATA=${DATA:-../shared/data/physiclear}
TR=${TR:-.venv/bin/python -m tacreasoner}
PY=${PY:-.venv/bin/python}
CONFIG=${CONFIG:-physiclear-smollm2-cpu}
SEEDS=("$@")
[ $# -eq 0 ] && SEEDS=(0)
read -r -a VARIANTS <<< "${VARIANTS:-rec}"
declare -A SETS=([rec]="" [no_dyn]="--set model.encoder.use_temporal=false"
                 [cot]="--set data.stage2_data=touchcot --set data.touchcot=$W/touchcot/touchcot/touchcot_train.jsonl --set data.max_length=512"
                 [no_stage1]="--set stage1.skip=true"
                 [heads]="--set model.encoder.cross_video=3 --set model.encoder.clip_reader=true"
                 [long]="--set stage1.steps=300 --set stage2.steps=600"
                 [compact]="--set data.stage2_data=compact"
                 [know]="--set data.stage2_data=compact --set data.knowledge=all --set data.scenario_knowledge=true"
                 [know_noname]="--set data.stage2_data=compact --set data.knowledge=without_eval_names --set data.scenario_knowledge=true"
                 [plain_know]="--set data.knowledge=without_eval_names --set data.scenario_knowledge=true")
declare -A STAGE1_FROM=([compact]=rec [know]=rec [know_noname]=rec [plain_know]=rec)
declare -A LABEL=([rec]="TacReasoner core, recommended recipe" [no_dyn]="w/o temporal branch"
                  [cot]="Stage II on TouchCoT" [no_stage1]="w/o Stage I"
                  [heads]="core + cross-fitted read-out heads (plug-in)" [long]="core, Stage I 300 + II 600 steps"
                  [compact]="Stage II on compact describe-then-conclude reasoning"
                  [know]="compact + object and scenario knowledge as text"
                  [know_noname]="compact + knowledge without the val/test objects' names"
                  [plain_know]="plain + knowledge as text without the val/test objects' names")
mkdir -p "$W/logs"
step() {  # step NAME DONE_FILE COMMAND...: run unless DONE_FILE exists; log its wall time
    local name=$1 done=$2 start
    shift 2
    if [ -e "$done" ]; then echo "[$(date +%H:%M:%S)] $name: done before"; return 0; fi
    start=$(date +%s)
    "$@" > "$W/logs/$name.log" 2>&1 || { echo "[$(date +%H:%M:%S)] $name FAILED (see $W/logs/$name.log)"; exit 1; }
    printf '%s\t%s\n' "$name" "$(( $(date +%s) - start ))" >> "$W/times.tsv"
    echo "[$(date +%H:%M:%S)] $name: $(( $(date +%s) - start )) s"
}

step llm runs/smollm2/config.json $TR llm get smollm2 --out runs/smollm2
step encoder runs/effnet/model.safetensors $TR encoder get efficientnet-lite0 --out runs/effnet
step bench "$W/bench/bench.json" $TR build-bench --source physiclear --data "$DATA" --out "$W/bench"
[[ " ${VARIANTS[*]} " == *" cot "* ]] && step touchcot "$W/touchcot/touchcot/touchcot_train.jsonl" \
    $TR build-cot --bench "$W/bench" --out "$W/touchcot" --teacher rules
for kind in random majority; do
    step "baseline_$kind" "$W/baselines/$kind/report.json" bash -c \
        "$TR baseline --bench $W/bench --kind $kind --split val --out $W/baselines/$kind/preds/$kind.jsonl && \
         $TR score $W/baselines/$kind/preds/$kind.jsonl --bench $W/bench --split val --out $W/baselines/$kind"
done
PROBE="benchmarks/results/encoder_candidates.json#efficientnet_lite0 block112 (240x320, contact, keep)"
rows=(--row "random=$W/baselines/random" --row "majority=$W/baselines/majority"
      --row "frozen-encoder linear probe (the recipe's encoder)=$PROBE"
      --row "frozen-encoder linear probe (the masked-video ViT)=benchmarks/results/encoder_candidates.json#vit (64x64, uniform, subtract)")
heldout_rows=()
for v in "${VARIANTS[@]}"; do
    models=()
    seeds_of_v="SEEDS_$v"
    read -r -a vseeds <<< "${!seeds_of_v:-${SEEDS[*]}}"
    tag="$v.seeds$(IFS=-; echo "${vseeds[*]}")"
    for s in "${vseeds[@]}"; do
        out="$W/runs/$v.seed$s"
        shared="$W/runs/${STAGE1_FROM[$v]:-none}.seed$s/stage1"
        if [ -e "$shared/model/config.json" ] && [ ! -e "$out/stage1/model/config.json" ]; then
            mkdir -p "$out" && cp -r "$shared" "$out/stage1" && echo "[$(date +%H:%M:%S)] $v.seed$s.stage1: ${STAGE1_FROM[$v]}'s"
        fi
        for st in 1 2; do
            [ "$v" = no_stage1 ] && [ "$st" = 1 ] && continue
            # shellcheck disable=SC2086  # SETS holds several words
            step "$v.seed$s.stage$st" "$out/stage$st/model/config.json" $TR train --stage "$st" --config "$CONFIG" \
                --set seed="$s" --set output_dir="$out" --set model.llm=runs/smollm2 --set model.appearance=runs/effnet \
                --set data.bench="$W/bench" --set data.video_cache="$W/video_cache" --set runtime.progress=false \
                ${SETS[$v]}
        done
        models+=(--model "$out/stage2/model")
    done
    [ "${TRAIN_ONLY:-0}" = 1 ] && continue
    if [ "${EVAL:-1}" = 1 ]; then
        step "$tag.eval_val" "$W/eval_val/$tag/octopi.json" $TR evaluate-physiclear "${models[@]}" --data "$DATA" \
            --split val --out "$W/eval_val/$tag"
        step "$tag.eval_val_heldout" "$W/eval_val_heldout/$tag/octopi.json" $TR evaluate-physiclear "${models[@]}" \
            --data "$DATA" --split val --wording heldout --out "$W/eval_val_heldout/$tag"
        [ "${STEPWISE:-0}" = 1 ] && step "$tag.eval_val_stepwise" "$W/eval_val_stepwise/$tag/octopi.json" \
            $TR evaluate-physiclear "${models[@]}" --data "$DATA" --split val --answers stepwise \
            --out "$W/eval_val_stepwise/$tag"
    fi
    [ -e "$W/eval_val/$tag/octopi.json" ] && rows+=(--row "${LABEL[$v]} (${#vseeds[@]} seed(s))=$W/eval_val/$tag")
    [ -e "$W/eval_val_stepwise/$tag/octopi.json" ] && \
        rows+=(--row "${LABEL[$v]}, stepwise answers (${#vseeds[@]} seed(s))=$W/eval_val_stepwise/$tag")
    [ -e "$W/eval_val_heldout/$tag/octopi.json" ] && \
        heldout_rows+=(--row "${LABEL[$v]}, held-out wordings (${#vseeds[@]} seed(s))=$W/eval_val_heldout/$tag")
done
{ [ "${TRAIN_ONLY:-0}" = 1 ] || [ "${TABLE:-1}" = 0 ]; } && exit 0
$PY benchmarks/physiclear_table.py --split val --name "${NAME:-physiclear_val}" "${rows[@]}" "${heldout_rows[@]}" \
    --notes "Trained and answered on ${MACHINE:-2 CPU cores (this machine)} by $(for v in "${VARIANTS[@]}"; do n="SEEDS_$v"; [ -n "${!n:-}" ] && printf "SEEDS_%s='%s' " "$v" "${!n}"; done)VARIANTS='${VARIANTS[*]}' bash benchmarks/physiclear_recipe.sh ${SEEDS[*]}: the shipped config $CONFIG (SmolLM2-135M-Instruct from a 4-bit GGUF, EfficientNet-Lite0 ImageNet appearance encoder, the paper's core modules; variants: ${VARIANTS[*]}, see the script); step wall times in seconds: $(tr '\t\n' '= ' < "$W/times.tsv"). Val: PhysiCLeAR's 7 val objects (Octopi's split); 'held-out wordings' rows ask the same val items in wordings no training used (tasks/paraphrases/heldout.yaml: TFA, combined, PC, SOI only)." \
    > "$W/logs/table.log" 2>&1 && echo "[$(date +%H:%M:%S)] table written" || echo "table FAILED (see $W/logs/table.log)"
