#!/bin/bash
# Publish heldout8 results (run after run_h8.sh) from the main checkout.
set -e
M=${M:-$(git rev-parse --show-toplevel)}
cd $M
for v in auto; do
  commit=$([ $v = auto ] && echo "2e21e0f (lexicon v6)" || echo "327976c (lexicon v4)")
  PYTHONPATH=$M/src $M/.venv/bin/python benchmarks/dyntac_wordings.py --wording heldout8 --name dyntac_heldout8_${v}_val \
    $(for s in 0 1 2; do echo --seed $s=runs/words/dyn/bench_direct/seed$s/scored/val.jsonl:runs/words/dyn/h8_$v/seed$s/scored/val.jsonl; done) \
    --machine "2-core AMD EPYC with AVX512_BF16 (the quickstart's 3 seeds, runs/qs_stepwise, trained 2026-11-29)" \
    --notes "heldout8 answered auto at commit $commit (tacreasoner evaluate --bench <paraphrase-bench --wording heldout8 of the quickstart bench> --split val --dtype float32 --answers auto, training sharing the 2 cores); benchmark wordings answered direct (= auto on them); experiments/2026-11-29_lexicon_v4/run_h8.sh; rule: experiments/2026-11-29_lexicon_v4/criteria.md (addendum 2)"
done
