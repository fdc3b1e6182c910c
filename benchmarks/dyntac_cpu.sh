#!/usr/bin/env bash
# The paper's ablations (Tables 3/4) on DynTAC-Sim val, trained and answered on this machine's CPU, one chain after
# another (2 cores hold one training at a time): the CPU counterpart of benchmarks/dyntac_gpu.sh, same variants, same
# folder layout, so benchmarks/dyntac_ablations.py --run $OUT makes the table. Each ablation is paired with the
# recipe trained here with the same seed (a CPU run and an H100 run of one seed differ as two seeds do).
#   Q      a quickstart run folder (`tacreasoner quickstart`): its bench, encoder, llm and clip cache are used as is
#   OUT    where runs/<variant>.seed<S>/ and eval/<variant>.seed<S>/val/ go (default runs/dyntac_cpu)
#   JOBS   variant:seed pairs in order, e.g. "rec:1 no_dyn:0 no_qcond:0 cot:0" (default: all, seeds 0-2)
#   DRY    a dry run's settings, e.g. DRY="--set stage1.steps=2 --set stage2.steps=2" LIMIT="--limit 8"
#   HELDOUT=1  also score val asked in held-out wordings (paraphrase-bench, built once): eval/<v>.seed<S>/val_heldout
#   TR_EVAL  the command that answers (default: TR), e.g. training pinned by PYTHONPATH to another checkout while
#          answering uses this one's evaluation (which records the replies the reply budget cut)
#   EXTRA  more settings for every training, e.g. EXTRA="--set data.paraphrases=false --set runtime.threads=2"
#          (the recipe before data.paraphrases shipped; threads fixed instead of read from the load at each start)
#   ARCHIVE  a .tgz rewritten after every scored run with what a table needs (scored predictions, reports, run
#          records, chains.log), e.g. benchmarks/results/<name>_inputs/scored.tgz: commit it as seeds finish, so
#          that losing the machine loses no finished run (a machine shut down mid-chain took the run folder once)
# Variants: rec (the shipped config), no_dyn (use_temporal=false), no_qcond (question_conditioning=false), cot
# (Stage II on TouchCoT from rec's Stage I of the seed, built once with the offline rules teacher), no_stage1
# (stage1.skip=true: Stage II from the untrained projector), no_stage2 (rec's Stage I model answers); and a recipe
# candidate, not a paper ablation: para (data.paraphrases=true: each train item also asked in a training wording),
# and para_osc (para with OSC's examples twice: OSC has no training wording, so para halves its share of Stage II);
# and a quickstart budget candidate, b4 (batch 4 instead of 8 in both stages: as many updates, half the tokens).
# rec:0 is the quickstart's own seed-0 model when Q holds it (train/seed0 and eval_val/: linked, not retrained).
# Resumable: a finished stage is marked run.done, training resumes from its last checkpoint, a scored split is
# skipped. Measured on a 2-core AMD EPYC with AVX512_BF16 (bf16): ~30 min of training and ~3 min of answering a chain.
#   Q=runs/quickstart JOBS="no_dyn:0 no_qcond:0" bash benchmarks/dyntac_cpu.sh
set -eu
Q=${Q:-runs/quickstart}
OUT=${OUT:-runs/dyntac_cpu}
TR=${TR:-tacreasoner}
TR_EVAL=${TR_EVAL:-$TR}
CONFIG=${CONFIG:-quickstart-smollm2-cpu}
DRY=${DRY:-}
EXTRA=${EXTRA:-}
LIMIT=${LIMIT:-}
ARCHIVE=${ARCHIVE:-}
read -r -a JOBS <<< "${JOBS:-rec:1 rec:2 no_dyn:0 no_qcond:0 no_dyn:1 no_qcond:1 no_dyn:2 no_qcond:2 cot:0 cot:1 cot:2}"
declare -A SETS=([rec]="" [no_dyn]="--set model.encoder.use_temporal=false"
                 [no_qcond]="--set model.encoder.question_conditioning=false"
                 [para]="--set data.paraphrases=true"
                 [para_osc]="--set data.paraphrases=true --set data.repeat={\"OSC\":2}"
                 [cot]="--set data.stage2_data=touchcot --set data.touchcot=$OUT/touchcot/touchcot/touchcot_train.jsonl --set data.max_length=512"
                 [no_stage1]="--set stage1.skip=true" [no_stage2]=""
                 [b4]="--set stage1.batch_size=4 --set stage2.batch_size=4")
# Stage II from another variant's Stage I of the seed: cot (its Stage I is the recipe's), para_osc (Stage I has no OSC
# item, so repeating OSC changes Stage II only)
declare -A STAGE1_FROM=([cot]=rec [para_osc]=para)
for need in bench encoder llm video_cache; do
    [ -e "$Q/$need" ] || { echo "error: $Q/$need missing: Q must be a finished quickstart run folder" >&2; exit 2; }
done
mkdir -p "$OUT/runs" "$OUT/eval" "$OUT/logs"
say() { echo "[$(date -u +%H:%M:%S)] $*" | tee -a "$OUT/chains.log"; }

train() {  # train VARIANT SEED STAGE
    local v=$1 s=$2 st=$3 dir="$OUT/runs/$1.seed$2"
    [ -e "$dir/stage$st/run.done" ] && return 0
    say "$v seed $s: Stage $st"
    # shellcheck disable=SC2086  # SETS holds several words
    $TR train --stage "$st" --resume --config "$CONFIG" --set seed="$s" --set output_dir="$dir" \
        --set model.llm="$Q/llm" --set model.appearance="$Q/encoder" --set data.bench="$Q/bench" \
        --set data.video_cache="$Q/video_cache" --set runtime.progress=false --set runtime.log_with=none \
        ${SETS[$v]} $EXTRA $DRY >> "$OUT/logs/$v.seed$s.stage$st.log" 2>&1 || { say "FAILED: $OUT/logs/$v.seed$s.stage$st.log"; return 1; }
    touch "$dir/stage$st/run.done"  # (set -e does not act inside a function called from an && list: hence the ||)
}

score() {  # score VARIANT SEED MAX_NEW_TOKENS [MODEL]: val, and with HELDOUT=1 val in held-out wordings
    local v=$1 s=$2 bench=$Q/bench out="$OUT/eval/$1.seed$2/val" model=${4:-$OUT/runs/$1.seed$2/stage2/model}
    for wording in benchmark ${HELDOUT:+heldout}; do
        if [ "$wording" = heldout ]; then
            bench=$OUT/bench_heldout out=$out"_heldout"
            [ -e "$bench/val.jsonl" ] || $TR paraphrase-bench --bench "$Q/bench" --out "$bench" --splits val \
                >> "$OUT/logs/paraphrase-bench.log" 2>&1 || return 1
        fi
        [ -e "$out/report.json" ] && continue
        say "$v seed $s: answering val ($wording wordings)"
        # shellcheck disable=SC2086
        $TR_EVAL evaluate --model "$model" --bench "$bench" --split val --out "$out" \
            --batch-size 48 --max-new-tokens "$3" --video-cache "$Q/video_cache" $LIMIT \
            >> "$OUT/logs/$v.seed$s.eval.log" 2>&1 || { say "FAILED: $OUT/logs/$v.seed$s.eval.log"; return 1; }
        pack
    done
}

pack() {  # with ARCHIVE: every scored run so far (eval/ follows its links, so rec seed 0's answers are in it)
    [ -n "$ARCHIVE" ] || return 0
    local dest; dest=$(realpath -m "$ARCHIVE") && mkdir -p "$(dirname "$dest")" || return 1
    (cd "$OUT" && shopt -s nullglob && have=() && for p in chains.log eval/*/*/report.json eval/*/*/predictions \
        eval/*/*/scored runs/*/stage*/run.json; do [ -e "$p" ] && have+=("$p"); done
     tar czhf "$dest.part" "${have[@]}") && mv "$dest.part" "$dest"
}

link_quickstart_seed0() {  # the quickstart's own seed-0 run is rec.seed0: same config, same data
    local dir="$OUT/runs/rec.seed0"
    [ -e "$dir" ] || [ ! -e "$Q/train/seed0/stage2/model/config.json" ] && return 0
    mkdir -p "$dir" && for st in 1 2; do
        ln -s "$(realpath "$Q/train/seed0/stage$st")" "$dir/stage$st"
        touch "$dir/stage$st/run.done"  # the quickstart finished both stages: never retrain them (cot reads Stage I)
    done
    if [ -e "$Q/eval_val/scored" ]; then  # its val answers, when scored (tacreasoner evaluate --split val)
        mkdir -p "$OUT/eval/rec.seed0" && ln -s "$(realpath "$Q/eval_val")" "$OUT/eval/rec.seed0/val"
    fi
    say "rec seed 0: the quickstart's own run ($Q/train/seed0)"
}

touchcot() {  # the TouchCoT train file for cot, built once (offline rules teacher)
    [ -e "$OUT/touchcot/touchcot/touchcot_train.jsonl" ] && return 0
    say "building TouchCoT (rules teacher)"
    $TR build-cot --bench "$Q/bench" --out "$OUT/touchcot" --teacher rules >> "$OUT/logs/touchcot.log" 2>&1 || return 1
}

for job in "${JOBS[@]}"; do  # every entry checked before any work: a typo at the end must not wait hours to fail
    v=${job%:*} s=${job#*:}
    [[ -v "SETS[$v]" && $s =~ ^[0-9]+$ ]] || { echo "error: JOBS entry '$job': expected VARIANT:SEED with VARIANT" \
        "one of ${!SETS[*]}" >&2; exit 2; }
done
link_quickstart_seed0
for job in "${JOBS[@]}"; do
    v=${job%:*} s=${job#*:}
    if [ "$v" = no_stage2 ]; then  # no training: the recipe's Stage I model of the seed answers
        train rec "$s" 1 && score "$v" "$s" 64 "$OUT/runs/rec.seed$s/stage1/model" || exit 1
    elif [ "$v" = no_stage1 ]; then
        train "$v" "$s" 2 && score "$v" "$s" 64 || exit 1
    elif [ -n "${STAGE1_FROM[$v]:-}" ]; then  # Stage II only, from the Stage I of another variant with the same seed
        base=${STAGE1_FROM[$v]}
        train "$base" "$s" 1 || exit 1
        [ "$v" = cot ] && { touchcot || exit 1; }
        mkdir -p "$OUT/runs/$v.seed$s"
        [ -e "$OUT/runs/$v.seed$s/stage1" ] || ln -s "../$base.seed$s/stage1" "$OUT/runs/$v.seed$s/stage1"
        train "$v" "$s" 2 && score "$v" "$s" "$([ "$v" = cot ] && echo 512 || echo 64)" || exit 1
    else
        train "$v" "$s" 1 && train "$v" "$s" 2 && score "$v" "$s" 64 || exit 1
    fi
done
say "done: ${JOBS[*]}"
