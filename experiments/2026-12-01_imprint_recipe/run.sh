#!/bin/bash
# As run (2026-12-01), from the main checkout, after experiments/2026-12-01_sensor_swap_train/run.sh built runs/sens
# and runs/swt and experiments/2026-11-29_sensor_varied/run.py --sensors mini built runs/mini_ctl (with its
# gel_reference.json and gel_swap.json measured as the quickstart measures them): 3 fresh seeds of each recipe, the
# same session and precision, then val under each recipe's answer-time preparation (criteria.md).
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
E=experiments/2026-12-01_imprint_recipe
export PYTHONUNBUFFERED=1
SPLIT=${SPLIT:-val}
SEEDS=${SEEDS:-3 4 5}
date
for s in $SEEDS; do
  $PY $E/train_seeds.py --out runs/swt --seeds $s; date
  $PY $E/train_seeds.py --out runs/mini_ctl --seeds $s; date
done
models() { for s in $SEEDS; do echo $1/train/seed$s/stage2/model; done; }
$PY benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/swt/eval_imprint --split-suffix $SPLIT \
  --preparations match+gel+imprint --no-plain-seen --dtype float32 \
  --gel-reference runs/swt/gel_reference.json --gel-image runs/swt/gel_image.json \
  --criteria $E/criteria.md --name sensor_transfer_imprint_recipe_$SPLIT \
  --trained-on "Mini clips, every frame swapped to the train clips' average gel at rest (bf16, seeds $SEEDS)" \
  --models $(models runs/swt)
date
$PY benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/mini_ctl/eval_gate --split-suffix $SPLIT \
  --preparations match+gel+swap+gate --no-plain-seen --dtype float32 \
  --gel-reference runs/mini_ctl/gel_reference.json --gel-image runs/mini_ctl/gel_swap.json \
  --criteria $E/criteria.md --name sensor_transfer_imprint_recipe_control_$SPLIT \
  --trained-on "Mini clips, the plain look (the quickstart recipe; bf16, seeds $SEEDS, trained beside the candidate)" \
  --models $(models runs/mini_ctl)
date
echo DONE
