#!/bin/bash
# As run, from the main checkout whose runs/ holds runs/mini_ctl (the control) and runs/sens (the two-style bench);
# WT: a worktree of the commit that added temporal_norm (82da8ea).
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python
mkdir -p runs/tnorm && for d in sim bench llm encoder video_cache; do ln -sfn $M/runs/mini_ctl/$d runs/tnorm/$d; done
# (run at 82da8ea with this folder's own run.py, since folded into sensor_varied/run.py's --set: the same stages)
PYTHONPATH=$WT/src $PY experiments/2026-11-29_sensor_varied/run.py --sensors mini --out runs/tnorm --set model.encoder.temporal_norm=true
PYTHONPATH=$WT/src $PY experiments/2026-11-29_sensor_temporal_diag/still_effect.py runs/mini_ctl/eval_sens/seed0/model_match runs/tnorm/train/seed0/stage2/model
PYTHONPATH=$WT/src $PY benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/tnorm/eval_sens --preparations match \
  --name sensor_transfer_temporal_norm_val --trained-on 'Mini clips, the plain look, model.encoder.temporal_norm=true' \
  --models runs/tnorm/train/seed0/stage2/model runs/tnorm/train/seed1/stage2/model runs/tnorm/train/seed2/stage2/model
