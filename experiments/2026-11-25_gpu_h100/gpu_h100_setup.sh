# Sourced by benchmarks/gpu_h100.sh and gpu_h100_fp32.sh: the lent H100's setup, from the repository root with a
# .gpu/ folder beside the code: whl/ (av 18.1.0, peft 0.21.2, transformers 5.24.0 wheels for Python 3.12: the
# machine has no registry), run/encoder (the quickstart's pre-trained appearance encoder) and run/data.tgz (the
# quickstart's bench/ with video_root "../sim", and touchcot/touchcot/touchcot_train.jsonl). The clips are
# simulated and the tiny LLM pre-trained there. Output and files go to $OUT.
set -u
export PYTHONUNBUFFERED=1
T0=$(date +%s)
el() { echo "[$(( $(date +%s) - T0 )) s] $*"; }
# train_logged STAGE ARGS...: one stage with the tiny config, its whole output in $OUT/stageN.log, the end shown.
train_logged() {
    local stage=$1 start
    shift
    start=$(date +%s)
    $TR train --stage "$stage" --config configs/tiny-cpu.yaml "$@" 2>&1 | tee "$OUT/stage$stage.log" \
        | tr '\r' '\n' | grep -v "━━━━━━━━━━━ *[0-9]*/[0-9]* " | tail -15
    el "stage$stage wall $(( $(date +%s) - start )) s"
}
# evaluate_and_pack NAME: the Stage II model on the test objects, then the run's records in $OUT/NAME.tgz.
evaluate_and_pack() {
    local start
    start=$(date +%s)
    $TR evaluate --model runs/gpu/stage2/model --bench runs/quickstart/bench --out runs/gpu/eval 2>&1 \
        | tr '\r' '\n' | tail -8
    el "evaluate wall $(( $(date +%s) - start )) s"
    tar czf "$OUT/$1.tgz" llm.log runs/gpu/stage1/run.json runs/gpu/stage2/run.json runs/gpu/stage1/train_log.jsonl \
        runs/gpu/stage2/train_log.jsonl runs/gpu/eval/report.md runs/gpu/eval/*.json 2>/dev/null
}
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .gpu/whl/*.whl || exit 1
export PYTHONPATH=/tmp/site:$PWD/src
TR="python3 -m tacreasoner"
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv
python3 -c "import torch,transformers,peft,accelerate,av,numpy;print('torch',torch.__version__,'cuda',torch.cuda.is_available(),torch.cuda.get_device_name(0),'bf16',torch.cuda.is_bf16_supported());print('transformers',transformers.__version__,'peft',peft.__version__,'accelerate',accelerate.__version__,'av',av.__version__,'numpy',numpy.__version__)"
nproc; python3 --version
mkdir -p runs/quickstart && cp -r .gpu/run/encoder runs/quickstart/ && tar xzf .gpu/run/data.tgz -C runs/quickstart
el "simulate + pretrain-llm (CPU, 6 threads) side by side"
(S=$(date +%s); $TR pretrain-llm --out runs/quickstart/llm --threads 6 --no-eval > llm.log 2>&1; echo "llm rc=$? $(( $(date +%s) - S )) s" >> llm.log) &
$TR simulate --out runs/quickstart/sim --workers 10 2>&1 | tail -2; el simulated; wait; tail -4 llm.log; el "llm done"
