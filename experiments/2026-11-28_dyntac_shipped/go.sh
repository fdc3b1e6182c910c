#!/usr/bin/env bash
# The paper's ablations on the SHIPPED recipe (paraphrases + OSC x2), on this CPU, paired with the shipped recipe's
# CPU seeds (runs/dyntac_cpu para_osc.seedS linked as rec.seedS, see README.md). Resumable: run it again to go on.
# Code: a worktree pinned at 7aa9243 (git worktree add --detach . 7aa9243), so edits to the checkout
# do not change runs half-way.
cd "$(git rev-parse --show-toplevel)"
export PYTHONPATH=${PINNED:-.}/src
export Q=${Q:-runs/quickstart} OUT=${OUT:-runs/dyntac_shipped} EXTRA="--set runtime.threads=2"
export TR="${PY:-.venv/bin/python} -m tacreasoner"
export JOBS="${JOBS:-no_stage2:0 no_stage2:1 no_stage2:2 no_dyn:0 no_qcond:0 no_dyn:1 no_qcond:1 no_dyn:2 no_qcond:2 no_stage1:0 no_stage1:1 no_stage1:2 cot:0 cot:1 cot:2}"
exec bash "${PINNED:-.}/benchmarks/dyntac_cpu.sh"
