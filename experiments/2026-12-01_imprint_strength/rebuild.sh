#!/bin/bash
# As run (2026-12-01 evening), from the main checkout with an empty runs/: runs/ was lost between sessions, so the
# folders run.sh reads are built again by the commands that first built them (experiments/2026-12-01_sensor_swap_train,
# experiments/2026-12-01_imprint_recipe, experiments/2026-12-01_larger_sensor_val), the candidate only (the gain
# question does not involve the control), then run.sh. The models' val figures are checked against the committed
# sensor_transfer_imprint_recipe_val300 page (same seeds, same commands) in decision.md.
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
E=experiments/2026-12-01_imprint_strength
L=experiments/2026-12-01_larger_sensor_val
export PYTHONUNBUFFERED=1
date
[ -f runs/sens/sim/.done ] || { $PY -m tacreasoner simulate --out runs/sens/sim --objects 100 --repeats 5 --sensors mini,digit && touch runs/sens/sim/.done; }
[ -d runs/sens/bench ] || $PY -m tacreasoner build-bench --source sim --data runs/sens/sim --out runs/sens/bench --heldout-sensor digit
date
$PY $E/rebuild_parts.py --out runs/swt
date
for s in 3 4 5; do $PY experiments/2026-12-01_imprint_recipe/train_seeds.py --out runs/swt --seeds $s; date; done
[ -f runs/sens300/sim/.done ] || { $PY -m tacreasoner simulate --out runs/sens300/sim --objects 300 --sensors mini,digit --seed 300 && touch runs/sens300/sim/.done; }
[ -d runs/sens300/bench ] || $PY -m tacreasoner build-bench --source sim --data runs/sens300/sim --out runs/sens300/bench \
  --heldout-sensor digit --fractions 0.4,0.3,0.3 --per-task 150 --keep-train-of runs/swt/bench
$PY $L/check_disjoint.py --trained runs/swt/bench --new runs/sens300/bench
date
$PY benchmarks/sensor_transfer.py --bench runs/sens300/bench --out runs/swt/eval300 --split-suffix val \
  --preparations match+gel+imprint --no-plain-seen --dtype float32 \
  --gel-reference runs/swt/gel_reference.json --gel-image runs/swt/gel_image.json \
  --criteria $L/criteria.md --name sensor_transfer_imprint_recipe_val300_rebuilt \
  --trained-on "Mini clips, every frame swapped to the train clips' average gel at rest (bf16, seeds 3 4 5; rebuilt)" \
  --models $(for s in 3 4 5; do echo runs/swt/train/seed$s/stage2/model; done)
date
bash $E/run.sh
