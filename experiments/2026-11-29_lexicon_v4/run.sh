#!/bin/bash
# heldout6: auto with lexicon v4 (WT, this experiment's commit) and v3 (WT3, commit 1388371), in the main checkout
# (M) whose runs/ holds the trained models. As run: WT=/tmp/wt_lex4 WT3=/tmp/wt_lex3 bash run.sh
set -e
M=${M:-$(git rev-parse --show-toplevel)}; WT=${WT:-$M}; PY=$M/.venv/bin/python
cd $M
T="$PY -m tacreasoner"
[ -f runs/words/bench_h6/bench.json ] || PYTHONPATH=$WT/src $T paraphrase-bench --bench runs/qs_stepwise/bench --out runs/words/bench_h6 --wording heldout6 --splits val
MODELS=(runs/qs_stepwise/model runs/qs_stepwise/train/seed1/stage2/model runs/qs_stepwise/train/seed2/stage2/model)
for s in 0 1 2; do
  m=${MODELS[$s]}
  [ -f runs/words/dyn/h6_auto/seed$s/report.json ] || PYTHONPATH=$WT/src $T evaluate --model $m --bench runs/words/bench_h6 --split val --out runs/words/dyn/h6_auto/seed$s --dtype float32 --answers auto
  [ -f runs/words/dyn/h6_auto_v3/seed$s/report.json ] || PYTHONPATH=$WT3/src $T evaluate --model $m --bench runs/words/bench_h6 --split val --out runs/words/dyn/h6_auto_v3/seed$s --dtype float32 --answers auto
  date
done
echo DONE
