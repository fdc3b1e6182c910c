#!/bin/bash
# One held-out set answered under `auto` by the quickstart's three models, once per lexicon version, in the main
# checkout (M) whose runs/ holds the trained models. Each version is a worktree of the commit that holds it:
#   SET=heldout6 VERSIONS="auto=/tmp/wt_lex4 auto_v3=/tmp/wt_lex3" bash run.sh     (v4 at 66fb374, v3 at 1388371)
#   SET=heldout7 VERSIONS="auto=/tmp/wt_lex5 auto_v4=/tmp/wt_lex4b" bash run.sh    (v5 at c60aa17, v4 at 327976c)
#   SET=heldout8 VERSIONS="auto=/tmp/wt_lex6" bash run.sh                          (v6 at 2e21e0f)
# (as run, in three scripts of this shape: run.sh, run_h7.sh, run_h8.sh before they were merged into this one)
set -e
M=${M:-$(git rev-parse --show-toplevel)}; PY=$M/.venv/bin/python
cd $M
n=${SET#heldout}
first=${VERSIONS%% *}; first=${first#*=}
[ -f runs/words/bench_h$n/bench.json ] || PYTHONPATH=$first/src $PY -m tacreasoner paraphrase-bench \
  --bench runs/qs_stepwise/bench --out runs/words/bench_h$n --wording $SET --splits val
MODELS=(runs/qs_stepwise/model runs/qs_stepwise/train/seed1/stage2/model runs/qs_stepwise/train/seed2/stage2/model)
for s in 0 1 2; do
  for version in $VERSIONS; do
    name=${version%%=*}; wt=${version#*=}; out=runs/words/dyn/h${n}_$name/seed$s
    [ -f $out/report.json ] || PYTHONPATH=$wt/src $PY -m tacreasoner evaluate --model ${MODELS[$s]} \
      --bench runs/words/bench_h$n --split val --out $out --dtype float32 --answers auto
  done
  date
done
echo DONE
