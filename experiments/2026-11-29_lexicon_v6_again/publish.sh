#!/bin/bash
# Publish one held-out set's DynTAC-Sim results (after run.sh) from the main checkout:
#   SET=heldout9 VERSIONS="auto=a3fb3e1:v6" bash publish.sh
#   SET=heldout10 VERSIONS="auto=<v7 commit>:v7" bash publish.sh
set -e
M=${M:-$(git rev-parse --show-toplevel)}
cd $M
n=${SET#heldout}
for version in $VERSIONS; do
  name=${version%%=*}; commit=${version#*=}; commit="${commit%%:*} (lexicon ${commit#*:})"
  PYTHONPATH=$M/src $M/.venv/bin/python benchmarks/dyntac_wordings.py --wording $SET --name dyntac_${SET}_${name}_val \
    $(for s in 0 1 2; do echo --seed $s=runs/words/dyn/bench_direct/seed$s/scored/val.jsonl:runs/words/dyn/h${n}_$name/seed$s/scored/val.jsonl; done) \
    --machine "2-core AMD EPYC with AVX512_BF16 (the quickstart's 3 seeds, runs/qs_stepwise, trained 2026-11-29)" \
    --notes "$SET answered auto at commit $commit (tacreasoner evaluate --bench <paraphrase-bench --wording $SET of the quickstart bench> --split val --dtype float32 --answers auto, alone on the 2 cores); benchmark wordings answered direct (= auto on them); experiments/2026-11-29_lexicon_v6_again: criteria.md, run.sh, decision.md"
done
