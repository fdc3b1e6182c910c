#!/usr/bin/env bash
# The fp32 run of benchmarks/results/gpu_h100.md (setup and .gpu/ layout: benchmarks/gpu_h100_setup.sh): Stage I
# with runtime.mixed_precision=no, then the Stage II fits (clip reader, comparator) at one Stage II step; the full
# Stage II and evaluation only where time is left (it was not, in the 2026-11-25 run). Also checks that the
# re-simulated clips are byte-identical to the CPU quickstart's (md5 of two clips and the manifest).
source "$(dirname "$0")/gpu_h100_setup.sh"
md5sum runs/quickstart/sim/clips/mini/banana_fake_0027_1.mp4 runs/quickstart/sim/clips/mini/apple_real_0.mp4 runs/quickstart/sim/manifest.jsonl
train_logged 1 --set output_dir=runs/gpu --set runtime.mixed_precision=no
mkdir -p runs/fit/stage1 && ln -sfn $PWD/runs/gpu/stage1/model runs/fit/stage1/model
$TR train --stage 2 --config configs/tiny-cpu.yaml --set output_dir=runs/fit --set runtime.mixed_precision=no --set stage2.steps=1 2>&1 | tail -2
cp runs/gpu/stage1/run.json $OUT/stage1_run.json; cp runs/fit/stage2/run.json $OUT/fit_run.json; el "fits done"
if [ $(( $(date +%s) - T0 )) -lt 265 ]; then
train_logged 2 --set output_dir=runs/gpu --set runtime.mixed_precision=no
evaluate_and_pack gpu_fp32
fi
el done
