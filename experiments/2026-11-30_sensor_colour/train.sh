#!/bin/bash
# As run (2026-11-30), from the main checkout M, code frozen in a worktree WT at the session's start commit: the
# plain quickstart recipe retrained on Mini clips, 3 seeds, after the two-style benchmark the sensor figures read (the control of experiments/2026-11-29_sensor_plain_control,
# the machine's runs/ having been emptied between sessions).
set -e
M=${M:-$(git rev-parse --show-toplevel)}; cd $M
PY=$M/.venv/bin/python; WT=${WT:-$M}
export PYTHONPATH=$WT/src PYTHONUNBUFFERED=1
date
[ -f runs/sens/sim/.done ] || { $PY -m tacreasoner simulate --out runs/sens/sim --objects 100 --repeats 5 --sensors mini,digit && touch runs/sens/sim/.done; }
[ -d runs/sens/bench ] || $PY -m tacreasoner build-bench --source sim --data runs/sens/sim --out runs/sens/bench --heldout-sensor digit
date
$PY $WT/experiments/2026-11-29_sensor_varied/run.py --sensors mini --out runs/mini_ctl
date
echo DONE
