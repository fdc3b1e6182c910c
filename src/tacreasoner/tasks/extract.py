"""Answer extraction from model output of the form ``<think>…</think><answer>…</answer>``.

Two modes, lm-evaluation-harness style:

* ``strict`` — the format the model is trained to produce. The text must be, apart from surrounding
  whitespace, an optional ``<think>…</think>`` block followed by exactly one ``<answer>…</answer>``
  block, with no further think/answer tags anywhere. Anything else is a format failure (``None``).
* ``lenient`` — for baselines (API VLMs, untuned LLMs) that half-follow the format. It tries, in
  order: the last closed ``<answer>…</answer>``; the tail after an unclosed ``<answer>``; the text
  after a final "Answer:" / "answer is"; the whole text without its reasoning (nothing after an unclosed
  ``<think>``: that text is reasoning). It never raises.

Tags are matched case-insensitively. Whenever ``strict`` returns ``s``, ``lenient`` returns ``s`` too
(strict ⊆ lenient), so a lenient score can only be higher than a strict one. Both return ``None``
for an empty answer: an empty answer can never be scored right, and treating it as "no answer"
keeps the two modes consistent.
"""

from __future__ import annotations

import re
from typing import Literal

__all__ = ["MODES", "Mode", "extract_answer", "has_tags", "split_reasoning"]

Mode = Literal["strict", "lenient"]
MODES: tuple[str, ...] = ("strict", "lenient")

_TAG = re.compile(r"<(/?)(think|answer)>", re.IGNORECASE)
_ANSWER_CUE = re.compile(r"\banswer\s*(?:is\b|:)", re.IGNORECASE)
_LEADING_JUNK = re.compile(r"^[\s:：*_\-–—>]+")


def has_tags(text: str) -> bool:
    """True when ``text`` holds any ``<think>``, ``</think>``, ``<answer>`` or ``</answer>`` tag (any case)."""
    return _TAG.search(text) is not None


def _tags(text: str) -> list[tuple[str, int, int]]:
    """Tags in order as (``"<think>"``-style lower-case name, start, end)."""
    return [(f"<{m.group(1)}{m.group(2).lower()}>", m.start(), m.end()) for m in _TAG.finditer(text)]


def _strict(text: str) -> str | None:
    tags = _tags(text)
    names = [t[0] for t in tags]
    if names not in (["<answer>", "</answer>"], ["<think>", "</think>", "<answer>", "</answer>"]):
        return None
    # Only whitespace may sit outside the blocks: before the first tag, between </think> and <answer>,
    # and after </answer>.
    gaps = [text[: tags[0][1]], text[tags[-1][2]:]]
    if len(tags) == 4:
        gaps.append(text[tags[1][2]: tags[2][1]])
    if any(g.strip() for g in gaps):
        return None
    answer = text[tags[-2][2]: tags[-1][1]].strip()
    return answer or None


def _without_tags(text: str) -> str:
    return _TAG.sub(" ", text)


def _last_block(text: str, tags: list[tuple[str, int, int]]) -> str | None:
    """Content of the last closed answer block: from the last <answer> before the last </answer>."""
    close = next((t for t in reversed(tags) if t[0] == "</answer>"), None)
    if close is None:
        return None
    open_ = next((t for t in reversed(tags) if t[0] == "<answer>" and t[2] <= close[1]), None)
    if open_ is None:
        return None
    return _without_tags(text[open_[2]: close[1]]).strip()


def _lenient(text: str) -> str | None:
    tags = _tags(text)
    block = _last_block(text, tags)
    if block is not None:
        return block or None
    opens = [t for t in tags if t[0] == "<answer>"]
    if opens:
        return _without_tags(text[opens[-1][2]:]).strip() or None
    think_closes = [t for t in tags if t[0] == "</think>"]
    # After a (possibly template-opened) think block. Reasoning is never an answer: after an unclosed <think> only
    # an answer cue inside it ("... Answer: sliding") is read.
    unclosed = any(t[0] == "<think>" for t in tags) and not think_closes
    body = text[think_closes[-1][2]:] if think_closes else text
    body = _without_tags(body)
    cues = list(_ANSWER_CUE.finditer(body))
    if cues:
        tail = _LEADING_JUNK.sub("", body[cues[-1].end():]).strip()
        if tail:
            return tail
    return None if unclosed else body.strip() or None


def extract_answer(text: str, mode: Mode | str = "strict") -> str | None:
    """The answer text of a model output, stripped, or ``None`` when there is none (see module doc)."""
    if mode == "strict":
        return _strict(text)
    if mode == "lenient":
        return _lenient(text)
    raise ValueError(f"extraction mode must be one of {MODES}, got {mode!r}")


def split_reasoning(text: str) -> tuple[str | None, str | None]:
    """(reasoning, answer) of a model output; either is ``None`` when absent.

    Reasoning is the content of the first think block (closed; unclosed up to ``<answer>`` or the end;
    or, when only ``</think>`` is present because a chat template opened the block, everything before
    it). The answer is the content of the last closed ``<answer>`` block. Both are stripped. This is
    for consumers that want both parts (CoT filtering, display); scoring uses :func:`extract_answer`.
    """
    tags = _tags(text)
    think: str | None = None
    open_i = next((i for i, t in enumerate(tags) if t[0] == "<think>"), None)
    if open_i is not None:
        start = tags[open_i][2]
        end_tag = next((t for t in tags[open_i + 1:] if t[0] in ("</think>", "<answer>")), None)
        think = _without_tags(text[start: end_tag[1] if end_tag else len(text)]).strip()
    else:
        close = next((t for t in tags if t[0] == "</think>"), None)
        if close is not None:
            think = _without_tags(text[: close[1]]).strip()
    return think, _last_block(text, tags)
