"""QA builders: labelled ``TactileClip``s → ``QAItem``s for every benchmark task.

Each task family is one module under ``tasks/families/`` registered by task name
(:data:`tacreasoner.tasks.building.TASK_BUILDERS`); this module checks a request and runs the builders.

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

import warnings
import zlib
from collections import Counter
from collections.abc import Sequence

import numpy as np

from tacreasoner.data.clip import TactileClip
from tacreasoner.tasks import families
from tacreasoner.tasks.building import (
    TASK_BUILDERS,
    BuildContext,
    Builder,
    BuildReport,
    TaskBuildWarning,
    TaskReport,
    check_split_allows,
)
from tacreasoner.tasks.scenarios import load_scenarios
from tacreasoner.tasks.schema import SPLITS, TASKS, ZERO_SHOT_TASKS, QAItem
from tacreasoner.tasks.templating import load_templates
from tacreasoner.tasks.vocab import get_vocabulary

__all__ = [
    "ZERO_SHOT_TASKS",
    "BuildReport",
    "TaskBuildWarning",
    "TaskReport",
    "build_items",
    "build_items_with_report",
    "build_ocse",
    "build_osc",
    "build_pc",
    "build_rfor",
    "build_sfd",
    "build_soi",
    "build_tfa",
    "build_tfa_combined",
    "build_tsa",
    "builder_for",
    "check_split_allows",
    "check_task",
]


def check_task(task: str, vocabulary: str) -> None:
    """ValueError unless ``task`` is known and defined for ``vocabulary``."""
    if task not in TASKS:
        raise ValueError(f"unknown task {task!r}; known: {', '.join(TASKS)}")
    vocab = get_vocabulary(vocabulary)
    attribute = task.removeprefix("TFA-")
    if task.startswith("TFA-") and task != "TFA-combined" and attribute not in vocab:
        raise ValueError(f"task {task!r} is not defined for the {vocabulary} vocabulary "
                         f"(attributes: {', '.join(vocab)})")


def builder_for(task: str) -> Builder:
    """The registered builder of ``task``; ValueError listing the registered tasks when there is none."""
    try:
        return TASK_BUILDERS[task]
    except KeyError:
        raise ValueError(f"no builder registered for task {task!r}; registered: {', '.join(TASK_BUILDERS)} "
                         f"(families: {', '.join(families.__all__)})") from None


def _prepare(clips: Sequence[TactileClip]) -> list[TactileClip]:
    """Clips in a canonical order (by id) so results do not depend on listing order."""
    ids = Counter(c.clip_id for c in clips)
    dupes = sorted(i for i, k in ids.items() if k > 1)
    if dupes:
        raise ValueError(f"duplicate clip ids: {', '.join(dupes[:5])}{' …' if len(dupes) > 5 else ''}")
    return sorted(clips, key=lambda c: c.clip_id)


def _build_task(task: str, clips: list[TactileClip], *, vocabulary: str, split: str, seed: int, n: int | None,
                source: str, report: BuildReport) -> list[QAItem]:
    build = builder_for(task)
    rng = np.random.default_rng(np.random.SeedSequence([seed, zlib.crc32(task.encode())]))
    ctx = BuildContext(task, vocabulary, split, source, rng, load_templates(), load_scenarios(), TaskReport(task))
    report.tasks[task] = ctx.report
    return build(clips, n, ctx)


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
