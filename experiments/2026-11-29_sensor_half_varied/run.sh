#!/bin/bash
# As run, from the main checkout (M) whose runs/ holds runs/qs_stepwise and runs/sens (the plain recipe's bench).
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
PYTHONPATH=$M/src $PY experiments/2026-11-29_sensor_varied/run.py --sensors mini+varied50 --out runs/var50 --reuse runs/qs_stepwise
PYTHONPATH=$M/src $PY benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/var50/eval_sens --preparations match \
  --name sensor_transfer_varied50_val --trained-on 'Mini clips, about half each drawn with its own look (mini+varied50)' \
  --models runs/var50/train/seed0/stage2/model runs/var50/train/seed1/stage2/model runs/var50/train/seed2/stage2/model
