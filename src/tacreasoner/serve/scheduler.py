"""The one thread that runs the model for the server, fed by a bounded queue, batching what can be batched.

The model uses every core for one ``generate`` call, so requests are answered one call at a time; concurrency is
a queue in front of it (full → the caller is told the server is busy, instead of every request slowing down).
Non-streamed requests that decode alike (:meth:`Sampling.batch_key`) and wait at the same moment are answered by
one batched call; streamed ones run alone, token by token. A job may instead be a piece of work on the engine (a
stepwise answer: several batched passes and a rule), run alone; streamed, its reply comes as two pieces at the end.
Callers live on an asyncio loop; results come back to it thread-safely.
"""

from __future__ import annotations

import asyncio
import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from tacreasoner.serve.engine import Reply, Sampling, TactileEngine
from tacreasoner.serve.stream import Delta

__all__ = ["Busy", "Scheduler"]


class Busy(RuntimeError):
    """The queue is full: try again later."""


@dataclass
class _Job:
    prepared: Any
    sampling: Sampling
    loop: asyncio.AbstractEventLoop
    stream: bool
    out: asyncio.Queue | asyncio.Future  # stream: pieces then None; else: the Reply or an exception
    cancelled: threading.Event = field(default_factory=threading.Event)
    work: Callable[[TactileEngine, float | None], Reply] | None = None
    """Set for a job that is not one ``generate`` call: run alone, given the engine and the decode timeout."""

    @property
    def batchable(self) -> bool:
        return not self.stream and self.work is None


_STOP = object()


class Scheduler:
    """Owns the model's thread. ``max_pending`` jobs may wait; ``max_batch`` > 1 turns batching on, gathering for up
    to ``batch_window_s`` once a batchable job is at the head of the queue."""

    def __init__(self, engine: TactileEngine, *, max_pending: int = 64, max_batch: int = 8,
                 batch_window_s: float = 0.01, decode_timeout_s: float | None = 120.0) -> None:
        self.engine = engine
        self.max_batch = max(1, max_batch)
        self.batch_window_s = batch_window_s
        self.decode_timeout_s = decode_timeout_s
        self.max_pending = max_pending
        self._queue: queue.Queue[Any] = queue.Queue()
        self._room = threading.Lock()
        self._waiting = 0
        """Jobs submitted and not yet started: queued, or held back while a batch gathered."""
        self._held: deque[_Job] = deque()
        self.stats = {"calls": 0, "batched_requests": 0, "largest_batch": 0}
        self._thread = threading.Thread(target=self._run, name="tacreasoner-scheduler", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ asyncio side
    def submit(self, prepared: Any, sampling: Sampling, *, stream: bool,
               work: Callable[[TactileEngine, float | None], Reply] | None = None) -> _Job:
        """Queue a request (``prepared`` for ``engine``; or ``work`` to run on it); :class:`Busy` when
        ``max_pending`` requests wait already, those held back from a batch included."""
        loop = asyncio.get_running_loop()
        out: asyncio.Queue | asyncio.Future = asyncio.Queue() if stream else loop.create_future()
        job = _Job(prepared, sampling, loop, stream, out, work=work)
        with self._room:
            if self._waiting >= self.max_pending:
                raise Busy(f"the server is busy ({self.max_pending} requests waiting); retry shortly")
            self._waiting += 1
        self._queue.put_nowait(job)
        return job

    @property
    def waiting(self) -> int:
        """Requests not yet taken by the model's thread: in the queue, or held back while a batch gathered."""
        return self._waiting

    def _started(self, jobs: int) -> None:
        with self._room:
            self._waiting -= jobs

    def close(self) -> None:
        self._queue.put(_STOP)
        self._thread.join(timeout=30)

    # ------------------------------------------------------------------ model thread
    def _next(self, timeout: float | None = None) -> Any:
        if self._held:
            return self._held.popleft()
        return self._queue.get(timeout=timeout)

    def _run(self) -> None:
        while True:
            job = self._next()
            if job is _STOP:
                return
            if job.work is not None or job.stream:
                self._started(1)
                if job.work is not None:
                    self._work(job)
                else:
                    self._stream(job)
                continue
            batch = [job]
            key = job.sampling.batch_key()
            if self.max_batch > 1 and key is not None:
                batch += self._gather(key)
            self._started(len(batch))
            self._complete(batch)

    def _gather(self, key: tuple[Any, ...]) -> list[_Job]:
        """More jobs with the same key, waiting up to the batch window; others are held for after."""
        found: list[_Job] = []
        others: list[Any] = []
        deadline = time.perf_counter() + self.batch_window_s
        while len(found) + 1 < self.max_batch:
            left = deadline - time.perf_counter()
            try:
                job = self._queue.get(timeout=max(left, 0.0)) if left > 0 else self._queue.get_nowait()
            except queue.Empty:
                break
            if job is not _STOP and job.batchable and job.sampling.batch_key() == key:
                found.append(job)
            else:
                others.append(job)
        self._held.extend(others)
        return found

    def _complete(self, batch: list[_Job]) -> None:
        live = [j for j in batch if not (isinstance(j.out, asyncio.Future) and j.out.cancelled())]
        if not live:
            return
        self.stats["calls"] += 1
        self.stats["batched_requests"] += len(live) if len(live) > 1 else 0
        self.stats["largest_batch"] = max(self.stats["largest_batch"], len(live))
        try:
            replies: list[Reply | BaseException] = list(self.engine.complete_batch(
                [j.prepared for j in live], [j.sampling for j in live], timeout_s=self.decode_timeout_s))
        except BaseException as exc:  # every job of the call gets the failure
            replies = [exc] * len(live)
        for job, reply in zip(live, replies, strict=True):
            job.loop.call_soon_threadsafe(_settle, job.out, reply)

    def _work(self, job: _Job) -> None:
        if (isinstance(job.out, asyncio.Future) and job.out.cancelled()) or job.cancelled.is_set():
            return
        self.stats["calls"] += 1
        try:
            reply: Reply | BaseException = job.work(self.engine, self.decode_timeout_s)  # type: ignore[misc]
        except BaseException as exc:
            reply = exc
        if not job.stream:
            job.loop.call_soon_threadsafe(_settle, job.out, reply)
            return
        put = job.out.put_nowait  # type: ignore[union-attr]
        if isinstance(reply, Reply):
            for channel, text in (("reasoning", reply.reasoning), ("content", reply.content)):
                if text:
                    job.loop.call_soon_threadsafe(put, Delta(channel, text))
        job.loop.call_soon_threadsafe(put, reply)
        job.loop.call_soon_threadsafe(put, None)

    def _stream(self, job: _Job) -> None:
        self.stats["calls"] += 1
        put = job.out.put_nowait  # type: ignore[union-attr]
        try:
            for piece in self.engine.stream(job.prepared, job.sampling, timeout_s=self.decode_timeout_s,
                                            cancelled=job.cancelled):
                job.loop.call_soon_threadsafe(put, piece)
        except BaseException as exc:
            job.loop.call_soon_threadsafe(put, exc)
        job.loop.call_soon_threadsafe(put, None)


def _settle(future: asyncio.Future, value: Any) -> None:
    if future.done():
        return
    if isinstance(value, BaseException):
        future.set_exception(value)
    else:
        future.set_result(value)
