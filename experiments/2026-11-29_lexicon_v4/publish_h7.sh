#!/bin/bash
# Publish heldout7 results (run after run_h7.sh) from the main checkout.
set -e
M=${M:-$(git rev-parse --show-toplevel)}
cd $M
for v in auto auto_v4; do
  commit=$([ $v = auto ] && echo "c60aa17 (lexicon v5)" || echo "327976c (lexicon v4)")
  PYTHONPATH=$M/src $M/.venv/bin/python benchmarks/dyntac_wordings.py --wording heldout7 --name dyntac_heldout7_${v}_val \
    $(for s in 0 1 2; do echo --seed $s=runs/words/dyn/bench_direct/seed$s/scored/val.jsonl:runs/words/dyn/h7_$v/seed$s/scored/val.jsonl; done) \
    --machine "2-core AMD EPYC with AVX512_BF16 (the quickstart's 3 seeds, runs/qs_stepwise, trained 2026-11-29)" \
    --notes "heldout7 answered auto at commit $commit (tacreasoner evaluate --bench <paraphrase-bench --wording heldout7 of the quickstart bench> --split val --dtype float32 --answers auto, training sharing the 2 cores); benchmark wordings answered direct (= auto on them); experiments/2026-11-29_lexicon_v4/run_h7.sh; rule: experiments/2026-11-29_lexicon_v4/criteria.md (addendum)"
done
