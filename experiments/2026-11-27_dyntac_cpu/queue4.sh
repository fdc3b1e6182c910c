#!/usr/bin/env bash
# 2026-11-27 session 8: the OSC candidate (para with OSC's examples twice), 3 seeds, val and held-out val, paired with
# para's seeds; code frozen in a worktree at the commit that adds this file.
cd . && PATH=.venv/bin:$PATH TR="env PYTHONPATH=src .venv/bin/tacreasoner" \
    Q=runs/quickstart OUT=runs/dyntac_cpu HELDOUT=1 JOBS="para_osc:0 para_osc:1 para_osc:2" \
    EXTRA="--set runtime.threads=2" bash benchmarks/dyntac_cpu.sh
