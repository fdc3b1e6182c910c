"""The commonsense corpus: text-only world knowledge for the tiny LLM, with a held-out evaluation set.

A real LLM knows that a tangerine is soft and that scraping ice needs something hard; a model trained
from scratch knows nothing, so it reads this corpus before any tactile training. It holds

- **documents** (plain text): object facts in both vocabularies' level phrases and in varied wording,
  descriptions, the order of each attribute's levels, comparatives ("a steel block is harder than a
  real peach"), what each scenario needs, and which of two objects suits a scenario;
- **dialogues** (chat messages): questions answered with short explicit reasoning,
  ``<think>fact about X. fact about Y. conclusion.</think><answer>…</answer>``. Stating each object's
  level before comparing is what lets a small transformer compose facts it learnt separately.

It never holds clips, benchmark questions (``tasks/templates``) or anything derived from clip labels:
object facts come from the simulator catalogue's material parameters and ``tasks/everyday_objects.yaml``.

**Holdout.** A fraction of object pairs and of scenarios is held out: the corpus still states every
object's and every scenario's own facts, but no document or dialogue names both objects of a held-out
pair, and no dialogue or suitability statement mentions a held-out scenario. ``eval_questions`` ask
exactly those comparisons and scenario choices, so answering them means composing separately learnt
facts, not recalling a memorised answer. Everything is deterministic in ``seed``.
"""

from __future__ import annotations

import itertools
import random
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from tacreasoner.knowledge.facts import (
    ATTRIBUTES,
    VOCABULARIES_OF,
    KnowledgeObject,
    Wording,
    capital,
    knowledge_objects,
    level_phrase,
    level_state,
    load_wording,
)
from tacreasoner.tasks.scenarios import Scenario, load_scenarios

__all__ = ["EVAL_KINDS", "Corpus", "EvalQuestion", "build_corpus", "chatml", "normalise_answer"]

EVAL_KINDS = ("compare_yesno", "compare_which", "scenario")
Message = dict[str, str]


def chatml(messages: Sequence[Mapping[str, str]], add_generation_prompt: bool = False) -> str:
    """ChatML text of string-content messages, exactly as ``model.tokenizer.CHAT_TEMPLATE`` renders it."""
    text = "".join(f"<|im_start|>{m['role']}\n{m['content']}<|im_end|>\n" for m in messages)
    return text + ("<|im_start|>assistant\n" if add_generation_prompt else "")


def normalise_answer(text: str) -> str:
    """Lower case, no leading article, no surrounding punctuation: ``The Steel block.`` → ``steel block``."""
    text = re.sub(r"\s+", " ", text.strip().lower())
    text = text.strip(" .,!?;:\"'")
    return re.sub(r"^(a|an|the)\s+", "", text)


@dataclass(frozen=True)
class EvalQuestion:
    """A text-only question with its gold answer (``answer``) and the two options it chooses between."""

    id: str
    kind: str
    question: str
    answer: str
    options: tuple[str, ...]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def chance(self) -> float:
        return 1.0 / len(self.options)

    def messages(self) -> list[Message]:
        return [{"role": "user", "content": self.question}]

    def is_correct(self, answer: str | None) -> bool:
        return answer is not None and normalise_answer(answer) == normalise_answer(self.answer)

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "kind": self.kind, "question": self.question, "answer": self.answer,
                "options": list(self.options), "meta": self.meta}


@dataclass
class Corpus:
    seed: int
    holdout_fraction: float
    documents: list[str]
    dialogues: list[list[Message]]
    eval_questions: list[EvalQuestion]
    """Held-out pairs and scenarios: never compared or asked about in the corpus."""
    seen_questions: list[EvalQuestion]
    """The same question kinds on pairs and scenarios the corpus does train on (a memorisation reference)."""
    heldout_pairs: tuple[tuple[str, str], ...]
    """Bare object names, each pair sorted."""
    heldout_scenarios: tuple[str, ...]
    """Scenario ids."""
    objects: tuple[KnowledgeObject, ...]

    @staticmethod
    def render_dialogue(messages: Sequence[Mapping[str, str]]) -> str:
        return chatml(messages)

    def stats(self) -> dict[str, Any]:
        return {
            "documents": len(self.documents), "dialogues": len(self.dialogues),
            "document_chars": sum(map(len, self.documents)),
            "dialogue_chars": sum(len(m["content"]) for d in self.dialogues for m in d),
            "objects": len(self.objects), "heldout_pairs": len(self.heldout_pairs),
            "heldout_scenarios": list(self.heldout_scenarios),
            "eval_questions": dict(Counter(q.kind for q in self.eval_questions)),
            "seen_questions": dict(Counter(q.kind for q in self.seen_questions)),
        }


# ------------------------------------------------------------------------------------------ builder


def _vocab_of(attributes: Sequence[str]) -> tuple[str, ...]:
    """Vocabularies that phrase every one of ``attributes``."""
    common = set(VOCABULARIES_OF[attributes[0]])
    for a in attributes[1:]:
        common &= set(VOCABULARIES_OF[a])
    return tuple(v for v in ("vtv150k", "physiclear") if v in common)


def _pair_key(a: KnowledgeObject, b: KnowledgeObject) -> tuple[str, str]:
    return tuple(sorted((a.bare, b.bare)))  # type: ignore[return-value]


class _Builder:
    """Sentence and dialogue factories over one fact base, one wording and one random stream."""

    def __init__(self, objects: Sequence[KnowledgeObject], scenarios: Sequence[Scenario], wording: Wording,
                 rng: random.Random) -> None:
        self.objects, self.scenarios, self.w, self.rng = list(objects), list(scenarios), wording, rng

    # -- slots
    @staticmethod
    def obj(o: KnowledgeObject, prefix: str = "x") -> dict[str, str]:
        return {prefix: o.name, prefix.upper(): capital(o.name)}

    @staticmethod
    def scn(s: Scenario) -> dict[str, str]:
        return {"s": s.text, "S": capital(s.text)}

    def needs(self, s: Scenario) -> str:
        return " and ".join(self.w.attributes[a]["high" if lvl == "high" else "low"] for a, lvl in s.needs.items())

    def need_slots(self, s: Scenario) -> dict[str, str]:
        """Scenario slots plus its needs as adjectives ("soft and elastic") and as levels ("low hardness and ...")."""
        levels = " and ".join(f"{lvl} {a}" for a, lvl in s.needs.items())
        return {**self.scn(s), "needs": self.needs(s), "levels": levels}

    def states(self, o: KnowledgeObject, attributes: Sequence[str], vocabulary: str) -> str:
        parts = [level_state(o.phrase(a, vocabulary)) for a in attributes]
        return parts[0] if len(parts) == 1 else f"{', '.join(parts[:-1])} and {parts[-1]}"

    def fact(self, o: KnowledgeObject, attributes: Sequence[str], vocabulary: str) -> str:
        return self.w.reasoning["fact"].format(**self.obj(o), state=self.states(o, attributes, vocabulary))

    def pick(self, texts: Sequence[str]) -> str:
        return texts[self.rng.randrange(len(texts))]

    # -- documents
    def object_documents(self, o: KnowledgeObject, passes: int) -> list[str]:
        """Paragraphs about one object only (never two: held-out pairs must not co-occur)."""
        docs = []
        for _ in range(passes):
            sentences = []
            for a in ATTRIBUTES:
                for v in VOCABULARIES_OF[a]:
                    phrase = o.phrase(a, v)
                    slots = {**self.obj(o), "state": level_state(phrase), "phrase": phrase, "attribute": a}
                    sentences.append(self.w.reasoning["fact"].format(**slots))
                    sentences.append(self.pick(self.w.documents["fact"]).format(**slots))
            self.rng.shuffle(sentences)
            while sentences:
                k = self.rng.randint(3, 6)
                docs.append(" ".join(sentences[:k]))
                sentences = sentences[k:]
            for v in ("vtv150k", "physiclear"):
                attrs = [a for a in ATTRIBUTES if v in VOCABULARIES_OF[a]]
                docs.append(self.pick(self.w.documents["describe"]).format(
                    **self.obj(o), material=o.material, states=self.states(o, attrs, v)))
        return docs

    def scale_documents(self) -> list[str]:
        docs = []
        for a in ATTRIBUTES:
            for v in VOCABULARIES_OF[a]:
                low, mid, high = (level_phrase(a, r, v) for r in (0, 1, 2))
                docs += [t.format(attribute=a, Attribute=capital(a), low=low, mid=mid, high=high)
                         for t in self.w.documents["scale"]]
        for r in (0, 1, 2):
            a, b = level_phrase("hardness", r, "physiclear"), level_phrase("hardness", r, "vtv150k")
            docs += [t.format(attribute="hardness", a=a, b=b) for t in self.w.documents["same_level"]]
        return docs

    def need_documents(self, s: Scenario, passes: int) -> list[str]:
        slots = self.need_slots(s)
        docs = []
        for _ in range(passes):
            sentences = [self.w.reasoning["need"].format(**slots),
                         *(t.format(**slots) for t in self.w.documents["need"])]
            self.rng.shuffle(sentences)
            docs.append(" ".join(sentences[:3]))
            docs.append(" ".join(sentences[3:]))
        return docs

    def comparative_document(self, a: KnowledgeObject, b: KnowledgeObject, attribute: str) -> str:
        more = a.ranks[attribute] > b.ranks[attribute]
        if self.rng.random() < 0.5:  # phrase it with the other comparative, from the other side
            a, b, more = b, a, not more
        cmp = self.w.attributes[attribute]["more" if more else "less"]
        return self.pick(self.w.documents["comparative"]).format(**self.obj(a), **self.obj(b, "y"), cmp=cmp)

    def suits_document(self, s: Scenario, better: KnowledgeObject, worse: KnowledgeObject) -> str:
        return self.pick(self.w.documents["suits"]).format(**self.scn(s), **self.obj(better), **self.obj(worse, "y"))

    # -- questions with reasoning
    def level_fact(self, o: KnowledgeObject, attribute: str, vocabulary: str) -> str:
        return self.w.reasoning["level_fact"].format(**self.obj(o), level=o.ranks[attribute],
                                                     state=level_state(o.phrase(attribute, vocabulary)))

    def score_fact(self, o: KnowledgeObject, s: Scenario, vocabulary: str) -> str:
        parts = []
        for a, need in s.needs.items():
            level = o.ranks[a]
            parts.append(self.w.reasoning["score_state"].format(
                state=level_state(o.phrase(a, vocabulary)), level=level, score=level if need == "high" else 2 - level,
                need=need, attribute=a))
        states = parts[0] if len(parts) == 1 else f"{', '.join(parts[:-1])} and {parts[-1]}"
        return self.w.reasoning["score_fact"].format(**self.obj(o), states=states, total=s.score(o.ranks))

    def compare(self, a: KnowledgeObject, b: KnowledgeObject, attribute: str, kind: str,
                direction: str, vocabulary: str) -> tuple[str, str, str, tuple[str, ...]]:
        """(question, reasoning, answer, options) comparing ``a`` (named first) with ``b``."""
        a_wins = (a.ranks[attribute] > b.ranks[attribute]) == (direction == "more")
        cmp = self.w.attributes[attribute][direction]
        question = self.pick(self.w.questions[kind]).format(**self.obj(a), **self.obj(b, "y"), cmp=cmp)
        conclusion = self.w.reasoning["compare_true" if a_wins else "compare_false"]
        think = " ".join([self.level_fact(a, attribute, vocabulary), self.level_fact(b, attribute, vocabulary),
                          conclusion.format(the_x=a.the, the_y=b.the, cmp=cmp, Cmp=capital(cmp),
                                            way="higher" if direction == "more" else "lower",
                                            **_numbers(a.ranks[attribute], b.ranks[attribute]))])
        if kind == "compare_yesno":
            return question, think, "yes" if a_wins else "no", ("yes", "no")
        return question, think, (a if a_wins else b).bare, (a.bare, b.bare)

    def scenario(self, s: Scenario, a: KnowledgeObject, b: KnowledgeObject,
                 vocabulary: str) -> tuple[str, str, str, tuple[str, ...]]:
        a_better = s.score(a.ranks) > s.score(b.ranks)
        question = self.pick(self.w.questions["scenario"]).format(**self.scn(s), **self.obj(a), **self.obj(b, "y"))
        conclusion = self.w.reasoning["scenario_first" if a_better else "scenario_second"]
        think = " ".join([self.w.reasoning["need"].format(**self.need_slots(s)),
                          self.score_fact(a, s, vocabulary), self.score_fact(b, s, vocabulary),
                          conclusion.format(the_x=a.the, the_y=b.the,
                                            **_numbers(s.score(a.ranks), s.score(b.ranks)))])
        return question, think, (a if a_better else b).bare, (a.bare, b.bare)


def _numbers(x: int, y: int) -> dict[str, str]:
    return {"lx": str(x), "ly": str(y), "rel": "higher" if x > y else "lower"}


def _dialogue(question: str, think: str, answer: str) -> list[Message]:
    return [{"role": "user", "content": question},
            {"role": "assistant", "content": f"<think>{think}</think><answer>{answer}</answer>"}]


def _compare_items(b: _Builder, combos: list[tuple[KnowledgeObject, KnowledgeObject, str]], n: int,
                   kinds: Sequence[str], prefix: str) -> list[EvalQuestion]:
    """``n`` comparison questions per kind from (object, object, attribute) combos with different ranks.

    Yes/no answers, comparative directions and which object is named first are balanced by cycling.
    """
    out: list[EvalQuestion] = []
    if not combos:
        return out
    for kind in kinds:
        order = list(range(len(combos)))
        b.rng.shuffle(order)
        for i in range(n):
            x, y, attribute = combos[order[i % len(order)]]
            direction = ("more", "less")[i % 2]
            first_wins = (i // 2) % 2 == 0
            if ((x.ranks[attribute] > y.ranks[attribute]) == (direction == "more")) != first_wins:
                x, y = y, x
            vocabulary = b.pick(VOCABULARIES_OF[attribute])
            q, think, answer, options = b.compare(x, y, attribute, kind, direction, vocabulary)
            meta = {"objects": [x.bare, y.bare], "attribute": attribute, "direction": direction,
                    "vocabulary": vocabulary, "reasoning": think}
            out.append(EvalQuestion(f"{prefix}{kind}-{i:04d}", kind, q, answer, options, meta))
    return out


def _scenario_items(b: _Builder, combos: list[tuple[Scenario, KnowledgeObject, KnowledgeObject]], n: int,
                    prefix: str) -> list[EvalQuestion]:
    out: list[EvalQuestion] = []
    if not combos:
        return out
    order = list(range(len(combos)))
    b.rng.shuffle(order)
    for i in range(n):
        s, x, y = combos[order[i % len(order)]]
        if (s.score(x.ranks) > s.score(y.ranks)) != (i % 2 == 0):  # better option named first half the time
            x, y = y, x
        vocabulary = b.pick(_vocab_of(list(s.needs)))
        q, think, answer, options = b.scenario(s, x, y, vocabulary)
        meta = {"objects": [x.bare, y.bare], "scenario": s.id, "needs": dict(s.needs), "vocabulary": vocabulary,
                "reasoning": think}
        out.append(EvalQuestion(f"{prefix}scenario-{i:04d}", "scenario", q, answer, options, meta))
    return out


def build_corpus(seed: int = 0, holdout_fraction: float = 0.2, *, n_compare: int = 3000, n_scenario: int = 3000,
                 yesno_share: float = 0.4,
                 n_fact: int = 600, n_eval: int = 120, n_seen: int = 40, fact_passes: int = 2, need_passes: int = 20,
                 objects: Sequence[KnowledgeObject] | None = None, scenarios: Sequence[Scenario] | None = None,
                 wording: Wording | None = None) -> Corpus:
    """The corpus for ``seed``: documents, dialogues, and held-out evaluation questions.

    ``n_compare`` / ``n_scenario`` / ``n_fact`` are training dialogues per family (``yesno_share`` of the
    comparisons are yes/no questions, the rest which-of-two); ``n_eval`` and ``n_seen`` are questions per kind in
    ``EVAL_KINDS``; ``fact_passes`` / ``need_passes`` are how often each object's and scenario's facts are
    restated in documents (differently worded each pass).
    """
    if not 0.0 <= holdout_fraction <= 0.9:
        raise ValueError(f"holdout_fraction must be in [0, 0.9], got {holdout_fraction}")
    if not 0.0 <= yesno_share <= 1.0:
        raise ValueError(f"yesno_share must be in [0, 1], got {yesno_share}")
    for name, value in (("n_compare", n_compare), ("n_scenario", n_scenario), ("n_fact", n_fact),
                        ("n_eval", n_eval), ("n_seen", n_seen), ("fact_passes", fact_passes),
                        ("need_passes", need_passes)):
        if value < 0:
            raise ValueError(f"{name} must be >= 0, got {value}")
    objs = list(knowledge_objects() if objects is None else objects)
    scns = list(load_scenarios() if scenarios is None else scenarios)
    # Separate random streams: the holdout and the evaluation questions do not change when the amount of
    # training text does (string seeds are hashed with SHA-512: stable across runs and platforms).
    rng = random.Random(f"{seed}:holdout")
    words = load_wording() if wording is None else wording
    b = _Builder(objs, scns, words, random.Random(f"{seed}:train"))
    b_eval = _Builder(objs, scns, words, random.Random(f"{seed}:eval"))

    pairs = list(itertools.combinations(objs, 2))
    rng.shuffle(pairs)
    n_pairs_out = round(holdout_fraction * len(pairs))
    held_pairs = {_pair_key(x, y) for x, y in pairs[:n_pairs_out]}
    train_pairs = [(x, y) for x, y in pairs[n_pairs_out:]]
    ids = [s.id for s in scns]
    rng.shuffle(ids)
    held_scn = set(ids[:round(holdout_fraction * len(ids))])

    def differing(pair_list: list) -> list[tuple[KnowledgeObject, KnowledgeObject, str]]:
        return [(x, y, a) for x, y in pair_list for a in ATTRIBUTES if x.ranks[a] != y.ranks[a]]

    def separated(scenario_list: list[Scenario], pair_list: list) -> list[tuple[Scenario, KnowledgeObject,
                                                                             KnowledgeObject]]:
        return [(s, x, y) for s in scenario_list for x, y in pair_list if s.score(x.ranks) != s.score(y.ranks)]

    train_scn = [s for s in scns if s.id not in held_scn]
    compare_train, scenario_train = differing(train_pairs), separated(train_scn, train_pairs)

    # Documents: one object / one scenario per paragraph, comparisons only of training pairs.
    documents = [d for o in objs for d in b.object_documents(o, fact_passes)]
    documents += b.scale_documents()
    documents += [d for s in scns for d in b.need_documents(s, need_passes)]
    documents += [b.comparative_document(x, y, a) for x, y, a in compare_train]
    for s, x, y in scenario_train[:: max(1, len(scenario_train) // max(1, 12 * len(train_scn)))]:
        better, worse = (x, y) if s.score(x.ranks) > s.score(y.ranks) else (y, x)
        documents.append(b.suits_document(s, better, worse))

    # Dialogues: the same question kinds as the evaluation, on training pairs and scenarios only.
    dialogues: list[list[Message]] = []
    # Yes/no comparisons are learnt first and best; which-of-two needs more examples (answering with a name).
    n_yesno = round(n_compare * yesno_share)
    for item in [*_compare_items(b, compare_train, n_yesno, ("compare_yesno",), "train-"),
                 *_compare_items(b, compare_train, n_compare - n_yesno, ("compare_which",), "train-")]:
        dialogues.append(_dialogue(item.question, item.meta["reasoning"], item.answer))
    for item in _scenario_items(b, scenario_train, n_scenario, "train-"):
        dialogues.append(_dialogue(item.question, item.meta["reasoning"], item.answer))
    for _ in range(n_fact):
        o, a = b.pick(objs), b.pick(ATTRIBUTES)
        v = b.pick(VOCABULARIES_OF[a])
        q = b.pick(b.w.questions["fact"]).format(**b.obj(o), attribute=a)
        dialogues.append(_dialogue(q, b.fact(o, [a], v), o.phrase(a, v)))
    for o in objs:
        for v in ("vtv150k", "physiclear"):
            attrs = [a for a in ATTRIBUTES if v in VOCABULARIES_OF[a]]
            answer = "; ".join(f"{a}: {o.phrase(a, v)}" for a in attrs)
            dialogues.append(_dialogue(b.pick(b.w.questions["describe"]).format(**b.obj(o)), b.fact(o, attrs, v),
                                       answer))
    for s in train_scn:
        slots = b.need_slots(s)
        dialogues.append(_dialogue(b.pick(b.w.questions["need"]).format(**b.scn(s)),
                                   b.w.reasoning["need"].format(**slots), slots["needs"]))
    b.rng.shuffle(documents)
    b.rng.shuffle(dialogues)

    held_pair_list = [(x, y) for x, y in pairs[:n_pairs_out]]
    eval_questions = _compare_items(b_eval, differing(held_pair_list), n_eval, ("compare_yesno", "compare_which"),
                                    "")
    eval_questions += _scenario_items(b_eval, separated([s for s in scns if s.id in held_scn], pairs), n_eval, "")
    seen = _compare_items(b_eval, compare_train, n_seen, ("compare_yesno", "compare_which"), "seen-")
    seen += _scenario_items(b_eval, scenario_train, n_seen, "seen-")
    return Corpus(seed, holdout_fraction, documents, dialogues, eval_questions, seen,
                  tuple(sorted(held_pairs)), tuple(s for s in ids if s in held_scn), tuple(objs))
