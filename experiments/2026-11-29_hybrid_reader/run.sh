#!/bin/bash
# As run, from the main checkout (M) whose runs/ holds the trained models. READER=words: a worktree (WT) of the word
# list alone (2cdd7c5 + criteria); READER=hybrid: a worktree of the hybrid reader's commit. Same set, same models.
#   READER=words WT=/tmp/wt_words bash experiments/2026-11-29_hybrid_reader/run.sh
#   READER=hybrid WT=/tmp/wt_hybrid bash experiments/2026-11-29_hybrid_reader/run.sh
set -e
M=${M:-$(git rev-parse --show-toplevel)}; PY=$M/.venv/bin/python; SET=${SET:-heldout13}; READER=${READER:-hybrid}
cd $M
n=${SET#heldout}
name=auto; [ "$READER" = hybrid ] || name=auto_$READER
SET=$SET VERSIONS="$name=$WT" bash $WT/experiments/2026-11-29_lexicon_v4/run.sh
P=runs/physiclear/runs
out=runs/words/pc_h${n}; [ "$READER" = hybrid ] || out=${out}_$READER
[ -f $out/report.json ] || PYTHONPATH=$WT/src $PY -m tacreasoner evaluate-physiclear \
  --model $P/rec.seed0/stage2/model --model $P/rec.seed1/stage2/model --model $P/rec.seed2/stage2/model \
  --data ../shared/data/physiclear --split val --wording $SET --answers stepwise-vote --out $out
date
echo DONE
