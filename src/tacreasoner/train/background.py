"""A command that runs in a child process while the foreground goes on, its output in a log file.

Why: on 2 cores torch at 2 threads is only ~1.35x faster than at 1 thread, so ``tacreasoner quickstart``
pre-trains the tiny LLM at one thread in the background while its data stages (simulation, benchmark,
TouchCoT: multi-process numpy work) run, instead of after them: about a minute less wall time.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

__all__ = ["BackgroundJob", "BackgroundJobError"]

TAIL_LINES = 15


class BackgroundJobError(ChildProcessError):
    """The background command failed; the message names its log file and quotes the log's last lines."""


def _die_with_parent() -> Callable[[], None] | None:
    """On Linux, a pre-exec hook so the child gets SIGTERM when its parent dies, even by SIGKILL (no orphans)."""
    if not sys.platform.startswith("linux"):
        return None
    import ctypes

    prctl = ctypes.CDLL(None, use_errno=True).prctl
    parent = os.getpid()

    def hook() -> None:
        prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
        if os.getppid() != parent:  # the parent died before the line above
            os.kill(os.getpid(), signal.SIGTERM)

    return hook


class BackgroundJob:
    """``command`` started now in a child process, stdout and stderr into ``log`` (overwritten).

    :meth:`wait` blocks until it ends (raising :class:`BackgroundJobError` if it failed); :meth:`stop`
    terminates it (then kills it after ``grace`` seconds). Use ``try/finally: job.stop()`` around the
    foreground work so a failure or Ctrl-C there does not leave the child running.
    """

    def __init__(self, name: str, command: Sequence[str], log: Path, env: Mapping[str, str] | None = None) -> None:
        self.name = name
        self.log = log
        log.parent.mkdir(parents=True, exist_ok=True)
        with log.open("wb") as out:
            self.process = subprocess.Popen(list(command), stdin=subprocess.DEVNULL, stdout=out,
                                            stderr=subprocess.STDOUT, env={**os.environ, **(env or {})},
                                            preexec_fn=_die_with_parent())

    def wait(self, progress: Callable[[], None] | None = None, interval: float = 1.0) -> None:
        """Block until the command ends, calling ``progress()`` every ``interval`` seconds and once at the end."""
        while True:
            if progress is not None:
                progress()
            try:
                code = self.process.wait(timeout=interval)
                break
            except subprocess.TimeoutExpired:
                continue
        if progress is not None:
            progress()
        if code != 0:
            tail = "\n".join(self.tail())
            raise BackgroundJobError(f"{self.name} failed (exit code {code}); log {self.log}, last lines:\n{tail}")

    def stop(self, grace: float = 5.0) -> None:
        """Terminate the command if it still runs; kill it if it has not ended ``grace`` seconds later."""
        if self.process.poll() is not None:
            return
        self.process.terminate()
        try:
            self.process.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()

    def tail(self, lines: int = TAIL_LINES) -> list[str]:
        """The log's last ``lines`` lines."""
        try:
            return self.log.read_text(encoding="utf-8", errors="replace").splitlines()[-lines:]
        except OSError:
            return []
