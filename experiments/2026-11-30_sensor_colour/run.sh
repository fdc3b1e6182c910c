#!/bin/bash
# As run (2026-11-30), from the main checkout M after train.sh, code in a worktree WT of the commit that holds
# video.gel_reference (a9f85a1): the reference from train-split Mini clips, then the control's three models under
# `match` and `match+gel`, val only (criteria.md). SEEDS="0": only the seeds given (this session: seed 0, below).
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python; WT=${WT:-$M}
export PYTHONPATH=$WT/src PYTHONUNBUFFERED=1
[ -f runs/sens/gel_mini.json ] || $PY $WT/experiments/2026-11-30_sensor_colour/gel_reference.py --bench runs/sens/bench \
  --out runs/sens/gel_mini.json
$PY $WT/benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/mini_ctl/eval_sens --preparations match match+gel \
  --gel-reference runs/sens/gel_mini.json --name sensor_transfer_gel_val \
  --trained-on 'Mini clips, the plain look (the control, retrained 2026-11-30)' \
  --models $(for s in ${SEEDS:-0 1 2}; do echo runs/mini_ctl/train/seed$s/stage2/model; done)
date
echo DONE
