#!/bin/bash
# As run, from the main checkout (M) whose runs/ holds runs/qs_stepwise and runs/sens (the plain recipe's bench).
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
SRC=${SRC:-$M/src}
PYTHONPATH=$SRC $PY experiments/2026-11-29_sensor_varied/run.py --sensors mini --out runs/mini_ctl --reuse runs/qs_stepwise
PYTHONPATH=$SRC $PY benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/mini_ctl/eval_sens --preparations match \
  --name sensor_transfer_plain_control_val --trained-on 'Mini clips, the plain look, retrained with the mixes script (control)' \
  --models runs/mini_ctl/train/seed0/stage2/model runs/mini_ctl/train/seed1/stage2/model runs/mini_ctl/train/seed2/stage2/model
