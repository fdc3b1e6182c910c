"""The QA item: one question over 1–3 tactile videos, its gold answer text and its machine-readable gold.

This schema is the contract between the QA builders, the file formats, the scorers, the CoT builder
and the model's processor. Every ``<tactile>`` placeholder in ``question`` stands for one entry of
``videos``, in order.

Gold conventions per task (``gold`` dict) and the gold answer text (``answer``):

| task | videos | gold | answer text |
|---|---|---|---|
| ``TFA-<attribute>`` | 1 | ``{"attribute": a, "level": 0..2}`` | the level phrase, e.g. ``moderately deformable`` |
| ``TFA-combined`` | 1 | ``{"levels": {attribute: 0..2, …}}`` (vocabulary order) | ``hardness: …; protrusion: …; …`` |
| ``SFD`` | 2 | ``{"kind": "which", "index": 0|1, "attribute": a, "direction": d}`` | ``the first/second object`` |
| ``SFD`` | 2 | ``{"kind": "yesno", "value": bool, "attribute": a, "direction": …}`` | ``yes`` / ``no`` |
| ``PC`` | 2 | ``{"attribute": a, "relation": "more"|"less"|"similar"}`` | ``more`` / ``less`` / ``similar`` |
| ``SOI`` | 3 | ``{"index": 0..2, "attribute": a, "direction": "most"|"least"}`` | ``the first/second/third object`` |
| ``OSC`` | 3 | ``{"assignment": [k0, k1, k2]}``: video v ↔ option letter ``"ABC"[k_v]`` | ``1-B, 2-A, 3-C`` |
| ``TSA`` | 2 | ``{"letter": "A"|"B", "scenario": id, "needs": {attribute: "high"|"low"}}`` | ``A`` / ``B`` |
| ``RFOR`` | 1 | ``{"real": bool, "fruit": name}`` | ``real`` / ``fake`` |
| ``OCSE`` | 1 segment | ``{"state": s}`` with s in ``CONTACT_STATES`` | the state phrase, e.g. ``sliding`` |

SFD's direction ``d`` is ``"more"`` or ``"less"`` (the comparative asked about). PC is Octopi's property
comparison (PhysiCLeAR benchmarks only): the first object has more, less or the same level ("similar") of the
attribute than the second; its pairs may share a level, SFD's never do.

Multiple-choice items list their choices in ``options`` (OSC: object names; TSA: the two
candidates; OCSE: contact states), in the order the question shows them.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field

from tacreasoner.fields import reject_unknown_fields

PLACEHOLDER = "<tactile>"
TFA_TASKS = ("TFA-hardness", "TFA-protrusion", "TFA-elasticity", "TFA-friction", "TFA-roughness",
             "TFA-bumpiness", "TFA-combined")
TASKS = (*TFA_TASKS, "SFD", "PC", "SOI", "OSC", "TSA", "RFOR", "OCSE")
PC_RELATIONS = ("more", "less", "similar")
"""PC answers: the first object's level of the attribute against the second's (higher, lower, equal)."""
ORDINALS = ("first", "second", "third")
CONTACT_STATES = ("pressing", "holding", "sliding", "rotating", "releasing")
"""OCSE answer phrases; simulator phases map press→pressing, hold→holding, slide→sliding, …"""
PHASE_TO_STATE = {"press": "pressing", "hold": "holding", "slide": "sliding", "rotate": "rotating",
                  "release": "releasing"}
SPLITS = ("train", "val", "test")
ZERO_SHOT_TASKS = ("TSA",)
"""Tasks never trained on (no train-split items, no TouchCoT): TSA is evaluated zero-shot."""


@dataclass(frozen=True)
class VideoRef:
    """One tactile video of an item: a clip, optionally a frame segment of it (OCSE)."""

    clip_id: str
    path: str | None = None
    """Video file, relative to the benchmark/dataset root or absolute."""
    start: int | None = None
    end: int | None = None
    """Segment [start, end) in frames; None = the whole clip."""


@dataclass
class QAItem:
    id: str
    task: str
    question: str
    answer: str
    gold: dict
    videos: list[VideoRef]
    objects: list[str]
    vocabulary: str = "vtv150k"
    options: list[str] = field(default_factory=list)
    split: str = ""
    source: str = ""
    """Where the clips come from: sim, physiclear, vtv150k, …"""
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ValueError naming the item when it breaks the schema."""
        where = f"item {self.id!r}"
        if self.task not in TASKS:
            raise ValueError(f"{where}: unknown task {self.task!r}; known: {', '.join(TASKS)}")
        if not self.videos:
            raise ValueError(f"{where}: needs at least one video")
        n_placeholders = self.question.count(PLACEHOLDER)
        if n_placeholders != len(self.videos):
            raise ValueError(f"{where}: question has {n_placeholders} {PLACEHOLDER} placeholders "
                             f"but {len(self.videos)} videos")
        if not self.answer.strip():
            raise ValueError(f"{where}: empty gold answer")
        if self.split and self.split not in SPLITS:
            raise ValueError(f"{where}: split must be one of {SPLITS}, got {self.split!r}")

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), ensure_ascii=False)

    @classmethod
    def from_dict(cls, data: dict) -> QAItem:
        reject_unknown_fields(cls, data, "unknown QA item fields")
        missing = {"id", "task", "question", "answer", "gold", "videos", "objects"} - set(data)
        if missing:
            raise ValueError(f"missing QA item fields {sorted(missing)}")
        videos = [v if isinstance(v, VideoRef) else VideoRef(**v) for v in data["videos"]]
        return cls(**{**data, "videos": videos})
