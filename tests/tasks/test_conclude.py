"""Describe, then conclude: the rule that turns per-object levels into an answer, and the consistency measure."""

from __future__ import annotations

import pytest

from tacreasoner.tasks.builders import build_items
from tacreasoner.tasks.conclude import (
    REASONED_TASKS,
    consistency,
    implied_answers,
    item_levels,
    option_levels,
    parsed_answer,
    stated_levels,
)
from tacreasoner.tasks.paraphrase import reword_items
from tacreasoner.tasks.schema import QAItem, VideoRef
from tests.tasks.clipfactory import make_clips

TASKS = {"vtv150k": ["SFD", "SOI", "OSC", "TSA"], "physiclear": ["SFD", "PC", "SOI", "OSC", "TSA"]}


@pytest.fixture(scope="module", params=sorted(TASKS))
def items(request: pytest.FixtureRequest) -> list[QAItem]:
    clips = make_clips(n_objects=30, repeats=2)
    built = build_items(clips, tasks=TASKS[request.param], vocabulary=request.param, split="val", seed=0)
    return built + reword_items(built, "heldout")


def _item(task: str, gold: dict, answer: str, ranks: list, options: list[str] | None = None) -> QAItem:
    n = len(ranks)
    return QAItem(id=f"t-{task}", task=task, question="\n".join(["<tactile>"] * n) + "\nQ?", answer=answer, gold=gold,
                  videos=[VideoRef(clip_id=f"c{k}") for k in range(n)], objects=[f"o{k}" for k in range(n)],
                  vocabulary="physiclear", options=options or [], meta={"attribute": gold.get("attribute"),
                                                                        "ranks": ranks})


def test_every_built_items_gold_follows_from_its_labels(items: list[QAItem]) -> None:
    assert {i.task for i in items} >= {"SFD", "SOI", "OSC", "TSA"}
    for item in items:
        options = option_levels(item) if item.task == "OSC" else ()
        gold = parsed_answer(item, f"<answer>{item.answer}</answer>")
        assert gold is not None, item.id
        assert gold in implied_answers(item, item_levels(item), options), item.id


def test_ties_allow_every_answer_they_leave_open() -> None:
    soi = _item("SOI", {"index": 0, "attribute": "hardness", "direction": "most"}, "the first object", [2, 2, 0])
    assert implied_answers(soi, item_levels(soi)) == {0, 1}
    pc = _item("PC", {"attribute": "roughness", "relation": "similar"}, "similar", [1, 1])
    assert implied_answers(pc, item_levels(pc)) == {"similar"}
    assert implied_answers(pc, [{"roughness": 2}, {"roughness": 0}]) == {"more"}
    yesno = _item("SFD", {"kind": "yesno", "value": False, "attribute": "hardness", "direction": "more"}, "no", [1, 1])
    assert implied_answers(yesno, item_levels(yesno)) == {False}  # "is the first harder?" no, they are equal
    which = _item("SFD", {"kind": "which", "index": 1, "attribute": "hardness", "direction": "less"},
                  "the second object", [2, 0])
    assert implied_answers(which, item_levels(which)) == {1}


def test_osc_matches_videos_to_the_closest_named_objects() -> None:
    levels = [{"hardness": 2, "roughness": 0, "bumpiness": 0}, {"hardness": 0, "roughness": 2, "bumpiness": 1},
              {"hardness": 1, "roughness": 1, "bumpiness": 2}]
    osc = _item("OSC", {"assignment": [2, 0, 1]}, "1-C, 2-A, 3-B", levels, ["wool", "brush", "ice"])
    assert option_levels(osc) == [levels[1], levels[2], levels[0]]
    assert implied_answers(osc, levels, option_levels(osc)) == {(2, 0, 1)}
    same = [levels[0]] * 3  # three alike: every matching is as good
    assert len(implied_answers(osc, same, same)) == 6


def test_tsa_picks_the_object_that_fits_the_needs() -> None:
    tsa = QAItem(id="t-TSA", task="TSA", question="<tactile>\n<tactile>\nQ?", answer="B",
                 gold={"letter": "B", "scenario": "wipe_screen", "needs": {"roughness": "low", "hardness": "low"}},
                 videos=[VideoRef(clip_id="a"), VideoRef(clip_id="b")], objects=["a", "b"], vocabulary="physiclear",
                 options=["the first object", "the second object"],
                 meta={"ranks": [{"hardness": 2, "roughness": 1}, {"hardness": 0, "roughness": 1}]})
    assert implied_answers(tsa, item_levels(tsa)) == {"B"}


def test_consistency_reads_the_levels_a_reply_stated() -> None:
    soi = _item("SOI", {"index": 2, "attribute": "hardness", "direction": "least"}, "the third object", [2, 1, 0])
    good = "<think>Video 1: hard. Video 2: moderately hard. Video 3: soft. The softest is Video 3.</think>" \
           "<answer>the third object</answer>"
    assert consistency(soi, good).status == "consistent"
    # right answer, but not the one its own reading implies: a defect, even though it scores as correct
    wrong_reading = good.replace("Video 3: soft", "Video 3: hard").replace("Video 1: hard", "Video 1: soft")
    assert consistency(soi, wrong_reading).status == "inconsistent"
    assert consistency(soi, "<answer>the third object</answer>").status == "no levels"
    missing = "<think>Video 1: hard. Video 3: soft.</think><answer>the third object</answer>"
    assert consistency(soi, missing).status == "no levels"
    twice = good.replace("Video 2: moderately hard", "Video 2: soft, hard")  # two levels of one property
    assert stated_levels(soi, twice.split("</think>")[0].removeprefix("<think>")) is None
    unread = good.replace("<answer>the third object</answer>", "<answer>the fourth one</answer>")
    assert consistency(soi, unread).status == "no answer"


def test_moderately_hard_is_not_also_read_as_hard() -> None:
    pc = _item("PC", {"attribute": "hardness", "relation": "less"}, "less", [1, 2])
    reply = "<think>Video 1: moderately hard. Video 2: hard. Video 1 has less hardness than Video 2.</think>" \
            "<answer>less</answer>"
    assert stated_levels(pc, reply) == ([{"hardness": 1}, {"hardness": 2}], [])
    assert consistency(pc, reply).consistent


def test_osc_consistency_needs_the_named_objects_levels_too() -> None:
    levels = [{"hardness": 2, "roughness": 0, "bumpiness": 0}, {"hardness": 0, "roughness": 2, "bumpiness": 1},
              {"hardness": 1, "roughness": 1, "bumpiness": 2}]
    osc = _item("OSC", {"assignment": [2, 0, 1]}, "1-C, 2-A, 3-B", levels, ["wool", "brush", "ice"])
    videos = ("Video 1: hard, smooth, no bumps. Video 2: soft, rough, small bumps. "
              "Video 3: moderately hard, slightly rough, big bumps.")
    named = ("(A) wool: soft, rough, small bumps. (B) brush: moderately hard, slightly rough, big bumps. "
             "(C) ice: hard, smooth, no bumps.")
    assert consistency(osc, f"<think>{videos} {named} Closest match: 1-C, 2-A, 3-B.</think><answer>1-C, 2-A, 3-B"
                            "</answer>").consistent
    assert consistency(osc, f"<think>{videos} {named}</think><answer>1-A, 2-B, 3-C</answer>").status == \
        "inconsistent"
    assert consistency(osc, f"<think>{videos}</think><answer>1-C, 2-A, 3-B</answer>").status == "no levels"


def test_single_clip_tasks_are_not_reasoned_over_objects() -> None:
    tfa = QAItem(id="t", task="TFA-hardness", question="<tactile>\nQ?", answer="soft",
                 gold={"attribute": "hardness", "level": 0}, videos=[VideoRef(clip_id="a")], objects=["a"],
                 vocabulary="physiclear")
    assert "TFA-hardness" not in REASONED_TASKS
    with pytest.raises(ValueError, match="not reasoned over objects"):
        implied_answers(tfa, [{"hardness": 0}])


@pytest.mark.parametrize(("question", "vocabulary", "expected"), [
    ("How firm does this feel? <tactile>", "physiclear", ["hardness"]),
    ("<tactile>\nDoes it feel squishy or solid?", "physiclear", ["hardness"]),
    ("<tactile>\nWhat is the texture like: smooth or rough?", "physiclear", ["roughness"]),
    ("<tactile>\nWhat is the texture like: smooth or rough?", "vtv150k", ["friction"]),  # VTV-150K's wording
    ("<tactile>\nCan you feel any lumps?", "physiclear", ["bumpiness"]),
    ("<tactile>\nCan you feel any lumps?", "vtv150k", ["protrusion"]),
    ("<tactile>\nIs it hard and rough?", "physiclear", ["hardness", "roughness"]),
    ("<tactile>\nWhat does this feel like?", "physiclear", ["hardness", "roughness", "bumpiness"]),
    ("Is this a real orange or a fake one? <tactile>", "physiclear", None),
    ("<tactile>\nIs this surface slippery?", "physiclear", None),  # friction is no PhysiCLeAR property
    # fourth version: an analogy's things are examples, not the property asked
    ("<tactile>\nIs it slippery like ice or sticky like rubber?", "vtv150k", ["friction"]),
    ("Is it more like sandpaper or more like glass? <tactile>", "physiclear", ["roughness"]),  # only an analogy
    ("I'd like to know if it is hard or rubbery <tactile>", "vtv150k", ["hardness", "elasticity"]),  # not one
    # ... and a press described in an elasticity question is not a hardness question too
    ("When you squash it and let go, does it spring right back? <tactile>", "vtv150k", ["elasticity"]),
    ("Does the dent stay after you push in? <tactile>", "vtv150k", ["elasticity"]),
    ("Does the dent stay after you push in? <tactile>", "physiclear", ["hardness"]),  # no elasticity there
    ("Is it soft, and does it spring back? <tactile>", "vtv150k", ["hardness", "elasticity"]),
    ("<tactile>\nIs anything poking out?", "vtv150k", ["protrusion"]),
    # fifth version: a gripper is the robot's hand; what the robot did counts only when nothing else is asked
    ("Will the gripper have trouble with it, is it hard? <tactile>", "vtv150k", ["hardness"]),
    ("The sensor slid along it: <tactile> Is it bumpy?", "physiclear", ["bumpiness"]),
    ("The sensor slid along it: <tactile> How easily?", "vtv150k", ["friction"]),
    ("We sell cushions. Is this one firm? <tactile>", "vtv150k", ["hardness"]),
    # sixth version: poking something is no protrusion, something poking out is; resisting a press is hardness
    ("If I poke it, does it spring back or keep my fingerprint? <tactile>", "vtv150k", ["elasticity"]),
    ("<tactile>\nIs there a stem poking out?", "vtv150k", ["protrusion"]),
    ("Does it give way when pressed, or resist pressure? <tactile>", "physiclear", ["hardness"]),
    # seventh version: a feature standing proud of the surface, or sitting flush
    ("Does any part of it stand proud of the rest? <tactile>", "vtv150k", ["protrusion"]),
    ("<tactile> Is the screw head sitting flush?", "vtv150k", ["protrusion"]),
    ("<tactile> Is the screw head sitting flush?", "physiclear", ["bumpiness"]),
    # eighth version: holding a dent or deforming for good is the elasticity question's other answer
    ("Is it springy, or does it hold the dent? <tactile>", "vtv150k", ["elasticity"]),
    ("<tactile> Rubbery and self-restoring, or does it deform permanently?", "vtv150k", ["elasticity"]),
    ("<tactile> Does it deform easily?", "vtv150k", ["hardness"]),  # no "for good": a hardness question still
    # "like in terms of" is no analogy: every property it names is asked
    ("<tactile> What's it like in terms of hardness, roughness and bumpiness?", "physiclear",
     ["hardness", "roughness", "bumpiness"]),
    # tenth version: an analogy's span that names a property by its name keeps it
    ("She asked what it felt like - so what are its hardness, roughness and bumpiness? <tactile>", "physiclear",
     ["hardness", "roughness", "bumpiness"]),
    ("Is it sticky like a rubber mat? <tactile>", "vtv150k", ["friction"]),
    # eleventh version: "hard to" a difficulty is no hardness; "hard to the touch" is, and so is a hardness verb
    ("Is it hard to keep hold of, is it slippery? <tactile>", "vtv150k", ["friction"]),
    ("<tactile> It hardly slides at all, does it?", "vtv150k", ["friction"]),
    ("<tactile> Is it hard to the touch?", "vtv150k", ["hardness"]),
    ("<tactile> Is it hard to squeeze?", "physiclear", ["hardness"]),
    # twelfth version: a story's words are background, the property asked is the one its question names...
    ("We test rough-terrain tyres. <tactile> Is the tread lumpy or flat?", "physiclear", ["bumpiness"]),
    # ...and a question naming two properties, or none, keeps what the whole reads
    ("We test tyres. Is it hard? Is it rough? <tactile>", "physiclear", ["hardness", "roughness"]),
    ("Rough and hard, I reckon. Tell me. <tactile>", "physiclear", ["hardness", "roughness"]),
])
def test_a_one_clip_questions_properties_are_read_from_everyday_words(question: str, vocabulary: str,
                                                                     expected: list[str] | None) -> None:
    from tacreasoner.tasks.conclude import asked_properties

    assert asked_properties(question, vocabulary) == expected


@pytest.mark.parametrize(("question", "kind"), [
    ("Which one is harder? <tactile> <tactile>", "which"),
    ("Pick the harder one: <tactile> <tactile>", "which"),
    ("<tactile> <tactile> Please identify the object that is harder.", "which"),  # tenth version
    ("Choose the harder of these two: <tactile> <tactile>", "which"),
    ("Is the first harder than the second? <tactile> <tactile>", "yesno"),
    # a "pick" or "which" in the context does not turn a question that asks for yes or no into a which-question
    ("I must pick a sample. <tactile> <tactile> Is the first harder than the second? Yes or no.", "yesno"),
])
def test_a_comparisons_kind_is_read_from_its_words(question: str, kind: str) -> None:
    from tacreasoner.tasks.conclude import asked

    assert asked("SFD", question, "vtv150k") == {"attribute": "hardness", "direction": "more", "kind": kind}


def test_a_fallback_reads_only_what_the_words_leave_unread() -> None:
    from tacreasoner.tasks.conclude import asked_properties

    asked_of: list[str] = []

    def fallback(question: str, vocabulary: str) -> str | None:
        asked_of.append(question)
        return "roughness" if "ruff" in question else ("friction" if "zing" in question else None)

    assert asked_properties("<tactile> smoth or ruff?", "physiclear", fallback) == ["roughness"]
    assert asked_properties("<tactile> Is it hard?", "physiclear", fallback) == ["hardness"]
    assert asked_properties("<tactile> how does it zing?", "physiclear", fallback) is None, \
        "a property outside the vocabulary is no reading"
    assert asked_properties("<tactile> anything?", "physiclear", fallback) is None
    # a real-or-fake question or one touch cannot answer has a reply of its own: never sent to the fallback
    for question in ("<tactile> Is this a ruff fake?", "<tactile> a ruff orange, or a plastic one?",
                     "<tactile> What colour is this ruff thing?"):
        assert asked_properties(question, "physiclear", fallback) is None
    assert asked_of == ["<tactile> smoth or ruff?", "<tactile> how does it zing?", "<tactile> anything?"]
