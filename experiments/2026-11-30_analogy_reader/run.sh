#!/bin/bash
# As run (2026-11-30), from the main checkout M after experiments/2026-11-30_sensor_colour/run.sh (whose `val` answers
# in the benchmark's wordings are the same items' baseline): heldout18 rendered on the two-style benchmark's val split
# (the Mini clips) and answered under `auto` by the control's models (SEEDS, default 0 1 2), code in a worktree WT of
# reader v13.
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python; WT=${WT:-$M}
export PYTHONPATH=$WT/src PYTHONUNBUFFERED=1
[ -f runs/words/bench_h18/bench.json ] || $PY -m tacreasoner paraphrase-bench --bench runs/sens/bench \
  --out runs/words/bench_h18 --wording heldout18 --splits val
for s in ${SEEDS:-0 1 2}; do
  out=runs/words/dyn/h18_auto/seed$s
  [ -f $out/report.json ] || $PY -m tacreasoner evaluate --model runs/mini_ctl/train/seed$s/stage2/model \
    --bench runs/words/bench_h18 --split val --out $out --dtype float32 --answers auto
done
date
echo DONE
