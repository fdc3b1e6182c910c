#!/bin/bash
# Reordered (20:05): settle the 'para' recipe candidate before the ablations (which must run on the final recipe).
cd .
until [ -f runs/dyntac_cpu/eval/rec.seed1/val_heldout/report.json ]; do sleep 10; done
sleep 5
export Q=runs/quickstart OUT=runs/dyntac_cpu TR="env PYTHONPATH=src .venv/bin/tacreasoner"
HELDOUT=1 JOBS="para:1" bash runs/dyntac_cpu/dyntac_cpu.sh
HELDOUT=1 JOBS="rec:2 para:2" bash runs/dyntac_cpu/dyntac_cpu.sh
echo QUEUE2 DONE
