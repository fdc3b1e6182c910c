#!/bin/bash
# As run, from the main checkout (M) whose runs/ holds runs/qs_stepwise and runs/sens (the plain recipe's bench).
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
SRC=${SRC:-$M/src}
PYTHONPATH=$SRC $PY experiments/2026-11-29_sensor_varied/run.py --sensors mini+varied25 --out runs/var25 --reuse runs/qs_stepwise
PYTHONPATH=$SRC $PY benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/var25/eval_sens --preparations match \
  --name sensor_transfer_varied25_val --trained-on 'Mini clips, about a quarter each drawn with its own look (mini+varied25)' \
  --models runs/var25/train/seed0/stage2/model runs/var25/train/seed1/stage2/model runs/var25/train/seed2/stage2/model
