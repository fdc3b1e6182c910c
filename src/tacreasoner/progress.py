"""The one progress display of long jobs (simulation, preprocessing, TouchCoT, training, evaluation).

On a terminal it is a rich live bar on stderr. Written to a file or a CI log, a live bar leaves truncated redraws
("st…", "ETA 0:0…"), so without a terminal it prints a whole plain line instead: when a stage starts, every
``every_s`` seconds, and when it ends.
"""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import IO, Any

__all__ = ["ClipProgress", "ProgressBar", "StageProgress"]


class ProgressBar:
    """Progress of one stage at a time (``stage`` starts the next); a no-op when not ``enabled``.

    ``unit`` names what is counted ("clips", "steps"); ``info`` (per update) is shown after the count, e.g. the loss.
    ``live``: force the rich bar (True) or plain lines (False); default: the bar only when stderr is a terminal.
    """

    def __init__(self, enabled: bool = True, *, live: bool | None = None, every_s: float = 30.0,
                 stream: IO[str] | None = None) -> None:
        self.enabled = enabled
        self.stream = stream or sys.stderr
        self.live = (self.stream.isatty() if live is None else live) if enabled else False
        self.every_s = every_s
        self._progress: Any = None
        self._task: Any = None
        self._label, self._unit, self._total = "", "", 0
        self._started = self._printed = 0.0
        self._first, self._done, self._info = 0, 0, ""

    def stage(self, label: str, total: int, done: int = 0, unit: str = "") -> None:
        """Start showing a new stage (the previous one ends)."""
        if not self.enabled:
            return
        self._finish_plain()
        self._label, self._unit, self._total = label, unit, total
        self._started = self._printed = time.perf_counter()
        self._first = self._done = done
        self._info = ""
        if self.live:
            if self._progress is None:
                self._progress = _rich_progress(self.stream)
                self._progress.start()
            elif self._task is not None:
                self._progress.stop_task(self._task)
            self._task = self._progress.add_task(label, total=total, completed=done, unit=unit, info="")
        else:
            self._line("started")

    def update(self, done: int, info: str = "") -> None:
        if not self.enabled or not self._label:
            return
        self._done, self._info = done, info
        if self.live:
            self._progress.update(self._task, completed=done, info=info)
        elif time.perf_counter() - self._printed >= self.every_s:
            self._line()

    def close(self) -> None:
        if not self.enabled:
            return
        self._finish_plain()
        if self._progress is not None:
            self._progress.stop()
            self._progress = None

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ plain lines
    def _finish_plain(self) -> None:
        if not self.live and self._label:
            self._line("done" if self._done >= self._total else "stopped")
            self._label = ""

    def _line(self, state: str = "") -> None:
        now = time.perf_counter()
        self._printed = now
        elapsed = now - self._started
        share = f" ({self._done / self._total:.0%})" if self._total else ""
        parts = [f"{self._label}: {self._done}/{self._total}{' ' + self._unit if self._unit else ''}{share}"]
        rate = (self._done - self._first) / elapsed if elapsed > 0 else 0.0
        if rate > 0:
            parts.append(f"{rate:.2f} {self._unit or 'items'}/s")
        parts.append(f"elapsed {_clock(elapsed)}")
        if rate > 0 and self._done < self._total:
            parts.append(f"ETA {_clock((self._total - self._done) / rate)}")
        if self._info:
            parts.append(self._info)
        if state:
            parts.append(state)
        print("  ".join(parts), file=self.stream, flush=True)



class ClipProgress:
    """A progress display fed by a ``progress(done, total)`` callback (``generate_dataset``'s and others alike).

    It starts on the first report, so a run that fails its argument checks prints nothing, and work already on
    disk (resume) counts as done without inflating the rate.
    """

    def __init__(self, label: str = "simulating", unit: str = "clips") -> None:
        self._label = label
        self._unit = unit
        self._bar = ProgressBar()
        self._started = False

    def __call__(self, done: int, total: int) -> None:
        if not self._started:
            self._bar.stage(self._label, total, done, unit=self._unit)
            self._started = True
        else:
            self._bar.update(done)

    def __enter__(self) -> ClipProgress:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        self._bar.close()


class StageProgress:
    """One progress display per named stage, called as ``(stage, done, total)`` (prepare: clips, else samples)."""

    def __init__(self) -> None:
        self._bars: dict[str, ClipProgress] = {}

    def __call__(self, stage: str, done: int, total: int) -> None:
        if stage not in self._bars:
            for bar in self._bars.values():
                bar.close()
            self._bars[stage] = ClipProgress(stage, "clips" if stage == "prepare" else "samples")
        self._bars[stage](done, total)
        if total and done >= total:  # say "done" now, not when the next stage (or the whole command) ends
            self._bars.pop(stage).close()

    def close(self) -> None:
        for bar in self._bars.values():
            bar.close()

    def __enter__(self) -> StageProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _clock(seconds: float) -> str:
    seconds = int(seconds)
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


def _rich_progress(stream: IO[str]) -> Any:
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    return Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TextColumn("{task.fields[unit]}"), TextColumn("{task.fields[info]}"), TimeElapsedColumn(),
                    TextColumn("ETA"), TimeRemainingColumn(), console=Console(file=stream))
