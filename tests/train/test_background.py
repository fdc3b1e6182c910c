"""BackgroundJob: a child process with its output in a log, waited for with progress, stopped without orphans."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tacreasoner.train.background import BackgroundJob, BackgroundJobError


def python(code: str) -> list[str]:
    return [sys.executable, "-c", code]


def gone(pid: int) -> bool:
    """The process has ended (a zombie nobody reaps counts as ended)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    status = Path(f"/proc/{pid}/status")
    return status.is_file() and "State:\tZ" in status.read_text()


def wait_for(condition, seconds: float = 10.0) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return condition()


def test_wait_reports_progress_and_the_log_holds_stdout_stderr_and_env(tmp_path: Path) -> None:
    log = tmp_path / "logs" / "job.log"
    job = BackgroundJob("demo", python("import os, sys, time; print('out', os.environ['DEMO_VAR']); "
                                       "time.sleep(0.3); print('err', file=sys.stderr)"), log, env={"DEMO_VAR": "42"})
    calls: list[int] = []
    job.wait(lambda: calls.append(1), interval=0.05)
    assert job.process.returncode == 0
    assert len(calls) >= 3  # at the start, while it ran, at the end
    assert log.read_text().splitlines() == ["out 42", "err"]


def test_a_failing_command_raises_with_the_log_name_and_its_last_lines(tmp_path: Path) -> None:
    log = tmp_path / "job.log"
    job = BackgroundJob("demo", python("import sys\nfor i in range(30): print('line', i)\nsys.exit(3)"), log)
    with pytest.raises(BackgroundJobError) as info:
        job.wait()
    message = str(info.value)
    assert "demo failed (exit code 3)" in message and str(log) in message
    assert "line 29" in message and "line 15" in message and "line 14" not in message
    assert isinstance(info.value, OSError)  # the CLI's cli_errors turns it into one error line


def test_stop_terminates_a_running_child_and_is_idempotent(tmp_path: Path) -> None:
    job = BackgroundJob("sleeper", python("import time; time.sleep(60)"), tmp_path / "job.log")
    job.stop()
    assert job.process.returncode == -signal.SIGTERM and gone(job.process.pid)
    job.stop()


def test_stop_kills_a_child_that_ignores_sigterm(tmp_path: Path) -> None:
    log = tmp_path / "job.log"
    job = BackgroundJob("stubborn", python("import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
                                           "print('ready', flush=True); time.sleep(60)"), log)
    assert wait_for(lambda: "ready" in log.read_text())
    start = time.monotonic()
    job.stop(grace=0.3)
    assert job.process.returncode == -signal.SIGKILL and gone(job.process.pid)
    assert time.monotonic() - start < 5


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux only")
def test_the_child_dies_with_a_parent_killed_outright(tmp_path: Path) -> None:
    parent = ("import os, signal, sys; from pathlib import Path; "
              "from tacreasoner.train.background import BackgroundJob; "
              f"job = BackgroundJob('sleeper', [sys.executable, '-c', 'import time; time.sleep(60)'], "
              f"Path({str(tmp_path / 'job.log')!r})); print(job.process.pid, flush=True); "
              "os.kill(os.getpid(), signal.SIGKILL)")
    result = subprocess.run(python(parent), capture_output=True, text=True, timeout=30)
    assert result.returncode == -signal.SIGKILL, result.stderr
    assert wait_for(lambda: gone(int(result.stdout)))
