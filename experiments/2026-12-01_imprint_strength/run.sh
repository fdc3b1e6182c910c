#!/bin/bash
# As run (2026-12-01), from the main checkout, after experiments/2026-12-01_larger_sensor_val/run.sh (runs/sens300,
# runs/swt/eval300): the DIGIT gain from the train objects' clips, then the larger val's DIGIT items with it.
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
E=experiments/2026-12-01_imprint_strength
export PYTHONUNBUFFERED=1
date
$PY $E/gain.py --out runs/swt/imprint_gain.json
for s in 3 4 5; do
  $PY $E/with_gain.py --model runs/swt/train/seed$s/stage2/model --gain runs/swt/imprint_gain.json \
    --out runs/swt/gain_models/seed$s
  out=runs/swt/eval300_gain/seed$((s - 3))/val_heldout_sensor
  [ -f $out/report.json ] || $PY -m tacreasoner evaluate --model runs/swt/gain_models/seed$s \
    --bench runs/sens300/bench --split val_heldout_sensor --out $out --dtype float32
  date
done
$PY $E/compare.py > $E/compare.md
cat $E/compare.md
echo DONE
