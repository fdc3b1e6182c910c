#!/bin/bash
# Publish one held-out set's results (after run.sh) from the main checkout, one result file per lexicon version:
#   SET=heldout6 VERSIONS="auto=66fb374:v4 auto_v3=1388371:v3" bash publish.sh
#   SET=heldout7 VERSIONS="auto=c60aa17:v5 auto_v4=327976c:v4" bash publish.sh
#   SET=heldout8 VERSIONS="auto=2e21e0f:v6" bash publish.sh
# (CORES and SOURCE, what the notes say of the answering and where the rule is, default to this experiment's)
set -e
CORES=${CORES:-"training sharing the 2 cores"}
SOURCE=${SOURCE:-"experiments/2026-11-29_lexicon_v4/run.sh; rule: experiments/2026-11-29_lexicon_v4/criteria.md"}
M=${M:-$(git rev-parse --show-toplevel)}
cd $M
n=${SET#heldout}
for version in $VERSIONS; do
  name=${version%%=*}; commit=${version#*=}; commit="${commit%%:*} (lexicon ${commit#*:})"
  PYTHONPATH=$M/src $M/.venv/bin/python benchmarks/dyntac_wordings.py --wording $SET --name dyntac_${SET}_${name}_val \
    $(for s in 0 1 2; do echo --seed $s=runs/words/dyn/bench_direct/seed$s/scored/val.jsonl:runs/words/dyn/h${n}_$name/seed$s/scored/val.jsonl; done) \
    --machine "2-core AMD EPYC with AVX512_BF16 (the quickstart's 3 seeds, runs/qs_stepwise, trained 2026-11-29)" \
    --notes "$SET answered auto at commit $commit (tacreasoner evaluate --bench <paraphrase-bench --wording $SET of the quickstart bench> --split val --dtype float32 --answers auto, $CORES); benchmark wordings answered direct (= auto on them); $SOURCE"
done
