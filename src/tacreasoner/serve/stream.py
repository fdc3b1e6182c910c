"""Turning generated text into the two channels a client reads: the reasoning and the answer, as it is produced.

A reply is ``<think>…</think><answer>…</answer>``. Clients of the server (DeepSeek's ``reasoning_content``
convention) and the terminal stream want the two parts apart while tokens still arrive, so the tags are parsed
incrementally: text that could still be the start of a tag or of a stop string is held back until the next piece
settles it. The same splitter runs over a whole reply at once for non-streamed answers, so a streamed reply,
joined, is exactly the non-streamed one.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

__all__ = ["Delta", "ReasoningSplitter", "StopMatcher", "split_channels"]

Channel = Literal["reasoning", "content"]
_TAG = re.compile(r"<(/?)(think|answer)>", re.IGNORECASE)
_LONGEST_TAG = len("</answer>")


@dataclass(frozen=True)
class Delta:
    """A piece of the reply on one channel."""

    channel: Channel
    text: str


class ReasoningSplitter:
    """Feed text pieces, get :class:`Delta` s: inside ``<think>`` → reasoning; inside ``<answer>``, or outside any
    tag → content; after ``</answer>`` nothing (the reply is over). Tags are dropped, and so is the whitespace that
    opens each part, so joined deltas equal the stripped parts."""

    def __init__(self) -> None:
        self._pending = ""
        self._state: Literal["outside", "think", "answer", "done"] = "outside"
        self._at_part_start = True

    def feed(self, text: str) -> list[Delta]:
        self._pending += text
        return self._drain(final=False)

    def finish(self) -> list[Delta]:
        """Whatever was held back (an unfinished tag is text after all)."""
        return self._drain(final=True)

    def _drain(self, final: bool) -> list[Delta]:
        out: list[Delta] = []
        while self._pending:
            m = _TAG.search(self._pending)
            if m is None:
                keep = 0 if final else _partial_tag_length(self._pending)
                self._emit(self._pending[: len(self._pending) - keep], out)
                self._pending = self._pending[len(self._pending) - keep:]
                break
            self._emit(self._pending[: m.start()], out)
            self._pending = self._pending[m.end():]
            self._switch(m.group(1) == "/", m.group(2).lower())
        return out

    def _switch(self, closing: bool, name: str) -> None:
        if self._state == "done":
            return
        if not closing:
            self._state = "think" if name == "think" else "answer"
        elif name == "answer":
            self._state = "done"
        else:
            self._state = "outside"
        self._at_part_start = True

    def _emit(self, text: str, out: list[Delta]) -> None:
        if self._state == "done" or not text:
            return
        if self._at_part_start:
            text = text.lstrip()
            if not text:
                return
            self._at_part_start = False
        channel: Channel = "reasoning" if self._state == "think" else "content"
        if out and out[-1].channel == channel:
            out[-1] = Delta(channel, out[-1].text + text)
        else:
            out.append(Delta(channel, text))


def _partial_tag_length(text: str) -> int:
    """Length of the longest suffix of ``text`` that could still grow into a tag."""
    start = text.rfind("<", max(0, len(text) - _LONGEST_TAG))
    if start < 0:
        return 0
    tail = text[start:].lower()
    tags = ("<think>", "</think>", "<answer>", "</answer>")
    return len(tail) if any(t.startswith(tail) for t in tags) else 0


def split_channels(text: str) -> tuple[str, str]:
    """(reasoning, content) of a whole reply, exactly as the joined stream of it; trailing space stripped."""
    splitter = ReasoningSplitter()
    parts = {"reasoning": "", "content": ""}
    for delta in [*splitter.feed(text), *splitter.finish()]:
        parts[delta.channel] += delta.text
    return parts["reasoning"].rstrip(), parts["content"].rstrip()


class StopMatcher:
    """OpenAI's ``stop``: the reply ends before the first stop string. ``push`` takes the text so far and returns how
    much of it is safe to show (never a prefix of a stop string that may still complete), and whether it stopped."""

    def __init__(self, stops: Sequence[str]) -> None:
        self.stops = tuple(s for s in stops if s)
        self._hold = max((len(s) for s in self.stops), default=1) - 1

    def push(self, text: str) -> tuple[str, bool]:
        cut = min((i for i in (text.find(s) for s in self.stops) if i >= 0), default=-1)
        if cut >= 0:
            return text[:cut], True
        if not self._hold:
            return text, False
        safe = len(text)
        for s in self.stops:
            for k in range(min(len(s) - 1, len(text)), 0, -1):
                if text.endswith(s[:k]):
                    safe = min(safe, len(text) - k)
                    break
        return text[:safe], False
