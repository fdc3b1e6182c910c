#!/bin/bash
# As run (2026-11-30, session 14:39-17:39 UTC), from the main checkout M after run.sh chose `match+gel` on val: src
# frozen in a worktree WT of 1c0f331 with this commit's benchmarks/sensor_transfer.py (--no-plain-seen). The test
# objects read once, the adopted preparation only: the held-out DIGIT style and the seen Mini style, both under
# `match+gel` (criteria.md had said both preparations; `match` on the held-out style was left unread for the
# session's time). Seed 0's seen style without the map was answered before --no-plain-seen was added (the first
# launch, stopped after it): its figure is in decision.md. The reference is the train-clip file the val figures used.
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python; WT=${WT:-$M}
export PYTHONPATH=$WT/src PYTHONUNBUFFERED=1
date
$PY $WT/benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/mini_ctl/eval_sens --split-suffix test \
  --preparations match+gel --gel-reference runs/sens/gel_mini.json --name sensor_transfer_gel_test --no-plain-seen \
  --trained-on 'Mini clips, the plain look (the control, retrained 2026-11-30)' \
  --models $(for s in 0 1 2; do echo runs/mini_ctl/train/seed$s/stage2/model; done)
date
echo DONE
