"""The generation loop: jobs → prompts → teacher → one appended line per sample, resumable.

Reliability rules (what a user paying for API calls needs):
- every reply is appended to ``samples.jsonl`` (flushed) as soon as it arrives, one line per job;
- a job whose content-hash key is already in the file is never sent again;
- a line cut short by a kill (the last line only) is dropped on restart and the job redone;
- a job whose teacher call fails after its retries is recorded in ``failures.jsonl`` and is
  retried on the next run (it is not "done").
"""

from __future__ import annotations

import asyncio
import dataclasses
import datetime as _dt
import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from tacreasoner.cot.schema import CoTJob, CoTSample, Prompt, TeacherReply, normalise_output

SAMPLES = "samples.jsonl"
FAILURES = "failures.jsonl"


@dataclass
class GenerationResult:
    total: int
    already_done: int
    generated: int
    failed: int
    unusable: int
    """Replies that could not be normalised into think + answer (stored, later rejected as ``format``)."""
    seconds: float
    dropped_partial_line: bool = False
    failures: list[str] = field(default_factory=list)

    @property
    def samples_per_second(self) -> float:
        return self.generated / self.seconds if self.seconds > 0 else 0.0


def load_samples(path: str | Path, *, repair: bool = False) -> tuple[list[CoTSample], bool]:
    """Samples in file order. A malformed *last* line is what a kill leaves behind: with ``repair`` it is
    cut off the file; a malformed line anywhere else is corruption and raises naming the line."""
    path = Path(path)
    if not path.exists():
        return [], False
    raw = path.read_bytes()
    lines = raw.split(b"\n")
    samples: list[CoTSample] = []
    good_bytes = 0
    dropped = False
    for lineno, line in enumerate(lines, 1):
        if not line.strip():
            good_bytes += len(line) + 1
            continue
        try:
            samples.append(CoTSample.from_dict(json.loads(line)))
        except (json.JSONDecodeError, TypeError, ValueError) as exc:
            is_last = all(not rest.strip() for rest in lines[lineno:])
            if not is_last:
                raise ValueError(f"{path}:{lineno}: corrupt sample line ({exc})") from None
            dropped = True
            break
        good_bytes += len(line) + 1
    if dropped and repair:
        with path.open("r+b") as fh:
            fh.truncate(min(good_bytes, len(raw)))
    return samples, dropped


def make_sample(job: CoTJob, prompt: Prompt, reply: TeacherReply, teacher_name: str,
                normalised: tuple[str, str] | None) -> CoTSample:
    item = job.item
    output = normalise_output(*normalised) if normalised else reply.text
    return CoTSample(
        key=job.key, item_id=item.id, task=item.task, split=item.split, objects=list(item.objects),
        question=item.question, gold_answer=item.answer, videos=[dataclasses.asdict(v) for v in item.videos],
        output=output, teacher=teacher_name, model=reply.model, prompt_version=prompt.version,
        created=_dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        stages=list(job.stages), cues=[dataclasses.asdict(v) for v in job.videos],
        usage={"prompt_tokens": reply.prompt_tokens, "completion_tokens": reply.completion_tokens,
               "cost_usd": reply.cost_usd, "attempts": reply.attempts},
        meta={"item": item.to_dict(), "normalised": normalised is not None,
              **({"reasoning_channel": True} if reply.reasoning else {})},
    )


async def _generate_all(jobs: Sequence[CoTJob], teacher, prompt_fn: Callable[[CoTJob], Prompt], out: Path,
                        concurrency: int, progress: Callable[[int, int], None] | None,
                        done_before: int, total: int) -> tuple[int, int, list[str]]:
    from tacreasoner.cot.backends import reply_to_output

    semaphore = asyncio.Semaphore(concurrency)
    generated = unusable = 0
    failures: list[str] = []
    samples_fh = (out / SAMPLES).open("a", encoding="utf-8")
    failures_fh = (out / FAILURES).open("a", encoding="utf-8")

    async def one(job: CoTJob) -> None:
        nonlocal generated, unusable
        prompt = prompt_fn(job)
        async with semaphore:
            try:
                reply = await teacher.generate(job, prompt)
            except Exception as exc:  # a failed job is recorded and retried next run, never lost
                failures.append(job.key)
                failures_fh.write(json.dumps({"key": job.key, "item_id": job.item.id,
                                              "error": f"{type(exc).__name__}: {exc}"}) + "\n")
                failures_fh.flush()
                return
        normalised = reply_to_output(reply)
        unusable += normalised is None
        sample = make_sample(job, prompt, reply, teacher.name, normalised)
        samples_fh.write(json.dumps(sample.to_dict(), ensure_ascii=False) + "\n")
        samples_fh.flush()
        os.fsync(samples_fh.fileno())
        generated += 1
        if progress:
            progress(done_before + generated, total)

    try:
        await asyncio.gather(*(one(job) for job in jobs))
    finally:
        samples_fh.close()
        failures_fh.close()
    return generated, unusable, failures


def generate(jobs: Sequence[CoTJob], teacher, prompt_fn: Callable[[CoTJob], Prompt], out_dir: str | Path, *,
             concurrency: int = 8, progress: Callable[[int, int], None] | None = None) -> GenerationResult:
    """Generate a sample for every job whose key is not yet in ``out_dir/samples.jsonl`` (resumable)."""
    if concurrency < 1:
        raise ValueError(f"concurrency must be at least 1, got {concurrency}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    existing, dropped = load_samples(out / SAMPLES, repair=True)
    done = {s.key for s in existing}
    keys = [j.key for j in jobs]
    if any(not k for k in keys):
        raise ValueError("every job needs a key (CoTJob.compute_key) before generation")
    if len(set(keys)) != len(keys):
        raise ValueError("two jobs share a key: duplicate items in the input")
    todo = [j for j in jobs if j.key not in done]
    already = len(jobs) - len(todo)
    if progress:
        progress(already, len(jobs))
    start = time.perf_counter()
    generated, unusable, failures = asyncio.run(
        _generate_all(todo, teacher, prompt_fn, out, concurrency, progress, already, len(jobs)))
    return GenerationResult(total=len(jobs), already_done=already, generated=generated, failed=len(failures),
                            unusable=unusable, seconds=time.perf_counter() - start, dropped_partial_line=dropped,
                            failures=failures)
