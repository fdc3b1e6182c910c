"""A person's question over several objects answered stepwise by a served model (``ask``, ``serve`` and ``demo``
with ``--answers stepwise`` or ``stepwise-vote``).

The same mode as the evaluation's (:mod:`tacreasoner.evaluate.stepwise`): what the question asks is read from its
words (:func:`~tacreasoner.evaluate.stepwise.free_question_view`), each video is read in a pass of its own (named
objects and a scenario's needs asked as text), and the rule writes the conclusion; the reply shows the readings and
the step. A question it cannot read is left to the one-pass answer (:meth:`StepwiseAnswerer.view` returns None).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Sequence
from typing import Any

from tacreasoner.evaluate.stepwise import (
    EMBEDDING_MODES,
    READING_TEMPLATE,
    REASKING_MODES,
    SINGLE_CLIP_MODES,
    STEP_TOKENS,
    TRAINED_ONE_PASS_MODES,
    conclude,
    free_question_view,
    pick_reasked,
    reading_templates,
    reasked_questions,
    steps_for,
)
from tacreasoner.model.processing import saved_processor_config
from tacreasoner.serve.engine import Prompt, Reply, Sampling, TactileEngine
from tacreasoner.serve.stream import split_channels
from tacreasoner.tasks.schema import QAItem

__all__ = ["StepwiseAnswerer", "answer_stepwise", "answer_view", "model_answers", "model_vocabulary"]


def answer_view(engine: TactileEngine, view: QAItem, videos: Sequence[Any],
                templates: Sequence[str] = (READING_TEMPLATE,), timeout_s: float | None = None) -> Reply:
    """The stepwise reply to a question's ``view`` (:func:`~tacreasoner.evaluate.stepwise.free_question_view`) about
    ``videos`` (paths or frames, one per ``<tactile>``), each video read in each of ``templates`` (the majority
    level; ``evaluate.stepwise.VOTE_TEMPLATES`` for all). Greedy sub-replies of at most
    :data:`~tacreasoner.evaluate.stepwise.STEP_TOKENS` tokens, in one batch."""
    keys = [(f"video{k + 1}", None, None) for k in range(len(videos))]
    video_of = dict(zip(keys, videos, strict=True))
    steps = steps_for(view, keys, templates)
    start = time.perf_counter()
    sampling = Sampling(max_new_tokens=STEP_TOKENS)
    replies = engine.complete_batch([Prompt.ask(s.question, [video_of[k] for k in s.videos]) for s in steps],
                                    [sampling] * len(steps), timeout_s=timeout_s) if steps else []
    composed = conclude(view, keys, {s.key: r.text for s, r in zip(steps, replies, strict=True)}, templates)
    reasoning, content = split_channels(composed.reply)  # as a served reply's two channels
    total = time.perf_counter() - start
    completion = sum(r.completion_tokens for r in replies)
    return Reply(text=composed.reply, reasoning=reasoning, content=content, finish_reason="stop",
                 prompt_tokens=sum(r.prompt_tokens for r in replies), completion_tokens=completion,
                 timings={"total_s": round(total, 4), "steps": len(steps),
                          "tokens_per_s": round(completion / total, 2) if total > 0 else 0.0})


def answer_stepwise(engine: TactileEngine, question: str, videos: Sequence[Any], vocabulary: str,
                    *, templates: Sequence[str] = (READING_TEMPLATE,), timeout_s: float | None = None,
                    single_clip: bool = False, embedding: bool = False) -> Reply | None:
    """:func:`answer_view` of ``question`` read in ``vocabulary``'s level words; ``single_clip``: a one-clip question
    in untrained words is read too (``embedding``: by a sentence embedding where its words name no property). None
    when the question is not one the mode reads."""
    view = free_question_view(question, len(videos), vocabulary, single_clip, embedding=embedding)
    return None if view is None else answer_view(engine, view, videos, templates, timeout_s)


def model_vocabulary(model_dir: str | os.PathLike[str]) -> str:
    """The level words a model folder was trained on (``processor_config.json``'s ``vocabulary``, recorded at saving
    since 2026-11-29); ``physiclear`` for a folder saved before then or without it."""
    return str(saved_processor_config(model_dir).get("vocabulary") or "physiclear")


def model_answers(model_dir: str | os.PathLike[str]) -> str:
    """The answering mode a model folder's recipe recommends (``processor_config.json``'s ``answers``: the
    quickstart's ``auto``, the PhysiCLeAR recipe's ``stepwise-vote``); ``direct`` where none is recorded."""
    return str(saved_processor_config(model_dir).get("answers") or "direct")


class StepwiseAnswerer:
    """How ``ask``, a server or the demo answers: ``direct`` (every question in one pass), ``stepwise``,
    ``stepwise-vote`` or ``auto`` (a question it reads, greedy; on a server or the demo a sampled request keeps its
    one sampled pass, since the readings and the rule are deterministic)."""

    def __init__(self, answers: str = "direct", vocabulary: str = "physiclear") -> None:
        from tacreasoner.evaluate.predict import check_answers
        from tacreasoner.tasks.vocab import get_vocabulary

        check_answers(answers)
        get_vocabulary(vocabulary)
        self.answers = answers
        self.vocabulary = vocabulary

    def view(self, prompt: Prompt, sampling: Sampling | None = None) -> QAItem | None:
        """What a one-turn ``prompt`` (a system turn allowed) asks, when this mode answers it stepwise; None for
        ``direct``, a conversation, a sampled request (``sampling`` not greedy) or a question the mode does not read:
        answered in one pass."""
        users = [m for m in prompt.messages if m["role"] == "user"]
        if self.answers == "direct" or (sampling is not None and not sampling.greedy) or len(users) != 1 or \
                any(m["role"] == "assistant" for m in prompt.messages):
            return None
        return free_question_view(users[0]["content"], len(prompt.videos), self.vocabulary,
                                  single_clip=self.answers in SINGLE_CLIP_MODES,
                                  trained_one_pass=self.answers in TRAINED_ONE_PASS_MODES,
                                  reask=self.answers in REASKING_MODES,
                                  embedding=self.answers in EMBEDDING_MODES)

    def answer(self, engine: TactileEngine, view: QAItem, videos: Sequence[Any],
               timeout_s: float | None = None) -> Reply:
        """The reply to a question's ``view``: asked again in the benchmark's words where this mode does that
        (``REASKING_MODES``; one pass per wording, the majority's reply, its ``asked_as`` naming the wording), else
        read stepwise."""
        questions = reasked_questions(view) if self.answers in REASKING_MODES else ()
        if not questions:
            return answer_view(engine, view, videos, reading_templates(self.answers), timeout_s)
        start = time.perf_counter()
        sampling = Sampling(max_new_tokens=STEP_TOKENS)
        replies = engine.complete_batch([Prompt.ask(q, videos) for q in questions], [sampling] * len(questions),
                                        timeout_s=timeout_s)
        chosen = pick_reasked([r.text for r in replies])
        return dataclasses.replace(replies[chosen], asked_as=questions[chosen], timings={
            **replies[chosen].timings, "steps": len(questions), "total_s": round(time.perf_counter() - start, 4)})
