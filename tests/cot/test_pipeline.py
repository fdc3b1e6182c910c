"""Generation reliability over real HTTP: faults, failed jobs retried, kill -9 and resume, partial lines."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tacreasoner.cot.backends import TeacherConfig, make_teacher
from tacreasoner.cot.filter import filter_samples
from tacreasoner.cot.pipeline import SAMPLES, generate, load_samples
from tacreasoner.cot.prompts import build_prompt
from tacreasoner.cot.schema import CoTJob
from tests.cot.fake_openai_server import FakeOpenAIServer
from tests.cot.touchcot_bench import prepared

MARKER = "The correct answer is:"


@pytest.fixture(scope="module")
def bench_and_jobs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[CoTJob]]:
    bench, jobs, _ = prepared(small_sim_dataset, tmp_path_factory.mktemp("pipeline"))
    for job in jobs:
        job.compute_key("touchcot-v1", "openai:fake")
    return bench, jobs


def _teacher(server: FakeOpenAIServer, **overrides):
    os.environ["FAKE_OPENAI_KEY"] = "sk-test"
    cfg = TeacherConfig(backend="openai", model="fake", base_url=server.base_url, api_key_env="FAKE_OPENAI_KEY",
                        concurrency=4, timeout_s=0.5, max_retries=3, backoff_base_s=0.01, backoff_max_s=0.05,
                        **overrides)
    return make_teacher(cfg)


def test_faults_are_retried_and_bad_answers_are_filtered(bench_and_jobs, tmp_path: Path) -> None:
    _, all_jobs = bench_and_jobs
    jobs = all_jobs[:12]
    with FakeOpenAIServer(answer_marker=MARKER, slow_s=1.0) as server:
        server.script(["429", "500", "slow", "malformed", "503", "wrong"])
        result = generate(jobs, _teacher(server), lambda j: build_prompt(j), tmp_path, concurrency=4)
    assert result.generated == 12 and result.failed == 0
    samples, _ = load_samples(tmp_path / SAMPLES)
    assert sorted(s.key for s in samples) == sorted(j.key for j in jobs)
    filtered = filter_samples(samples)
    wrong = [s for s in filtered.samples if "wrong_answer" in s.reject_reasons]
    assert len(wrong) == 1
    assert sum(s.usage["attempts"] for s in samples) >= 12 + 5  # five faults cost one extra attempt each


def test_failed_jobs_are_recorded_and_retried_next_run(bench_and_jobs, tmp_path: Path) -> None:
    _, all_jobs = bench_and_jobs
    jobs = all_jobs[:6]
    doomed = build_prompt(jobs[2]).user
    with FakeOpenAIServer(answer_marker=MARKER) as server:
        server.script_for(doomed, ["500"] * 4)  # max_retries=3 → 4 attempts, all fail
        first = generate(jobs, _teacher(server), lambda j: build_prompt(j), tmp_path)
        assert first.failed == 1 and first.generated == 5
        assert (tmp_path / "failures.jsonl").read_text().count(jobs[2].key) == 1
        calls_before = {j.key: server.per_prompt[build_prompt(j).user] for j in jobs}
        second = generate(jobs, _teacher(server), lambda j: build_prompt(j), tmp_path)
        assert second.generated == 1 and second.already_done == 5
        for job in jobs:
            expected = calls_before[job.key] + (1 if job.key == jobs[2].key else 0)
            assert server.per_prompt[build_prompt(job).user] == expected  # no paid call repeated
    assert len(load_samples(tmp_path / SAMPLES)[0]) == 6


_WORKER = """
import sys
from pathlib import Path
from tacreasoner.cot.backends import TeacherConfig, make_teacher
from tacreasoner.cot.pipeline import generate
from tacreasoner.cot.prepare import prepare_jobs
from tacreasoner.cot.prompts import build_prompt

bench, cues, out, url, n = sys.argv[1:6]
jobs = prepare_jobs(bench, "train", cache_dir=cues)[: int(n)]
for job in jobs:
    job.compute_key("touchcot-v1", "openai:fake")
cfg = TeacherConfig(backend="openai", model="fake", base_url=url, api_key_env="FAKE_OPENAI_KEY", concurrency=2,
                    timeout_s=5, max_retries=2, backoff_base_s=0.01, backoff_max_s=0.05)
generate(jobs, make_teacher(cfg), lambda j: build_prompt(j), out, concurrency=2)
"""


def test_kill_minus_nine_then_resume_loses_and_repeats_nothing(bench_and_jobs, small_sim_dataset: Path,
                                                               tmp_path: Path) -> None:
    bench, all_jobs = bench_and_jobs
    n = 30
    jobs = all_jobs[:n]
    cues = tmp_path.parent / "cues-for-kill"
    script = tmp_path / "worker.py"
    script.write_text(_WORKER)
    out = tmp_path / "out"
    env = {**os.environ, "FAKE_OPENAI_KEY": "sk-test"}
    with FakeOpenAIServer(answer_marker=MARKER, hold_s=0.15) as server:
        # Warm the cue cache so the worker reaches the generation loop quickly.
        subprocess.run([sys.executable, str(script), str(bench), str(cues), str(out), server.base_url, "0"],
                       env=env, check=True, timeout=120)
        proc = subprocess.Popen([sys.executable, str(script), str(bench), str(cues), str(out), server.base_url,
                                 str(n)], env=env)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            path = out / SAMPLES
            if path.exists() and path.read_text().count("\n") >= 8:
                break
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        done_before = [s.key for s in load_samples(out / SAMPLES, repair=True)[0]]
        assert 8 <= len(done_before) < n
        prompts = {j.key: build_prompt(j).user for j in jobs}
        result = generate(jobs, _teacher(server), lambda j: build_prompt(j), out)
        assert result.already_done == len(done_before)
        for key in done_before:
            assert server.per_prompt[prompts[key]] == 1  # finished before the kill: never sent again
    keys = [s.key for s in load_samples(out / SAMPLES)[0]]
    assert len(keys) == len(set(keys)) == n  # nothing lost, nothing duplicated


def test_partial_last_line_is_dropped_and_redone(bench_and_jobs, tmp_path: Path) -> None:
    _, all_jobs = bench_and_jobs
    jobs = all_jobs[:3]
    teacher = make_teacher(TeacherConfig(backend="rules", model="rules-v1"))
    generate(jobs[:2], teacher, lambda j: build_prompt(j), tmp_path)
    path = tmp_path / SAMPLES
    with path.open("a") as fh:  # what a kill in the middle of a write leaves behind
        fh.write(json.dumps({"key": jobs[2].key})[:15])
    result = generate(jobs, teacher, lambda j: build_prompt(j), tmp_path)
    assert result.dropped_partial_line and result.generated == 1
    assert [s.key for s in load_samples(path)[0]] == [j.key for j in jobs]


def test_corrupt_line_in_the_middle_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / SAMPLES
    path.write_text('{"broken": \n{"also": "broken"}\n')
    with pytest.raises(ValueError, match=":1: corrupt sample line"):
        load_samples(path)
