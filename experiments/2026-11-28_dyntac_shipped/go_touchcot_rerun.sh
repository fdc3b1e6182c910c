#!/usr/bin/env bash
# TouchCoT against the shipped recipe, 3 seeds paired, val, self-contained: the recipe's seeds and TouchCoT's from one
# fresh quickstart (Q, README command 1 at 67e4788 in ., which also answered val into Q/eval_val), after the
# first run folder was lost with its machine. Trained and answered by the fresh clone's own install (never edited);
# the chain script is copied beside the run (bash reads a script as it runs: an edit to benchmarks/ must not reach a
# running chain). Started 2026-11-28 ~16:35 UTC on a 2-core AMD EPYC with AVX2 only (float32: ~30 s a Stage II
# step, ~5 h a TouchCoT seed): it only helps if that machine lives on; a GPU lease does all six chains in ~10 minutes
# (benchmarks/dyntac_gpu.sh).
# ARCHIVE collects every scored run as it finishes: commit it (benchmarks/results/touchcot_cpu_val_inputs/).
set -eu
cd .
export Q=runs/quickstart OUT=runs/touchcot_cpu EXTRA="--set runtime.threads=2"
export TR=".venv/bin/python -m tacreasoner" TR_EVAL=".venv/bin/python -m tacreasoner"
export ARCHIVE=benchmarks/results/touchcot_cpu_val_inputs/scored.tgz
export JOBS="${JOBS:-cot:0 rec:1 cot:1 rec:2 cot:2}"
mkdir -p "$OUT"
[ -e "$OUT/dyntac_cpu.sh" ] || cp benchmarks/dyntac_cpu.sh "$OUT/dyntac_cpu.sh"
exec bash "$OUT/dyntac_cpu.sh"
