"""The commonsense corpus: deterministic, held-out items really held out, no benchmark wording, valid facts."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tacreasoner.knowledge import EVAL_KINDS, build_corpus, knowledge_objects, load_wording
from tacreasoner.knowledge.corpus import chatml, normalise_answer
from tacreasoner.sim.materials import catalogue, derive_labels
from tacreasoner.tasks.extract import extract_answer
from tacreasoner.tasks.scenarios import load_scenarios
from tacreasoner.tasks.templating import TEMPLATE_DIR

SMALL = {"n_compare": 400, "n_scenario": 300, "n_fact": 100, "n_eval": 30, "n_seen": 10, "fact_passes": 1,
         "need_passes": 1}


@pytest.fixture(scope="module")
def corpus():
    return build_corpus(seed=0)


def _names(text: str, bares: list[str]) -> set[str]:
    return {b for b in bares if re.search(rf"\b{re.escape(b)}\b", text)}


def test_deterministic_for_a_seed() -> None:
    a, b, c = build_corpus(seed=3, **SMALL), build_corpus(seed=3, **SMALL), build_corpus(seed=4, **SMALL)
    assert a.documents == b.documents and a.dialogues == b.dialogues and a.eval_questions == b.eval_questions
    assert a.heldout_pairs == b.heldout_pairs and a.heldout_scenarios == b.heldout_scenarios
    assert a.heldout_pairs != c.heldout_pairs


def test_heldout_pairs_never_co_occur(corpus) -> None:
    bares = [o.bare for o in corpus.objects]
    held = set(corpus.heldout_pairs)
    assert len(held) == round(0.2 * len(bares) * (len(bares) - 1) / 2)
    texts = [*corpus.documents, *(chatml(d) for d in corpus.dialogues)]
    for text in texts:
        named = sorted(_names(text, bares))
        assert len(named) <= 2, text
        if len(named) == 2:
            assert tuple(named) not in held, text
    compare = [q for q in corpus.eval_questions if q.kind.startswith("compare")]
    assert compare and all(tuple(sorted(q.meta["objects"])) in held for q in compare)


def test_heldout_scenarios_only_state_their_needs(corpus) -> None:
    bares = [o.bare for o in corpus.objects]
    held = [s for s in load_scenarios() if s.id in corpus.heldout_scenarios]
    assert len(held) == round(0.2 * len(load_scenarios()))
    for s in held:
        docs = [d for d in corpus.documents if s.text in d]
        assert docs, f"{s.id}: its needs must still be stated"
        assert all(not _names(d, bares) for d in docs)
        assert all(s.text not in m["content"] for d in corpus.dialogues for m in d)
    scenario_q = [q for q in corpus.eval_questions if q.kind == "scenario"]
    assert scenario_q and all(q.meta["scenario"] in corpus.heldout_scenarios for q in scenario_q)
    seen = [q for q in corpus.seen_questions if q.kind == "scenario"]
    assert seen and all(q.meta["scenario"] not in corpus.heldout_scenarios for q in seen)


def test_no_benchmark_question_wording(corpus) -> None:
    """No literal piece (≥ 16 characters) of any benchmark question template appears in the corpus."""
    pieces = set()
    for path in sorted(Path(TEMPLATE_DIR).glob("*.yaml")):
        for text in re.findall(r'text: "(.*)"', path.read_text(encoding="utf-8")):
            text = text.replace("\\n", "\n").replace('\\"', '"')
            for piece in re.split(r"\{\w+\}|<tactile>|\n", text):
                if len(piece.strip()) >= 16:
                    pieces.add(piece.strip())
    assert len(pieces) > 20
    everything = "\n".join([*corpus.documents, *(m["content"] for d in corpus.dialogues for m in d)])
    found = sorted(p for p in pieces if p in everything)
    assert not found, found
    assert "<tactile>" not in everything and "video" not in everything.lower()


def test_facts_match_the_catalogue_and_vocabularies(corpus) -> None:
    objects = {o.sim_name: o for o in corpus.objects if o.source == "catalogue"}
    assert len(objects) == 15
    for m in catalogue():
        labels = derive_labels(m)
        o = objects[m.name]
        assert o.bare == re.sub(r"^(a|an|the)\s+", "", m.display_name)
        assert {a: o.ranks[a] for a in labels["vtv150k"]} == labels["vtv150k"]
        assert o.ranks["roughness"] == labels["physiclear"]["roughness"]
    text = "\n".join(corpus.documents)
    assert "A steel block is extremely hard." in text and "A steel block is hard." in text
    assert "A kitchen sponge is highly deformable." in text and "A kitchen sponge is soft." in text
    assert "For scraping frost off a car windscreen, an object should be hard: high hardness." in text


def test_dialogues_reason_then_answer_correctly(corpus) -> None:
    for d in corpus.dialogues[:500]:
        assert [m["role"] for m in d] == ["user", "assistant"]
        assert extract_answer(d[1]["content"], "strict") is not None
    for q in [*corpus.eval_questions, *corpus.seen_questions]:
        assert q.kind in EVAL_KINDS and q.chance == 0.5
        assert normalise_answer(q.answer) in {normalise_answer(o) for o in q.options}
        if q.kind.startswith("compare"):
            a, direction = q.meta["attribute"], q.meta["direction"]
            first, second = (next(o for o in corpus.objects if o.bare == n) for n in q.meta["objects"])
            first_wins = (first.ranks[a] > second.ranks[a]) == (direction == "more")
            expected = ("yes" if first_wins else "no") if q.kind == "compare_yesno" else \
                (first if first_wins else second).bare
            assert q.answer == expected, q


def test_eval_answers_are_balanced(corpus) -> None:
    for kind in EVAL_KINDS:
        items = [q for q in corpus.eval_questions if q.kind == kind]
        assert len(items) == 120
        first = sum(normalise_answer(q.answer) == normalise_answer(q.options[0]) for q in items)
        assert abs(first - len(items) / 2) <= 1


def test_object_names_do_not_contain_each_other(tmp_path: Path) -> None:
    bares = [o.bare for o in knowledge_objects()]
    assert len(set(bares)) == len(bares) >= 25
    bad = tmp_path / "objects.yaml"
    bad.write_text("objects:\n  - {name: a real apple tree, material: wood, ranks: {hardness: 2, protrusion: 0, "
                   "elasticity: 0, friction: 1, roughness: 1}}\n")
    with pytest.raises(ValueError, match="occurs inside"):
        knowledge_objects(bad)


@pytest.mark.parametrize(("text", "message"), [
    ("objects:\n  - {name: tangerine, material: peel, ranks: {hardness: 0, protrusion: 1, elasticity: 1, "
     "friction: 1, roughness: 1}}\n", "must start with its article"),
    ("objects:\n  - {name: a tangerine, material: peel, ranks: {hardness: 3, protrusion: 1, elasticity: 1, "
     "friction: 1, roughness: 1}}\n", r"objects.yaml:2: rank for 'hardness'"),
    ("objects:\n  - {name: a tangerine, material: peel, ranks: {hardness: 0}}\n", "ranks must give exactly"),
    ("things: []\n", "only an 'objects' list"),
])
def test_bad_objects_file_names_file_and_line(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "objects.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        knowledge_objects(path)


def test_bad_wording_names_file_line_and_slot(tmp_path: Path) -> None:
    from tacreasoner.knowledge.facts import WORDING_FILE

    good = WORDING_FILE.read_text(encoding="utf-8")
    path = tmp_path / "wording.yaml"
    path.write_text(good.replace('"Is {x} {cmp} than {y}?"', '"Is {x} {cmp} than {z}?"'))
    lineno = next(i for i, line in enumerate(good.splitlines(), 1) if "Is {x} {cmp} than {y}?" in line)
    with pytest.raises(ValueError, match=rf"wording.yaml:{lineno}: questions.compare_yesno\[0\]: unknown slot"):
        load_wording(path)
    path.write_text(good.replace('"Is {x} {cmp} than {y}?"', '"Is {x} harder than {y}?"'))
    with pytest.raises(ValueError, match=r"needs one of the slots \['cmp'\]"):
        load_wording(path)


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="holdout_fraction"):
        build_corpus(holdout_fraction=1.5)
    with pytest.raises(ValueError, match="n_eval"):
        build_corpus(n_eval=-1)


def test_evaluation_does_not_depend_on_the_amount_of_training_text() -> None:
    small, large = build_corpus(seed=5, **SMALL), build_corpus(seed=5, **{**SMALL, "n_compare": 900, "n_fact": 7})
    assert small.heldout_pairs == large.heldout_pairs and small.heldout_scenarios == large.heldout_scenarios
    assert small.eval_questions == large.eval_questions
