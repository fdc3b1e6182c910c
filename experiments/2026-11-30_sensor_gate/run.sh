#!/bin/bash
# As run (2026-11-30), from the main checkout after experiments/2026-11-30_sensor_swap (its models, benchmark, R,
# colour reference and answers in runs/mini_ctl/eval_sens, reused): the gate's threshold from train-split Mini clips,
# then the three control models under the gated swap, val (criteria.md). SPLIT=test reads the test objects, once,
# after the choice (decision.md); PREPARATIONS and MODELS narrow a run.
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
export PYTHONUNBUFFERED=1
SPLIT=${SPLIT:-val}
[ -f runs/sens/gel_gate_mini.json ] || $PY experiments/2026-11-30_sensor_gate/swap_above.py --bench runs/sens/bench \
  --gel-reference runs/sens/gel_mini.json --gel-image runs/sens/gel_image_mini.json \
  --model runs/mini_ctl/train/seed0/stage2/model --out runs/sens/gel_gate_mini.json
$PY benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/mini_ctl/eval_sens --split-suffix $SPLIT \
  --preparations ${PREPARATIONS:-match+gel match+gel+swap+gate} --no-plain-seen \
  --gel-reference runs/sens/gel_mini.json --gel-image runs/sens/gel_gate_mini.json --name ${NAME:-sensor_transfer_gate_$SPLIT} \
  --trained-on 'Mini clips, the plain look (the control, retrained 2026-11-30)' \
  --models ${MODELS:-runs/mini_ctl/train/seed0/stage2/model runs/mini_ctl/train/seed1/stage2/model runs/mini_ctl/train/seed2/stage2/model}
date
echo DONE
