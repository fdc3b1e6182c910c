"""The OpenAI-compatible teacher over real HTTP, against a local fake server with scripted faults."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Iterator

import pytest

from tacreasoner.cot.backends import Teacher, TeacherConfig, TeacherError, reply_to_output
from tacreasoner.cot.openai_backend import OpenAITeacher
from tacreasoner.cot.schema import CoTJob, Prompt, VideoCues
from tacreasoner.tasks.schema import QAItem, VideoRef
from tests.cot.fake_openai_server import FakeOpenAIServer

KEY_ENV = "TACREASONER_TEST_KEY"


@pytest.fixture
def fake() -> Iterator[FakeOpenAIServer]:
    with FakeOpenAIServer() as server:
        yield server


@pytest.fixture(autouse=True)
def _key(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(KEY_ENV, "sk-test")


def teacher_for(server: FakeOpenAIServer, **overrides) -> OpenAITeacher:
    settings = {"backend": "openai", "model": "deepseek-chat", "base_url": server.base_url, "api_key_env": KEY_ENV,
                "timeout_s": 5.0, "max_retries": 3, "backoff_base_s": 0.01, "backoff_max_s": 0.05,
                **overrides}
    return OpenAITeacher(TeacherConfig.from_dict(settings))


def job_and_prompt(n: int = 0, gold: str = "soft") -> tuple[CoTJob, Prompt]:
    item = QAItem(id=f"item-{n}", task="TFA-hardness", question="How hard is the object in <tactile>?",
                  answer=gold, gold={"attribute": "hardness", "level": 0}, videos=[VideoRef(clip_id=f"clip-{n}")],
                  objects=["sponge"])
    cues = VideoCues(clip_id=f"clip-{n}", phases={"press": [0, 10]}, phase_source="ground_truth", cues={})
    job = CoTJob(item=item, stages=["press", "hold", "release"], videos=[cues])
    prompt = Prompt(system="You explain tactile readings.", user=f"[item-{n}] {item.question}\nGold answer: {gold}",
                    version="touchcot-test", task=item.task)
    return job, prompt


def generate(teacher: OpenAITeacher, n: int = 0, gold: str = "soft"):
    return asyncio.run(teacher.generate(*job_and_prompt(n, gold)))


def test_is_a_teacher(fake: FakeOpenAIServer) -> None:
    teacher = teacher_for(fake)
    assert isinstance(teacher, Teacher)
    assert (teacher.name, teacher.model) == ("openai", "deepseek-chat")


def test_success_echoes_gold_and_counts_usage(fake: FakeOpenAIServer) -> None:
    teacher = teacher_for(fake, price_per_1k_prompt=1.0, price_per_1k_completion=2.0)
    reply = generate(teacher, gold="moderately deformable")
    assert reply_to_output(reply)[1] == "moderately deformable"
    assert reply.attempts == 1 and reply.model == "deepseek-chat"
    assert reply.prompt_tokens > 0 and reply.completion_tokens > 0
    assert reply.cost_usd == pytest.approx((reply.prompt_tokens * 1.0 + reply.completion_tokens * 2.0) / 1000)
    body = fake.requests[0]["body"]
    assert [m["role"] for m in body["messages"]] == ["system", "user"]
    assert body["model"] == "deepseek-chat" and body["max_tokens"] == 1024
    assert fake.requests[0]["headers"]["authorization"] == "Bearer sk-test"
    summary = teacher.usage.summary()
    assert summary["requests"] == 1 and summary["by_status"] == {"ok": 1}
    assert summary["cost_usd"] == pytest.approx(reply.cost_usd)


def test_extra_goes_into_the_request_body(fake: FakeOpenAIServer) -> None:
    generate(teacher_for(fake, extra={"top_p": 0.5, "seed": 7}))
    body = fake.requests[0]["body"]
    assert body["top_p"] == 0.5 and body["seed"] == 7


def test_429_then_success_honours_retry_after(fake: FakeOpenAIServer) -> None:
    fake.retry_after = "0.3"
    fake.script(["429", "ok"])
    teacher = teacher_for(fake, backoff_base_s=0.001, backoff_max_s=1.0)
    start = time.perf_counter()
    reply = generate(teacher)
    waited = fake.requests[1]["time"] - fake.requests[0]["time"]
    assert reply.attempts == 2 and fake.calls("item-0") == 2
    assert 0.28 <= waited < 1.0, waited
    assert time.perf_counter() - start < 2.0
    assert teacher.usage.summary()["by_status"] == {"429": 1, "ok": 1}
    assert teacher.usage.summary()["retries"] == 1


def test_retry_after_is_capped(fake: FakeOpenAIServer) -> None:
    fake.retry_after = "30"
    fake.script(["429", "ok"])
    start = time.perf_counter()
    reply = generate(teacher_for(fake, backoff_max_s=0.1))
    assert reply.attempts == 2
    assert time.perf_counter() - start < 1.5


def test_server_errors_then_success(fake: FakeOpenAIServer) -> None:
    fake.script_for("item-0", ["500", "500", "ok"])
    reply = generate(teacher_for(fake))
    assert reply.attempts == 3 and fake.calls("item-0") == 3


def test_502_and_503_are_retried(fake: FakeOpenAIServer) -> None:
    fake.script(["502", "503", "ok"])
    assert generate(teacher_for(fake)).attempts == 3


def test_timeout_then_success(fake: FakeOpenAIServer) -> None:
    fake.slow_s = 1.0
    fake.script(["slow", "ok"])
    teacher = teacher_for(fake, timeout_s=0.3)
    start = time.perf_counter()
    reply = generate(teacher)
    assert reply.attempts == 2 and fake.calls("item-0") == 2
    assert time.perf_counter() - start < 0.9
    assert teacher.usage.summary()["by_status"] == {"ok": 1, "timeout": 1}


@pytest.mark.parametrize("fault", ["malformed", "no_choices", "html"])
def test_malformed_reply_then_success(fake: FakeOpenAIServer, fault: str) -> None:
    fake.script([fault, "ok"])
    teacher = teacher_for(fake)
    reply = generate(teacher)
    assert reply.attempts == 2 and reply_to_output(reply) is not None
    assert teacher.usage.summary()["by_status"] == {"malformed": 1, "ok": 1}


def test_connection_refused_is_retried_then_fails(fake: FakeOpenAIServer) -> None:
    teacher = teacher_for(fake, max_retries=1)
    fake.stop()
    with pytest.raises(TeacherError, match="gave up after 2 attempts"):
        generate(teacher)
    assert teacher.usage.summary()["by_status"] == {"connection": 2}


def test_401_is_not_retried_and_names_the_key(fake: FakeOpenAIServer) -> None:
    fake.script(["401", "ok"])
    teacher = teacher_for(fake)
    with pytest.raises(TeacherError) as excinfo:
        generate(teacher)
    message = str(excinfo.value)
    assert "\n" not in message and "401" in message and KEY_ENV in message
    assert excinfo.value.fatal and excinfo.value.status == 401
    assert fake.calls("item-0") == 1
    # a bad key fails every later job too: no more requests are sent
    with pytest.raises(TeacherError, match="401"):
        generate(teacher, n=1)
    assert len(fake.requests) == 1
    summary = teacher.usage.summary()
    assert summary["failures"] == 2 and summary["requests"] == 1


def test_wrong_key_rejected_by_server(fake: FakeOpenAIServer) -> None:
    fake.expected_key = "sk-real"
    with pytest.raises(TeacherError, match=KEY_ENV):
        generate(teacher_for(fake))


@pytest.mark.parametrize("status", ["400", "403", "404"])
def test_client_errors_are_not_retried(fake: FakeOpenAIServer, status: str) -> None:
    fake.script([status, "ok"])
    with pytest.raises(TeacherError) as excinfo:
        generate(teacher_for(fake))
    assert str(excinfo.value).count(status) >= 1 and excinfo.value.attempts == 1
    assert excinfo.value.fatal == (status != "400")
    assert fake.calls("item-0") == 1


def test_retries_exhausted(fake: FakeOpenAIServer) -> None:
    fake.script_for("item-0", ["500"] * 10)
    teacher = teacher_for(fake, max_retries=2)
    with pytest.raises(TeacherError) as excinfo:
        generate(teacher)
    assert "gave up after 3 attempts" in str(excinfo.value) and "500" in str(excinfo.value)
    assert excinfo.value.attempts == 3 and fake.calls("item-0") == 3
    summary = teacher.usage.summary()
    assert summary["failures"] == 1 and summary["retries"] == 2 and summary["by_status"] == {"5xx": 3}


def test_concurrency_is_bounded(fake: FakeOpenAIServer) -> None:
    fake.hold_s = 0.05
    fake.script_for("item-3]", ["503"])  # a retry must not break the bound either
    teacher = teacher_for(fake, concurrency=4)

    async def run_all():
        return await asyncio.gather(*(teacher.generate(*job_and_prompt(n, gold=f"g{n}")) for n in range(20)))

    replies = asyncio.run(run_all())
    assert [reply_to_output(r)[1] for r in replies] == [f"g{n}" for n in range(20)]
    assert 2 <= fake.max_in_flight <= 4
    assert len(fake.requests) == 21
    summary = teacher.usage.summary()
    assert summary["requests"] == 21 and summary["by_status"] == {"5xx": 1, "ok": 20}
    assert summary["prompt_tokens"] == sum(r.prompt_tokens for r in replies)


def test_reusable_across_event_loops(fake: FakeOpenAIServer) -> None:
    """The pipeline calls ``asyncio.run`` once per ``generate`` run; a teacher must survive several runs."""
    teacher = teacher_for(fake, concurrency=2)
    for n in range(3):
        assert generate(teacher, n=n).attempts == 1
    assert teacher.usage.summary()["requests"] == 3


def test_deepseek_reasoning_content_is_captured(fake: FakeOpenAIServer) -> None:
    fake.script(["reasoning"])
    teacher = teacher_for(fake, model="deepseek-reasoner")
    reply = generate(teacher, gold="the second object")
    assert reply.text == "the second object"
    assert reply.reasoning and "press" in reply.reasoning
    think, answer = reply_to_output(reply)
    assert answer == "the second object" and think == reply.reasoning


def test_missing_key_is_a_one_line_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(KEY_ENV)
    with pytest.raises(ValueError) as excinfo:
        OpenAITeacher(TeacherConfig(backend="openai", model="m", api_key_env=KEY_ENV))
    assert KEY_ENV in str(excinfo.value) and "\n" not in str(excinfo.value)


def test_reserved_extra_keys_are_rejected() -> None:
    with pytest.raises(ValueError, match="messages"):
        OpenAITeacher(TeacherConfig(backend="openai", model="m", api_key_env=KEY_ENV, extra={"messages": []}))


def test_backoff_is_full_jitter_and_capped(fake: FakeOpenAIServer) -> None:
    teacher = teacher_for(fake, backoff_base_s=1.0, backoff_max_s=5.0)
    delays = [teacher._backoff(attempt, None) for attempt in range(1, 10) for _ in range(50)]
    assert min(delays) >= 0.0 and max(delays) <= 5.0
    assert max(teacher._backoff(1, None) for _ in range(200)) <= 1.0
    assert teacher._backoff(1, 2.5) == 2.5 and teacher._backoff(1, 99.0) == 5.0
