#!/bin/bash
# Publish one held-out set's DynTAC-Sim results (after run.sh) from the main checkout, with the earlier experiment's
# publish.sh and this experiment's notes:
#   SET=heldout9 VERSIONS="auto=a3fb3e1:v6" bash publish.sh
#   SET=heldout10 VERSIONS="auto=7df5a1a:v7" bash publish.sh
#   SET=heldout11 VERSIONS="auto=2509f09:v7" bash publish.sh
#   SET=heldout12 VERSIONS="auto=cc08bca:v8" bash publish.sh
set -e
CORES="alone on the 2 cores" SOURCE="experiments/2026-11-29_lexicon_v6_again: criteria.md, run.sh, decision.md" \
  bash "$(dirname "$0")/../2026-11-29_lexicon_v4/publish.sh"
