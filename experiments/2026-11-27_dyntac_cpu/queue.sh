#!/bin/bash
# This session's CPU queue (code at 39ac1c8 in .): after rec seed 1 (runs/pair1/chain.sh) is scored.
cd .
until [ -f runs/pair1/eval_val_packed/report.json ]; do sleep 10; done
pkill -f runs/pair1/chain.sh; sleep 1; pkill -f "output_dir=runs/pair1/padded"; sleep 3
export Q=runs/quickstart OUT=runs/dyntac_cpu TR="env PYTHONPATH=src .venv/bin/tacreasoner"
HELDOUT=1 JOBS="para:0" bash runs/dyntac_cpu/dyntac_cpu.sh
HELDOUT=1 JOBS="rec:1" bash runs/dyntac_cpu/dyntac_cpu.sh
JOBS="no_dyn:0 no_qcond:0 no_dyn:1 no_qcond:1" bash runs/dyntac_cpu/dyntac_cpu.sh
echo QUEUE DONE
