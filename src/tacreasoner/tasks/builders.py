"""QA builders: labelled ``TactileClip``s → ``QAItem``s for every benchmark task.

- **Wording is data**: questions come from ``tasks/templates/*.yaml``, TSA scenarios from
  ``tasks/scenarios.yaml``; gold answer text comes from :func:`answers.render_answer`, which follows
  the table in ``schema.py`` exactly.
- **Deterministic**: clips are sorted by ``clip_id`` and every task draws from its own random stream
  seeded by ``(seed, task)``, so the same inputs give the same items and adding a task to a run does
  not change the items of the others.
- **Balanced**: answer positions, letters, yes/no, real/fake, contact states, attributes, directions
  and templates are drawn from shuffled plans that use every value equally often; multi-video items
  always show distinct objects and never a tie (except PC, whose "similar" answer is a tie by design).
- **Missing labels**: a clip without the labels a task needs is skipped for that task and counted in
  the report (``TaskReport.skipped``).
- **Nothing to build**: a task that yields no item (or fewer than asked) is *not* an error, because a
  small split may simply lack fruit, phases or rank variety. :func:`build_items` then emits a
  :class:`TaskBuildWarning`; :func:`build_items_with_report` returns the full :class:`BuildReport`.
  Mistakes in the request itself raise ``ValueError``: unknown task or vocabulary, a TFA attribute the
  vocabulary lacks, and TSA in a ``train`` split (TSA is zero-shot and never trained on).
"""

from __future__ import annotations

import itertools
import re
import warnings
import zlib
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar

import numpy as np

from tacreasoner.data.clip import TactileClip
from tacreasoner.tasks.answers import LETTERS, ordinal_answer, render_answer
from tacreasoner.tasks.scenarios import Scenario, load_scenarios, scenarios_for
from tacreasoner.tasks.schema import CONTACT_STATES, PC_RELATIONS, PHASE_TO_STATE, SPLITS, TASKS, QAItem, VideoRef
from tacreasoner.tasks.templating import Template, load_templates
from tacreasoner.tasks.vocab import Attribute, get_vocabulary

T = TypeVar("T")

ZERO_SHOT_TASKS = ("TSA",)
"""Tasks that must never appear in a training split."""
MIN_SEGMENT = 4
"""OCSE: shortest contact-phase run (and segment) in frames."""
MAX_TRIES = 50
"""Draws per planned item before giving up on it (no valid, non-duplicate combination found)."""
TSA_OPTIONS = (ordinal_answer(0), ordinal_answer(1))

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


class _Cycler(Generic[T]):
    """Draws without replacement, reshuffling when exhausted, so a pool is used evenly."""

    def __init__(self, items: Sequence[T], rng: np.random.Generator) -> None:
        self.items = list(items)
        self.rng = rng
        self.queue: list[T] = []

    def next(self) -> T:
        if not self.queue:
            self.queue = [self.items[i] for i in self.rng.permutation(len(self.items))]
        return self.queue.pop()


def _balanced(values: Sequence[T], n: int, rng: np.random.Generator) -> list[T]:
    """``n`` values using each value equally often (±1), in random order."""
    k = len(values)
    out = list(values) * (n // k) + [values[i] for i in rng.permutation(k)[: n % k]]
    return [out[i] for i in rng.permutation(n)]


def _plan(n: int, rng: np.random.Generator, **axes: Sequence[Any]) -> list[dict[str, Any]]:
    """``n`` targets, each axis balanced on its own and shuffled independently of the others."""
    columns = {name: _balanced(values, n, rng) for name, values in axes.items()}
    return [{name: col[i] for name, col in columns.items()} for i in range(n)]


def _pick(pool: Sequence[T], rng: np.random.Generator) -> T:
    return pool[int(rng.integers(len(pool)))]


def _join(words: Sequence[str]) -> str:
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


def _video(clip: TactileClip, start: int | None = None, end: int | None = None) -> VideoRef:
    path = Path(clip.path).as_posix() if clip.path is not None else None
    return VideoRef(clip.clip_id, path, start, end)


def _rank_groups(clips: Sequence[TactileClip], vocabulary: str, attribute: str) -> dict[int, list[TactileClip]]:
    groups: dict[int, list[TactileClip]] = {}
    for c in clips:
        r = rank_of(c, vocabulary, attribute)
        if r is not None:
            groups.setdefault(r, []).append(c)
    return dict(sorted(groups.items()))


def _partner(groups: Mapping[int, Sequence[TactileClip]], value: int, rng: np.random.Generator) -> TactileClip | None:
    """A clip from any group other than ``value``, uniformly over those clips (without listing them)."""
    sizes = [(key, len(g)) for key, g in groups.items() if key != value]
    i = int(rng.integers(max(1, sum(n for _, n in sizes))))
    for key, n in sizes:
        if i < n:
            return groups[key][i]
        i -= n
    return None


# ------------------------------------------------------------------------------------------ context


@dataclass
class _Context:
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
        cyclers: dict[tuple[str, Any], _Cycler[Template]] = {}
        for p in plan:
            k = kind if isinstance(kind, str) else kind(p)
            key = (k, p[within] if within else None)
            if key not in cyclers:
                cyclers[key] = _Cycler(self.templates[k], self.rng)
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
            videos=videos if videos is not None else [_video(c) for c in clips],
            objects=[c.object_id for c in clips], vocabulary=self.vocabulary, options=list(options),
            split=self.split, source=self.source,
            meta={"template": template.id, "slots": dict(slots), "object_names": [c.object_name for c in clips],
                  **(meta or {})},
        ))
        return True

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


# ------------------------------------------------------------------------------------------ tasks


def _tfa(clips: Sequence[TactileClip], n: int | None, ctx: _Context, attribute: str) -> list[QAItem]:
    attr = ctx.vocab[attribute]
    eligible = [c for c in clips if rank_of(c, ctx.vocabulary, attribute) is not None]
    ctx.skip(len(clips) - len(eligible), f"no {ctx.vocabulary} label for {attribute}")
    if not eligible:
        return ctx.finish()
    cycler = _Cycler(eligible, ctx.rng)
    plan = ctx.with_templates(_plan(len(eligible) if n is None else n, ctx.rng), "tfa")
    quoted = [f'"{phrase}"' for phrase in attr.levels]
    choices = f"{', '.join(quoted[:-1])} or {quoted[-1]}"

    def attempt(p: dict) -> bool:
        c = cycler.next()
        level = rank_of(c, ctx.vocabulary, attribute)
        return ctx.add((c.clip_id,), p["template"], [c], {"attribute": attribute, "level": level},
                       {"attribute": attribute, "choices": choices}, meta={"attribute": attribute, "ranks": [level]})

    return ctx.run(plan, attempt, "clip")


def _tfa_combined(clips: Sequence[TactileClip], n: int | None, ctx: _Context) -> list[QAItem]:
    attrs = list(ctx.vocab)
    eligible = [c for c in clips if ranks_of(c, ctx.vocabulary, attrs) is not None]
    ctx.skip(len(clips) - len(eligible), f"missing some {ctx.vocabulary} labels ({', '.join(attrs)})")
    if not eligible:
        return ctx.finish()
    cycler = _Cycler(eligible, ctx.rng)
    plan = ctx.with_templates(_plan(len(eligible) if n is None else n, ctx.rng), "tfa_combined")
    slots = {"attributes": _join(attrs), "format": "; ".join(f"{a}: …" for a in attrs)}

    def attempt(p: dict) -> bool:
        c = cycler.next()
        levels = ranks_of(c, ctx.vocabulary, attrs)
        return ctx.add((c.clip_id,), p["template"], [c], {"levels": levels}, slots, meta={"ranks": [levels]})

    return ctx.run(plan, attempt, "clip")


def _labelled_any(clips: Sequence[TactileClip], ctx: _Context) -> list[TactileClip]:
    labelled = [c for c in clips if any(rank_of(c, ctx.vocabulary, a) is not None for a in ctx.vocab)]
    ctx.skip(len(clips) - len(labelled), f"no {ctx.vocabulary} labels")
    return labelled


_SFD_ANSWERS = (("which", 0), ("which", 1), ("yesno", True), ("yesno", False))


def _pairwise_pools(clips: Sequence[TactileClip], ctx: _Context
                    ) -> tuple[list[TactileClip], dict[str, dict[int, list[TactileClip]]], list[str], dict] | None:
    """SFD/PC: the labelled clips, their rank groups per attribute, the attributes with two ranks or more and a
    cycler over each one's clips; None (noted) when no attribute has two ranks."""
    labelled = _labelled_any(clips, ctx)
    groups = {a: _rank_groups(labelled, ctx.vocabulary, a) for a in ctx.vocab}
    attrs = [a for a, g in groups.items() if len(g) >= 2]
    if not attrs:
        ctx.report.notes.append("no attribute has two different ranks among the clips")
        return None
    return labelled, groups, attrs, {a: _Cycler([c for g in groups[a].values() for c in g], ctx.rng) for a in attrs}


def _sfd(clips: Sequence[TactileClip], n: int | None, ctx: _Context) -> list[QAItem]:
    pools = _pairwise_pools(clips, ctx)
    if pools is None:
        return ctx.finish()
    labelled, groups, attrs, cyclers = pools
    plan = _plan(len(labelled) if n is None else n, ctx.rng, attribute=attrs, direction=("more", "less"),
                 answer=_SFD_ANSWERS)
    plan = ctx.with_templates(plan, lambda p: f"sfd_{p['answer'][0]}")

    def attempt(p: dict) -> bool:
        a_name, direction, (kind, value) = p["attribute"], p["direction"], p["answer"]
        a = cyclers[a_name].next()
        ra = rank_of(a, ctx.vocabulary, a_name)
        b = _partner(groups[a_name], ra, ctx.rng)
        if b is None or b.object_id == a.object_id:
            return False
        rb = rank_of(b, ctx.vocabulary, a_name)
        winner, loser = (a, b) if (ra > rb) == (direction == "more") else (b, a)
        winner_pos = value if kind == "which" else (0 if value else 1)
        pair = [winner, loser] if winner_pos == 0 else [loser, winner]
        gold = ({"kind": "which", "index": value} if kind == "which" else {"kind": "yesno", "value": value})
        gold |= {"attribute": a_name, "direction": direction}
        attr = ctx.vocab[a_name]
        slots = {"attribute": a_name, "comparative": attr.more if direction == "more" else attr.less}
        ranks = [rank_of(c, ctx.vocabulary, a_name) for c in pair]
        key = (*(c.clip_id for c in pair), a_name, direction, kind)
        return ctx.add(key, p["template"], pair, gold, slots, meta={"attribute": a_name, "ranks": ranks})

    return ctx.run(plan, attempt, "pair of different objects with different ranks")


def _pc(clips: Sequence[TactileClip], n: int | None, ctx: _Context) -> list[QAItem]:
    """PC (Octopi's property comparison): more, less or similar X in the first object than in the second, each
    relation equally often; "similar" pairs two different objects of the same level."""
    pools = _pairwise_pools(clips, ctx)
    if pools is None:
        return ctx.finish()
    labelled, groups, attrs, cyclers = pools
    plan = ctx.with_templates(_plan(len(labelled) if n is None else n, ctx.rng, attribute=attrs,
                                    relation=PC_RELATIONS), "pc")
    beyond = {"more": lambda r, ra: r < ra, "less": lambda r, ra: r > ra, "similar": lambda r, ra: r == ra}

    def attempt(p: dict) -> bool:
        a_name, relation = p["attribute"], p["relation"]
        a = cyclers[a_name].next()
        ra = rank_of(a, ctx.vocabulary, a_name)
        pool = [c for r, g in groups[a_name].items() if beyond[relation](r, ra) for c in g
                if c.object_id != a.object_id]
        if not pool:
            return False
        b = _pick(pool, ctx.rng)
        gold = {"attribute": a_name, "relation": relation}
        ranks = [ra, rank_of(b, ctx.vocabulary, a_name)]
        return ctx.add((a.clip_id, b.clip_id, a_name), p["template"], [a, b], gold, {"attribute": a_name},
                       meta={"attribute": a_name, "ranks": ranks})

    return ctx.run(plan, attempt, "pair of different objects in that relation")


def _extreme_pools(groups: Mapping[int, list[TactileClip]]) -> dict[str, tuple[list, dict[int, list]]]:
    """Per direction: clips that can be a unique extreme, and per rank the clips strictly beyond it.

    A clip can be the unique extreme when at least two other objects rank strictly beyond it.
    """
    out = {}
    for direction, beyond in (("most", lambda r, q: q < r), ("least", lambda r, q: q > r)):
        extremes, others = [], {}
        for r, g in groups.items():
            others[r] = [c for q, h in groups.items() if beyond(r, q) for c in h]
            if len({c.object_id for c in others[r]}) >= 2:
                extremes.extend(g)
        if extremes:
            out[direction] = (extremes, others)
    return out


def _soi(clips: Sequence[TactileClip], n: int | None, ctx: _Context) -> list[QAItem]:
    labelled = _labelled_any(clips, ctx)
    groups = {a: _rank_groups(labelled, ctx.vocabulary, a) for a in ctx.vocab}
    pools = {(a, d): pool for a in ctx.vocab for d, pool in _extreme_pools(groups[a]).items()}
    if not pools:
        ctx.report.notes.append("no attribute has a rank with two other objects ranked strictly beyond it")
        return ctx.finish()
    cyclers = {k: _Cycler(extremes, ctx.rng) for k, (extremes, _) in pools.items()}
    plan = ctx.with_templates(_plan(len(labelled) if n is None else n, ctx.rng, combo=list(pools),
                                    index=(0, 1, 2)), "soi")

    def attempt(p: dict) -> bool:
        (a_name, direction), index = p["combo"], p["index"]
        e = cyclers[p["combo"]].next()
        candidates = pools[p["combo"]][1][rank_of(e, ctx.vocabulary, a_name)]
        i, j = ctx.rng.choice(len(candidates), size=2, replace=False)
        others = [candidates[i], candidates[j]]
        if len({e.object_id, *(c.object_id for c in others)}) < 3:
            return False
        trio = [*others[:index], e, *others[index:]]
        attr = ctx.vocab[a_name]
        slots = {"attribute": a_name, "superlative": attr.most if direction == "most" else attr.least}
        gold = {"index": index, "attribute": a_name, "direction": direction}
        ranks = [rank_of(c, ctx.vocabulary, a_name) for c in trio]
        key = (*(c.clip_id for c in trio), a_name, direction)
        return ctx.add(key, p["template"], trio, gold, slots, meta={"attribute": a_name, "ranks": ranks})

    return ctx.run(plan, attempt, "triple with a unique extreme")


def _osc(clips: Sequence[TactileClip], n: int | None, ctx: _Context) -> list[QAItem]:
    attrs = list(ctx.vocab)
    profile = {c.clip_id: r for c in clips if (r := ranks_of(c, ctx.vocabulary, attrs)) is not None}
    labelled = [c for c in clips if c.clip_id in profile]
    ctx.skip(len(clips) - len(labelled), f"missing some {ctx.vocabulary} labels ({', '.join(attrs)})")
    eligible = [c for c in labelled if object_label(c)]
    ctx.skip(len(labelled) - len(eligible), "no object name")
    if len({object_label(c) for c in eligible}) < 3:
        ctx.report.notes.append("fewer than three distinct object names")
        return ctx.finish()
    cycler = _Cycler(eligible, ctx.rng)
    plan = ctx.with_templates(_plan(len(eligible) if n is None else n, ctx.rng,
                                    assignment=list(itertools.permutations(range(3)))), "osc")

    def attempt(p: dict) -> bool:
        trio = [cycler.next(), _pick(eligible, ctx.rng), _pick(eligible, ctx.rng)]
        names = [object_label(c) for c in trio]
        ranks = [profile[c.clip_id] for c in trio]
        vectors = {tuple(r.values()) for r in ranks}
        if len({c.object_id for c in trio}) < 3 or len(set(names)) < 3 or len(vectors) < 3:
            return False
        assignment = list(p["assignment"])
        options = [""] * 3
        for v, k in enumerate(assignment):
            options[k] = names[v]
        shown = " ".join(f"({letter}) {name}" for letter, name in zip(LETTERS, options, strict=True))
        return ctx.add(tuple(c.clip_id for c in trio), p["template"], trio, {"assignment": assignment},
                       {"options": shown}, options=options, meta={"ranks": ranks})

    return ctx.run(plan, attempt, "triple of distinguishable objects with distinct names")


def _tsa(clips: Sequence[TactileClip], n: int | None, ctx: _Context) -> list[QAItem]:
    check_split_allows(ctx.task, ctx.split)
    applicable = scenarios_for(ctx.vocabulary, ctx.scenarios)
    if not applicable:
        ctx.report.notes.append(f"no scenario applies to the {ctx.vocabulary} vocabulary")
        return ctx.finish()
    groups: dict[str, dict[int, list[TactileClip]]] = {}
    needed: dict[tuple[str, str], dict[str, int]] = {}
    """(scenario, clip) → the clip's ranks on the scenario's needs."""
    for s in applicable:
        scored: dict[int, list[TactileClip]] = {}
        for c in clips:
            ranks = ranks_of(c, ctx.vocabulary, list(s.needs))
            if ranks is not None:
                needed[s.id, c.clip_id] = ranks
                scored.setdefault(s.score(ranks), []).append(c)
        if len(scored) >= 2:
            groups[s.id] = dict(sorted(scored.items()))
    usable = {clip_id for _, clip_id in needed}
    ctx.skip(len(clips) - len(usable), f"no {ctx.vocabulary} labels for any scenario's needs")
    feasible = [s for s in applicable if s.id in groups]
    if not feasible:
        ctx.report.notes.append("no scenario separates any two clips")
        return ctx.finish()
    cyclers = {s.id: _Cycler([c for g in groups[s.id].values() for c in g], ctx.rng) for s in feasible}
    plan = ctx.with_templates(_plan(len(usable) if n is None else n, ctx.rng, scenario=feasible, letter=("A", "B")),
                              "tsa", within="letter")
    shown = " ".join(f"({letter}) {o}" for letter, o in zip(LETTERS, TSA_OPTIONS, strict=False))

    def attempt(p: dict) -> bool:
        s: Scenario = p["scenario"]
        a = cyclers[s.id].next()
        sa = s.score(needed[s.id, a.clip_id])
        b = _partner(groups[s.id], sa, ctx.rng)
        if b is None or b.object_id == a.object_id:
            return False
        sb = s.score(needed[s.id, b.clip_id])
        better, worse = (a, b) if sa > sb else (b, a)
        pair = [better, worse] if p["letter"] == "A" else [worse, better]
        gold = {"letter": p["letter"], "scenario": s.id, "needs": dict(s.needs)}
        ranks = [needed[s.id, c.clip_id] for c in pair]
        meta = {"scenario_text": s.text, "scores": [s.score(r) for r in ranks], "ranks": ranks}
        return ctx.add((*(c.clip_id for c in pair), s.id), p["template"], pair, gold,
                       {"scenario": s.text, "options": shown}, options=TSA_OPTIONS, meta=meta)

    return ctx.run(plan, attempt, "pair of different objects with different scenario scores")


def _rfor_targets(n: int | None, real: list, fake: list, ctx: _Context) -> list[bool]:
    """Real/fake targets: balanced when both exist; with ``n=None`` each clip once, balanced as far as possible."""
    present = [v for v, pool in ((True, real), (False, fake)) if pool]
    if len(present) == 1:
        ctx.report.notes.append(f"only {'real' if present[0] else 'fake'} fruit clips: RFOR cannot be balanced")
    if n is not None:
        return _balanced(present, n, ctx.rng)
    k = min(len(real), len(fake))
    rest = [len(real) > len(fake)] * (len(real) + len(fake) - 2 * k)
    targets = [True, False] * k + rest
    return [targets[i] for i in ctx.rng.permutation(len(targets))]


def _rfor(clips: Sequence[TactileClip], n: int | None, ctx: _Context) -> list[QAItem]:
    for c in clips:
        if c.is_real is not None and not isinstance(c.is_real, bool):
            raise ValueError(f"clip {c.clip_id!r}: labels['real'] must be true, false or null, got {c.is_real!r}")
    labelled = [c for c in clips if c.is_real is not None]
    ctx.skip(len(clips) - len(labelled), "no real/fake label")
    eligible = [c for c in labelled if c.category]
    ctx.skip(len(labelled) - len(eligible), "no fruit category")
    if not eligible:
        return ctx.finish()
    pools = {True: [c for c in eligible if c.is_real], False: [c for c in eligible if not c.is_real]}
    cyclers = {v: _Cycler(pool, ctx.rng) for v, pool in pools.items() if pool}
    plan = [{"real": t} for t in _rfor_targets(n, pools[True], pools[False], ctx)]
    plan = ctx.with_templates(plan, "rfor")

    def attempt(p: dict) -> bool:
        c = cyclers[p["real"]].next()
        return ctx.add((c.clip_id,), p["template"], [c], {"real": p["real"], "fruit": c.category},
                       {"fruit": c.category})

    return ctx.run(plan, attempt, "fruit clip")


def contact_runs(phases: Sequence[str], min_length: int = MIN_SEGMENT) -> list[tuple[str, int, int]]:
    """Maximal runs ``(state, start, end)`` of one contact phase lasting at least ``min_length`` frames."""
    runs, start = [], 0
    for i in range(1, len(phases) + 1):
        if i == len(phases) or phases[i] != phases[start]:
            state = PHASE_TO_STATE.get(phases[start])
            if state is not None and i - start >= min_length:
                runs.append((state, start, i))
            start = i
    return runs


def _ocse(clips: Sequence[TactileClip], n: int | None, ctx: _Context) -> list[QAItem]:
    phases = {c.clip_id: list(c.phases or []) for c in clips}
    with_phases = [c for c in clips if phases[c.clip_id]]
    ctx.skip(len(clips) - len(with_phases), "no per-frame phases")
    consistent = [c for c in with_phases if c.n_frames is None or len(phases[c.clip_id]) == c.n_frames]
    ctx.skip(len(with_phases) - len(consistent), "phase list length differs from n_frames")
    runs = {c.clip_id: contact_runs(phases[c.clip_id]) for c in consistent}
    eligible = [c for c in consistent if runs[c.clip_id]]
    ctx.skip(len(consistent) - len(eligible), f"no contact phase lasting {MIN_SEGMENT}+ frames")
    if not eligible:
        return ctx.finish()
    cycler = _Cycler(eligible, ctx.rng)
    plan = ctx.with_templates(_plan(len(eligible) if n is None else n, ctx.rng), "ocse")
    used: Counter = Counter()
    options = list(CONTACT_STATES)

    def attempt(p: dict) -> bool:
        c = cycler.next()
        states = [s for s in CONTACT_STATES if any(r[0] == s for r in runs[c.clip_id])]
        fewest = min(used[s] for s in states)
        state = _pick([s for s in states if used[s] == fewest], ctx.rng)
        _, r0, r1 = _pick([r for r in runs[c.clip_id] if r[0] == state], ctx.rng)
        length = int(ctx.rng.integers(MIN_SEGMENT, r1 - r0 + 1))
        start = r0 + int(ctx.rng.integers(0, r1 - r0 - length + 1))
        meta = {"phase": phases[c.clip_id][start], "run": [r0, r1], "action": c.action}
        added = ctx.add((c.clip_id, start, start + length), p["template"], [c], {"state": state},
                        {"options": ", ".join(options)}, videos=[_video(c, start, start + length)],
                        options=options, meta=meta)
        used[state] += added
        return added

    return ctx.run(plan, attempt, "segment")


_BUILDERS: dict[str, Callable[[Sequence[TactileClip], int | None, _Context], list[QAItem]]] = {
    "TFA-combined": _tfa_combined, "SFD": _sfd, "PC": _pc, "SOI": _soi, "OSC": _osc, "TSA": _tsa, "RFOR": _rfor,
    "OCSE": _ocse,
}


# ------------------------------------------------------------------------------------------ public API


def check_split_allows(task: str, split: str) -> None:
    """TSA is zero-shot: refuse to build it for training."""
    if task in ZERO_SHOT_TASKS and split == "train":
        raise ValueError(f"{task} is zero-shot and must never be used in training; refusing to build it for "
                         f"split 'train' (build it for 'val' or 'test')")


def check_task(task: str, vocabulary: str) -> None:
    """ValueError unless ``task`` is known and defined for ``vocabulary``."""
    if task not in TASKS:
        raise ValueError(f"unknown task {task!r}; known: {', '.join(TASKS)}")
    vocab = get_vocabulary(vocabulary)
    attribute = task.removeprefix("TFA-")
    if task.startswith("TFA-") and task != "TFA-combined" and attribute not in vocab:
        raise ValueError(f"task {task!r} is not defined for the {vocabulary} vocabulary "
                         f"(attributes: {', '.join(vocab)})")


def _prepare(clips: Sequence[TactileClip]) -> list[TactileClip]:
    """Clips in a canonical order (by id) so results do not depend on listing order."""
    ids = Counter(c.clip_id for c in clips)
    dupes = sorted(i for i, k in ids.items() if k > 1)
    if dupes:
        raise ValueError(f"duplicate clip ids: {', '.join(dupes[:5])}{' …' if len(dupes) > 5 else ''}")
    return sorted(clips, key=lambda c: c.clip_id)


def _build_task(task: str, clips: list[TactileClip], *, vocabulary: str, split: str, seed: int, n: int | None,
                source: str, report: BuildReport) -> list[QAItem]:
    rng = np.random.default_rng(np.random.SeedSequence([seed, zlib.crc32(task.encode())]))
    ctx = _Context(task, vocabulary, split, source, rng, load_templates(), load_scenarios(), TaskReport(task))
    report.tasks[task] = ctx.report
    if task in _BUILDERS:
        return _BUILDERS[task](clips, n, ctx)
    return _tfa(clips, n, ctx, task.removeprefix("TFA-"))


def build_items_with_report(clips: Sequence[TactileClip], *, tasks: Sequence[str], vocabulary: str, split: str,
                            seed: int, per_task: int | None = None, source: str = "",
                            ) -> tuple[list[QAItem], BuildReport]:
    """Like :func:`build_items`, returning the :class:`BuildReport` instead of emitting warnings."""
    for task in tasks:
        check_task(task, vocabulary)
        check_split_allows(task, split)
    repeated = sorted(t for t, k in Counter(tasks).items() if k > 1)
    if repeated:
        raise ValueError(f"tasks listed more than once: {', '.join(repeated)}")
    if split and split not in SPLITS:
        raise ValueError(f"split must be one of {SPLITS}, got {split!r}")
    if per_task is not None and per_task < 1:
        raise ValueError(f"per_task must be None or >= 1, got {per_task}")
    ordered = _prepare(clips)
    report = BuildReport()
    items: list[QAItem] = []
    for task in tasks:
        items += _build_task(task, ordered, vocabulary=vocabulary, split=split, seed=seed, n=per_task,
                             source=source, report=report)
    return items, report


def build_items(clips: Sequence[TactileClip], *, tasks: Sequence[str], vocabulary: str, split: str, seed: int,
                per_task: int | None = None, source: str = "") -> list[QAItem]:
    """QA items for ``tasks`` from labelled clips, deterministic in ``seed``.

    ``per_task=None`` builds one item per usable clip for single-clip tasks and as many items as
    there are usable clips for multi-clip tasks. Item ids are ``{source}-{split}-{task}-{n:05d}``
    (empty parts left out). A task that cannot build any item, or fewer than asked, emits a
    :class:`TaskBuildWarning` (see :func:`build_items_with_report` for the structured report).
    """
    items, report = build_items_with_report(clips, tasks=tasks, vocabulary=vocabulary, split=split, seed=seed,
                                            per_task=per_task, source=source)
    for message in report.warnings:
        warnings.warn(message, TaskBuildWarning, stacklevel=2)
    return items


def _one(task: str, clips: Sequence[TactileClip], vocabulary: str, split: str, seed: int, n: int | None,
         source: str) -> list[QAItem]:
    items, report = build_items_with_report(clips, tasks=[task], vocabulary=vocabulary, split=split, seed=seed,
                                            per_task=n, source=source)
    for message in report.warnings:
        warnings.warn(message, TaskBuildWarning, stacklevel=3)
    return items


def build_tfa(clips: Sequence[TactileClip], attribute: str, *, vocabulary: str = "vtv150k", split: str = "test",
              seed: int = 0, n: int | None = None, source: str = "") -> list[QAItem]:
    """TFA-<attribute>: the level phrase of one property of one object."""
    return _one(f"TFA-{attribute}", clips, vocabulary, split, seed, n, source)


def build_tfa_combined(clips: Sequence[TactileClip], *, vocabulary: str = "vtv150k", split: str = "test",
                       seed: int = 0, n: int | None = None, source: str = "") -> list[QAItem]:
    """TFA-combined: every property of one object, ``attribute: phrase; …`` in vocabulary order."""
    return _one("TFA-combined", clips, vocabulary, split, seed, n, source)


def build_sfd(clips: Sequence[TactileClip], *, vocabulary: str = "vtv150k", split: str = "test", seed: int = 0,
              n: int | None = None, source: str = "") -> list[QAItem]:
    """SFD: which of two objects is more/less X, or a yes/no comparison; never a tie."""
    return _one("SFD", clips, vocabulary, split, seed, n, source)


def build_pc(clips: Sequence[TactileClip], *, vocabulary: str = "physiclear", split: str = "test", seed: int = 0,
             n: int | None = None, source: str = "") -> list[QAItem]:
    """PC: does the first object have more, less or similar X than the second (Octopi's property comparison)."""
    return _one("PC", clips, vocabulary, split, seed, n, source)


def build_soi(clips: Sequence[TactileClip], *, vocabulary: str = "vtv150k", split: str = "test", seed: int = 0,
              n: int | None = None, source: str = "") -> list[QAItem]:
    """SOI: the most/least X of three objects, with a unique extreme."""
    return _one("SOI", clips, vocabulary, split, seed, n, source)


def build_osc(clips: Sequence[TactileClip], *, vocabulary: str = "vtv150k", split: str = "test", seed: int = 0,
              n: int | None = None, source: str = "") -> list[QAItem]:
    """OSC: match three videos to three object names shown as (A) (B) (C)."""
    return _one("OSC", clips, vocabulary, split, seed, n, source)


def build_tsa(clips: Sequence[TactileClip], *, vocabulary: str = "vtv150k", split: str = "test", seed: int = 0,
              n: int | None = None, source: str = "") -> list[QAItem]:
    """TSA: which of two objects suits a scenario better (zero-shot; refuses ``split="train"``)."""
    return _one("TSA", clips, vocabulary, split, seed, n, source)


def build_rfor(clips: Sequence[TactileClip], *, vocabulary: str = "vtv150k", split: str = "test", seed: int = 0,
               n: int | None = None, source: str = "") -> list[QAItem]:
    """RFOR: is this fruit real or fake (clips with ``labels["real"]`` set)."""
    return _one("RFOR", clips, vocabulary, split, seed, n, source)


def build_ocse(clips: Sequence[TactileClip], *, vocabulary: str = "vtv150k", split: str = "test", seed: int = 0,
               n: int | None = None, source: str = "") -> list[QAItem]:
    """OCSE: the contact state of a segment inside one contact-phase run of a clip."""
    return _one("OCSE", clips, vocabulary, split, seed, n, source)
