#!/bin/bash
# As run (2026-11-30), from the main checkout after experiments/2026-11-30_sensor_colour (its models, benchmark,
# reference and match+gel answers in runs/mini_ctl/eval_sens, reused): the swap image from train-split Mini clips,
# then the three control models under match+gel+swap, val only (criteria.md). The second candidate ran as
# PREPARATIONS="match+gel match+gel+swap match+gel+light" bash run.sh (the first's answers reused).
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
export PYTHONUNBUFFERED=1
[ -f runs/sens/gel_image_mini.json ] || $PY experiments/2026-11-30_sensor_swap/gel_image.py --bench runs/sens/bench \
  --model runs/mini_ctl/train/seed0/stage2/model --out runs/sens/gel_image_mini.json
$PY benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/mini_ctl/eval_sens \
  --preparations ${PREPARATIONS:-match+gel match+gel+swap} --no-plain-seen \
  --gel-reference runs/sens/gel_mini.json --gel-image runs/sens/gel_image_mini.json --name sensor_transfer_swap_val \
  --trained-on 'Mini clips, the plain look (the control, retrained 2026-11-30)' \
  --models runs/mini_ctl/train/seed{0,1,2}/stage2/model
date
echo DONE
