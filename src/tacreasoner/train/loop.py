"""The step loop every trainer runs (Stage I/II in :mod:`trainer`, the encoder's masked-video pre-training in
:mod:`pretrain_encoder`): steps from where a resumed run left off, one JSONL record per ``log_every`` steps (mean
loss of the window, throughput when the step reports it, elapsed time), the progress bar, checkpoints every
``checkpoint_every`` steps and at the end. What a step computes, and how a checkpoint is written, stay with each
trainer; the bookkeeping around them lives once here."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tacreasoner.progress import ProgressBar
from tacreasoner.train.state import truncate_log

__all__ = ["LoopResult", "StepLoop", "StepStats"]


@dataclass(frozen=True)
class StepStats:
    """What one optimiser step reports: its loss and, for token-level training, how much it read."""

    loss: float
    tokens: int | None = None
    examples: int | None = None


@dataclass(frozen=True)
class LoopResult:
    """``stopped``: the loop ended at ``stop_after`` before ``steps`` (nothing saved at the end)."""

    done: int
    last_loss: float | None
    seconds: float
    stopped: bool = False


@dataclass
class StepLoop:
    """Steps ``start..steps`` of a run. ``log``: the JSONL file the records go to (None: this process writes
    none, as on the non-main processes of a distributed run). ``describe()``: fields of the record read when it is
    written (learning rates); ``extra``: fixed fields added to every record. ``elapsed_before``: training seconds
    of the run before a resume (counted in ``elapsed_s`` and in the result)."""

    steps: int
    start: int = 0
    log_every: int = 10
    checkpoint_every: int = 100
    log: Path | None = None
    bar: ProgressBar | None = None
    describe: Callable[[], dict[str, Any]] = dict
    extra: dict[str, Any] = field(default_factory=dict)
    elapsed_before: float = 0.0

    def run(self, step: Callable[[int], StepStats], *,
            checkpoint: Callable[[int, float, float], None] | None = None,
            on_record: Callable[[dict[str, Any]], None] | None = None,
            stop_after: int | None = None) -> LoopResult:
        """Run ``step(index)`` for each remaining step; ``checkpoint(done, last_loss, elapsed)`` on the cadence
        and after the last step; ``on_record(record)`` after each record is written."""
        if self.log is not None:
            truncate_log(self.log, self.start)
        window: list[StepStats] = []
        window_start = started = time.perf_counter()
        last: float | None = None
        for index in range(self.start, self.steps):
            if stop_after is not None and index >= stop_after:
                return LoopResult(index, last, self._elapsed(started), stopped=True)
            stats = step(index)
            last, done = stats.loss, index + 1
            window.append(stats)
            if done % self.log_every == 0 or done == self.steps:
                record = self._record(done, window, time.perf_counter() - window_start, self._elapsed(started))
                if self.log is not None:
                    with self.log.open("a", encoding="utf-8") as f:
                        f.write(json.dumps(record) + "\n")
                if on_record is not None:
                    on_record(record)
                if self.bar is not None:
                    self.bar.update(done, _bar_text(record))
                window, window_start = [], time.perf_counter()
            if checkpoint is not None and (done % self.checkpoint_every == 0 or done == self.steps):
                checkpoint(done, stats.loss, self._elapsed(started))
        return LoopResult(self.steps, last, self._elapsed(started))

    def _elapsed(self, started: float) -> float:
        return self.elapsed_before + time.perf_counter() - started

    def _record(self, done: int, window: list[StepStats], seconds: float, elapsed: float) -> dict[str, Any]:
        record: dict[str, Any] = {"step": done, "loss": round(sum(s.loss for s in window) / len(window), 5),
                                  **self.describe()}
        if all(s.tokens is not None for s in window):
            record["tokens_per_s"] = round(sum(s.tokens or 0 for s in window) / max(seconds, 1e-9), 1)
        if all(s.examples is not None for s in window):
            record["examples_per_s"] = round(sum(s.examples or 0 for s in window) / max(seconds, 1e-9), 2)
        return {**record, "elapsed_s": round(elapsed, 2), **self.extra}


def _bar_text(record: dict[str, Any]) -> str:
    text = f"loss {record['loss']:.4f}"
    return text + (f"  {record['tokens_per_s']:,.0f} tokens/s" if "tokens_per_s" in record else "")
