"""The progress display: whole plain lines when stderr is not a terminal (a log, CI), a live bar on one."""

from __future__ import annotations

import io
import sys

import pytest

from tacreasoner.progress import ProgressBar, StageProgress


def test_without_a_terminal_each_stage_prints_whole_lines_at_start_periodically_and_at_the_end() -> None:
    out = io.StringIO()
    with ProgressBar(stream=out, every_s=0.0) as bar:
        bar.stage("stage 1 training", 4, unit="steps")
        for step in range(1, 5):
            bar.update(step, f"loss {1 / step:.2f}")
        bar.stage("evaluating", 2, unit="items")
        bar.update(1)
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("stage 1 training: 0/4 steps (0%)") and lines[0].endswith("started")
    assert any(line.startswith("stage 1 training: 2/4 steps (50%)") and "loss 0.50" in line and "ETA" in line
               for line in lines)
    assert "stage 1 training: 4/4 steps (100%)" in lines[-4] and lines[-4].endswith("done")
    assert lines[-1].startswith("evaluating: 1/2 items (50%)") and lines[-1].endswith("stopped")
    assert "\r" not in out.getvalue() and "\x1b" not in out.getvalue()  # no redraws, no colour codes


def test_plain_lines_are_spaced_in_time_and_a_disabled_bar_prints_nothing() -> None:
    out = io.StringIO()
    bar = ProgressBar(stream=out, every_s=3600.0)
    bar.stage("simulating", 1000, unit="clips")
    for done in range(1, 1000):
        bar.update(done)
    bar.close()
    assert len(out.getvalue().splitlines()) == 2  # started, stopped: nothing in between within the hour
    quiet = io.StringIO()
    off = ProgressBar(False, stream=quiet)
    off.stage("x", 3)
    off.update(2)
    off.close()
    assert quiet.getvalue() == ""


def test_on_a_terminal_it_is_a_live_bar() -> None:
    out = io.StringIO()
    with ProgressBar(stream=out, live=True) as bar:
        bar.stage("stage 2 training", 3, unit="steps")
        bar.update(3, "loss 0.1")
    assert "stage 2 training" in out.getvalue() and "3/3" in out.getvalue()


def test_a_finished_stage_says_done_at_once_not_when_the_next_one_starts(capsys: pytest.CaptureFixture[str]) -> None:
    # piped quickstart logs printed an evaluation's "done" line after the next stage's output
    with StageProgress() as bars:
        bars("test, seed 0", 0, 2)
        bars("test, seed 0", 2, 2)
        print("next stage", file=sys.stderr)
    lines = capsys.readouterr().err.splitlines()
    done = [i for i, line in enumerate(lines) if line.startswith("test, seed 0: 2/2") and line.endswith("done")]
    assert len(done) == 1 and done[0] < lines.index("next stage")
    assert sum(line.endswith(("done", "stopped")) for line in lines) == 1
