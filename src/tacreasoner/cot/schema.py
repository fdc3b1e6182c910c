"""TouchCoT records: what goes to a teacher, what comes back, and what is kept.

The contract between the four steps of the builder (paper §3.1): *prepare* turns a QA item into a
:class:`CoTJob` (the item, the interaction stages its reasoning must cover, and measured cues per
video); a *teacher* answers a :class:`Prompt` with a :class:`TeacherReply`; the *pipeline* stores a
:class:`CoTSample` per job (append-only, keyed by the job's content hash); the *filter* marks it
accepted or rejected with reasons; *format* writes training files from the accepted ones.

A sample's ``output`` is always normalised to ``<think>…</think><answer>…</answer>``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field

from tacreasoner.fields import reject_unknown_fields
from tacreasoner.tasks.schema import QAItem

STAGES = ("press", "hold", "slide", "rotate", "release")
"""Interaction stages a reasoning trace can be grounded in (step indicators)."""


@dataclass
class VideoCues:
    """Measured cues of one video of an item (one entry per ``<tactile>`` placeholder, in order)."""

    clip_id: str
    phases: dict[str, list[int]]
    """Stage → [start, end) frame range present in the clip (or segment), from ground truth or detection."""
    phase_source: str
    """``ground_truth`` (simulator) or ``detected`` (phase detector on the pixels)."""
    cues: dict[str, float]
    """Named, interpretable measurements (``tacreasoner.data.cues.clip_cues`` plus stage timings)."""
    fps: float = 0.0


@dataclass
class CoTJob:
    item: QAItem
    stages: list[str]
    """Stages the reasoning must cover for this task (e.g. press → hold → slide → release)."""
    videos: list[VideoCues]
    key: str = ""
    """Content hash: same item text, gold, cues, prompt version and teacher → same key → no new call."""

    def compute_key(self, prompt_version: str, teacher_id: str) -> str:
        payload = json.dumps({
            "id": self.item.id, "question": self.item.question, "answer": self.item.answer, "gold": self.item.gold,
            "stages": self.stages, "cues": [dataclasses.asdict(v) for v in self.videos],
            "prompt_version": prompt_version, "teacher": teacher_id,
        }, sort_keys=True, ensure_ascii=False)
        self.key = hashlib.sha256(payload.encode("utf-8")).hexdigest()[:32]
        return self.key


@dataclass
class Prompt:
    system: str
    user: str
    version: str
    """Template set + version, e.g. ``touchcot-v1``; recorded with every sample."""
    task: str


@dataclass
class TeacherReply:
    text: str
    """The final message content (may or may not already carry think/answer tags)."""
    reasoning: str | None = None
    """Separate reasoning channel when the API has one (DeepSeek ``reasoning_content``)."""
    model: str = ""
    prompt_tokens: int = 0
    completion_tokens: int = 0
    cost_usd: float = 0.0
    attempts: int = 1


@dataclass
class CoTSample:
    key: str
    item_id: str
    task: str
    split: str
    objects: list[str]
    question: str
    gold_answer: str
    videos: list[dict]
    """The item's VideoRefs as dicts (clip_id, path, start, end)."""
    output: str
    """Normalised ``<think>…</think><answer>…</answer>``."""
    teacher: str
    model: str
    prompt_version: str
    created: str
    """UTC date-time of generation (ISO 8601)."""
    stages: list[str]
    cues: list[dict]
    usage: dict = field(default_factory=dict)
    accepted: bool | None = None
    reject_reasons: list[str] = field(default_factory=list)
    review: str | None = None
    """Manual audit decision: ``accept`` / ``reject`` / None (not reviewed)."""
    meta: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> CoTSample:
        reject_unknown_fields(cls, data, "unknown CoT sample fields")
        return cls(**data)


def normalise_output(think: str, answer: str) -> str:
    """The one output form every teacher's reply is turned into."""
    return f"<think>{think.strip()}</think><answer>{answer.strip()}</answer>"
