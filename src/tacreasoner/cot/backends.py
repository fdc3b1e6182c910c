"""Teacher backends: one interface for every LLM that writes TouchCoT reasoning (paper §3.1, step 2).

The pipeline only sees :class:`Teacher` (``name``, ``model``, ``async generate(job, prompt)``), so an
OpenAI-compatible API (DeepSeek is the paper's teacher), a local Hugging Face model and the offline
rule-based teacher are interchangeable. A :class:`TeacherConfig` (YAML) picks and tunes one;
:func:`make_teacher` builds it and fails fast on bad configuration, before any job is sent.
:func:`reply_to_output` turns whatever a teacher said into ``(think, answer)``. The shared types live in
``teacher.py`` (the backends import them from there) and are importable from here too.
"""

from __future__ import annotations

import re
from typing import Any

from tacreasoner.cot.schema import TeacherReply
from tacreasoner.cot.teacher import (
    BACKENDS,
    DEEPSEEK_KEY_ENV,
    DEFAULT_KEY_ENV,
    Teacher,
    TeacherConfig,
    TeacherError,
    UsageMeter,
    cost_of,
    load_teacher_config,
)

__all__ = ["BACKENDS", "DEEPSEEK_KEY_ENV", "DEFAULT_KEY_ENV", "Teacher", "TeacherConfig", "TeacherError", "UsageMeter",
           "cost_of", "load_teacher_config", "make_teacher", "reply_to_output"]


def make_teacher(config: TeacherConfig | dict[str, Any]) -> Teacher:
    """Build the configured teacher. Heavy dependencies are imported only for the backend asked for."""
    if isinstance(config, dict):
        config = TeacherConfig.from_dict(config)
    if config.backend == "openai":
        from tacreasoner.cot.openai_backend import OpenAITeacher

        return OpenAITeacher(config)
    if config.backend == "hf":
        from tacreasoner.cot.hf_backend import HFTeacher

        return HFTeacher(config)
    if config.backend == "rules":
        from tacreasoner.cot.rules import RulesTeacher

        return RulesTeacher(seed=int(config.extra.get("seed", 0)), style=str(config.extra.get("style", "full")))
    raise ValueError(f"teacher: unknown backend {config.backend!r}; known: {', '.join(BACKENDS)}")


_THINK = re.compile(r"<think>(.*?)</think>", re.DOTALL | re.IGNORECASE)
_ANSWER = re.compile(r"<answer>(.*?)</answer>", re.DOTALL | re.IGNORECASE)
# "Answer:" / "**Final answer:**" (ASCII or full-width colon, as Chinese-first teachers write it)
_ANSWER_LABEL = re.compile(r"(?:\*\*|__)?\s*\b(?:final\s+)?answer\s*(?:\*\*|__)?\s*[:\uff1a]\s*(?:\*\*|__)?",
                           re.IGNORECASE)


def _clean_answer(text: str) -> str:
    return text.strip().strip("*_").strip()


def _split_on_label(text: str) -> tuple[str, str] | None:
    """``…reasoning… Answer: X`` → (reasoning, X), at the last label; None without one."""
    matches = list(_ANSWER_LABEL.finditer(text))
    if not matches:
        return None
    last = matches[-1]
    return text[:last.start()].strip(), _clean_answer(text[last.end():])


def reply_to_output(reply: TeacherReply) -> tuple[str, str] | None:
    """A teacher reply as ``(think, answer)``, or None when it cannot be read as reasoning + answer.

    Accepted forms, in order: ``<think>…</think><answer>…</answer>`` tags (a missing think tag is filled
    from the reasoning channel or the text before ``<answer>``; a missing answer tag from the text after
    ``</think>``); a separate reasoning channel (DeepSeek-reasoner's ``reasoning_content``) with the final
    text as the answer; plain text ending in ``Answer: …``.
    """
    text = (reply.text or "").strip()
    reasoning = (reply.reasoning or "").strip()
    think_m = _THINK.search(text)
    answer_ms = list(_ANSWER.finditer(text))
    if answer_ms:
        answer = _clean_answer(answer_ms[-1].group(1))
        if think_m and think_m.group(1).strip():
            think = think_m.group(1).strip()
        else:
            think = reasoning or _THINK.sub("", text[:answer_ms[-1].start()]).replace("<think>", "").strip()
        return (think, answer) if think and answer else None
    if think_m:
        think = think_m.group(1).strip()
        rest = text[think_m.end():].strip()
        split = _split_on_label(rest)
        if split is not None:
            before, answer = split
            think = f"{think}\n\n{before}".strip() if before else think
        else:
            answer = _clean_answer(rest)
        return (think, answer) if think and answer else None
    if reasoning:
        split = _split_on_label(text)
        if split is not None:
            before, answer = split
            think = f"{reasoning}\n\n{before}".strip() if before else reasoning
        else:
            think, answer = reasoning, _clean_answer(text)
        return (think, answer) if answer else None
    split = _split_on_label(text)
    if split is not None and split[0] and split[1]:
        return split
    return None
