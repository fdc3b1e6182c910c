#!/bin/bash
# heldout8: auto with lexicon v6 (WT, addendum 2), in the main checkout (M)
# whose runs/ holds the trained models. As run: WT=/tmp/wt_lex6 bash run_h8.sh
set -e
M=${M:-$(git rev-parse --show-toplevel)}; WT=${WT:-$M}; PY=$M/.venv/bin/python
cd $M
T="$PY -m tacreasoner"
[ -f runs/words/bench_h8/bench.json ] || PYTHONPATH=$WT/src $T paraphrase-bench --bench runs/qs_stepwise/bench --out runs/words/bench_h8 --wording heldout8 --splits val
MODELS=(runs/qs_stepwise/model runs/qs_stepwise/train/seed1/stage2/model runs/qs_stepwise/train/seed2/stage2/model)
for s in 0 1 2; do
  m=${MODELS[$s]}
  [ -f runs/words/dyn/h8_auto/seed$s/report.json ] || PYTHONPATH=$WT/src $T evaluate --model $m --bench runs/words/bench_h8 --split val --out runs/words/dyn/h8_auto/seed$s --dtype float32 --answers auto
  date
done
echo DONE
