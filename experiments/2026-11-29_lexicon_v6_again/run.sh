#!/bin/bash
# As run, from the main checkout (M) whose runs/ holds the trained models; WT: a worktree of the lexicon's commit.
#   WT=/tmp/wt_lex6b bash experiments/2026-11-29_lexicon_v6_again/run.sh                  (v6 on heldout9, a3fb3e1)
#   SET=heldout10 WT=/tmp/wt_lex7 bash experiments/2026-11-29_lexicon_v6_again/run.sh     (v7 on heldout10)
set -e
M=${M:-$(git rev-parse --show-toplevel)}; WT=${WT:-$M}; PY=$M/.venv/bin/python; SET=${SET:-heldout9}
cd $M
n=${SET#heldout}
SET=$SET VERSIONS="auto=$WT" bash $WT/experiments/2026-11-29_lexicon_v4/run.sh
P=runs/physiclear/runs
[ -f runs/words/pc_h$n/report.json ] || PYTHONPATH=$WT/src $PY -m tacreasoner evaluate-physiclear \
  --model $P/rec.seed0/stage2/model --model $P/rec.seed1/stage2/model --model $P/rec.seed2/stage2/model \
  --data ../shared/data/physiclear --split val --wording $SET --answers stepwise-vote --out runs/words/pc_h$n
date
echo DONE
