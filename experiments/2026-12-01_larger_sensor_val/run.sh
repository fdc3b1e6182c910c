#!/bin/bash
# As run (2026-12-01), from the main checkout whose runs/ holds what experiments/2026-12-01_imprint_recipe/run.sh
# left (runs/swt and runs/mini_ctl, seeds 3–5 trained; their preparation files): the larger two-style corpus, its
# benchmark with the models' train objects kept out of val and test, the check, then val for both recipes.
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
E=experiments/2026-12-01_larger_sensor_val
export PYTHONUNBUFFERED=1
date
$PY -m tacreasoner simulate --out runs/sens300/sim --objects 300 --sensors mini,digit --seed 300
$PY -m tacreasoner build-bench --source sim --data runs/sens300/sim --out runs/sens300/bench --heldout-sensor digit \
  --fractions 0.4,0.3,0.3 --per-task 150 --keep-train-of runs/swt/bench
$PY $E/check_disjoint.py --trained runs/swt/bench --new runs/sens300/bench
date
models() { for s in 3 4 5; do echo $1/train/seed$s/stage2/model; done; }
$PY benchmarks/sensor_transfer.py --bench runs/sens300/bench --out runs/swt/eval300 --split-suffix val \
  --preparations match+gel+imprint --no-plain-seen --dtype float32 \
  --gel-reference runs/swt/gel_reference.json --gel-image runs/swt/gel_image.json \
  --criteria $E/criteria.md --name sensor_transfer_imprint_recipe_val300 \
  --trained-on "Mini clips, every frame swapped to the train clips' average gel at rest (bf16, seeds 3 4 5)" \
  --models $(models runs/swt)
date
$PY benchmarks/sensor_transfer.py --bench runs/sens300/bench --out runs/mini_ctl/eval300 --split-suffix val \
  --preparations match+gel+swap+gate --no-plain-seen --dtype float32 \
  --gel-reference runs/mini_ctl/gel_reference.json --gel-image runs/mini_ctl/gel_swap.json \
  --criteria $E/criteria.md --name sensor_transfer_imprint_recipe_control_val300 \
  --trained-on "Mini clips, the plain look (the quickstart recipe before the imprint; bf16, seeds 3 4 5)" \
  --models $(models runs/mini_ctl)
date
$PY $E/compare.py > $E/compare.md
cat $E/compare.md
echo DONE
