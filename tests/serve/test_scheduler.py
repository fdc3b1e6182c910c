"""The server's scheduler: what waits counts against ``max_pending``, held-back requests included; work jobs run."""

from __future__ import annotations

import asyncio
import threading
from typing import Any

import pytest

from tacreasoner.serve.engine import Reply, Sampling
from tacreasoner.serve.scheduler import Busy, Scheduler
from tacreasoner.serve.stream import Delta


def _reply(text: str = "x") -> Reply:
    return Reply(text=text, reasoning="", content=text, finish_reason="stop", prompt_tokens=1, completion_tokens=1)


class _BlockedEngine:
    """Answers only once ``go`` is set, so requests pile up behind the one running."""

    def __init__(self) -> None:
        self.go = threading.Event()
        self.started = threading.Event()

    def complete_batch(self, prompts: list[Any], samplings: list[Sampling], timeout_s: float | None = None,
                       ) -> list[Reply]:
        self.started.set()
        self.go.wait(10)
        return [_reply() for _ in prompts]

    def stream(self, prepared: Any, sampling: Sampling, **kwargs: Any) -> Any:
        self.go.wait(10)
        yield _reply()


def test_requests_held_back_from_a_batch_count_against_max_pending() -> None:
    async def main() -> list[str]:
        engine = _BlockedEngine()
        scheduler = Scheduler(engine, max_pending=2, max_batch=8, batch_window_s=0.5)  # type: ignore[arg-type]
        outcome = []
        try:
            first = scheduler.submit("a", Sampling(), stream=False)  # the model's thread takes it and gathers
            await asyncio.sleep(0.05)
            scheduler.submit("b", Sampling(), stream=True)  # a streamed one cannot join: held back for after
            assert await asyncio.to_thread(engine.started.wait, 10)  # the window closed, the first one runs
            assert scheduler.waiting == 1
            scheduler.submit("c", Sampling(), stream=True)
            assert scheduler.waiting == 2
            with pytest.raises(Busy, match="2 requests waiting"):  # the held one counts: 2 wait, not 1
                scheduler.submit("d", Sampling(), stream=True)
            outcome.append("refused")
            engine.go.set()
            assert (await asyncio.wait_for(first.out, 10)).text == "x"  # type: ignore[arg-type]
        finally:
            engine.go.set()
            await asyncio.to_thread(scheduler.close)
        assert scheduler.waiting == 0
        return outcome

    assert asyncio.run(main()) == ["refused"]


def test_a_work_job_runs_alone_and_a_streamed_one_ends_with_its_reply() -> None:
    async def main() -> tuple[Reply, list[Any]]:
        engine = _BlockedEngine()
        engine.go.set()
        scheduler = Scheduler(engine, max_batch=8)  # type: ignore[arg-type]
        seen: list[Any] = []

        def work(given: Any, timeout_s: float | None) -> Reply:
            seen.append((given is engine, timeout_s))
            return Reply(text="<think>t</think><answer>a</answer>", reasoning="t", content="a",
                         finish_reason="stop", prompt_tokens=2, completion_tokens=3)

        try:
            plain = await asyncio.wait_for(scheduler.submit(None, Sampling(), stream=False, work=work).out, 10)
            streamed = scheduler.submit(None, Sampling(), stream=True, work=work)
            pieces = []
            while (piece := await asyncio.wait_for(streamed.out.get(), 10)) is not None:  # type: ignore[union-attr]
                pieces.append(piece)
        finally:
            await asyncio.to_thread(scheduler.close)
        assert seen == [(True, 120.0), (True, 120.0)]
        return plain, pieces  # type: ignore[return-value]

    plain, pieces = asyncio.run(main())
    assert plain.content == "a"
    assert pieces[:2] == [Delta("reasoning", "t"), Delta("content", "a")] and isinstance(pieces[2], Reply)
