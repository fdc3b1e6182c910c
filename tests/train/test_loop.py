"""The step loop both trainers share (tacreasoner.train.loop): its records, checkpoints, resume and early stop."""

from __future__ import annotations

import json
from pathlib import Path

from tacreasoner.train.loop import StepLoop, StepStats


def _records(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_records_average_each_window_and_checkpoints_follow_the_cadence(tmp_path: Path) -> None:
    log, saved = tmp_path / "log.jsonl", []
    loop = StepLoop(7, log_every=3, checkpoint_every=4, log=log, describe=lambda: {"lr": 0.5},
                    extra={"preprocess_s": 1.0})
    result = loop.run(lambda i: StepStats(float(i), tokens=10, examples=2),
                      checkpoint=lambda done, loss, _elapsed: saved.append((done, loss)))
    records = _records(log)
    assert [r["step"] for r in records] == [3, 6, 7]  # every 3 steps, and the last one
    assert [r["loss"] for r in records] == [1.0, 4.0, 6.0]  # the mean of each window, not of the run
    assert all(r["lr"] == 0.5 and r["preprocess_s"] == 1.0 and r["tokens_per_s"] > 0 for r in records)
    assert all(abs(r["tokens_per_s"] - 5 * r["examples_per_s"]) <= 0.01 * r["tokens_per_s"] for r in records)
    assert saved == [(4, 3.0), (7, 6.0)]
    assert (result.done, result.last_loss, result.stopped) == (7, 6.0, False)


def test_throughput_only_where_every_step_reports_it(tmp_path: Path) -> None:
    log = tmp_path / "log.jsonl"
    StepLoop(2, log_every=2, log=log).run(lambda i: StepStats(1.0))
    (record,) = _records(log)
    assert "tokens_per_s" not in record and "examples_per_s" not in record and record["elapsed_s"] >= 0


def test_resume_drops_the_records_after_its_step_and_counts_earlier_seconds(tmp_path: Path) -> None:
    log = tmp_path / "log.jsonl"
    StepLoop(6, log_every=2, log=log).run(lambda i: StepStats(1.0))
    assert [r["step"] for r in _records(log)] == [2, 4, 6]
    ran: list[int] = []
    result = StepLoop(6, start=2, log_every=2, log=log, elapsed_before=100.0).run(
        lambda i: ran.append(i) or StepStats(2.0))
    assert ran == [2, 3, 4, 5]  # only the steps after the checkpoint
    records = _records(log)
    assert [(r["step"], r["loss"]) for r in records] == [(2, 1.0), (4, 2.0), (6, 2.0)]  # redone, not doubled
    assert records[-1]["elapsed_s"] >= 100.0 and result.seconds >= 100.0


def test_stop_after_ends_early_without_the_final_checkpoint(tmp_path: Path) -> None:
    saved: list[int] = []
    result = StepLoop(10, checkpoint_every=100).run(lambda i: StepStats(0.5), stop_after=3,
                                                     checkpoint=lambda done, *_: saved.append(done))
    assert (result.done, result.last_loss, result.stopped) == (3, 0.5, True)
    assert saved == []


def test_a_process_without_a_log_writes_nothing_but_still_checkpoints(tmp_path: Path) -> None:
    saved: list[int] = []
    seen: list[dict] = []
    StepLoop(4, log_every=2, checkpoint_every=2, log=None).run(
        lambda i: StepStats(1.0), checkpoint=lambda done, *_: saved.append(done), on_record=seen.append)
    assert saved == [2, 4] and [r["step"] for r in seen] == [2, 4] and not list(tmp_path.iterdir())
