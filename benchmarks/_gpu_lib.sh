# Shared by the lent-GPU scripts (dyntac_gpu.sh, physiclear_gpu.sh): source it after setting W (the work folder).
# Each step logs to $W/logs/NAME.log, is skipped when its DONE_FILE exists (so a rerun resumes), records its wall
# time in $W/times.tsv and leaves $W/logs/NAME.failed when it fails.

say() { echo "[$(date +%H:%M:%S)] $*"; }

step() {  # step NAME DONE_FILE COMMAND...: run unless DONE_FILE exists; log its wall time
    local name=$1 done=$2 start
    shift 2
    [ -e "$done" ] && return 0
    mkdir -p "$W/logs"
    start=$(date +%s)
    "$@" > "$W/logs/$name.log" 2>&1 || { say "$name FAILED (see $W/logs/$name.log)"; touch "$W/logs/$name.failed"; return 1; }
    printf '%s\t%s\n' "$name" "$(( $(date +%s) - start ))" >> "$W/times.tsv"
    say "$name: $(( $(date +%s) - start )) s"
}

wait_for_jobs_until() {  # wait_for_jobs_until EPOCH_SECONDS: wait while background jobs run, at most until then;
    # returns 1 when some are still running at the deadline (the caller stops them its own way)
    while [ "$(date +%s)" -lt "$1" ] && [ -n "$(jobs -r)" ]; do sleep 3; done
    [ -z "$(jobs -r)" ]
}
