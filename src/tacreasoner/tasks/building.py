"""What every task family's builder shares: the build reports, balanced plans, rank look-ups, the per-task build
context and the registry that maps a task name to its builder.

A task family is one module under ``tasks/families/`` whose builders are registered with :func:`register`
(lm-evaluation-harness style): adding a task is a new module and a name in ``schema.TASKS``, not an edit to a
dispatcher. Every builder has one signature, ``(clips, n, ctx) -> items``, and draws only from ``ctx.rng``, so a
task's items depend on nothing but its clips, the seed and its own name.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar

import numpy as np

from tacreasoner.data.clip import TactileClip
from tacreasoner.tasks.answers import render_answer
from tacreasoner.tasks.scenarios import Scenario
from tacreasoner.tasks.schema import ZERO_SHOT_TASKS, QAItem, VideoRef
from tacreasoner.tasks.templating import Template
from tacreasoner.tasks.vocab import Attribute, get_vocabulary

__all__ = [
    "MAX_TRIES",
    "TASK_BUILDERS",
    "BuildContext",
    "BuildReport",
    "Builder",
    "Cycler",
    "TaskBuildWarning",
    "TaskReport",
    "balanced",
    "check_split_allows",
    "join_words",
    "labelled_any",
    "object_label",
    "partner",
    "pick",
    "plan_targets",
    "rank_groups",
    "rank_of",
    "ranks_of",
    "register",
    "video_ref",
]

T = TypeVar("T")

MAX_TRIES = 50
"""Draws per planned item before giving up on it (no valid, non-duplicate combination found)."""

_VARIANT_SUFFIX = re.compile(r"\s*\(variant \d+\)$")
_ARTICLE = re.compile(r"^(a|an|the)\s+", re.IGNORECASE)


class TaskBuildWarning(UserWarning):
    """A task produced no items, or fewer than requested."""


# ------------------------------------------------------------------------------------------ reports


@dataclass
class TaskReport:
    """What one task's builder did with the clips it was given."""

    task: str
    requested: int = 0
    built: int = 0
    skipped: Counter = field(default_factory=Counter)
    """reason → number of clips left out of this task."""
    notes: list[str] = field(default_factory=list)

    def problems(self) -> list[str]:
        """Human-readable warnings: nothing built, or fewer items than planned."""
        why = "; ".join([*(f"{n} clip(s) skipped: {r}" for r, n in self.skipped.items()), *self.notes])
        why = f" ({why})" if why else ""
        if self.built == 0:
            return [f"{self.task}: no items could be built from the given clips{why}"]
        if self.built < self.requested:
            return [f"{self.task}: built {self.built} of {self.requested} requested items{why}"]
        return []


@dataclass
class BuildReport:
    tasks: dict[str, TaskReport] = field(default_factory=dict)

    @property
    def counts(self) -> dict[str, int]:
        return {t: r.built for t, r in self.tasks.items()}

    @property
    def warnings(self) -> list[str]:
        return [p for r in self.tasks.values() for p in r.problems()]


# ------------------------------------------------------------------------------------------ helpers


class Cycler(Generic[T]):
    """Draws without replacement, reshuffling when exhausted, so a pool is used evenly."""

    def __init__(self, items: Sequence[T], rng: np.random.Generator) -> None:
        self.items = list(items)
        self.rng = rng
        self.queue: list[T] = []

    def next(self) -> T:
        if not self.queue:
            self.queue = [self.items[i] for i in self.rng.permutation(len(self.items))]
        return self.queue.pop()


def balanced(values: Sequence[T], n: int, rng: np.random.Generator) -> list[T]:
    """``n`` values using each value equally often (±1), in random order."""
    k = len(values)
    out = list(values) * (n // k) + [values[i] for i in rng.permutation(k)[: n % k]]
    return [out[i] for i in rng.permutation(n)]


def plan_targets(n: int, rng: np.random.Generator, **axes: Sequence[Any]) -> list[dict[str, Any]]:
    """``n`` targets, each axis balanced on its own and shuffled independently of the others."""
    columns = {name: balanced(values, n, rng) for name, values in axes.items()}
    return [{name: col[i] for name, col in columns.items()} for i in range(n)]


def pick(pool: Sequence[T], rng: np.random.Generator) -> T:
    return pool[int(rng.integers(len(pool)))]


def join_words(words: Sequence[str]) -> str:
    """``a, b and c``."""
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"


def rank_of(clip: TactileClip, vocabulary: str, attribute: str) -> int | None:
    """The clip's 0/1/2 rank, None when unlabelled; ValueError naming the clip on a malformed label."""
    r = clip.rank(vocabulary, attribute)
    if r is None:
        return None
    if isinstance(r, bool) or r not in (0, 1, 2):
        raise ValueError(f"clip {clip.clip_id!r}: {vocabulary} rank for {attribute!r} must be 0, 1 or 2, got {r!r}")
    return int(r)


def ranks_of(clip: TactileClip, vocabulary: str, attributes: Sequence[str]) -> dict[str, int] | None:
    """Ranks for all ``attributes``, or None when any is missing."""
    out = {a: rank_of(clip, vocabulary, a) for a in attributes}
    if any(v is None for v in out.values()):
        return None
    return {a: int(v) for a, v in out.items() if v is not None}


def object_label(clip: TactileClip) -> str:
    """The object's name as an OSC option: no leading article, no simulator ``(variant N)`` suffix."""
    name = (clip.object_name or clip.object_id).strip()
    return _ARTICLE.sub("", _VARIANT_SUFFIX.sub("", name))


def video_ref(clip: TactileClip, start: int | None = None, end: int | None = None) -> VideoRef:
    path = Path(clip.path).as_posix() if clip.path is not None else None
    return VideoRef(clip.clip_id, path, start, end)


def rank_groups(clips: Sequence[TactileClip], vocabulary: str, attribute: str) -> dict[int, list[TactileClip]]:
    groups: dict[int, list[TactileClip]] = {}
    for c in clips:
        r = rank_of(c, vocabulary, attribute)
        if r is not None:
            groups.setdefault(r, []).append(c)
    return dict(sorted(groups.items()))


def partner(groups: Mapping[int, Sequence[TactileClip]], value: int, rng: np.random.Generator) -> TactileClip | None:
    """A clip from any group other than ``value``, uniformly over those clips (without listing them)."""
    sizes = [(key, len(g)) for key, g in groups.items() if key != value]
    i = int(rng.integers(max(1, sum(n for _, n in sizes))))
    for key, n in sizes:
        if i < n:
            return groups[key][i]
        i -= n
    return None


@dataclass
class BuildContext:
    """Per-task state: where items go, how they are named, what was skipped."""

    task: str
    vocabulary: str
    split: str
    source: str
    rng: np.random.Generator
    templates: Mapping[str, tuple[Template, ...]]
    scenarios: tuple[Scenario, ...]
    report: TaskReport
    items: list[QAItem] = field(default_factory=list)
    seen: set = field(default_factory=set)

    @property
    def vocab(self) -> dict[str, Attribute]:
        return get_vocabulary(self.vocabulary)

    def item_id(self, n: int) -> str:
        return "-".join(p for p in (self.source, self.split, self.task, f"{n:05d}") if p)

    def skip(self, n: int, reason: str) -> None:
        if n:
            self.report.skipped[reason] += n

    def with_templates(self, plan: list[dict[str, Any]], kind: Callable[[dict], str] | str,
                       within: str | None = None) -> list[dict[str, Any]]:
        """Give each planned item a template, balanced within each template kind, and, with ``within`` (a plan
        key such as ``"letter"``), within each of its values: every wording then carries each answer about
        equally often, so no fixed answer per wording beats chance (TSA, bench version 2)."""
        cyclers: dict[tuple[str, Any], Cycler[Template]] = {}
        for p in plan:
            k = kind if isinstance(kind, str) else kind(p)
            key = (k, p[within] if within else None)
            if key not in cyclers:
                cyclers[key] = Cycler(self.templates[k], self.rng)
            p["template"] = cyclers[key].next()
        return plan

    def add(self, key: tuple, template: Template, clips: Sequence[TactileClip], gold: dict, slots: dict[str, str],
            *, videos: list[VideoRef] | None = None, options: Sequence[str] = (), meta: dict | None = None) -> bool:
        """Append an item unless an identical one exists; the answer is rendered from ``gold``."""
        key = (template.id, *key)
        if key in self.seen:
            return False
        self.seen.add(key)
        self.items.append(QAItem(
            id=self.item_id(len(self.items)), task=self.task, question=template.render(**slots),
            answer=render_answer(self.task, gold, self.vocabulary), gold=gold,
            videos=videos if videos is not None else [video_ref(c) for c in clips],
            objects=[c.object_id for c in clips], vocabulary=self.vocabulary, options=list(options),
            split=self.split, source=self.source,
            meta={"template": template.id, "slots": dict(slots), "object_names": [c.object_name for c in clips],
                  **(meta or {})},
        ))
        return True

    def clip_plan(self, clips: Sequence[TactileClip], eligible: list[TactileClip], reason: str, kind: str,
                  n: int | None) -> tuple[Cycler[TactileClip], list[dict[str, Any]]] | None:
        """A one-clip task's start: the clips left out (``reason``) counted, a cycler over the ``eligible`` ones and
        ``n`` planned items (one per eligible clip when None) with ``kind`` templates; None when none is eligible."""
        self.skip(len(clips) - len(eligible), reason)
        if not eligible:
            return None
        return Cycler(eligible, self.rng), self.with_templates(plan_targets(len(eligible) if n is None else n,
                                                                            self.rng), kind)

    def run(self, plan: list[dict[str, Any]], attempt: Callable[[dict[str, Any]], bool], what: str) -> list[QAItem]:
        """Fill the plan; each target gets ``MAX_TRIES`` draws to find a valid new item."""
        self.report.requested = len(plan)
        dropped = sum(not any(attempt(p) for _ in range(MAX_TRIES)) for p in plan)
        if dropped:
            self.report.notes.append(f"{dropped} planned item(s) dropped: no new {what} found in {MAX_TRIES} draws")
        return self.finish()

    def finish(self) -> list[QAItem]:
        self.report.built = len(self.items)
        return self.items


def labelled_any(clips: Sequence[TactileClip], ctx: BuildContext) -> list[TactileClip]:
    labelled = [c for c in clips if any(rank_of(c, ctx.vocabulary, a) is not None for a in ctx.vocab)]
    ctx.skip(len(clips) - len(labelled), f"no {ctx.vocabulary} labels")
    return labelled


def check_split_allows(task: str, split: str) -> None:
    """TSA is zero-shot: refuse to build it for training."""
    if task in ZERO_SHOT_TASKS and split == "train":
        raise ValueError(f"{task} is zero-shot and must never be used in training; refusing to build it for "
                         f"split 'train' (build it for 'val' or 'test')")


# ------------------------------------------------------------------------------------------ registry

Builder = Callable[[Sequence[TactileClip], "int | None", BuildContext], list[QAItem]]
"""A task's builder: the task's clips (sorted by id), how many items to plan (None: one per usable clip) and the
task's build context; returns the items it built (``ctx.run``/``ctx.finish``)."""

TASK_BUILDERS: dict[str, Builder] = {}
"""Task name → its builder, filled by :func:`register` when ``tacreasoner.tasks.families`` is imported (as
:mod:`tacreasoner.tasks.builders` does)."""


def register(*tasks: str) -> Callable[[Builder], Builder]:
    """Decorator: ``builder`` builds ``tasks``; a task registered twice is a ValueError naming both builders."""

    def add(builder: Builder) -> Builder:
        for task in tasks:
            if task in TASK_BUILDERS:
                raise ValueError(f"task {task!r} already has a builder ({TASK_BUILDERS[task].__module__}."
                                 f"{TASK_BUILDERS[task].__qualname__}); cannot register {builder.__qualname__}")
            TASK_BUILDERS[task] = builder
        return builder

    return add

