#!/bin/bash
# heldout5 measurement of auto with the wordings chosen on val (criteria.md, addendum). As run: from a frozen
# worktree of the commit that made the choice (WT), in the main checkout (M) whose runs/ holds the trained models.
set -e
M=${M:-$(git rev-parse --show-toplevel)}; WT=${WT:-$M}; PY=$M/.venv/bin/python
export PYTHONPATH=$WT/src
cd $M
T="$PY -m tacreasoner"
[ -f runs/words/bench_h5/bench.json ] || $T paraphrase-bench --bench runs/qs_stepwise/bench --out runs/words/bench_h5 --wording heldout5 --splits val
MODELS=(runs/qs_stepwise/model runs/qs_stepwise/train/seed1/stage2/model runs/qs_stepwise/train/seed2/stage2/model)
for s in 0 1 2; do
  m=${MODELS[$s]}
  for mode in auto stepwise-vote; do
    [ -f runs/words/dyn/h5_$mode/seed$s/report.json ] || $T evaluate --model $m --bench runs/words/bench_h5 --split val --out runs/words/dyn/h5_$mode/seed$s --dtype float32 --answers $mode
  done
  date
done
echo DONE
