"""TouchCoT filter (paper §3.1 step 3): keep only teacher outputs that are well-formed, right and grounded.

Each sample is checked and marked ``accepted`` (True/False) with named ``reject_reasons``:

* ``format`` — the output must be exactly ``<think>…</think><answer>…</answer>`` (strict extraction,
  and the think block must be there). A format failure short-circuits the other checks: without a
  well-formed output they would only repeat the same failure under other names.
* ``wrong_answer`` — the answer must be judged right by the task scorer in strict mode, so the model
  is trained only on answers the benchmark would count as right.
* ``missing_stages`` — the reasoning must mention every stage in ``sample.stages`` (stage words,
  verb forms and synonyms, see :data:`STAGE_PATTERNS`). Mentions are counted, not understood: "no
  sliding occurred" covers *slide*.
* ``contradiction`` — the reasoning's own last readable conclusion ("so / therefore / thus / hence /
  overall / which means …") must not name another value than the answer; it is read with the same
  task parser as answers, in lenient mode (via :func:`~tacreasoner.tasks.scoring.score_item`). No
  readable conclusion → no contradiction. Negated conclusions ("so it is not hard") are not read
  (except RFOR, whose parser understands negation), and a yes/no item's conclusion is read only when
  it starts with yes/no ("So yes, …"): "no" is far more often a determiner ("no slip").
* ``too_short`` / ``too_long`` — think length in characters; an over-long answer is ``too_long`` too.
* ``near_duplicate`` — the think text is a near copy (character 5-gram Jaccard ≥ threshold) of an
  earlier *accepted* sample of the same task; the first one is kept. Candidates come from MinHash
  LSH, and every candidate is verified with the exact Jaccard, so a reported duplicate is a real one
  (a true duplicate at the threshold is missed with probability < 1e-3, by construction of the bands).
  ``dedup: false`` turns this check off (templated teachers repeat themselves by design).
* ``reviewer_reject`` — a manual auditor rejected it (:mod:`tacreasoner.cot.audit`); re-filtering
  keeps that verdict.

**How a sample carries its QA item**: ``sample.meta["item"] = item.to_dict()`` (a ``QAItem`` object
is accepted too). The sample's own fields cannot rebuild the item — they lack the machine-readable
gold, the vocabulary and the options the scorers need — so the pipeline stores the whole item, and
:func:`item_of` checks that it agrees with the sample (id, task, gold answer, question).

Details of each verdict (missing stages, the conclusion read, the duplicate's key and similarity) go
to ``sample.meta["filter"]`` for the audit page.
"""

from __future__ import annotations

import re
from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from tacreasoner.cot.schema import CoTSample
from tacreasoner.fields import reject_unknown_fields
from tacreasoner.tasks.extract import extract_answer, split_reasoning
from tacreasoner.tasks.schema import QAItem
from tacreasoner.tasks.scoring import score_item

__all__ = [
    "REASONS",
    "STAGE_PATTERNS",
    "FilterConfig",
    "FilterResult",
    "acceptance_stats",
    "class_labels",
    "conclusion",
    "filter_samples",
    "item_of",
    "jaccard",
    "missing_stages",
    "shingles",
    "stages_mentioned",
]

REASONS = ("format", "wrong_answer", "missing_stages", "contradiction", "too_short", "too_long", "near_duplicate",
           "reviewer_reject")
"""Every reject reason, in the order they are listed on a sample."""


# ------------------------------------------------------------------------------------------------ config


@dataclass
class FilterConfig:
    min_think_chars: int = 80
    max_think_chars: int = 4000
    max_answer_chars: int = 200
    dedup_threshold: float = 0.9
    """Character 5-gram Jaccard at or above which a think text is a near duplicate; 1.0 = exact copies only."""
    dedup: bool = True
    """False keeps repeated reasoning: a templated teacher (the rules teacher's brief style) repeats by
    design, and dropping its repeats would drop most of the short-reasoning tasks' data."""
    require_stages: bool = True
    skew_threshold: float = 0.10
    """Warn when a class's share among accepted samples differs from its share among all by more than this."""

    def __post_init__(self) -> None:
        if self.min_think_chars < 0 or self.max_think_chars < self.min_think_chars:
            raise ValueError(f"FilterConfig: need 0 <= min_think_chars <= max_think_chars, got "
                             f"{self.min_think_chars} and {self.max_think_chars}")
        if self.max_answer_chars < 1:
            raise ValueError(f"FilterConfig: max_answer_chars must be >= 1, got {self.max_answer_chars}")
        if not 0.0 < self.dedup_threshold <= 1.0:
            raise ValueError(f"FilterConfig: dedup_threshold must be in (0, 1], got {self.dedup_threshold}")
        if not 0.0 <= self.skew_threshold <= 1.0:
            raise ValueError(f"FilterConfig: skew_threshold must be in [0, 1], got {self.skew_threshold}")

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> FilterConfig:
        """From a YAML/JSON mapping; unknown keys are an error naming them and the known ones."""
        reject_unknown_fields(cls, data, "FilterConfig: unknown key(s)", known="declared")
        return cls(**data)


@dataclass
class FilterResult:
    samples: list[CoTSample]
    """The input samples, in order, with ``accepted`` and ``reject_reasons`` set."""
    stats: dict
    """See :func:`acceptance_stats`."""
    config: FilterConfig

    @property
    def accepted(self) -> list[CoTSample]:
        return [s for s in self.samples if s.accepted]

    @property
    def rejected(self) -> list[CoTSample]:
        return [s for s in self.samples if s.accepted is False]

    @property
    def warnings(self) -> list[str]:
        return list(self.stats.get("warnings", []))


# ------------------------------------------------------------------------------------------------ the item


def item_of(sample: CoTSample) -> QAItem:
    """The sample's QA item from ``meta["item"]``; ValueError naming the sample and field if absent or inconsistent."""
    where = f"sample {sample.key!r} (item {sample.item_id!r})"
    raw = sample.meta.get("item")
    if raw is None:
        raise ValueError(f"{where}: meta['item'] is missing; the pipeline must store meta['item'] = item.to_dict() "
                         f"so the filter can score the answer against the item's gold")
    try:
        item = raw if isinstance(raw, QAItem) else QAItem.from_dict(dict(raw))
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: meta['item'] is not a valid QA item: {e}") from None
    for name, mine, theirs in (("item_id", sample.item_id, item.id), ("task", sample.task, item.task),
                               ("gold_answer", sample.gold_answer, item.answer),
                               ("question", sample.question, item.question)):
        if mine != theirs:
            raise ValueError(f"{where}: field {name!r} is {mine!r} but meta['item'] says {theirs!r}")
    return item


# ------------------------------------------------------------------------------------------------ stages

STAGE_PATTERNS: dict[str, tuple[str, ...]] = {
    "press": (r"press(?:es|ed|ing)?", r"indent(?:s|ed|ing|ation|ations)?", r"load(?:ed|ing)",
              r"compress(?:es|ed|ing|ion)?"),
    "hold": (r"hold(?:s|ing)?", r"held", r"dwell(?:s|ed|ing)?", r"dwelt"),
    "slide": (r"slid(?:e|es|ing)?", r"shear(?:s|ed|ing)?", r"slip(?:s|ped|ping|page)?"),
    "rotate": (r"rotat(?:e|es|ed|ing|ion|ions|ional)", r"twist(?:s|ed|ing)?", r"torsion(?:al)?", r"torque"),
    "release": (r"releas(?:e|es|ed|ing)", r"unload(?:s|ed|ing)?", r"lift(?:s|ed|ing)?[\s-]*off", r"liftoff",
                r"retract(?:s|ed|ing|ion)?", r"withdr(?:aw|aws|awing|awn|ew|awal)"),
}
"""Regex fragments (whole words, case-insensitive) that count as mentioning a stage. "pressure" is not
a press, and "unloading" is a release, not a "loading"."""

_STAGE_RE = {stage: re.compile(r"\b(?:" + "|".join(forms) + r")\b", re.IGNORECASE)
             for stage, forms in STAGE_PATTERNS.items()}


def _stage_regex(stage: str) -> re.Pattern[str]:
    """Known stages use their synonyms; any other stage name matches as a word stem."""
    return _STAGE_RE.get(stage) or re.compile(r"\b" + re.escape(stage) + r"\w*", re.IGNORECASE)


def stages_mentioned(text: str, stages: Iterable[str] = tuple(STAGE_PATTERNS)) -> list[str]:
    """The stages of ``stages`` that ``text`` mentions, in the given order."""
    return [s for s in stages if _stage_regex(s).search(text)]


def missing_stages(text: str, stages: Iterable[str]) -> list[str]:
    """The stages of ``stages`` that ``text`` never mentions, in the given order."""
    stages = list(stages)
    found = set(stages_mentioned(text, stages))
    return [s for s in stages if s not in found]


# ------------------------------------------------------------------------------------------------ contradiction

_SENTENCE_END = re.compile(r"(?<=[.!?])\s+|\n+")
_MARKER = re.compile(
    r"^\W*overall\b|\boverall\s*,"  # "the overall area …" is an adjective, not a conclusion
    r"|\b(?:therefore|thus|hence|consequently|in conclusion|in summary|all in all|which means|this means|"
    r"i conclude|so(?!\s+(?:far|that|much|many|little|long|on|quickly|slowly|strongly|weakly)\b))\b",
    re.IGNORECASE)
_NEGATION = re.compile(r"\b(?:not|never|neither|nor|cannot)\b|n't\b", re.IGNORECASE)
_YES_NO_LEAD = re.compile(r"^\W*(?:the\s+answer\s+is\s+)?(yes|no)\b", re.IGNORECASE)


def _conclusions(think: str) -> list[str]:
    """Conclusion clauses (from the first marker on) of the sentences that have one, last sentence first."""
    sentences = [s.strip() for s in _SENTENCE_END.split(think) if s.strip()]
    clauses = []
    for sentence in reversed(sentences):
        m = _MARKER.search(sentence)
        if m:
            clauses.append(sentence[m.end():].strip(" ,:;—-"))
    return clauses


def _is_yes_no(item: QAItem) -> bool:
    return item.task == "SFD" and item.gold.get("kind") == "yesno"


def _read_value(item: QAItem, text: str) -> Any:
    """The value ``text`` names in the gold's terms (lenient task parser), or None."""
    if not text:
        return None
    if item.task != "RFOR" and _NEGATION.search(text):
        return None
    if _is_yes_no(item):
        m = _YES_NO_LEAD.match(text)
        if m is None:
            return None
        text = m.group(1)
    return score_item(item, f"<answer>{text}</answer>", "lenient").parsed


def _disagrees(concluded: Any, answered: Any) -> bool:
    if isinstance(concluded, dict) and isinstance(answered, dict):
        return any(v is not None and answered.get(k) is not None and v != answered[k] for k, v in concluded.items())
    return concluded != answered


def conclusion(item: QAItem, think: str) -> tuple[str, Any] | None:
    """(clause, value) of the reasoning's last readable conclusion, or None when it states none."""
    for clause in _conclusions(think):
        value = _read_value(item, clause)
        if value is not None and (not isinstance(value, dict) or any(v is not None for v in value.values())):
            return clause, value
    return None


# ------------------------------------------------------------------------------------------------ dedup

_SHINGLE = 5
_NUM_PERM = 128
_MASK = np.uint64(0xFFFFFFFFFFFFFFFF)


def _mix64(x: np.ndarray) -> np.ndarray:
    """splitmix64 finaliser (wrapping uint64 arithmetic): a fixed, platform-independent hash."""
    with np.errstate(over="ignore"):
        z = x + np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return z ^ (z >> np.uint64(31))


def shingles(text: str, k: int = _SHINGLE) -> np.ndarray:
    """Sorted unique 64-bit hashes of the character k-grams of ``text`` (lower case, spaces collapsed).

    Deterministic across processes (Python's ``hash`` is salted per process, so it is not used).
    """
    norm = " ".join(text.lower().split())
    codes = np.frombuffer(norm.encode("utf-32-le"), dtype=np.uint32).astype(np.uint64)
    if len(codes) == 0:
        return np.zeros(0, np.uint64)
    if len(codes) < k:
        codes = np.concatenate([codes, np.zeros(k - len(codes), np.uint64)])
    n = len(codes) - k + 1
    h = np.zeros(n, np.uint64)
    for j in range(k):
        h = _mix64(h ^ codes[j:j + n])
    return np.unique(h)


def jaccard(a: np.ndarray, b: np.ndarray) -> float:
    """Exact Jaccard similarity of two sorted unique shingle arrays (1.0 for two empty texts)."""
    if len(a) == 0 and len(b) == 0:
        return 1.0
    inter = len(np.intersect1d(a, b, assume_unique=True))
    return inter / (len(a) + len(b) - inter)


_PERM_SEEDS = _mix64(np.arange(1, _NUM_PERM + 1, dtype=np.uint64) * np.uint64(0x2545F4914F6CDD1D))


def _rows_per_band(threshold: float) -> int:
    """Largest band size whose chance of missing a pair at ``threshold`` is below 1e-3 (fewer false candidates)."""
    best = 1
    for rows in (1, 2, 4, 8, 16, 32):
        if (1.0 - threshold ** rows) ** (_NUM_PERM // rows) <= 1e-3:
            best = rows
    return best


class _DedupIndex:
    """MinHash LSH over accepted think texts of one task; candidates are verified with the exact Jaccard."""

    def __init__(self, threshold: float) -> None:
        self.threshold = threshold
        self.rows = _rows_per_band(threshold)
        self.buckets: dict[tuple[int, bytes], list[int]] = defaultdict(list)
        self.entries: list[tuple[str, np.ndarray]] = []

    def _bands(self, sh: np.ndarray) -> list[tuple[int, bytes]]:
        if len(sh) == 0:
            sig = np.full(_NUM_PERM, _MASK, np.uint64)
        else:
            sig = _mix64(sh[None, :] ^ _PERM_SEEDS[:, None]).min(axis=1)
        return [(b, sig[b * self.rows:(b + 1) * self.rows].tobytes()) for b in range(_NUM_PERM // self.rows)]

    def query(self, sh: np.ndarray) -> tuple[str, float] | None:
        """(key, similarity) of the most similar earlier entry at or above the threshold, first on ties."""
        candidates = sorted({i for band in self._bands(sh) for i in self.buckets.get(band, ())})
        best: tuple[str, float] | None = None
        for i in candidates:
            key, other = self.entries[i]
            sim = jaccard(sh, other)
            if sim >= self.threshold and (best is None or sim > best[1]):
                best = (key, sim)
        return best

    def add(self, key: str, sh: np.ndarray) -> None:
        for band in self._bands(sh):
            self.buckets[band].append(len(self.entries))
        self.entries.append((key, sh))


# ------------------------------------------------------------------------------------------------ filter


def _check(sample: CoTSample, config: FilterConfig) -> tuple[list[str], dict, str | None]:
    """(reasons, details, think) for one sample, all checks but dedup and review."""
    output = sample.output
    answer = extract_answer(output, "strict")
    think, _ = split_reasoning(output)
    if answer is None or think is None or not output.strip().lower().startswith("<think>"):
        return ["format"], {}, None
    item = item_of(sample)
    reasons: list[str] = []
    details: dict[str, Any] = {}
    try:
        score = score_item(item, output, "strict")
    except ValueError as e:
        raise ValueError(f"sample {sample.key!r} (item {sample.item_id!r}): {e}") from None
    if not score.correct:
        reasons.append("wrong_answer")
        details["answer_parsed"] = score.parsed
    if config.require_stages:
        missing = missing_stages(think, sample.stages)
        if missing:
            reasons.append("missing_stages")
            details["missing_stages"] = missing
    answered = score.parsed if score.parsed is not None else _read_value(item, answer)
    concluded = conclusion(item, think)
    if concluded is not None:
        details["conclusion"] = concluded[0]
        details["conclusion_parsed"] = concluded[1]
        if answered is not None and _disagrees(concluded[1], answered):
            reasons.append("contradiction")
    if len(think) < config.min_think_chars:
        reasons.append("too_short")
    if len(think) > config.max_think_chars or len(answer) > config.max_answer_chars:
        reasons.append("too_long")
    details["think_chars"] = len(think)
    return reasons, details, think


def filter_samples(samples: list[CoTSample], config: FilterConfig | None = None) -> FilterResult:
    """Mark every sample accepted or rejected (in place, in order) and return the samples with stats.

    Deterministic: dedup keeps the first of near-identical accepted samples in input order.
    """
    config = config or FilterConfig()
    indexes: dict[str, _DedupIndex] = {}
    for sample in samples:
        reasons, details, think = _check(sample, config)
        if sample.review == "reject":
            reasons.append("reviewer_reject")
        if config.dedup and not reasons and think is not None:
            index = indexes.setdefault(sample.task, _DedupIndex(config.dedup_threshold))
            sh = shingles(think)
            dup = index.query(sh)
            if dup is None:
                index.add(sample.key, sh)
            else:
                reasons.append("near_duplicate")
                details["duplicate_of"], details["similarity"] = dup[0], round(dup[1], 4)
        sample.reject_reasons = [r for r in REASONS if r in reasons]
        sample.accepted = not reasons
        sample.meta["filter"] = details
    return FilterResult(samples, acceptance_stats(samples, config.skew_threshold), config)


# ------------------------------------------------------------------------------------------------ stats


def class_labels(sample: CoTSample) -> list[tuple[str, str]]:
    """(group, class) pairs of a sample: its gold answer text, or one per attribute for TFA-combined.

    Class balance is compared within a group: a combined item is one hardness class, one protrusion
    class, … (its full answer would split the data into 81 tiny classes).
    """
    if sample.task == "TFA-combined":
        parts = [p.strip() for p in sample.gold_answer.split(";") if p.strip()]
        return [(p.partition(":")[0].strip(), p) for p in parts]
    return [("", sample.gold_answer)]


def _counts(samples: Sequence[CoTSample]) -> dict:
    accepted = sum(1 for s in samples if s.accepted)
    rejected = sum(1 for s in samples if s.accepted is False)
    reasons = Counter(r for s in samples if s.accepted is False for r in s.reject_reasons)
    out = {"total": len(samples), "accepted": accepted, "rejected": rejected,
           "acceptance_rate": round(accepted / len(samples), 4) if samples else None,
           "reasons": {r: reasons[r] for r in REASONS if reasons[r]}}
    unfiltered = len(samples) - accepted - rejected
    if unfiltered:
        out["unfiltered"] = unfiltered
    return out


def acceptance_stats(samples: Sequence[CoTSample], skew_threshold: float = 0.10) -> dict:
    """Counts of total/accepted/rejected (by reason) overall, per task and per class, plus skew warnings.

    A sample rejected for several reasons counts once under each. Per class: ``share_all`` is the class's
    share of the task's samples (within its group), ``share_accepted`` its share of the accepted ones; a
    difference above ``skew_threshold`` gives a warning, since filtering then changes what the model
    learns to answer, not only how well.
    """
    by_task: dict[str, list[CoTSample]] = defaultdict(list)
    for s in samples:
        by_task[s.task].append(s)
    warnings: list[str] = []
    tasks: dict[str, dict] = {}
    for task in sorted(by_task):
        group = by_task[task]
        entry = _counts(group)
        by_class: dict[tuple[str, str], list[CoTSample]] = defaultdict(list)
        for s in group:
            for label in class_labels(s):
                by_class[label].append(s)
        n_all: Counter[str] = Counter()
        n_acc: Counter[str] = Counter()
        for (g, _), members in by_class.items():
            n_all[g] += len(members)
            n_acc[g] += sum(1 for s in members if s.accepted)
        classes = {}
        for (g, label), members in sorted(by_class.items()):
            c = _counts(members)
            share_all = len(members) / n_all[g]
            share_acc = c["accepted"] / n_acc[g] if n_acc[g] else None
            c["share_all"] = round(share_all, 4)
            c["share_accepted"] = None if share_acc is None else round(share_acc, 4)
            classes[label] = c
            if share_acc is not None and abs(share_acc - share_all) > skew_threshold:
                warnings.append(f"{task}: class {label!r} is {100 * share_all:.1f}% of all samples but "
                                f"{100 * share_acc:.1f}% of accepted ({100 * (share_acc - share_all):+.1f} points); "
                                f"filtering skews the class balance")
        if entry["accepted"] == 0 and entry["rejected"]:
            warnings.append(f"{task}: no sample accepted ({entry['total']} rejected)")
        entry["classes"] = classes
        tasks[task] = entry
    return {**_counts(samples), "tasks": tasks, "warnings": warnings}
