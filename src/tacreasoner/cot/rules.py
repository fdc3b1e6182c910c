"""The offline rule-based TouchCoT teacher: varied, cue-grounded reasoning without a network.

It plays the paper's teacher (told the gold answer, asked to justify it) so the whole builder runs
offline and in tests. Wording lives in ``rules_bank.yaml``; this module decides *what* to say:

* each required stage gets a sentence quoting that stage's measured cues, joined to a reading of what
  the cue means for the gold answer; when a cue does not support the answer (judged against typical
  DynTAC-Sim ranges, or against the other videos), the sentence says it is not decisive instead of
  pretending it is;
* comparisons (SFD, SOI, OSC) quote every video's value of the same cue, stage by stage;
* the conclusion restates the gold answer, and the answer tag holds it verbatim.

``style="brief"`` writes short, number-free reasoning instead (~40–70 words): every required stage
named with the reading of the gold level, how each video feels for comparisons and matching, then the
conclusion. A tiny student LLM cannot learn to write the full style's quoted measurements in a CPU
budget (docs/training.md); the brief style keeps the think-then-answer shape it can learn. Brief
readings state the gold level's percept per stage without checking each cue against it.

``style="brief-first"`` is the brief style opened by the verdict (``<think>Answer: moderately deformable.
In the pressing stage, …``): the token that needs the tactile input comes right after the question, where
Stage I's plain answers taught the model to read it; the rest of the reasoning explains that verdict. It is
what the quickstart trains on (docs/training.md, "Where the tiny model stands").

``style="brief-levels"`` is brief-first except for SFD and SOI, which read every video first, with its level
number, and then decide by the number rule the commonsense corpus teaches (``Over the press and the hold,
Video 1 feels squashy (level 0) and Video 2 feels rigid (level 2). More hardness means a higher level; 0 is
lower than 2, so it is Video 2: the second object``): a comparison's answer follows from readings the model
has already written, not from a verdict it must give before reading any video. Off by default: on tactile
tokens the tiny model's per-video readings are still too poor for it to help (docs/training.md).

Every sentence is checked against the gold before it is used (no other level phrase, verdict or
contact state), and the conclusion must score as correct under the lenient scorer, so the reasoning
never contradicts the answer. Output is deterministic for (seed, job key).
"""

from __future__ import annotations

import hashlib
import random
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from tacreasoner.cot import cuetext
from tacreasoner.cot.rulebank import ACTION_KEY, BANK_FILE, RulesBank, RulesBankError, load_bank
from tacreasoner.cot.schema import CoTJob, Prompt, TeacherReply, VideoCues, normalise_output
from tacreasoner.tasks.building import join_words
from tacreasoner.tasks.schema import QAItem
from tacreasoner.tasks.scoring import score_item
from tacreasoner.tasks.vocab import Attribute, get_vocabulary

__all__ = ["BANK_FILE", "BRIEF_STYLES", "STYLES", "RulesBank", "RulesBankError", "RulesTeacher", "Trace", "load_bank"]

MAX_TRIES = 8
"""Variants tried per sentence before falling back to a plainer one."""

STYLES = {"full": "rules-v1", "brief": "rules-brief-v1", "brief-first": "rules-brief-first-v1",
          "brief-levels": "rules-brief-levels-v1"}
"""Writing style → the teacher's model id (part of every job's cache key, so styles never mix)."""

BRIEF_STYLES = frozenset({"brief", "brief-first", "brief-levels"})
"""The short styles (number-free, but for brief-levels' level numbers): they repeat by design (build-cot keeps
their near-duplicates)."""

_STAGE_NOUNS = {"press": "the press", "hold": "the hold", "slide": "the slide", "rotate": "the rotation",
                "release": "the release"}


_ORDINALS = ("first", "second", "third")


# ------------------------------------------------------------------------------------------- consistency


def _phrase_pattern(phrase: str) -> re.Pattern[str]:
    words = [re.escape(w) for w in phrase.lower().replace("-", " ").split()]
    return re.compile(r"(?<![\w-])" + r"[\s-]+".join(words) + r"(?![\w-])")


def _mentions(text: str, phrases: Mapping[str, Any]) -> set[Any]:
    """Values of the whole phrases found in ``text``; longer phrases claim their span first."""
    low = text.lower()
    claimed: list[tuple[int, int]] = []
    found = set()
    for phrase in sorted(phrases, key=lambda p: -len(p)):
        for m in _phrase_pattern(phrase).finditer(low):
            if any(m.start() < e and s < m.end() for s, e in claimed):
                continue
            claimed.append((m.start(), m.end()))
            found.add(phrases[phrase])
    return found


_VERDICT_WORDS = {"real": True, "genuine": True, "authentic": True, "fake": False, "artificial": False,
                  "imitation": False, "replica": False}
_STATE_FORMS = {"pressing": ("press", "presses", "pressed", "pressing"),
                "holding": ("hold", "holds", "held", "holding"),
                "sliding": ("slide", "slides", "slid", "sliding"),
                "rotating": ("rotate", "rotates", "rotated", "rotating", "rotation"),
                "releasing": ("release", "releases", "released", "releasing")}
_YES_NO = re.compile(r"\b(yes|no)\b", re.IGNORECASE)


def _contradicts(item: QAItem, sentence: str) -> bool:
    """Whether a reasoning sentence names an answer other than the gold one."""
    task, gold = item.task, item.gold
    if task == "TFA-combined":
        vocab = get_vocabulary(item.vocabulary)
        return any(_mentions(sentence, {p: r for r, p in enumerate(vocab[a].levels)}) - {level}
                   for a, level in gold["levels"].items())
    if task.startswith("TFA-"):
        attr = get_vocabulary(item.vocabulary)[task.removeprefix("TFA-")]
        return bool(_mentions(sentence, {p: r for r, p in enumerate(attr.levels)}) - {gold["level"]})
    if task == "RFOR":
        return bool(_mentions(sentence, _VERDICT_WORDS) - {gold["real"]})
    if task == "OCSE":
        forms = {f: s for s, fs in _STATE_FORMS.items() for f in fs}
        return bool(_mentions(sentence, forms) - {gold["state"]})
    if task == "SFD" and gold.get("kind") == "yesno":
        return bool(_YES_NO.search(sentence))
    return False


def _concludes(item: QAItem, sentence: str) -> bool:
    """The conclusion, read as an answer by the lenient scorer, is the gold answer."""
    return score_item(item, f"<answer>{sentence}</answer>", "lenient").correct and not _contradicts_conclusion(
        item, sentence)


def _contradicts_conclusion(item: QAItem, sentence: str) -> bool:
    return item.task != "SFD" and _contradicts(item, sentence)


# ------------------------------------------------------------------------------------------- writing


@dataclass
class Trace:
    """One composed reply: the reasoning, the answer and which bank entries each sentence used."""

    think: str
    answer: str
    sentences: list[str]
    templates: list[tuple[str, str]]
    """(stage or part, template id) per chosen template, e.g. ``("press", "observe.press.1.2")``."""

    @property
    def text(self) -> str:
        return normalise_output(self.think, self.answer)


def _sentence(text: str) -> str:
    text = text.strip()
    if not text:
        return text
    text = text[0].upper() + text[1:]
    return text if text[-1] in ".!?" else text + "."


def _capitalise_after_stop(text: str) -> str:
    """``". the press …"`` → ``". The press …"``: a connector may start a new sentence."""
    return re.sub(r"^(\.\s+)([a-z])", lambda m: m.group(1) + m.group(2).upper(), text)


def _lower_first(text: str) -> str:
    return text if text.startswith("Video") or not text else text[0].lower() + text[1:]


class _Slots(dict):
    """Slot values for the bank's templates; a slot without a value marks the variant unusable."""

    def __missing__(self, key: str) -> str:
        return cuetext.MISSING


def _fill(template: str, slots: Mapping[str, str]) -> str | None:
    """The filled template, or None when a slot it needs has no value (that variant is skipped)."""
    text = template.format_map(_Slots(slots))
    return None if cuetext.MISSING in text else text


class _Writer:
    """Choices for one job: a seeded RNG plus a record of every template used."""

    def __init__(self, bank: RulesBank, item: QAItem, rng: random.Random) -> None:
        self.bank, self.item, self.rng = bank, item, rng
        self.used: list[tuple[str, str]] = []
        self.raw: dict[str, str] = {}
        """tag → the raw template last chosen under it."""

    def pick(self, at: Sequence[str | int], slots: Mapping[str, str], tag: str,
             accept: Callable[[str], bool] | None = None) -> str | None:
        """A filled variant of the list at ``at`` (in a seeded random order) that ``accept`` allows."""
        options = self.bank.data
        for key in at:
            options = options[key]
        order = list(range(len(options)))
        self.rng.shuffle(order)
        for i in order[:MAX_TRIES]:
            text = _fill(options[i], slots)
            if text is not None and (accept is None or accept(text)):
                self.used.append((tag, ".".join(str(a) for a in (*at, i))))
                self.raw[tag] = options[i]
                return text
        return None

    def pick_plan(self, at: Sequence[str | int], slots: Mapping[str, str], tag: str,
                  accept: Callable[[str], bool] | None = None) -> str | None:
        """One paraphrase of one plan (list of lists): the plan and the paraphrase are both drawn."""
        plans = self.bank.data
        for key in at:
            plans = plans[key]
        order = list(range(len(plans)))
        self.rng.shuffle(order)
        for p in order:
            text = self.pick((*at, p), slots, tag, accept)
            if text is not None:
                return text
        return None

    def word(self, *at: str | int) -> str:
        options = self.bank.data
        for key in at:
            options = options[key]
        return self.rng.choice(options)

    def ok(self, text: str) -> bool:
        return not _contradicts(self.item, text)


def _stage_key(stage: str) -> str:
    return ACTION_KEY if stage in ("slide", "rotate") else stage


def _implied_level(bank: RulesBank, cue: str, value: float, sign: int) -> int:
    lo, hi = bank["typical"][cue]
    b = 0 if value < lo else (2 if value > hi else 1)
    return b if sign > 0 else 2 - b


def _supports(bank: RulesBank, cue: str, value: float, sign: int, level: int) -> bool:
    """A single video's value is consistent with the level (not at the opposite extreme of typical)."""
    return abs(_implied_level(bank, cue, value, sign) - level) <= 1


def _winner(gold: Mapping[str, Any]) -> int:
    """The video an SFD/SOI answer points at (the first for a yes, the second for a no)."""
    return gold["index"] if "index" in gold else (0 if gold["value"] else 1)


def _comparison(item: QAItem, n: int) -> tuple[list[tuple[int, int]], dict[str, str]]:
    """(higher, lower) video pairs the gold ordering asserts, and the wording slots of an SFD/PC/SOI item (PC
    "similar" asserts no pair and names no winner)."""
    gold = item.gold
    attribute = gold["attribute"]
    attr = get_vocabulary(item.vocabulary)[attribute]
    if item.task == "PC":
        ctx = {"attribute": attribute, "comparative": attr.more}
        if gold["relation"] == "similar":
            return [], ctx
        hi = 0 if gold["relation"] == "more" else 1
        return [(hi, 1 - hi)], ctx | {"winner": f"Video {hi + 1}"}
    if item.task == "SFD":
        winner = _winner(gold)
        more = gold["direction"] == "more"
        hi, lo = (winner, 1 - winner) if more else (1 - winner, winner)
        pairs = [(hi, lo)]
        ctx = {"comparative": attr.more if more else attr.less}
    else:
        winner = _winner(gold)
        others = [v for v in range(n) if v != winner]
        pairs = [(winner, o) for o in others] if gold["direction"] == "most" else [(o, winner) for o in others]
        ctx = {"superlative": attr.most if gold["direction"] == "most" else attr.least}
    return pairs, ctx | {"attribute": attribute, "winner": f"Video {winner + 1}"}


def _ranks(item: QAItem, n: int, kind: type) -> list | None:
    """Per-video attribute ranks the benchmark builder stored (``meta.ranks``), when well-formed."""
    ranks = item.meta.get("ranks")
    if isinstance(ranks, list) and len(ranks) == n and all(isinstance(r, kind) for r in ranks):
        return ranks
    return None


class RulesTeacher:
    """Offline teacher: ``generate(job, prompt)`` → ``<think>…</think><answer>gold</answer>``."""

    name = "rules"

    def __init__(self, seed: int = 0, bank: RulesBank | None = None, style: str = "full") -> None:
        if style not in STYLES:
            raise ValueError(f"rules teacher: style must be one of {', '.join(STYLES)}, got {style!r}")
        self.seed = int(seed)
        self.bank = bank or load_bank()
        self.style = style
        self.model = STYLES[style]

    @property
    def teacher_id(self) -> str:
        return f"{self.name}:{self.model}:seed{self.seed}"

    async def generate(self, job: CoTJob, prompt: Prompt | None = None) -> TeacherReply:
        return self.generate_sync(job, prompt)

    def generate_sync(self, job: CoTJob, prompt: Prompt | None = None) -> TeacherReply:
        trace = self.compose(job)
        return TeacherReply(text=trace.text, model=self.model, completion_tokens=len(trace.text.split()))

    # ------------------------------------------------------------------------------------ composing

    def _rng(self, job: CoTJob) -> random.Random:
        key = job.key or hashlib.sha256(f"{job.item.id}\n{job.item.question}".encode()).hexdigest()
        digest = hashlib.sha256(f"{self.seed}:{key}".encode()).digest()
        return random.Random(int.from_bytes(digest[:8], "big"))

    def compose(self, job: CoTJob) -> Trace:
        """The reasoning for one job (deterministic for this teacher's seed and the job's key)."""
        item = job.item
        if item.task == "TSA":
            raise ValueError(f"item {item.id!r}: TSA is zero-shot and never gets TouchCoT reasoning")
        w = _Writer(self.bank, item, self._rng(job))
        task = item.task
        if self.style in BRIEF_STYLES:
            if self.style == "brief-levels" and task in ("SFD", "SOI"):
                levelled = self._levels_compare(w, job)
                if levelled is not None:
                    return Trace(" ".join(levelled), item.answer, levelled, w.used)
            body, ctx = self._brief(w, job)
            conclusion = self._conclusion(w, item, ctx)
            verdict = [f"Answer: {item.answer}"] if self.style in ("brief-first", "brief-levels") else []
            sentences = [_sentence(s) for s in verdict + body] + [conclusion]
            return Trace(" ".join(sentences), item.answer, sentences, w.used)
        if task == "TFA-combined":
            body, ctx = self._combined(w, job)
        elif task.startswith("TFA-"):
            body, ctx = self._tfa(w, job)
        elif task in ("SFD", "SOI"):
            body, ctx = self._compare(w, job)
        elif task == "PC":
            body, ctx = self._pc(w, job)
        elif task == "OSC":
            body, ctx = self._osc(w, job)
        elif task == "RFOR":
            body, ctx = self._rfor(w, job)
        elif task == "OCSE":
            body, ctx = self._ocse(w, job)
        else:
            raise ValueError(f"item {item.id!r}: the rules teacher has no plan for task {task!r}")
        family = "TFA" if task.startswith("TFA-") and task != "TFA-combined" else task
        opener = w.pick(("openers", family), ctx, "opener", w.ok) if w.rng.random() < 0.75 else None
        conclusion = self._conclusion(w, item, ctx)
        sentences = [_sentence(s) for s in ([opener] if opener else []) + body] + [conclusion]
        return Trace(" ".join(sentences), item.answer, sentences, w.used)

    def _conclusion(self, w: _Writer, item: QAItem, ctx: Mapping[str, str]) -> str:
        key = item.task
        if key.startswith("TFA-") and key != "TFA-combined":
            key = "TFA"
        elif key == "SFD":
            key = "SFD-which" if item.gold["kind"] == "which" else ("SFD-yes" if item.gold["value"] else "SFD-no")
        elif key == "PC":
            key = f"PC-{item.gold['relation']}"
        slots = {**ctx, "answer": item.answer}
        text = w.pick(("conclusions", key), slots, "conclusion", lambda s: _concludes(item, _sentence(s)))
        return _sentence(text) if text else _sentence(f"So the answer is {item.answer}")

    # ------------------------------------------------------------------------------------ one video

    def _stage_sentence(self, w: _Writer, video: VideoCues, stage: str, position: str,
                        reading: Callable[[str, float], tuple[str | None, str]] | None,
                        evidence: Sequence[Sequence[Any]], slots: Mapping[str, str]) -> str | None:
        """Observation of one stage + what its evidence means (``reading(cue, value)`` → clause, kind)."""
        values = {**cuetext.cue_slots(video), **slots}
        obs = w.pick_plan(("observe", stage), values, stage, w.ok)
        if obs is None:
            return None
        present = [(c, s) for c, s in evidence if c in video.cues]
        clause = None
        if present and reading is not None:
            supported = [(c, s) for c, s in present if reading(c, video.cues[c])[1] == "supports"]
            cue, _ = w.rng.choice(supported or present)
            clause, _ = reading(cue, video.cues[cue])
            if clause is not None and "{" + cue + "}" not in w.raw.get(stage, ""):
                slots = {"cue_label": w.word("cue_labels", cue), "value": cuetext.format_cue(cue, video.cues[cue])}
                obs += w.pick(("evidence_clause",), slots, f"{stage}.evidence") or ""
        connectors = "connectors"
        if clause is None:
            clause = w.pick(("context", stage), values, f"{stage}.context", w.ok)
            connectors = "context_connectors"
        text = obs
        if clause:
            joined = w.pick((connectors,), {"reading": clause}, f"{stage}.connector") or f" — {clause}"
            text += _capitalise_after_stop(joined)
        prefix = w.word("transitions", position)
        return prefix + _lower_first(text) if prefix else text

    def _single_stages(self, w: _Writer, job: CoTJob, evidence_of: Callable[[str], Sequence],
                       reading: Callable[[str, str, float], tuple[str | None, str]] | None,
                       slots: Mapping[str, str]) -> list[str]:
        video = job.videos[0]
        stages = [s for s in job.stages if s in video.phases] or list(job.stages)
        out = []
        for i, stage in enumerate(stages):
            position = "first" if i == 0 else ("last" if i == len(stages) - 1 else "middle")
            read = (lambda c, v, stage=stage: reading(stage, c, v)) if reading else None
            text = self._stage_sentence(w, video, stage, position, read, evidence_of(stage), slots)
            if text is None:  # the stage is required but absent from this video's phases
                text = f"the {stage} stage is not visible in this video"
            out.append(text)
        return out

    def _tfa(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        item = job.item
        attribute = item.task.removeprefix("TFA-")
        level = item.gold["level"]
        ctx = {"attribute": attribute}
        evidence = self.bank["evidence"].get(attribute, {})

        def reading(stage: str, cue: str, value: float) -> tuple[str | None, str]:
            sign = dict(map(tuple, evidence.get(_stage_key(stage), []))).get(cue, 1)
            if _supports(self.bank, cue, value, sign, level):
                text = w.pick(("readings", attribute, _stage_key(stage), level), ctx, f"{stage}.reading", w.ok)
                return text, "supports"
            label = w.word("cue_labels", cue)
            text = w.pick(("concede",), {**ctx, "cue_label": label, "value": cuetext.format_cue(cue, value)},
                          f"{stage}.concede", w.ok)
            return text, "concedes"

        body = self._single_stages(w, job, lambda s: evidence.get(_stage_key(s), []), reading, ctx)
        return body, ctx

    def _rfor(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        item = job.item
        real = bool(item.gold["real"])
        ctx = {"fruit": str(item.gold.get("fruit", "fruit"))}
        evidence = self.bank["evidence"]["real"]

        def reading(stage: str, cue: str, value: float) -> tuple[str | None, str]:
            sign = dict(map(tuple, evidence.get(stage, []))).get(cue, 1)
            if _supports(self.bank, cue, value, sign, 2 if real else 0):
                return w.pick(("rfor_readings", stage, real), ctx, f"{stage}.reading", w.ok), "supports"
            slots = {**ctx, "cue_label": w.word("cue_labels", cue), "value": cuetext.format_cue(cue, value)}
            return w.pick(("rfor_concede",), slots, f"{stage}.concede", w.ok), "concedes"

        body = self._single_stages(w, job, lambda s: evidence.get(s, []), reading, ctx)
        return body, ctx

    def _combined(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        item = job.item
        vocab = get_vocabulary(item.vocabulary)
        names = list(vocab)
        ctx = {"attributes": join_words(names)}
        body = self._single_stages(w, job, lambda s: [], None, ctx)
        video = job.videos[0]
        for attribute, level in item.gold["levels"].items():
            body.append(self._combined_verdict(w, video, attribute, vocab[attribute], level))
        return body, ctx

    def _combined_verdict(self, w: _Writer, video: VideoCues, attribute: str, attr: Attribute, level: int) -> str:
        evidence = self.bank["evidence"].get(attribute, {})
        options = [(stage, c, s) for stage, cues in evidence.items() for c, s in cues if c in video.cues
                   and ((stage == ACTION_KEY and any(a in video.phases for a in ("slide", "rotate")))
                        or stage in video.phases)]
        phrase = attr.phrase(level)
        base = {"attribute": attribute, "Attribute": attribute.capitalize(), "phrase": phrase}
        supported = [o for o in options if _supports(self.bank, o[1], video.cues[o[1]], o[2], level)]
        if supported:
            stage, cue, _ = w.rng.choice(supported)
            reading = w.pick(("readings", attribute, stage, level), base, f"{attribute}.reading", w.ok)
            slots = {**base, "cue_label": w.word("cue_labels", cue), "value": cuetext.format_cue(cue, video.cues[cue]),
                     "reading": reading or "it fits"}
            text = w.pick(("combined_verdict",), slots, f"{attribute}.verdict", w.ok)
            if text:
                return text
        return f"for {attribute}, the cues are mixed, and on balance I rate it {phrase}"

    def _ocse(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        item, video = job.item, job.videos[0]
        state = item.gold["state"]
        values = cuetext.cue_slots(video)
        plans = list(range(len(self.bank["ocse_observe"])))
        w.rng.shuffle(plans)
        body = []
        for p in sorted(plans[: w.rng.choice((2, 3))]):
            text = w.pick(("ocse_observe", p), values, "segment", w.ok)
            if text:
                body.append(text)
        checks = self.bank["ocse_checks"][state]
        agree = any((video.cues.get(c, 0.0) > t) if op == ">" else (video.cues.get(c, 0.0) < t) for c, op, t in checks)
        ctx = {"state": state}
        reading = (w.pick(("ocse_readings", state), ctx, "segment.reading", w.ok) if agree
                   else w.pick(("ocse_concede",), ctx, "segment.concede", w.ok))
        if reading:
            body.append(reading)
        return body, ctx

    # ------------------------------------------------------------------------------------ brief style

    def _brief(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        item, task = job.item, job.item.task
        if task == "TFA-combined":
            return self._brief_combined(w, job)
        if task.startswith("TFA-"):
            attribute, level = task.removeprefix("TFA-"), item.gold["level"]
            ctx = {"attribute": attribute}
            return self._brief_stages(w, job, lambda stage: ("readings", attribute, _stage_key(stage), level), ctx), ctx
        if task == "RFOR":
            real = bool(item.gold["real"])
            ctx = {"fruit": str(item.gold.get("fruit", "fruit"))}
            return self._brief_stages(w, job, lambda stage: ("rfor_readings", stage, real), ctx), ctx
        if task in ("SFD", "PC", "SOI"):
            return self._brief_compare(w, job)
        if task == "OSC":
            return self._brief_osc(w, job)
        if task == "OCSE":
            ctx = {"state": item.gold["state"]}
            seen = w.pick(("brief_ocse", item.gold["state"]), ctx, "segment", w.ok)
            reading = w.pick(("ocse_readings", item.gold["state"]), ctx, "segment.reading", w.ok)
            return [s for s in (seen, reading) if s], ctx
        raise ValueError(f"item {item.id!r}: the rules teacher has no plan for task {task!r}")

    def _brief_stages(self, w: _Writer, job: CoTJob, at: Callable[[str], tuple], ctx: Mapping[str, str]) -> list[str]:
        """One short sentence per required stage: its label and what it says at the gold level."""
        out = []
        for stage in job.stages:
            options: Any = self.bank.data
            for key in at(stage):
                options = options.get(key) if isinstance(options, Mapping) else None
            reading = w.pick(at(stage), ctx, f"{stage}.reading", w.ok) if options else None
            reading = reading or w.pick(("context", stage), ctx, f"{stage}.context", w.ok)
            label = w.word("stage_labels", stage)
            out.append(f"{label}, {reading}" if reading else f"{label}, nothing decisive shows")
        return out

    def _brief_intro(self, w: _Writer, job: CoTJob) -> str:
        nouns = [_STAGE_NOUNS[s] for s in job.stages if s in _STAGE_NOUNS] or ["the contact"]
        return w.pick(("brief_stages",), {"stages": join_words(nouns)}, "stages") or f"across {join_words(nouns)}"

    def _brief_compare(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        """How each video feels for the asked attribute (its rank), which decides the comparison."""
        ranks = _ranks(job.item, len(job.videos), int)
        if ranks is None:
            return self._compare(w, job)
        _, ctx = _comparison(job.item, len(job.videos))
        feels = []
        for v, rank in enumerate(ranks):
            slots = {"n": str(v + 1), "descriptor": w.word("descriptors", ctx["attribute"], rank)}
            fallback = "Video {n} feels {descriptor}".format(**slots)
            feels.append(w.pick(("brief_feel",), slots, f"video{v + 1}", w.ok) or fallback)
        return [f"{self._brief_intro(w, job)}, {join_words(feels)}"], ctx

    def _levels_compare(self, w: _Writer, job: CoTJob) -> list[str] | None:
        """Each video's feel with its level, then the number rule that picks the answer (None without ranks)."""
        item = job.item
        ranks = _ranks(item, len(job.videos), int)
        if ranks is None:
            return None
        gold, attribute = item.gold, item.gold["attribute"]
        feels = []
        for v, rank in enumerate(ranks):
            slots = {"n": str(v + 1), "descriptor": w.word("descriptors", attribute, rank), "level": str(rank)}
            feels.append(w.pick(("level_feel",), slots, f"video{v + 1}", w.ok)
                         or "Video {n} feels {descriptor} (level {level})".format(**slots))
        higher = gold["direction"] in ("more", "most")
        winner = _winner(gold)
        slots = {"direction": gold["direction"], "Direction": gold["direction"].capitalize(), "attribute": attribute,
                 "way": "higher" if higher else "lower", "n": str(winner + 1), "ordinal": _ORDINALS[winner]}
        if item.task == "SOI":
            key = "SOI"
            slots |= {"extreme": "highest" if higher else "lowest", "best": str(ranks[winner])}
        else:
            x, y = ranks
            key = "SFD-which" if gold["kind"] == "which" else "SFD-yesno"
            slots |= {"lx": str(x), "ly": str(y), "rel": "higher" if x > y else "lower",
                      "yes_no": item.answer, "verdict": "has" if gold.get("value") else "does not have"}
        rule = w.pick(("level_rule", key), slots, "rule", lambda text: _concludes(item, _sentence(text)))
        if rule is None:
            return None
        return [_sentence(f"{self._brief_intro(w, job)}, {join_words(feels)}"), _sentence(rule)]

    def _brief_osc(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        item = job.item
        ranks = _ranks(item, len(job.videos), dict)
        if ranks is None:
            return self._osc(w, job)
        body = []
        for v, k in enumerate(item.gold["assignment"]):
            profile, _ = self._profile(w, job, v, ranks)
            slots = {"n": str(v + 1), "profile": profile, "name": item.options[k], "letter": "ABC"[k]}
            body.append(w.pick(("brief_match",), slots, "osc.match", w.ok)
                        or f"Video {v + 1} goes with the {item.options[k]} ({'ABC'[k]})")
        body[0] = f"{self._brief_intro(w, job)}, {_lower_first(body[0])}"
        return body, {"attributes": join_words(list(get_vocabulary(item.vocabulary)))}

    def _brief_combined(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        item = job.item
        ctx = {"attributes": join_words(list(get_vocabulary(item.vocabulary)))}
        profile = join_words([w.word("descriptors", a, level) for a, level in item.gold["levels"].items()])
        intro = self._brief_intro(w, job)
        text = w.pick(("brief_profile",), {"intro": intro, "profile": profile}, "profile", w.ok)
        return [text or f"{intro}, I rate {ctx['attributes']} in turn"], ctx

    # ------------------------------------------------------------------------------------ comparisons

    def _compare(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        pairs, ctx = _comparison(job.item, len(job.videos))
        evidence = self.bank["evidence"].get(ctx["attribute"], {})
        body = []
        for stage in job.stages:
            body.append(self._compare_stage(w, job, stage, evidence.get(_stage_key(stage), []), pairs, ctx))
        if not any(tag.endswith(".suffix") and tid.startswith("verdict") for tag, tid in w.used):
            body.append(self._tipping(w, job, evidence, pairs, ctx))
        return body, ctx

    def _pc(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        """PC: the stages side by side as for SFD; "similar" judges no stage and says the cues are close."""
        pairs, ctx = _comparison(job.item, len(job.videos))
        if pairs:
            return self._compare(w, job)
        evidence = self.bank["evidence"].get(ctx["attribute"], {})
        body = [self._compare_stage(w, job, stage, evidence.get(_stage_key(stage), []), [], ctx, judge=False)
                for stage in job.stages]
        body.append(w.pick(("pc_similar",), ctx, "similar", w.ok)
                    or f"the two videos' {ctx['attribute']} cues stay close to each other")
        return body, ctx

    def _tipping(self, w: _Writer, job: CoTJob, evidence: Mapping[str, Sequence], pairs: Sequence[tuple[int, int]],
                 ctx: Mapping[str, str]) -> str:
        """When no stage backed the answer: the cue over the whole contact that does, or say it is close."""
        backing = []
        for cues in evidence.values():
            for cue, sign in cues:
                if all(cue in v.cues for v in job.videos) and all(
                        sign * (job.videos[a].cues[cue] - job.videos[b].cues[cue]) > 0 for a, b in pairs):
                    backing.append(cue)
        if not backing:
            return w.pick(("close_call",), ctx, "tipping", w.ok) or "the cues are close, so this is a narrow call"
        cue = w.rng.choice(sorted(set(backing)))
        style = w.word("value_styles")
        items = [style.format(value=cuetext.format_cue(cue, v.cues[cue]), n=i + 1) for i, v in enumerate(job.videos)]
        values = ", ".join(items[:-1]) + f" and {items[-1]}"
        slots = {**ctx, "cue_label": w.word("cue_labels", cue), "values": values}
        text = w.pick(("tipping",), slots, "tipping", w.ok) or f"what tips it is {slots['cue_label']}: {values}"
        return text + (w.pick(("verdict", job.item.task), ctx, "tipping.suffix", w.ok) or "")

    def _compare_stage(self, w: _Writer, job: CoTJob, stage: str, evidence: Sequence, pairs: Sequence[tuple[int, int]],
                       ctx: Mapping[str, str], judge: bool = True) -> str:
        """One stage across videos: a cue's value per video, and whether it backs the gold ordering."""
        shown = [v for v, video in enumerate(job.videos) if stage in video.phases] or list(range(len(job.videos)))
        usable = [(c, s) for c, s in evidence if all(c in job.videos[v].cues for v in shown)]
        relevant = [(a, b) for a, b in pairs if a in shown and b in shown]

        def backs(cue: str, sign: int) -> bool:
            return bool(relevant) and all(sign * (job.videos[a].cues[cue] - job.videos[b].cues[cue]) > 0
                                          for a, b in relevant)

        backing = [(c, s) for c, s in usable if backs(c, s)]
        if usable:
            cue, _ = w.rng.choice(backing or usable)
            suffix_key = ("verdict", job.item.task) if backing else ("against",)
        else:
            cue = self.bank["stage_cue"][stage]
            suffix_key = ("neutral",)
            shown = [v for v in shown if cue in job.videos[v].cues] or shown
        labels = {"stage_label": w.word("stage_labels", stage), "cue_label": w.word("cue_labels", cue)}
        if len(shown) == 1 and len(job.videos) > 1:
            (v,) = shown
            slots = {**labels, "n": str(v + 1), "value": cuetext.format_cue(cue, job.videos[v].cues.get(cue, 0.0))}
            return (w.pick(("compare_single",), slots, stage, w.ok)
                    or f"{labels['stage_label']} (only Video {v + 1}), {labels['cue_label']} is {slots['value']}")
        style = w.word("value_styles")
        items = [style.format(value=cuetext.format_cue(cue, job.videos[v].cues.get(cue, 0.0)), n=v + 1) for v in shown]
        values = items[0] if len(items) == 1 else ", ".join(items[:-1]) + f" and {items[-1]}"
        slots = {**labels, "values": values}
        text = w.pick(("compare",), slots, stage, w.ok) or f"{labels['stage_label']}, {labels['cue_label']} is {values}"
        suffix = (w.pick(suffix_key, ctx, f"{stage}.suffix", w.ok) or "") if judge else ""
        return text + suffix

    def _osc(self, w: _Writer, job: CoTJob) -> tuple[list[str], dict[str, str]]:
        item = job.item
        assignment = item.gold["assignment"]
        ranks = _ranks(item, len(job.videos), dict)
        vocab = get_vocabulary(item.vocabulary)
        ctx = {"attributes": join_words(list(vocab))}
        body = []
        for stage in job.stages:
            cues = [c for a in vocab for c, _ in self.bank["evidence"].get(a, {}).get(_stage_key(stage), [])]
            body.append(self._compare_stage(w, job, stage, [(c, 0) for c in dict.fromkeys(cues)], [], ctx, judge=False))
        profiles = [self._profile(w, job, v, ranks) for v in range(len(job.videos))]
        for v, (profile, cue) in enumerate(profiles):
            video = job.videos[v]
            slots = {"n": str(v + 1), "profile": profile, "cue_label": w.word("cue_labels", cue),
                     "value": cuetext.format_cue(cue, video.cues.get(cue, 0.0))}
            body.append(w.pick(("osc_profile",), slots, "osc.profile", w.ok) or f"Video {v + 1} feels {profile}")
        order = list(range(len(job.videos)))
        w.rng.shuffle(order)
        for v in order:
            k = assignment[v]
            slots = {"n": str(v + 1), "profile": profiles[v][0], "name": item.options[k], "letter": "ABC"[k]}
            body.append(w.pick(("osc_match",), slots, "osc.match", w.ok)
                        or f"Video {v + 1} goes with the {item.options[k]} ({'ABC'[k]})")
        return body, ctx

    def _profile(self, w: _Writer, job: CoTJob, v: int, ranks: list[dict] | None) -> tuple[str, str]:
        """Descriptor words for video ``v`` from the attributes that set it apart, and a cue to cite.

        ``ranks``: one attribute → rank mapping per video, as :func:`_ranks` checks it (None: unknown)."""
        video = job.videos[v]
        fallback_cue = next((c for c in ("press_area", "creep", "shear_tint") if c in video.cues), "max_area")
        if ranks is None:
            return "distinct", fallback_cue
        mine = ranks[v]
        scored = []
        for a, level in mine.items():
            if a not in self.bank["descriptors"]:
                continue
            others = sum(r.get(a) != level for i, r in enumerate(ranks) if i != v)
            scored.append((others + (0.5 if level != 1 else 0.0) + w.rng.random() * 0.1, a, level))
        scored.sort(reverse=True)
        chosen = scored[:2]
        if not chosen:
            return "distinct", fallback_cue
        words = [w.word("descriptors", a, level) for _, a, level in chosen]
        profile = words[0] if len(words) == 1 else f"{words[0]} and {words[1]}"
        a0 = chosen[0][1]
        cues = [c for stage in self.bank["evidence"].get(a0, {}).values() for c, _ in stage if c in video.cues]
        return profile, (w.rng.choice(cues) if cues else fallback_cue)

