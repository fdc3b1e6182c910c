#!/usr/bin/env bash
# Seconds to answer the same val items in float32 and in bfloat16 (`tacreasoner evaluate --dtype`), alternated, on a
# quiet machine. Usage: Q=runs/quickstart N=390 ROUNDS=2 bash eval_dtype_time.sh > times.txt
set -eu
Q=${Q:-runs/quickstart}
N=${N:-390}
ROUNDS=${ROUNDS:-2}
TR=${TR:-tacreasoner}
tmp=$(mktemp -d)
for r in $(seq "$ROUNDS"); do
    for dtype in float32 bfloat16; do
        start=$(date +%s.%N)
        $TR evaluate --model "$Q/model" --bench "$Q/bench" --split val --out "$tmp/$dtype.$r" --limit "$N" \
            --batch-size 48 --max-new-tokens 64 --video-cache "$Q/video_cache" --dtype "$dtype" > /dev/null 2>&1
        echo "round $r $dtype $(echo "$(date +%s.%N) - $start" | bc) s for $N val items"
    done
done
rm -rf "$tmp"
