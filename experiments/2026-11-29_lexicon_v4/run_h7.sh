#!/bin/bash
# heldout7: auto with lexicon v5 (WT, the addendum's commit) and v4 (WT4, commit 327976c), in the main checkout (M)
# whose runs/ holds the trained models. As run: WT=/tmp/wt_lex5 WT4=/tmp/wt_lex4b bash run_h7.sh
set -e
M=${M:-$(git rev-parse --show-toplevel)}; WT=${WT:-$M}; PY=$M/.venv/bin/python
cd $M
T="$PY -m tacreasoner"
[ -f runs/words/bench_h7/bench.json ] || PYTHONPATH=$WT/src $T paraphrase-bench --bench runs/qs_stepwise/bench --out runs/words/bench_h7 --wording heldout7 --splits val
MODELS=(runs/qs_stepwise/model runs/qs_stepwise/train/seed1/stage2/model runs/qs_stepwise/train/seed2/stage2/model)
for s in 0 1 2; do
  m=${MODELS[$s]}
  [ -f runs/words/dyn/h7_auto/seed$s/report.json ] || PYTHONPATH=$WT/src $T evaluate --model $m --bench runs/words/bench_h7 --split val --out runs/words/dyn/h7_auto/seed$s --dtype float32 --answers auto
  [ -f runs/words/dyn/h7_auto_v4/seed$s/report.json ] || PYTHONPATH=$WT4/src $T evaluate --model $m --bench runs/words/bench_h7 --split val --out runs/words/dyn/h7_auto_v4/seed$s --dtype float32 --answers auto
  date
done
echo DONE
