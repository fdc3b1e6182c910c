"""The one thread that runs the model for the server, fed by a bounded queue, batching what can be batched.

The model uses every core for one ``generate`` call, so requests are answered one call at a time; concurrency is
a queue in front of it (full → the caller is told the server is busy, instead of every request slowing down).
Non-streamed requests that decode alike (:meth:`Sampling.batch_key`) and wait at the same moment are answered by
one batched call; streamed ones run alone, token by token. Callers live on an asyncio loop; results come back to it
thread-safely.
"""

from __future__ import annotations

import asyncio
import queue
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from tacreasoner.serve.engine import Reply, Sampling, TactileEngine

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
        self._queue: queue.Queue[Any] = queue.Queue(maxsize=max_pending)
        self._held: deque[_Job] = deque()
        self.stats = {"calls": 0, "batched_requests": 0, "largest_batch": 0}
        self._thread = threading.Thread(target=self._run, name="tacreasoner-scheduler", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ asyncio side
    def submit(self, prepared: Any, sampling: Sampling, *, stream: bool) -> _Job:
        loop = asyncio.get_running_loop()
        out: asyncio.Queue | asyncio.Future = asyncio.Queue() if stream else loop.create_future()
        job = _Job(prepared, sampling, loop, stream, out)
        try:
            self._queue.put_nowait(job)
        except queue.Full:
            raise Busy(f"the server is busy ({self._queue.maxsize} requests waiting); retry shortly") from None
        return job

    @property
    def waiting(self) -> int:
        """Requests in the queue, not yet taken by the model's thread."""
        return self._queue.qsize() + len(self._held)

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
            if job.stream:
                self._stream(job)
                continue
            batch = [job]
            key = job.sampling.batch_key()
            if self.max_batch > 1 and key is not None:
                batch += self._gather(key)
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
            if job is not _STOP and not job.stream and job.sampling.batch_key() == key:
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
