#!/usr/bin/env bash
# The fp32 run of benchmarks/results/gpu_h100.md (same .gpu/ layout as benchmarks/gpu_h100.sh): Stage I with
# runtime.mixed_precision=no, then the Stage II fits (clip reader, comparator) at one Stage II step; the full
# Stage II and evaluation only where time is left (it was not, in the 2026-11-25 run). Also checks that the
# re-simulated clips are byte-identical to the CPU quickstart's (md5 of two clips and the manifest).
set -u
export PYTHONUNBUFFERED=1
T0=$(date +%s)
el() { echo "[$(( $(date +%s) - T0 )) s] $*"; }
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
md5sum runs/quickstart/sim/clips/mini/banana_fake_0027_1.mp4 runs/quickstart/sim/clips/mini/apple_real_0.mp4 runs/quickstart/sim/manifest.jsonl
S=$(date +%s); $TR train --stage 1 --config configs/tiny-cpu.yaml --set output_dir=runs/gpu --set runtime.mixed_precision=no 2>&1 | tee $OUT/stage1.log | tr '\r' '\n' | grep -v "━━━━━━━━━━━ *[0-9]*/[0-9]* " | tail -15; el "stage1 wall $(( $(date +%s) - S )) s"
mkdir -p runs/fit/stage1 && ln -sfn $PWD/runs/gpu/stage1/model runs/fit/stage1/model
$TR train --stage 2 --config configs/tiny-cpu.yaml --set output_dir=runs/fit --set runtime.mixed_precision=no --set stage2.steps=1 2>&1 | tail -2
cp runs/gpu/stage1/run.json $OUT/stage1_run.json; cp runs/fit/stage2/run.json $OUT/fit_run.json; el "fits done"
if [ $(( $(date +%s) - T0 )) -lt 265 ]; then
S=$(date +%s); $TR train --stage 2 --config configs/tiny-cpu.yaml --set output_dir=runs/gpu --set runtime.mixed_precision=no 2>&1 | tee $OUT/stage2.log | tr '\r' '\n' | grep -v "━━━━━━━━━━━ *[0-9]*/[0-9]* " | tail -15; el "stage2 wall $(( $(date +%s) - S )) s"
S=$(date +%s); $TR evaluate --model runs/gpu/stage2/model --bench runs/quickstart/bench --out runs/gpu/eval 2>&1 | tr '\r' '\n' | tail -8; el "evaluate wall $(( $(date +%s) - S )) s"
tar czf $OUT/gpu_fp32.tgz llm.log runs/gpu/stage1/run.json runs/gpu/stage2/run.json runs/gpu/stage1/train_log.jsonl runs/gpu/stage2/train_log.jsonl runs/gpu/eval/report.md runs/gpu/eval/*.json 2>/dev/null
fi
el done
