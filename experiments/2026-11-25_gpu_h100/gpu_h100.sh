#!/usr/bin/env bash
# The bf16 run behind benchmarks/results/gpu_h100.md, on a lent H100 (the device tool): activation
# checkpointing and FSDP checks, then Stage I, Stage II and the evaluation with the tiny config.
# Setup and the .gpu/ layout it needs: benchmarks/gpu_h100_setup.sh.
source "$(dirname "$0")/gpu_h100_setup.sh"
el "checks: gradient checkpointing"
timeout 120 $TR train --stage 2 --config configs/tiny-cpu.yaml --set output_dir=runs/gc --set stage1.skip=true --set stage2.steps=30 --set model.gradient_checkpointing=true 2>&1 | tr '\r' '\n' | grep -v "━━━ *[0-9]*/" | tail -6; echo "gc rc=${PIPESTATUS[0]}"; ls runs/gc/stage2/model | head -3
el "checks: FSDP (1 process)"
L="accelerate launch --config_file configs/accelerate/fsdp-2gpu.yaml --num_processes 1 -m tacreasoner train --stage 2 --config configs/tiny-cpu.yaml --set output_dir=runs/fsdp --set stage1.skip=true --set runtime.checkpoint_every=10"
timeout 150 $L --set stage2.steps=20 > $OUT/fsdp.log 2>&1; echo "fsdp rc=$?"; grep -B2 -A3 "Error" $OUT/fsdp.log | head -30; ls runs/fsdp/stage2 runs/fsdp/stage2/checkpoints 2>&1 | head
[ -d runs/fsdp/stage2/checkpoints ] && { timeout 120 $L --set stage2.steps=30 --resume > $OUT/fsdp_resume.log 2>&1; echo "fsdp resume rc=$?"; }; tail -2 runs/fsdp/stage2/train_log.jsonl
train_logged 1 --set output_dir=runs/gpu
train_logged 2 --set output_dir=runs/gpu
evaluate_and_pack gpu_run
el done
