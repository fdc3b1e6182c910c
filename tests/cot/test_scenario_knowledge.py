"""Scenario knowledge as text: the training scenarios never hold an evaluation (TSA) scenario, and the examples'
choices follow from the scenario's needs."""

from __future__ import annotations

import re

import pytest

from tacreasoner.cot.knowledge import SCENARIO_FILE, content_words, scenario_examples
from tacreasoner.tasks.scenarios import load_scenarios

GRAMMAR = frozenset({"by", "can", "into", "it", "off", "out", "so", "that", "to", "under", "while", "without", "for",
                     "your", "you", "at", "up", "from", "over", "one", "its", "is", "or", "be", "not", "do", "doe",
                     "when", "them", "they", "after", "around", "through", "down", "back", "across"})


def test_training_scenarios_share_no_id_text_or_content_word_with_the_evaluation_bank() -> None:
    train, evaluation = load_scenarios(SCENARIO_FILE), load_scenarios()
    assert len(train) >= 100
    assert not {s.id for s in train} & {s.id for s in evaluation}
    normal = {re.sub(r"[^a-z ]", "", s.text.lower()) for s in evaluation}
    assert not {re.sub(r"[^a-z ]", "", s.text.lower()) for s in train} & normal
    eval_words = set().union(*(content_words(s.text) for s in evaluation)) - GRAMMAR
    shared = {w for s in train for w in content_words(s.text) & eval_words}
    assert not shared, f"training scenarios share words with TSA's evaluation bank: {sorted(shared)}"


@pytest.mark.parametrize("vocabulary", ["physiclear", "vtv150k"])
def test_examples_never_name_an_evaluation_scenario_and_choose_by_the_needs(vocabulary: str) -> None:
    examples = scenario_examples(vocabulary)
    texts = " ".join(e.question + e.target for e in examples).lower()
    for s in load_scenarios():
        assert s.text.lower() not in texts
    by_text = {s.text: s for s in load_scenarios(SCENARIO_FILE)}
    choices = [e for e in examples if "-choice-" in e.key]
    assert len(choices) >= 3 * len([e for e in examples if "-choice-" not in e.key])
    from tacreasoner.tasks.vocab import get_vocabulary

    vocab = get_vocabulary(vocabulary)
    for e in choices:
        first, second, scenario = re.match(r"First object: (.+)\.\nSecond object: (.+)\.\nYou need an object for "
                                           r"(.+)\. Which", e.question).groups()
        levels = [{a: vocab[a].levels.index(w) for a, w in zip(vocab, words.split(", "), strict=True)}
                  for words in (first, second)]
        scores = [by_text[scenario].score(lv) for lv in levels]
        assert scores[0] != scores[1]
        assert e.target.endswith(f"<answer>{'AB'[int(scores[1] > scores[0])]}</answer>")
        assert f"Video {int(scores[1] > scores[0]) + 1} fits better" in e.target
