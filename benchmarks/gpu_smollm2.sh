#!/usr/bin/env bash
# The SmolLM2 recipe (configs/smollm2-135m.yaml) on a lent GPU (the device tool), behind
# benchmarks/results/gpu_smollm2.md. The machine reaches no registry and a call carries at most 64 MiB, so the work
# is split over calls on one warm machine, everything kept under /tmp/w there:
#   bash benchmarks/gpu_smollm2.sh setup   # carry .gpu/whl (av, transformers, peft, gguf wheels for Python 3.12)
#                                          # and .gpu/run (encoder/ + data.tgz: bench/ and the TouchCoT train file);
#                                          # installs, unpacks, simulates the clips (byte-identical to the CPU's)
#   bash benchmarks/gpu_smollm2.sh part 1  # carry .gpu/g1: the first half of the SmolLM2 GGUF (split -b 49M)
#   bash benchmarks/gpu_smollm2.sh part 2  # carry .gpu/g2: the second half; joins them, then starts `pipeline`
#                                          # in its own session and follows its log
#   bash benchmarks/gpu_smollm2.sh wait    # follow the log until the pipeline ends or 9 minutes pass; pack $OUT
# The pipeline: `llm get smollm2` from the joined GGUF (sha256 checked), the cost benchmark on the GPU, then in
# parallel: seeds 0, 1, 2 of the recipe, and the Table 3/4 ablations (no temporal branch, no Stage I; no TouchCoT
# and no Stage II from seed 0's Stage I), each scored on val and test; the removed-touch control on val for seed 0.
set -u
export PYTHONUNBUFFERED=1 PYTHONPATH=/tmp/site:$PWD/src
W=/tmp/w
mkdir -p "$W"
TR="python3 -m tacreasoner"
FP32="--set runtime.mixed_precision=no --set runtime.progress=false"  # fp32 on a GPU: docs/training.md
el() { echo "[$(date +%H:%M:%S)] $*"; }

stage() {  # stage NAME STAGE ARGS...: one training stage of the recipe under $W/runs/NAME
    local name=$1 st=$2
    shift 2
    $TR train --stage "$st" --config configs/smollm2-135m.yaml --set output_dir="$W/runs/$name" \
        --set model.llm="$W/smollm2" --set model.appearance="$W/quickstart/encoder" \
        --set data.bench="$W/quickstart/bench" \
        --set data.touchcot="$W/quickstart/touchcot/touchcot/touchcot_train.jsonl" \
        --set data.video_cache="$W/cache/$name" $FP32 "$@" > "$W/logs/$name.stage$st.log" 2>&1
    el "$name stage $st rc=$?"
}
score() {  # score NAME MODEL_DIR: val and test
    local split
    for split in val test; do
        $TR evaluate --model "$2" --bench "$W/quickstart/bench" --split "$split" --out "$W/eval/$1/$split" \
            --batch-size 64 > "$W/logs/$1.eval_$split.log" 2>&1
        el "$1 $split rc=$? $(grep -m1 -i 'average' "$W/eval/$1/$split/report.md" 2>/dev/null)"
    done
}
variant() {  # variant NAME ARGS...: both stages, then scores
    stage "$1" 1 "${@:2}" && stage "$1" 2 "${@:2}" && score "$1" "$W/runs/$1/stage2/model"
}

case "${1:-}" in
setup)
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .gpu/whl/*.whl \
        || exit 1
    nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv
    python3 -c "import torch,transformers,peft,accelerate,av;print('torch',torch.__version__,torch.cuda.get_device_name(0),'transformers',transformers.__version__,'peft',peft.__version__,'accelerate',accelerate.__version__,'av',av.__version__)"
    mkdir -p $W/quickstart $W/logs && cp -r .gpu/run/encoder $W/quickstart/ && tar xzf .gpu/run/data.tgz -C $W/quickstart
    sed -i "s#\"/work/main/runs/quickstart/sim\"#\"$W/quickstart/sim\"#g" $W/quickstart/bench/bench.json
    $TR simulate --out $W/quickstart/sim --workers 14 2>&1 | tail -1
    el "setup done"
    ;;
part)
    cp ".gpu/g$2/part" "$W/gguf.part$2" && ls -la $W/gguf.part*
    if [ "$2" = 2 ]; then
        cat $W/gguf.part1 $W/gguf.part2 > $W/smollm2.gguf && rm $W/gguf.part*
        cp -r "$PWD" $W/repo  # the pipeline outlives this call's copy of the tree
        (cd $W/repo && setsid nohup bash benchmarks/gpu_smollm2.sh pipeline > $W/pipeline.log 2>&1 &)
        sleep 420; cat $W/pipeline.log
    fi
    ;;
pipeline)
    el "llm get"; $TR llm get smollm2 --gguf $W/smollm2.gguf --out $W/smollm2 2>&1 | grep -v -i "it/s\]" | tail -3
    python3 benchmarks/llm_cost.py --llm $W/smollm2 --device cuda --steps 20 --threads 4 --no-bf16 \
        --name gpu_smollm2_cost > $W/logs/cost_fp32.log 2>&1; el "cost fp32 rc=$?"
    python3 benchmarks/llm_cost.py --llm $W/smollm2 --device cuda --steps 20 --threads 4 \
        --name gpu_smollm2_cost_bf16 > $W/logs/cost_bf16.log 2>&1; el "cost bf16 rc=$?"
    export OMP_NUM_THREADS=3
    for s in 0 1 2; do variant "seed$s" --set seed=$s & done
    variant no_dyn --set model.encoder.use_temporal=false &
    (stage no_stage1 2 --set stage1.skip=true && score no_stage1 "$W/runs/no_stage1/stage2/model") &
    (while ! grep -qs steps_done "$W/runs/seed0/stage1/run.json"; do sleep 10; done
     mkdir -p $W/runs/no_cot && cp -r $W/runs/seed0/stage1 $W/runs/no_cot/
     stage no_cot 2 --set data.stage2_data=plain && score no_cot "$W/runs/no_cot/stage2/model") &
    (while ! grep -qs steps_done "$W/runs/seed0/stage1/run.json"; do sleep 10; done
     score no_stage2 "$W/runs/seed0/stage1/model") &
    wait
    python3 benchmarks/touch_control.py --model $W/runs/seed0/stage2/model --bench $W/quickstart/bench --split val \
        --out $W/eval/touch_seed0 --results-dir $W/results --name gpu_smollm2_touch_control --batch-size 64 \
        > $W/logs/touch.log 2>&1; el "touch control rc=$?"
    el "pipeline done"
    ;;
wait)
    for _ in $(seq 54); do grep -q "pipeline done" $W/pipeline.log 2>/dev/null && break; sleep 10; done
    cat $W/pipeline.log
    ;;
*)
    echo "usage: $0 setup | part 1 | part 2 | wait" >&2; exit 2 ;;
esac
if [ -n "${OUT:-}" ] && [ -d $W/logs ]; then  # what has come so far: logs, reports, cost results
    (cd $W && tar czf "$OUT/gpu_smollm2.tgz" pipeline.log logs eval results \
        runs/*/stage*/run.json runs/*/stage*/train_log.jsonl repo/benchmarks/results/gpu_smollm2_cost* 2>/dev/null)
fi
