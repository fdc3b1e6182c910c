"""A person's question over several objects answered stepwise by a served model (``ask --answers stepwise``).

The same mode as the evaluation's (:mod:`tacreasoner.evaluate.stepwise`): what the question asks is read from its
words (:func:`~tacreasoner.evaluate.stepwise.free_question_view`), each video is read in a pass of its own (named
objects and a scenario's needs asked as text), and the rule writes the conclusion; the reply shows the readings and
the step. A question it cannot read is left to the one-pass answer (this returns None).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from tacreasoner.evaluate.stepwise import READING_TEMPLATE, STEP_TOKENS, conclude, free_question_view, steps_for
from tacreasoner.serve.engine import Prompt, Reply, Sampling, TactileEngine
from tacreasoner.serve.stream import split_channels

__all__ = ["answer_stepwise"]


def answer_stepwise(engine: TactileEngine, question: str, videos: Sequence[Any], vocabulary: str,
                    *, templates: Sequence[str] = (READING_TEMPLATE,), timeout_s: float | None = None) -> Reply | None:
    """The stepwise reply to ``question`` about ``videos`` (paths or frames, one per ``<tactile>``), in
    ``vocabulary``'s level words, each video read in each of ``templates`` (the majority level;
    ``evaluate.stepwise.VOTE_TEMPLATES`` for all); None when the question is not one the mode reads. Greedy
    sub-replies of at most :data:`~tacreasoner.evaluate.stepwise.STEP_TOKENS` tokens, in one batch."""
    view = free_question_view(question, len(videos), vocabulary)
    if view is None:
        return None
    keys = [(f"video{k + 1}", None, None) for k in range(len(videos))]
    video_of = dict(zip(keys, videos, strict=True))
    steps = steps_for(view, keys, templates)
    start = time.perf_counter()
    sampling = Sampling(max_new_tokens=STEP_TOKENS)
    replies = engine.complete_batch([Prompt.ask(s.question, [video_of[k] for k in s.videos]) for s in steps],
                                    [sampling] * len(steps), timeout_s=timeout_s)
    composed = conclude(view, keys, {s.key: r.text for s, r in zip(steps, replies, strict=True)}, templates)
    reasoning, content = split_channels(composed.reply)  # as a served reply's two channels
    total = time.perf_counter() - start
    completion = sum(r.completion_tokens for r in replies)
    return Reply(text=composed.reply, reasoning=reasoning, content=content, finish_reason="stop",
                 prompt_tokens=sum(r.prompt_tokens for r in replies), completion_tokens=completion,
                 timings={"total_s": round(total, 4), "steps": len(steps),
                          "tokens_per_s": round(completion / total, 2) if total > 0 else 0.0})
