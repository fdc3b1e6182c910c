"""How many torch threads a training loop should use: the cores that other processes leave free.

With tiny matrices every op waits for its slowest thread, so 2 threads on 2 cores next to another busy
process trained 4-6x slower than 1 thread (measured while pre-training the tiny LLM and the encoder). But
the load average cannot tell *other* processes from this one: in the quickstart, where simulation and the
rules teacher have just kept both cores busy, it read ~2 and every later stage trained on one thread, 1.35x
slower than on two (Stage II, measured). So the busy cores are sampled now, minus this process's own use.
"""

from __future__ import annotations

import os
import time

__all__ = ["available_cores", "busy_cores_elsewhere", "free_threads", "training_threads"]

_STAT = "/proc/stat"


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS reports it), capped by OMP_NUM_THREADS."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    omp = os.environ.get("OMP_NUM_THREADS", "")
    if omp.isdigit() and int(omp) > 0:
        cores = min(cores, int(omp))
    return max(1, cores)


def _busy_seconds() -> float | None:
    """CPU seconds every process has spent running since boot (``/proc/stat``), or None off Linux."""
    try:
        with open(_STAT, encoding="ascii") as f:
            fields = f.readline().split()
    except OSError:
        return None
    if not fields or fields[0] != "cpu" or len(fields) < 5:
        return None
    ticks = [int(x) for x in fields[1:]]
    idle = ticks[3] + (ticks[4] if len(ticks) > 4 else 0)  # idle + iowait
    busy = sum(ticks[:8]) - idle  # user nice system idle iowait irq softirq steal; guest is inside user
    return busy / os.sysconf("SC_CLK_TCK")


def busy_cores_elsewhere(window: float = 0.25) -> float:
    """Cores kept busy by other processes over the next ``window`` seconds (this process's CPU time subtracted).

    Falls back to the 1-minute load average where ``/proc/stat`` does not exist (it then counts this process too).
    """
    before, own_before, wall_before = _busy_seconds(), time.process_time(), time.perf_counter()
    if before is None:
        try:
            return os.getloadavg()[0]
        except OSError:
            return 0.0
    time.sleep(window)
    after = _busy_seconds()
    elapsed = time.perf_counter() - wall_before
    own = time.process_time() - own_before
    return max(0.0, ((after or before) - before - own) / max(elapsed, 1e-6))


def free_threads() -> int:
    """Threads for a training loop: the available cores minus those other processes keep busy, at least 1."""
    return max(1, int(available_cores() - busy_cores_elsewhere() + 0.5))


def training_threads(configured: int | None, local_processes: int = 1) -> int:
    """``runtime.threads`` when set; with several processes on this machine an equal share of its cores (the same in
    every process, whatever the load when each starts); alone, :func:`free_threads`."""
    if configured is not None:
        return configured
    if local_processes > 1:
        return max(1, available_cores() // local_processes)
    return free_threads()
