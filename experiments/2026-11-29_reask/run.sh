#!/bin/bash
# heldout4 measurements (experiments/2026-11-29_reask/criteria.md). As run: from a frozen worktree of the criteria's
# commit (WT), in the main checkout (M) whose runs/ holds the trained models.
set -e
M=${M:-$(git rev-parse --show-toplevel)}; WT=${WT:-$M}; PY=$M/.venv/bin/python
export PYTHONPATH=$WT/src
cd $M
T="$PY -m tacreasoner"
[ -f runs/words/bench_h4/bench.json ] || $T paraphrase-bench --bench runs/qs_stepwise/bench --out runs/words/bench_h4 --wording heldout4 --splits val
MODELS=(runs/qs_stepwise/model runs/qs_stepwise/train/seed1/stage2/model runs/qs_stepwise/train/seed2/stage2/model)
for s in 0 1 2; do
  m=${MODELS[$s]}
  [ -f runs/words/dyn/bench_direct/seed$s/report.json ] || $T evaluate --model $m --bench runs/qs_stepwise/bench --split val --out runs/words/dyn/bench_direct/seed$s --dtype float32
  for mode in auto stepwise-vote; do
    [ -f runs/words/dyn/h4_$mode/seed$s/report.json ] || $T evaluate --model $m --bench runs/words/bench_h4 --split val --out runs/words/dyn/h4_$mode/seed$s --dtype float32 --answers $mode
  done
  date
done
echo DONE
# PhysiCLeAR: the shipped recipe's three seeds, its recommended stepwise-vote (re-asking does not apply to it)
P=runs/physiclear/runs
[ -f runs/words/pc_h4/octopi.json ] || $T evaluate-physiclear --model $P/rec.seed0/stage2/model --model $P/rec.seed1/stage2/model --model $P/rec.seed2/stage2/model --data ../shared/data/physiclear --split val --wording heldout4 --answers stepwise-vote --out runs/words/pc_h4
echo DONE_PC
