#!/usr/bin/env bash
# Joins per-seed PhysiCLeAR evaluations (eval_seed/VARIANT.seedS from benchmarks/physiclear_gpu.sh) into the
# results of issue 37: benchmarks/results/physiclear_val.{md,json} (every Octopi column, Wilson intervals, the
# recommended recipe and each direction over its seeds, beside chance, majority, the encoder probes and Octopi's
# published row; the held-out wordings) and one paired test per direction against the recipe
# (physiclear_direction_*.{md,json}: per seed, exact McNemar on the same items). Runs anywhere: it reads files.
#   W=runs/physiclear_gpu MACHINE="one H100 GPU" bash benchmarks/physiclear_directions.sh
set -u
W=${W:-runs/physiclear_gpu}
PY=${PY:-.venv/bin/python}
NAME=${NAME:-physiclear_val}
read -r -a VARIANTS <<< "${VARIANTS:-rec no_dyn cot no_stage1}"
here=$(dirname "$0")
declare -A LABEL=([rec]="TacReasoner core, recommended recipe" [no_dyn]="w/o temporal branch"
                  [cot]="Stage II on TouchCoT" [no_stage1]="w/o Stage I")
declare -A DIRECTION=([no_dyn]=temporal [cot]=touchcot [no_stage1]=stage1)
PROBE="benchmarks/results/encoder_candidates.json#efficientnet_lite0 block112 (240x320, contact, keep)"
rows=(--row "random=$W/baselines/random" --row "majority=$W/baselines/majority"
      --row "frozen-encoder linear probe (the recipe's encoder)=$PROBE"
      --row "frozen-encoder linear probe (the masked-video ViT)=benchmarks/results/encoder_candidates.json#vit (64x64, uniform, subtract)")
heldout=()
seeds_of() {  # the seeds of VARIANT evaluated in folder KIND
    local s
    for s in 0 1 2 3 4; do [ -e "$W/$2/$1.seed$s/scored/val.jsonl" ] && printf '%s ' "$s"; done
}
join_seeds() {  # join_seeds VARIANT KIND: $W/KIND/VARIANT.seeds/scored/seedS.jsonl, one per seed
    local v=$1 kind=$2 s
    rm -rf "$W/${kind}_joined/$v"
    mkdir -p "$W/${kind}_joined/$v/scored"
    for s in $(seeds_of "$v" "$kind"); do cp "$W/$kind/$v.seed$s/scored/val.jsonl" "$W/${kind}_joined/$v/scored/seed$s.jsonl"; done
}
for v in "${VARIANTS[@]}"; do
    read -r -a seeds <<< "$(seeds_of "$v" eval_seed)"
    [ ${#seeds[@]} -eq 0 ] && { echo "$v: no evaluated seed under $W/eval_seed"; continue; }
    join_seeds "$v" eval_seed
    rows+=(--row "${LABEL[$v]} (seeds ${seeds[*]})=$W/eval_seed_joined/$v")
    read -r -a hseeds <<< "$(seeds_of "$v" eval_seed_heldout)"
    if [ ${#hseeds[@]} -gt 0 ]; then
        join_seeds "$v" eval_seed_heldout
        heldout+=(--row "${LABEL[$v]}, held-out wordings (seeds ${hseeds[*]})=$W/eval_seed_heldout_joined/$v")
    fi
done
notes="Trained and answered on ${MACHINE:-this machine} by benchmarks/physiclear_gpu.sh (variants and seeds at once), \
joined by benchmarks/physiclear_directions.sh: the shipped config physiclear-smollm2-cpu (SmolLM2-135M-Instruct from \
a 4-bit GGUF, EfficientNet-Lite0 ImageNet appearance encoder, the paper's core modules, no read-out heads); \
'w/o temporal branch' sets model.encoder.use_temporal=false, 'Stage II on TouchCoT' trains Stage II on the rules \
teacher's TouchCoT instead of plain answers (from the recipe's Stage I of the same seed), 'w/o Stage I' starts Stage II \
from the untrained projector. Multi-seed rows: mean ± std over seeds, Wilson intervals on the pooled items. \
Val: PhysiCLeAR's 7 val objects (Octopi's split); no training read a val or test clip; 'held-out wordings' rows ask \
the same val items in wordings no training used (tasks/paraphrases/heldout.yaml: TFA, combined, PC, SOI only). \
Step wall times (s, parallel): $(tr '\t\n' '= ' < "$W/times.tsv" 2>/dev/null)"
$PY "$here/physiclear_table.py" --split val --name "$NAME" "${rows[@]}" "${heldout[@]}" --notes "$notes" || exit 1
for v in "${VARIANTS[@]}"; do
    [ "$v" = rec ] && continue
    [ -n "${DIRECTION[$v]:-}" ] || continue
    common=()
    for s in $(seeds_of rec eval_seed); do [ -e "$W/eval_seed/$v.seed$s/scored/val.jsonl" ] && common+=("$s"); done
    [ ${#common[@]} -eq 0 ] && continue
    $PY "$here/paired_seeds.py" --split val --name "physiclear_direction_${DIRECTION[$v]}" \
        --title "PhysiCLeAR val: the recommended recipe against ${LABEL[$v]}, paired by seed" \
        --a "${LABEL[rec]}" "${common[@]/#/$W/eval_seed/rec.seed}" \
        --b "${LABEL[$v]}" "${common[@]/#/$W/eval_seed/$v.seed}" --notes "$notes" || exit 1
done
