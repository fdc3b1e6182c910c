#!/usr/bin/env bash
# 2026-11-27 session 8: the candidate's (para) seeds on test once (chosen on val by the pre-set rule), then the
# TouchCoT ablation on the template-wording recipe, paired with rec seeds trained here.
set -u
cd .
TR="env PYTHONPATH=src .venv/bin/tacreasoner"
E=runs/dyntac_cpu/eval
Q=runs/quickstart
for s in 0 1 2; do
    [ -e "$E/para.seed$s/test/report.json" ] && continue
    echo "[$(date -u +%H:%M:%S)] para seed $s: answering test"
    $TR evaluate --model runs/dyntac_cpu/runs/para.seed$s/stage2/model --bench $Q/bench --split test \
        --out $E/para.seed$s/test --batch-size 48 --max-new-tokens 64 --video-cache $Q/video_cache \
        > runs/dyntac_cpu/logs/para.seed$s.test.log 2>&1 || { echo FAILED; exit 1; }
done
echo "[$(date -u +%H:%M:%S)] test scored"
PATH=.venv/bin:$PATH TR="$TR" Q=$Q OUT=runs/dyntac_cpu JOBS="cot:0 cot:1 cot:2" \
    EXTRA="--set data.paraphrases=false --set runtime.threads=2" bash benchmarks/dyntac_cpu.sh
