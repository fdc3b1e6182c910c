#!/usr/bin/env bash
# TouchCoT on the SHIPPED recipe on the CPU (max_length 512: no example left out; answered with up to 512 new tokens:
# the longest reasoning is ~420). Training code pinned like the other ablations (worktree ., d121e72);
# the chain script is benchmarks/dyntac_cpu.sh as of this session (copied here: cot at max_length 512, scored at 512, TR_EVAL).
cd .
export PYTHONPATH=src
export Q=runs/quickstart OUT=runs/dyntac_shipped EXTRA="--set runtime.threads=2"
export TR=".venv/bin/python -m tacreasoner"
# answering by this checkout (editable install, no PYTHONPATH): records the replies the budget cut; the
# answers are those of the pinned code (evaluation unchanged since d121e72 apart from that record)
export TR_EVAL="env -u PYTHONPATH .venv/bin/python -m tacreasoner"
export JOBS="${JOBS:-cot:0 cot:1 cot:2}"
exec bash runs/dyntac_shipped/dyntac_cpu_cot.sh  # = benchmarks/dyntac_cpu.sh of the commit that adds TR_EVAL
