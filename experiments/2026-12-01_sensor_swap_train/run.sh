#!/bin/bash
# As run (2026-12-01), from the main checkout M (runs/ empty at the start): the two-style benchmark the sensor figures
# read, the quickstart recipe trained on swapped frames (run.py, 3 seeds), then val under the same preparation
# (criteria.md). SPLIT=test reads the test objects, once, after the choice (decision.md).
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
export PYTHONUNBUFFERED=1
SPLIT=${SPLIT:-val}
date
[ -f runs/sens/sim/.done ] || { $PY -m tacreasoner simulate --out runs/sens/sim --objects 100 --repeats 5 --sensors mini,digit && touch runs/sens/sim/.done; }
[ -d runs/sens/bench ] || $PY -m tacreasoner build-bench --source sim --data runs/sens/sim --out runs/sens/bench --heldout-sensor digit
date
$PY experiments/2026-12-01_sensor_swap_train/run.py --out runs/swt
date
$PY benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/swt/eval_sens --split-suffix $SPLIT \
  --preparations match+gel+swap --no-plain-seen --dtype ${DTYPE:-float32} \
  --gel-reference runs/swt/gel_reference.json --gel-image runs/swt/gel_image.json \
  --criteria experiments/2026-12-01_sensor_swap_train/criteria.md --name sensor_transfer_swap_trained_$SPLIT \
  --trained-on 'Mini clips, every frame swapped to the train clips'"'"' average gel at rest (bf16)' \
  --models runs/swt/train/seed{0,1,2}/stage2/model
date
echo DONE
