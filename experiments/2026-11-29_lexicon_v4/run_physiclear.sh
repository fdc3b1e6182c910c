#!/bin/bash
# PhysiCLeAR val on heldout6: the PhysiCLeAR recipe's three seeds under stepwise-vote (their recorded mode), lexicon
# v4 (WT). As run after run.sh: WT=/tmp/wt_lex4 bash run_physiclear.sh
set -e
M=${M:-$(git rev-parse --show-toplevel)}; WT=${WT:-$M}; PY=$M/.venv/bin/python
export PYTHONPATH=$WT/src
cd $M
P=runs/physiclear/runs
[ -f runs/words/pc_h6/report.json ] || $PY -m tacreasoner evaluate-physiclear --model $P/rec.seed0/stage2/model --model $P/rec.seed1/stage2/model --model $P/rec.seed2/stage2/model --data ../shared/data/physiclear --split val --wording heldout6 --answers stepwise-vote --out runs/words/pc_h6
date
echo DONE
