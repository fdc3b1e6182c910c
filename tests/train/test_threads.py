"""free_threads: cores left by *other* processes, never the caller's own load (which once cost a 1.35x slowdown)."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from tacreasoner.train import threads


def test_a_busy_other_process_is_counted() -> None:
    spinner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.5)
        assert threads.busy_cores_elsewhere(window=0.5) > 0.5
    finally:
        spinner.kill()
        spinner.wait()


def test_this_process_own_cpu_time_is_subtracted(monkeypatch: pytest.MonkeyPatch) -> None:
    # the whole machine ran 1.5 cores for 0.25 s; 0.25 of the 0.375 CPU seconds were this process's
    system = iter([100.0, 100.375])
    own = iter([10.0, 10.25])
    wall = iter([0.0, 0.25])
    monkeypatch.setattr(threads, "_busy_seconds", lambda: next(system))
    monkeypatch.setattr(threads.time, "process_time", lambda: next(own))
    monkeypatch.setattr(threads.time, "perf_counter", lambda: next(wall))
    monkeypatch.setattr(threads.time, "sleep", lambda _s: None)
    assert threads.busy_cores_elsewhere() == pytest.approx(0.5)


@pytest.mark.parametrize(("elsewhere", "cores", "expected"), [(0.0, 2, 2), (0.2, 2, 2), (0.9, 2, 1), (1.8, 2, 1),
                                                                (3.0, 2, 1), (1.0, 8, 7)])
def test_free_threads_leaves_the_busy_cores(monkeypatch: pytest.MonkeyPatch, elsewhere: float, cores: int,
                                            expected: int) -> None:
    monkeypatch.setattr(threads, "busy_cores_elsewhere", lambda: elsewhere)
    monkeypatch.setattr(threads, "available_cores", lambda: cores)
    assert threads.free_threads() == expected


def test_omp_num_threads_caps_the_cores(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    assert threads.available_cores() == 1
    monkeypatch.setenv("OMP_NUM_THREADS", "not a number")
    assert threads.available_cores() >= 1


def test_without_proc_stat_the_load_average_is_used(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(threads, "_STAT", "/nonexistent/stat")
    monkeypatch.setattr(threads.os, "getloadavg", lambda: (1.25, 0.0, 0.0))
    assert threads.busy_cores_elsewhere() == 1.25


def test_training_threads_follow_the_config_then_share_the_cores_between_local_processes(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(threads, "available_cores", lambda: 16)
    monkeypatch.setattr(threads, "busy_cores_elsewhere", lambda: 13.0)  # a load that varies from start to start
    assert threads.training_threads(3, local_processes=8) == 3
    assert threads.training_threads(None, local_processes=8) == 2  # the same in every process, whatever the load
    assert threads.training_threads(None, local_processes=32) == 1
    assert threads.training_threads(None) == 3  # alone: the cores others leave free
