#!/bin/bash
# As run, from the main checkout (M) whose runs/ holds the trained models; WT: a worktree of the lexicon's commit.
#   WT=/tmp/wt_lex6b bash experiments/2026-11-29_lexicon_v6_again/run.sh
set -e
M=${M:-$(git rev-parse --show-toplevel)}; WT=${WT:-$M}; PY=$M/.venv/bin/python
cd $M
SET=heldout9 VERSIONS="auto=$WT" bash $WT/experiments/2026-11-29_lexicon_v4/run.sh
P=runs/physiclear/runs
[ -f runs/words/pc_h9/report.json ] || PYTHONPATH=$WT/src $PY -m tacreasoner evaluate-physiclear \
  --model $P/rec.seed0/stage2/model --model $P/rec.seed1/stage2/model --model $P/rec.seed2/stage2/model \
  --data ../shared/data/physiclear --split val --wording heldout9 --answers stepwise-vote --out runs/words/pc_h9
date
echo DONE
