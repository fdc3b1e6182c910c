#!/usr/bin/env bash
# Lease call 1 of 3 (issue 61): the TouchCoT rerun's set-up (wheels installed, data unpacked, the simulation started
# in the background at low CPU priority), then the 7B Stage II step at micro-batch 4 and 8 while it simulates.
# Device `run`, carry [".gpu/whl", ".gpu/data"]; calls 2 and 3 are `part 1` and `part 2` of benchmarks/dyntac_gpu.sh.
set -u
export PYTHONUNBUFFERED=1
start=$(date +%s)
VARIANTS="rec cot" SEEDS="0 1 2" TEST=0 THREADS=2 bash benchmarks/dyntac_gpu.sh setup || exit 1
export PYTHONPATH=/tmp/site:$PWD/src
mkdir -p "$OUT/s2"
for mb in 4 8; do
    extra=$([ "$mb" = 8 ] && echo --profile)
    # shellcheck disable=SC2086
    python3 benchmarks/stage2_step.py --config configs/qwen2.5-7b.yaml --micro-batch "$mb" --steps 5 --warmup 2 \
        --measure-peak $extra --out "$OUT/s2" 2>&1 | grep -v Warning
done
cat "$OUT"/s2/*.md
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,power.draw,power.limit --format=csv
echo "call 1: $(( $(date +%s) - start )) s; simulation: $(cat /tmp/w/sim.done 2>/dev/null || echo running)"
