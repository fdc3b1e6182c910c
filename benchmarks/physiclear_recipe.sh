#!/usr/bin/env bash
# Real-data recipes on PhysiCLeAR, end to end on this machine's CPU, every step a `tacreasoner` command, behind
# benchmarks/results/physiclear_val.md: the LLM (SmolLM2), the DynTAC-Sim Mini clips and the appearance encoder
# pre-trained on them plus every PhysiCLeAR clip (labels unused), the PhysiCLeAR benchmark (Octopi's task set), the
# random and majority baselines, the frozen-encoder linear probe, then per variant Stage I and II of
# configs/physiclear-smollm2-cpu.yaml and `evaluate-physiclear` on val (the test objects are not in this copy):
#   core     PhysiCLeAR's train objects only (the config as written)
#   sim      the same plus the simulated clips asked in PhysiCLeAR's words (data.extra_benches)
#   no_dyn   core without the temporal branch (appearance only, VTV-LLM-like)
#   simonly  the simulated clips only (sim-to-real: never a real clip in Stage I or II)
#   heads    core with the cross-fitted read-out heads (clip reader, comparator, name matcher), beside the plain model
#   rag      core with retrieval augmentation (retrieval-bench: each video's 3 nearest train clips and their labels
#            in the prompt; evaluate-physiclear --retrieval asks val the same way)
# Each step is skipped when its output exists; its wall time goes to $W/times.tsv when it runs.
#   VARIANTS="core sim" bash benchmarks/physiclear_recipe.sh [SEED...]     # default: core, seed 0
# SEEDS_<variant>="0 1 2" gives one variant its own seeds; a variant answered by several seeds is evaluated in
# $W/eval_val/<variant>.seeds0-1-2, one seed in $W/eval_val/<variant> (never a resumed mix of both).
set -u
export PYTHONUNBUFFERED=1
W=${W:-runs/physiclear}
DATA=${DATA:-../shared/data/physiclear}
TR=${TR:-.venv/bin/python -m tacreasoner}
PY=${PY:-.venv/bin/python}
CONFIG=${CONFIG:-configs/physiclear-smollm2-cpu.yaml}
SEEDS=("$@")
[ $# -eq 0 ] && SEEDS=(0)
read -r -a VARIANTS <<< "${VARIANTS:-core}"
declare -A SETS=([core]="" [sim]="--set data.extra_benches=[$W/sim_bench]"
                 [no_dyn]="--set model.encoder.use_temporal=false" [simonly]="--set data.bench=$W/sim_bench"
                 [rag]="--set data.bench=$W/rag_bench --set data.max_length=512"
                 [heads]="--set model.encoder.cross_video=3 --set model.encoder.clip_reader=true")
declare -A EVAL_SETS=([rag]="--retrieval $W/rag_bench")
declare -A LABEL=([core]="TacReasoner core, SmolLM2-135M" [sim]="TacReasoner core + simulated clips"
                  [no_dyn]="w/o temporal branch" [simonly]="sim only (no real clip in training)"
                  [rag]="core + retrieval augmentation (k 3)" [heads]="core + cross-fitted read-out heads")
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
step simulate runs/quickstart/sim/manifest.jsonl $TR simulate --out runs/quickstart/sim --objects 100 --repeats 5
step encoder runs/quickstart/encoder/model.safetensors \
    $TR pretrain-encoder --out runs/quickstart/encoder --data runs/quickstart/sim --steps 400 --physiclear
step bench "$W/bench/bench.json" $TR build-bench --source physiclear --data "$DATA" --out "$W/bench"
step sim_bench "$W/sim_bench/bench.json" $TR build-bench --source sim --data runs/quickstart/sim \
    --vocabulary physiclear --out "$W/sim_bench"
[[ " ${VARIANTS[*]} " == *" rag "* ]] && step rag_bench "$W/rag_bench/bench.json" $TR retrieval-bench --bench "$W/bench" --encoder runs/quickstart/encoder \
    --out "$W/rag_bench" --k 3 --video-cache "$W/video_cache"
for kind in random majority; do
    step "baseline_$kind" "$W/baselines/$kind/report.json" bash -c \
        "$TR baseline --bench $W/bench --kind $kind --split val --out $W/baselines/$kind/preds/$kind.jsonl && \
         $TR score $W/baselines/$kind/preds/$kind.jsonl --bench $W/bench --split val --out $W/baselines/$kind"
done
step probe benchmarks/results/physiclear_probe.json \
    $PY benchmarks/physiclear_probe.py --encoder runs/quickstart/encoder --data "$DATA"
rows=(--row "random=$W/baselines/random" --row "majority=$W/baselines/majority"
      --row "frozen-encoder linear probe=benchmarks/results/physiclear_probe.json")
for v in "${VARIANTS[@]}"; do
    models=()
    seeds_of_v="SEEDS_$v"
    read -r -a vseeds <<< "${!seeds_of_v:-${SEEDS[*]}}"
    tag=$v
    [ "${#vseeds[@]}" -gt 1 ] && tag="$v.seeds$(IFS=-; echo "${vseeds[*]}")"
    for s in "${vseeds[@]}"; do
        out="$W/runs/$v.seed$s"
        for st in 1 2; do
            # shellcheck disable=SC2086  # SETS holds several words
            step "$v.seed$s.stage$st" "$out/stage$st/run.json" $TR train --stage "$st" --config "$CONFIG" \
                --set seed="$s" --set output_dir="$out" --set data.video_cache="$W/video_cache" \
                --set runtime.progress=false ${SETS[$v]}
        done
        models+=(--model "$out/stage2/model")
    done
    # shellcheck disable=SC2086  # EVAL_SETS holds several words
    step "$tag.eval_val" "$W/eval_val/$tag/octopi.json" $TR evaluate-physiclear "${models[@]}" --data "$DATA" \
        --split val --out "$W/eval_val/$tag" ${EVAL_SETS[$v]:-}
    rows+=(--row "${LABEL[$v]} (${#vseeds[@]} seed(s))=$W/eval_val/$tag")
done
$PY benchmarks/physiclear_table.py --split val --name physiclear_val "${rows[@]}" \
    --notes "Trained and answered on 2 CPU cores (this machine) by $(for v in "${VARIANTS[@]}"; do n="SEEDS_$v"; [ -n "${!n:-}" ] && printf "SEEDS_%s='%s' " "$v" "${!n}"; done)VARIANTS='${VARIANTS[*]}' bash benchmarks/physiclear_recipe.sh ${SEEDS[*]}: $CONFIG (Stage I 300 + Stage II 600 steps on plain answers, SmolLM2-135M-Instruct from a 4-bit GGUF, the paper's core modules only; variants: ${VARIANTS[*]}, see the script); step wall times in seconds: $(tr '\t\n' '= ' < "$W/times.tsv"). Val: PhysiCLeAR's 7 val objects (Octopi's split); the training recipe is the DynTAC-Sim one, unchanged; the variant recommended (heads) was chosen on this table, see docs/real-data.md. Step times of heads seeds 1-2 and no_dyn's Stage I were taken while other work shared the machine (heads seed 1's Stage II includes a 305 s pause)." \
    > "$W/logs/table.log" 2>&1 && echo "[$(date +%H:%M:%S)] table written" || echo "table FAILED (see $W/logs/table.log)"
