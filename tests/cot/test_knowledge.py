"""Object knowledge as text-only examples: the compact style's words, the benchmark's vocabulary, and name removal
that really removes the evaluation objects' names."""

from __future__ import annotations

import re
from pathlib import Path

from tacreasoner.cot.knowledge import bare_name, content_words, knowledge_examples, without_names
from tacreasoner.tasks.everyday_objects import EverydayObject, everyday_objects

RANKS = {"hardness": 2, "protrusion": 0, "elasticity": 0, "friction": 1, "roughness": 1}
OBJECTS = [EverydayObject("a glass jar", "glass", RANKS), EverydayObject("a pair of jeans", "denim", RANKS),
           EverydayObject("a lemon", "citrus peel", {**RANKS, "hardness": 1, "protrusion": 1}),
           EverydayObject("a wool scarf", "knitted wool", {**RANKS, "hardness": 0}),
           EverydayObject("a brick", "fired clay", {**RANKS, "roughness": 2}),
           EverydayObject("a steel spoon", "steel", {**RANKS, "roughness": 0})]


def test_examples_speak_the_vocabularys_level_words() -> None:
    examples = knowledge_examples("physiclear", objects=OBJECTS)
    one = {e.question: e.target for e in examples if not e.key.startswith("knowledge-group")}
    assert one["How does a lemon usually feel to the touch?"] == "<answer>moderately hard, slightly rough, small " \
                                                                "bumps</answer>"  # bumpiness = the protrusion rank
    groups = [e for e in examples if e.key.startswith("knowledge-group")]
    assert len(groups) == 2
    for g in groups:
        said = re.findall(r"\(([ABC])\) ([^:]+): ([^.]+)\.", g.target)
        assert [s[0] for s in said] == ["A", "B", "C"]
        assert all(f"({letter}) {name}" in g.question for letter, name, _ in said)
    vtv = knowledge_examples("vtv150k", objects=OBJECTS)
    assert any("extremely hard, no protrusion, no elasticity, moderate friction" in e.target for e in vtv)


def test_removing_evaluation_names_removes_every_entry_sharing_a_word() -> None:
    kept = without_names(OBJECTS, ["a ball of steel wool", "a pair of jeans", "a lemon"])
    assert [o.name for o in kept] == ["a glass jar", "a brick"]
    assert content_words("a pair of Jeans") == {"pair", "jean"} and bare_name("an egg") == "egg"
    examples = knowledge_examples("physiclear", objects=OBJECTS, exclude=["a lemon", "a ball of steel wool"])
    text = " ".join(e.question + e.target for e in examples).lower()
    assert not re.search(r"\b(lemon|steel|wool|ball)", text)


def test_train_objects_labels_win_over_an_entry_of_the_same_name() -> None:
    examples = knowledge_examples("physiclear", objects=OBJECTS, train_names=["a brick"])
    assert not any("brick" in e.question for e in examples)


def test_object_knowledge_leaves_out_the_benchmarks_val_and_test_names(physiclear_folder: Path, tmp_path: Path
                                                                       ) -> None:
    from tacreasoner.tasks.bench import build_bench, load_bench
    from tacreasoner.train.data import text_knowledge

    build_bench("physiclear", physiclear_folder, tmp_path / "bench")
    train = load_bench(tmp_path / "bench", "train")[1]

    def object_knowledge(bench: Path, knowledge: str) -> list:
        return text_knowledge(bench, train, knowledge)

    every = object_knowledge(tmp_path / "bench", "all")
    assert len(every) >= len(everyday_objects())  # one per entry and the groups of three
    assert object_knowledge(tmp_path / "bench", "none") == []
    eval_words = set()
    for split in ("val", "test"):
        for item in load_bench(tmp_path / "bench", split)[1]:
            for name in (*item.meta.get("object_names", ()), *item.objects):
                eval_words |= content_words(name)
    def named(text: str) -> set[str]:  # the object names an example's question gives
        single = re.fullmatch(r"How does (.+) usually feel to the touch\?", text)
        return {single.group(1)} if single else set(re.findall(r"\([ABC]\) ([^(]+?)(?= \(|$)", text))

    assert eval_words and any(named(e.question) for e in every)
    removed = object_knowledge(tmp_path / "bench", "without_eval_names")
    assert all(not content_words(n) & eval_words for e in removed for n in named(e.question))


def test_stage2_adds_scenario_knowledge_as_text_only_and_never_tsa(physiclear_folder: Path, tmp_path: Path) -> None:
    from tacreasoner.tasks.bench import build_bench
    from tacreasoner.train.data import load_examples

    build_bench("physiclear", physiclear_folder, tmp_path / "bench")
    plain = load_examples(2, tmp_path / "bench", stage2_data="compact")
    more = load_examples(2, tmp_path / "bench", stage2_data="compact", scenario_knowledge=True)
    added = more[len(plain):]
    assert added and {e.task for e in added} == {"scenario knowledge"} and all(e.videos == () for e in added)
    assert "TSA" not in {e.task for e in more}
    assert load_examples(1, tmp_path / "bench", scenario_knowledge=True) == load_examples(1, tmp_path / "bench")
