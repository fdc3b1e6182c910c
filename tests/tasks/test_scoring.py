"""Tests for the task scorers: gold texts accepted, perturbed answers rejected, lenient-only forms, ambiguity."""

from __future__ import annotations

from dataclasses import dataclass

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tacreasoner.tasks.schema import CONTACT_STATES, QAItem, VideoRef
from tacreasoner.tasks.scoring import check_gold, score_item, score_predictions
from tacreasoner.tasks.vocab import get_vocabulary


def make_item(task: str, gold: dict, answer: str, n_videos: int = 1, options: tuple[str, ...] = (),
              vocabulary: str = "vtv150k", item_id: str | None = None) -> QAItem:
    """A QA item written by hand after the gold table in schema.py."""
    return QAItem(id=item_id or f"{task}-{vocabulary}", task=task, question="<tactile> " * n_videos + "?",
                  answer=answer, gold=gold, videos=[VideoRef(f"clip{i}") for i in range(n_videos)],
                  objects=[f"object{i}" for i in range(n_videos)], vocabulary=vocabulary, options=list(options))


def wrap(answer: str) -> str:
    return f"<think>The contact area grew quickly during pressing.</think><answer>{answer}</answer>"


@dataclass
class Case:
    item: QAItem
    wrong: str
    """A perturbed answer: another level / ordinal / swapped pair / letter / verdict / state."""
    lenient_only: str
    """A free-text form of the gold answer that only lenient scoring accepts."""


OSC_OPTIONS = ("a stone", "a sponge", "a tangerine")
TSA_OPTIONS = ("the first object", "the second object")
COMBINED = ("hardness: extremely hard; protrusion: no protrusion; elasticity: moderate elasticity; "
            "friction: strong friction")

CASES = {
    "TFA-hardness": Case(make_item("TFA-hardness", {"attribute": "hardness", "level": 1}, "moderately deformable"),
                         "highly deformable", "The object is moderately deformable under pressing."),
    "TFA-protrusion": Case(make_item("TFA-protrusion", {"attribute": "protrusion", "level": 0}, "no protrusion"),
                           "strong protrusion", "There is no protrusion on the surface"),
    "TFA-elasticity": Case(make_item("TFA-elasticity", {"attribute": "elasticity", "level": 2}, "strong elasticity"),
                           "no elasticity", "It shows strong elasticity: the gel recovers at once."),
    "TFA-friction": Case(make_item("TFA-friction", {"attribute": "friction", "level": 0}, "slight friction"),
                         "moderate friction", "slight-friction"),
    "TFA-hardness-physiclear": Case(
        make_item("TFA-hardness", {"attribute": "hardness", "level": 1}, "moderately hard", vocabulary="physiclear"),
        "hard", "It feels moderately hard."),
    "TFA-roughness-physiclear": Case(
        make_item("TFA-roughness", {"attribute": "roughness", "level": 2}, "rough", vocabulary="physiclear"),
        "slightly rough", "The surface is rough."),
    "TFA-bumpiness-physiclear": Case(
        make_item("TFA-bumpiness", {"attribute": "bumpiness", "level": 0}, "no bumps", vocabulary="physiclear"),
        "big bumps", "I feel no bumps at all"),
    "TFA-combined": Case(
        make_item("TFA-combined", {"levels": {"hardness": 2, "protrusion": 0, "elasticity": 1, "friction": 2}},
                  COMBINED),
        COMBINED.replace("moderate elasticity", "strong elasticity"),
        "It is extremely hard with no protrusion, moderate elasticity and strong friction."),
    "TFA-combined-physiclear": Case(
        make_item("TFA-combined", {"levels": {"hardness": 0, "roughness": 1, "bumpiness": 2}},
                  "hardness: soft; roughness: slightly rough; bumpiness: big bumps", vocabulary="physiclear"),
        "hardness: soft; roughness: rough; bumpiness: big bumps",
        "Soft, slightly rough, with big bumps."),
    "SFD-which": Case(make_item("SFD", {"kind": "which", "index": 1, "attribute": "hardness", "direction": "more"},
                                "the second object", n_videos=2),
                      "the first object", "Object 2 is harder than object 1."),
    "SFD-yesno": Case(make_item("SFD", {"kind": "yesno", "value": True, "attribute": "hardness", "direction": "more"},
                                "yes", n_videos=2),
                      "no", "Yes, the first object is harder."),
    "PC": Case(make_item("PC", {"attribute": "hardness", "relation": "less"}, "less", n_videos=2,
                         vocabulary="physiclear"),
               "similar", "The first object is softer than the second."),
    "PC-similar": Case(make_item("PC", {"attribute": "bumpiness", "relation": "similar"}, "similar", n_videos=2,
                                 vocabulary="physiclear"),
                       "more", "Both have the same bumpiness."),
    "SOI": Case(make_item("SOI", {"index": 2, "attribute": "friction", "direction": "most"}, "the third object",
                          n_videos=3),
                "the first object", "Video 3 has the strongest friction."),
    "OSC": Case(make_item("OSC", {"assignment": [1, 0, 2]}, "1-B, 2-A, 3-C", n_videos=3, options=OSC_OPTIONS),
                "1-A, 2-B, 3-C", "Video 1: B\nVideo 2: A\nVideo 3: C"),
    "TSA": Case(make_item("TSA", {"letter": "B", "scenario": "scraping_ice", "needs": {"hardness": "high"}}, "B",
                          n_videos=2, options=TSA_OPTIONS),
                "A", "Option B is better suited."),
    "RFOR": Case(make_item("RFOR", {"real": False, "fruit": "banana"}, "fake"), "real", "It is not a real banana."),
    "OCSE": Case(make_item("OCSE", {"state": "sliding"}, "sliding", options=CONTACT_STATES), "pressing",
                 "The sensor slides along the surface."),
}
IDS = list(CASES)


# ----------------------------------------------------------------------------------------- gold vs perturbed


@pytest.mark.parametrize("name", IDS)
@pytest.mark.parametrize("mode", ["strict", "lenient"])
def test_gold_answer_is_accepted(name: str, mode: str) -> None:
    item = CASES[name].item
    score = score_item(item, wrap(item.answer), mode)
    assert score.correct, score
    assert not score.parse_failed
    check_gold(item)


@pytest.mark.parametrize("name", IDS)
@pytest.mark.parametrize("mode", ["strict", "lenient"])
def test_perturbed_answer_is_rejected(name: str, mode: str) -> None:
    case = CASES[name]
    score = score_item(case.item, wrap(case.wrong), mode)
    assert not score.correct
    assert not score.parse_failed, score.detail  # read fine, just wrong


@pytest.mark.parametrize("name", IDS)
def test_lenient_only_forms(name: str) -> None:
    case = CASES[name]
    strict = score_item(case.item, wrap(case.lenient_only), "strict")
    assert not strict.correct and strict.parse_failed
    lenient = score_item(case.item, wrap(case.lenient_only), "lenient")
    assert lenient.correct, lenient.detail


@pytest.mark.parametrize("name", IDS)
def test_strict_tolerates_case_whitespace_and_period(name: str) -> None:
    item = CASES[name].item
    assert score_item(item, wrap(f"  {item.answer.upper()}.  "), "strict").correct


@pytest.mark.parametrize("name", IDS)
def test_bare_gold_without_tags_is_lenient_only(name: str) -> None:
    item = CASES[name].item
    assert score_item(item, item.answer, "strict").parse_failed
    assert score_item(item, item.answer, "lenient").correct


def test_check_gold_catches_drift() -> None:
    item = make_item("TFA-hardness", {"attribute": "hardness", "level": 0}, "moderately deformable")
    with pytest.raises(ValueError, match="TFA-hardness-vtv150k"):
        check_gold(item)


# ------------------------------------------------------------------------------------------ per-task details


@pytest.mark.parametrize(("name", "answer"), [
    ("TFA-hardness", "highly deformable or moderately deformable"),
    ("TFA-hardness", "deformable"),                               # no whole level phrase
    ("TFA-elasticity", "no elasticity, or maybe strong elasticity"),
    ("TFA-hardness-physiclear", "soft, maybe moderately hard"),
    ("SFD-which", "the first or the second object"),
    ("SOI", "object 1 or object 3"),
    ("OSC", "video 1: A, video 1: B, video 2: C, video 3: A"),   # two letters for one video
    ("TSA", "(A) or (B)"),
    ("RFOR", "it could be real or fake"),
    ("OCSE", "pressing and sliding"),
])
def test_two_choices_named_is_a_parse_failure(name: str, answer: str) -> None:
    score = score_item(CASES[name].item, wrap(answer), "lenient")
    assert score.parse_failed and not score.correct and score.parsed is None


def test_longest_level_phrase_wins() -> None:
    hard = CASES["TFA-hardness-physiclear"].item  # gold: moderately hard; "hard" is another level
    assert score_item(hard, "It is moderately hard", "lenient").parsed == 1
    assert score_item(hard, "It is hard", "lenient").parsed == 2
    assert score_item(hard, "hardness: moderately hard", "lenient").parsed == 1  # "hardness" is not "hard"
    elastic = CASES["TFA-elasticity"].item
    assert score_item(elastic, "no elasticity", "lenient").parsed == 0


def test_combined_detail_per_attribute() -> None:
    item = CASES["TFA-combined"].item
    wrong = score_item(item, wrap(CASES["TFA-combined"].wrong), "strict")
    assert wrong.detail["per_attribute"] == {"hardness": True, "protrusion": True, "elasticity": False,
                                             "friction": True}
    shuffled = "friction: strong friction; elasticity: moderate elasticity; hardness: extremely hard; " \
               "protrusion: no protrusion;"
    assert score_item(item, wrap(shuffled), "strict").correct
    partial = score_item(item, wrap("extremely hard, no protrusion, strong friction"), "lenient")
    assert partial.parse_failed and not partial.correct
    assert partial.detail["unreadable_attributes"] == ["elasticity"]
    assert score_item(item, wrap("hardness: extremely hard; protrusion: no protrusion"), "strict").parse_failed


@pytest.mark.parametrize(("answer", "index"), [
    ("first", 0), ("The Second", 1), ("second object", 1), ("2nd", None), ("object 2", None),
])
def test_ordinal_strict_forms(answer: str, index: int | None) -> None:
    item = CASES["SFD-which"].item
    assert score_item(item, wrap(answer), "strict").parsed == index


@pytest.mark.parametrize(("answer", "index"), [
    ("2nd", 1), ("object 2", 1), ("Video #2", 1), ("2", 1), ("(2)", 1),
    ("The second object is harder than the first.", 1),
    ("The first is softer than the second", 1),                    # asked "harder": the object after "than"
    ("The first is harder than the second, the second softer", 0),
    ("The second is softer than the first.", 0),
    ("(A)", None), ("B", None),                                    # SFD does not letter its objects
])
def test_ordinal_lenient_forms(answer: str, index: int | None) -> None:
    assert score_item(CASES["SFD-which"].item, wrap(answer), "lenient").parsed == index


def test_an_opposite_comparison_names_none_of_three_objects() -> None:
    """Asked for the grippiest of three, "the first is smoother than the second" does not say which."""
    item = CASES["SOI"].item
    assert score_item(item, wrap("The third object"), "lenient").parsed == 2
    attribute = get_vocabulary(item.vocabulary)["friction"]
    said = f"The first is {attribute.less} than the second."
    assert score_item(item, wrap(said), "lenient").parsed is None
    assert score_item(item, wrap(f"The third is {attribute.more} than the first."), "lenient").parsed == 2


def test_ordinal_out_of_range_is_wrong_not_unparseable() -> None:
    score = score_item(CASES["SFD-which"].item, wrap("the third object"), "strict")
    assert not score.correct and not score.parse_failed and "invalid" in score.detail


@pytest.mark.parametrize(("answer", "value"), [("no", False), ("No, it is softer.", False), ("yes.", True),
                                               ("maybe", None), ("No doubt: yes.", None),  # says both: nothing read
                                               ("Yes, yes.", True)])
def test_yes_no_lenient(answer: str, value: bool | None) -> None:
    assert score_item(CASES["SFD-yesno"].item, wrap(answer), "lenient").parsed == value


@pytest.mark.parametrize(("answer", "parsed"), [
    ("1-B, 2-A, 3-C", [1, 0, 2]), ("3-C,1-B,2-A", [1, 0, 2]), ("1 - b, 2 - a, 3 - c.", [1, 0, 2]),
    ("1-B, 2-A", None), ("1-B 2-A 3-C", None), ("video 1: B, video 2: A, video 3: C", None),
])
def test_osc_strict_forms(answer: str, parsed: list[int] | None) -> None:
    assert score_item(CASES["OSC"].item, wrap(answer), "strict").parsed == parsed


@pytest.mark.parametrize(("answer", "parsed"), [
    ("1 → B, 2 → A, 3 → C", [1, 0, 2]),
    ("1 -> B; 2 -> A; 3 -> C", [1, 0, 2]),
    ("Video 2 is a stone, video 1 is a sponge, video 3 is a tangerine", [1, 0, 2]),
    ("a sponge, a stone, a tangerine", [1, 0, 2]),                # names in video order
    ("B, A, C", [1, 0, 2]),
    ("(1) B (2) A (3) C", [1, 0, 2]),
    ("video 1: B, video 2: B, video 3: C", [1, 1, 2]),            # readable, wrong for video 2
    ("video 1: B, video 2: A", None),                             # incomplete
])
def test_osc_lenient_forms(answer: str, parsed: list[int] | None) -> None:
    assert score_item(CASES["OSC"].item, wrap(answer), "lenient").parsed == parsed


def test_osc_detail_per_video() -> None:
    score = score_item(CASES["OSC"].item, wrap("1-B, 2-C, 3-A"), "strict")
    assert not score.correct and score.detail["per_video"] == [True, False, False]


@pytest.mark.parametrize(("answer", "strict", "lenient"), [
    ("B", "B", "B"), ("(b)", "B", "B"), ("b.", "B", "B"), ("Option B", None, "B"), ("B) the second object", None, "B"),
    ("The second object", None, "B"), ("The second one is better than the first", None, "B"),
    ("The answer is B", None, "B"), ("B is the better choice", None, "B"), ("I would pick B.", None, "B"),
    ("A soft object would fail here", None, None), ("A or B", None, None), ("Choice A, or maybe B", None, None),
])
def test_tsa_forms(answer: str, strict: str | None, lenient: str | None) -> None:
    item = CASES["TSA"].item
    assert score_item(item, wrap(answer), "strict").parsed == strict
    assert score_item(item, wrap(answer), "lenient").parsed == lenient


def test_tsa_option_texts_that_are_not_ordinals() -> None:
    item = make_item("TSA", {"letter": "A", "scenario": "s", "needs": {"hardness": "low"}}, "A", n_videos=2,
                     options=("a kitchen sponge", "a steel spoon"))
    assert score_item(item, wrap("I'd pick a kitchen sponge"), "lenient").correct
    assert score_item(item, wrap("a steel spoon"), "lenient").parsed == "B"


@pytest.mark.parametrize(("answer", "real"), [
    ("it is real", True), ("fake fruit", False), ("not real", False), ("It isn't fake.", True),
    ("This is an artificial banana", False), ("genuine", True), ("real or fake", None), ("really hard", None),
])
def test_rfor_lenient(answer: str, real: bool | None) -> None:
    assert score_item(CASES["RFOR"].item, wrap(answer), "lenient").parsed == real


@pytest.mark.parametrize(("answer", "state"), [
    ("pressed", "pressing"), ("the sensor holds still", "holding"), ("slid", "sliding"), ("rotation", "rotating"),
    ("released", "releasing"), ("Releasing.", "releasing"), ("pressure", None), ("threshold", None),
])
def test_ocse_lenient(answer: str, state: str | None) -> None:
    assert score_item(CASES["OCSE"].item, wrap(answer), "lenient").parsed == state


def test_ocse_strict_rejects_verb_forms() -> None:
    assert score_item(CASES["OCSE"].item, wrap("slides"), "strict").parse_failed


# -------------------------------------------------------------------------------------- properties / errors

FRAGMENTS = sorted({w for case in CASES.values() for text in (case.item.answer, case.wrong, case.lenient_only)
                    for w in text.split()} | {"<answer>", "</answer>", "not", "or", "than", "1-B,", " "})


@given(st.sampled_from(IDS), st.lists(st.sampled_from(FRAGMENTS), max_size=10).map(" ".join))
def test_strict_correct_implies_lenient_correct(name: str, text: str) -> None:
    item = CASES[name].item
    strict = score_item(item, text, "strict")
    lenient = score_item(item, text, "lenient")
    if not strict.parse_failed:
        assert lenient.parsed == strict.parsed
    assert lenient.correct or not strict.correct


def test_score_predictions_records_missing_and_unparseable() -> None:
    items = [CASES["RFOR"].item, CASES["OCSE"].item, CASES["TSA"].item]
    preds = {items[0].id: wrap("fake"), items[1].id: "no tags here: sliding"}
    records = score_predictions(items, preds, "strict")
    assert [r["id"] for r in records] == [i.id for i in items]
    assert [(r["correct"], r["parse_failed"], r["missing"]) for r in records] == \
        [(True, False, False), (False, True, False), (False, True, True)]
    assert records[2]["prediction"] is None
    assert records[0]["parsed"] is False and records[0]["task"] == "RFOR"
    lenient = score_predictions(items, preds, "lenient")
    assert [r["correct"] for r in lenient] == [True, True, False]


def test_bad_gold_names_the_item() -> None:
    item = make_item("SOI", {"index": 5, "attribute": "hardness", "direction": "most"}, "the third object", 3,
                     item_id="soi-42")
    with pytest.raises(ValueError, match=r"soi-42.*'index'"):
        score_item(item, wrap("the third object"))
    item = make_item("RFOR", {"fruit": "pear"}, "real", item_id="rfor-7")
    with pytest.raises(ValueError, match=r"rfor-7.*'real'"):
        score_item(item, wrap("real"))
    item = make_item("TFA-hardness", {"attribute": "hardness", "level": True}, "moderately deformable",
                     item_id="tfa-bool")
    with pytest.raises(ValueError, match="tfa-bool"):
        score_item(item, wrap("moderately deformable"))
    with pytest.raises(ValueError, match="mode"):
        score_item(CASES["RFOR"].item, "fake", "fuzzy")


@pytest.mark.parametrize(("answer", "relation"), [
    ("more", "more"), ("It has more bumpiness.", "more"), ("The first object is bumpier.", "more"),
    ("less bumpy than the second", "less"), ("lower", "less"), ("about the same", "similar"),
    ("equal bumpiness", "similar"), ("more or less", None), ("more, or maybe less", None), ("no idea", None),
])
def test_pc_lenient_reads_one_relation_or_none(answer: str, relation: str | None) -> None:
    from tacreasoner.tasks.scoring import parse_relation
    from tacreasoner.tasks.vocab import PHYSICLEAR

    assert parse_relation(answer, PHYSICLEAR["bumpiness"], lenient=True) == relation
    assert parse_relation(answer, PHYSICLEAR["bumpiness"]) == (answer if answer in ("more", "less") else None)


def test_pc_gold_outside_the_three_relations_names_the_item() -> None:
    item = CASES["PC"].item
    bad = make_item("PC", {"attribute": "hardness", "relation": "same"}, "less", n_videos=2, vocabulary="physiclear")
    with pytest.raises(ValueError, match="'PC-physiclear' \\(PC\\): gold 'relation' must be one of"):
        score_item(bad, wrap("less"))
    assert score_item(item, wrap("less")).correct

