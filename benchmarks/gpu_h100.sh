#!/usr/bin/env bash
# The single-GPU run behind benchmarks/results/gpu_h100.md, as run on a lent H100 (the device tool) from the
# repository root with a .gpu/ folder beside the code: whl/ (av 18.1.0, peft 0.21.2, transformers 5.24.0 wheels
# for Python 3.12: the machine has no registry), run/encoder (the quickstart's pre-trained appearance encoder)
# and run/data.tgz (the quickstart's bench/ with video_root "../sim", and touchcot/touchcot/touchcot_train.jsonl).
# The clips are simulated and the tiny LLM pre-trained there. Output and files go to $OUT.
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
el "checks: gradient checkpointing"
timeout 120 $TR train --stage 2 --config configs/tiny-cpu.yaml --set output_dir=runs/gc --set stage1.skip=true --set stage2.steps=30 --set model.gradient_checkpointing=true 2>&1 | tr '\r' '\n' | grep -v "━━━ *[0-9]*/" | tail -6; echo "gc rc=${PIPESTATUS[0]}"; ls runs/gc/stage2/model | head -3
el "checks: FSDP (1 process)"
L="accelerate launch --config_file configs/accelerate/fsdp-2gpu.yaml --num_processes 1 -m tacreasoner train --stage 2 --config configs/tiny-cpu.yaml --set output_dir=runs/fsdp --set stage1.skip=true --set runtime.checkpoint_every=10"
timeout 150 $L --set stage2.steps=20 > $OUT/fsdp.log 2>&1; echo "fsdp rc=$?"; grep -B2 -A3 "Error" $OUT/fsdp.log | head -30; ls runs/fsdp/stage2 runs/fsdp/stage2/checkpoints 2>&1 | head
[ -d runs/fsdp/stage2/checkpoints ] && { timeout 120 $L --set stage2.steps=30 --resume > $OUT/fsdp_resume.log 2>&1; echo "fsdp resume rc=$?"; }; tail -2 runs/fsdp/stage2/train_log.jsonl
S=$(date +%s); $TR train --stage 1 --config configs/tiny-cpu.yaml --set output_dir=runs/gpu 2>&1 | tee $OUT/stage1.log | tr '\r' '\n' | grep -v "━━━━━━━━━━━ *[0-9]*/[0-9]* " | tail -15; el "stage1 wall $(( $(date +%s) - S )) s"
S=$(date +%s); $TR train --stage 2 --config configs/tiny-cpu.yaml --set output_dir=runs/gpu 2>&1 | tee $OUT/stage2.log | tr '\r' '\n' | grep -v "━━━━━━━━━━━ *[0-9]*/[0-9]* " | tail -15; el "stage2 wall $(( $(date +%s) - S )) s"
S=$(date +%s); $TR evaluate --model runs/gpu/stage2/model --bench runs/quickstart/bench --out runs/gpu/eval 2>&1 | tr '\r' '\n' | tail -8; el "evaluate wall $(( $(date +%s) - S )) s"
tar czf $OUT/gpu_run.tgz llm.log runs/gpu/stage1/run.json runs/gpu/stage2/run.json runs/gpu/stage1/train_log.jsonl runs/gpu/stage2/train_log.jsonl runs/gpu/eval/report.md runs/gpu/eval/*.json 2>/dev/null
el done
