#!/bin/bash
# Publish heldout6 results (run after run.sh). As run from the experiment's worktree (WT) in the main checkout.
set -e
M=${M:-$(git rev-parse --show-toplevel)}; WT=${WT:-$M}
cd $M
for v in auto auto_v3; do
  commit=$([ $v = auto ] && echo "66fb374 (lexicon v4)" || echo "1388371 (lexicon v3)")
  PYTHONPATH=$WT/src $M/.venv/bin/python $WT/benchmarks/dyntac_wordings.py --wording heldout6 --name dyntac_heldout6_${v}_val \
    $(for s in 0 1 2; do echo --seed $s=runs/words/dyn/bench_direct/seed$s/scored/val.jsonl:runs/words/dyn/h6_$v/seed$s/scored/val.jsonl; done) \
    --machine "2-core AMD EPYC with AVX512_BF16 (the quickstart's 3 seeds, runs/qs_stepwise, trained 2026-11-29)" \
    --notes "heldout6 answered auto at commit $commit (tacreasoner evaluate --bench <paraphrase-bench --wording heldout6 of the quickstart bench> --split val --dtype float32 --answers auto, training sharing the 2 cores); benchmark wordings answered direct (= auto on them); experiments/2026-11-29_lexicon_v4/run.sh; rule: experiments/2026-11-29_lexicon_v4/criteria.md"
done
