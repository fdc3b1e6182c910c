"""The hallucination checks: reasoning that names another object, or concludes other than its own answer.

Items use the project's own question templates (every template of every task) and replies are written in the
TouchCoT teacher's styles (full, brief, brief-first, brief-levels; rules_bank.yaml), so the negative cases are
the reasoning a trained model is taught to write. The last test runs the rules teacher itself.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from tacreasoner.tasks.answers import render_answer
from tacreasoner.tasks.consistency import (
    REASONS,
    check_reasoning,
    conclusion_of,
    default_object_vocabulary,
    name_forms,
    named_objects,
    object_vocabulary,
)
from tacreasoner.tasks.schema import TASKS, QAItem, VideoRef
from tacreasoner.tasks.templating import load_templates
from tacreasoner.tasks.vocab import get_vocabulary

OSC_OPTIONS = ["fake banana", "kitchen sponge", "real apple"]
TSA_OPTIONS = ["the first object", "the second object"]
OCSE_OPTIONS = ["pressing", "holding", "sliding", "rotating", "releasing"]
KIND = {"TFA-combined": "tfa_combined", "PC": "pc", "SOI": "soi", "OSC": "osc", "TSA": "tsa", "RFOR": "rfor",
        "OCSE": "ocse"}
N_VIDEOS = {"SFD": 2, "PC": 2, "SOI": 3, "OSC": 3, "TSA": 2}


def item(task: str, gold: dict, *, vocabulary: str = "vtv150k", template: int = 0) -> QAItem:
    """A QA item whose question is rendered from the project's own template bank."""
    kind = KIND.get(task) or ("tfa" if task.startswith("TFA-") else f"sfd_{gold['kind']}")
    templates = load_templates()[kind]
    vocab = get_vocabulary(vocabulary)
    attr = vocab.get(gold.get("attribute", task.removeprefix("TFA-")))
    options = {"OSC": OSC_OPTIONS, "TSA": TSA_OPTIONS, "OCSE": OCSE_OPTIONS}.get(task, [])
    slots = {"attribute": attr.name if attr else "", "choices": ", ".join(attr.levels) if attr else "",
             "attributes": ", ".join(vocab), "format": "; ".join(f"{a}: …" for a in vocab),
             "comparative": (attr.more if gold.get("direction") == "more" else attr.less) if attr else "",
             "superlative": (attr.most if gold.get("direction") == "most" else attr.least) if attr else "",
             "fruit": gold.get("fruit", ""), "scenario": "scraping frost off a car windscreen",
             "options": (" ".join(f"({'ABC'[i]}) {o}" for i, o in enumerate(options)) if task in ("OSC", "TSA")
                         else ", ".join(options))}
    n = N_VIDEOS.get(task, 1)
    videos = [VideoRef(f"{task}-clip{i}", None, *((4, 10) if task == "OCSE" else (None, None))) for i in range(n)]
    return QAItem(id=f"{task}-{template}", task=task, question=templates[template % len(templates)].render(**slots),
                  answer=render_answer(task, gold, vocabulary), gold=gold, videos=videos,
                  objects=[f"obj{i}" for i in range(n)], vocabulary=vocabulary, options=list(options))


def reply(think: str | None, answer: str) -> str:
    return (f"<think>{think}</think>" if think is not None else "") + f"<answer>{answer}</answer>"


TSA_GOLD = {"letter": "A", "scenario": "scrape_ice", "needs": {"hardness": "high"}}
COMBINED = {"levels": {"hardness": 2, "protrusion": 0, "elasticity": 1, "friction": 2}}
COMBINED_TEXT = ("hardness: extremely hard; protrusion: no protrusion; elasticity: moderate elasticity; "
                 "friction: strong friction")

# task key → (item, consistent reasoning in a TouchCoT style, another answer that the reasoning contradicts)
CASES: dict[str, tuple[QAItem, str, str]] = {
    "TFA-hardness": (
        item("TFA-hardness", {"attribute": "hardness", "level": 1}),
        "Answer: moderately deformable. While pressing, the object yields somewhat but pushes back. As the sensor "
        "is released, recovery is fairly quick but not instant, which fits a moderately firm body. So the "
        "hardness of this object is moderately deformable.", "extremely hard"),
    "TFA-protrusion": (
        item("TFA-protrusion", {"attribute": "protrusion", "level": 0}, template=1),
        "During the press, nothing stands out from the contact surface. During the hold, the steady imprint "
        "shows an even surface. Therefore its protrusion: no protrusion.", "strong protrusion"),
    "TFA-elasticity": (
        item("TFA-elasticity", {"attribute": "elasticity", "level": 2}, template=2),
        "The press (0.76–1.72 s) drives the imprint to an intensity of 7.85, with edges of sharpness 0.23 — the "
        "material stores deformation. The release keeps the imprint at 12% of its peak intensity — the object "
        "pushes back strongly as the sensor withdraws. So the elasticity of this object is strong elasticity.",
        "no elasticity"),
    "TFA-friction": (
        item("TFA-friction", {"attribute": "friction", "level": 0}, template=3),
        "While pressing, the contact forms with little grip. During the slide, the imprint glides evenly, so "
        "the gel barely drags. Taken together, the friction is therefore best described as slight friction.",
        "moderate friction"),
    "TFA-roughness": (
        item("TFA-roughness", {"attribute": "roughness", "level": 2}, vocabulary="physiclear"),
        "While sliding, the imprint shudders over a coarse texture. All stages point the same way, so the "
        "object's roughness is rough.", "smooth"),
    "TFA-bumpiness": (
        item("TFA-bumpiness", {"attribute": "bumpiness", "level": 1}, vocabulary="physiclear", template=1),
        "During the press, a few small raised points show in the imprint. So the bumpiness of this object is "
        "small bumps.", "no bumps"),
    "TFA-combined": (
        item("TFA-combined", COMBINED),
        "Across the press, the hold, the rotation and the release, the object feels rigid, flat, somewhat "
        f"springy and grippy. Therefore: {COMBINED_TEXT}.",
        "hardness: extremely hard; protrusion: no protrusion; elasticity: strong elasticity; "
        "friction: strong friction"),
    "SFD-which": (
        item("SFD", {"kind": "which", "index": 1, "attribute": "hardness", "direction": "more"}),
        "Judging by the press, the hold and the release, Video 1 is yielding and Video 2 feels rigid. So the "
        "harder one is the second object.", "the first object"),
    "SFD-which-levels": (
        item("SFD", {"kind": "which", "index": 0, "attribute": "protrusion", "direction": "less"}, template=2),
        "Judging by the press, the hold and the slide, Video 1 is even (level 0) and Video 2 feels slightly "
        "ridged (level 1). Less protrusion means a lower level; 0 is lower than 1, so it is Video 1: the first "
        "object.", "the second object"),
    "SFD-yesno": (
        item("SFD", {"kind": "yesno", "value": False, "attribute": "hardness", "direction": "more"}, template=1),
        "Over the press, the hold and the release, Video 1 is yielding and Video 2 comes across as slightly "
        "yielding. Therefore no: the second object is harder than the first.", "yes"),
    "SFD-yesno-levels": (
        item("SFD", {"kind": "yesno", "value": False, "attribute": "hardness", "direction": "more"}, template=2),
        "Video 1 is yielding (level 0) and Video 2 comes across as slightly yielding (level 1). More hardness "
        "means a higher level; 0 is lower than 1, so no: the first object does not have more hardness.", "yes"),
    "PC-more": (
        item("PC", {"attribute": "hardness", "relation": "more"}, vocabulary="physiclear"),
        "Answer: more. Over the press and the hold, Video 1 feels firm and Video 2 is yielding. So the first "
        "object has more hardness than the second: more.", "less"),
    "PC-similar": (
        item("PC", {"attribute": "roughness", "relation": "similar"}, vocabulary="physiclear", template=1),
        "Stage by stage the two videos read alike for roughness. Therefore their roughness is about the same: "
        "similar.", "more"),
    "SOI": (
        item("SOI", {"index": 2, "attribute": "friction", "direction": "least"}, template=1),
        "Judging by the press, the slide and the release, Video 1 feels tacky, Video 2 comes across as tacky and "
        "Video 3 is moderately grippy. So the smoothest is the third object.", "the first object"),
    "SOI-winner": (
        item("SOI", {"index": 0, "attribute": "hardness", "direction": "most"}, template=2),
        "While pressing, Video 1 gives 20% of the pad, Video 2 55% and Video 3 61%. Video 1 is therefore the "
        "hardest: the first object.", "the third object"),
    "OSC": (
        item("OSC", {"assignment": [1, 0, 2]}),
        "Across the press, the hold and the release, Video 1 is squashy and springy, like the kitchen sponge (B). "
        "Video 2 feels springy and flat-surfaced, which fits the fake banana (A). The firm Video 3 goes with the "
        "real apple (C). Therefore: 1-B, 2-A, 3-C.", "1-A, 2-B, 3-C"),
    "TSA": (
        item("TSA", TSA_GOLD),
        "Scraping frost needs something hard. Video 1 barely deforms under the press, while Video 2 yields "
        "easily. So the first object is the better choice.", "B"),
    "TSA-letter": (
        item("TSA", {**TSA_GOLD, "letter": "B"}, template=1),
        "The task calls for hardness. Video 2 stays rigid under the press. Therefore B suits it better.", "A"),
    "RFOR": (
        item("RFOR", {"real": True, "fruit": "banana"}, template=1),
        "The key for a banana is viscoelastic behaviour: creep during the hold and a lingering dent after "
        "release. While pressing, the flesh yields like living tissue under the load. During the release, the "
        "lingering dent is the plastic set of fruit flesh. The banana is therefore real.", "fake"),
    "RFOR-negated": (
        item("RFOR", {"real": False, "fruit": "strawberry"}, template=2),
        "While pressing, the strawberry resists like a hollow shell and springs back at once, so it is not a "
        "real strawberry.", "real"),
    "OCSE": (
        item("OCSE", {"state": "sliding"}),
        "Over the segment the imprint travels across the pad. The contact state here is therefore sliding.",
        "holding"),
}


def test_cases_cover_every_task() -> None:
    assert {case[0].task for case in CASES.values()} == set(TASKS)


@pytest.mark.parametrize("key", list(CASES))
def test_consistent_reasoning_is_checked_and_not_flagged(key: str) -> None:
    qa, think, _ = CASES[key]
    check = check_reasoning(qa, reply(think, qa.answer))
    assert check.checkable, check.detail
    assert not check.hallucinated and check.reasons == [] and check.flag is False, check.detail
    assert check.conclusion is not None  # every TouchCoT style states a readable conclusion


@pytest.mark.parametrize("key", list(CASES))
def test_reasoning_that_concludes_another_answer_is_flagged(key: str) -> None:
    qa, think, other = CASES[key]
    check = check_reasoning(qa, reply(think, other))
    assert check.flag is True and check.reasons == ["contradicts_answer"], check.detail
    assert "concludes" in check.detail and repr(other) in check.detail


def test_the_brief_example_names_another_object() -> None:
    qa = dataclasses.replace(CASES["RFOR"][0], question="Is the banana in <tactile> real or fake?",
                             gold={"real": False, "fruit": "banana"}, answer="fake")
    text = reply("This video shows a banana being pressed. The imprint springs back at once, so this strawberry "
                 "is fake.", "fake")
    check = check_reasoning(qa, text)
    assert check.flag is True and check.reasons == ["other_object"]
    assert check.other_objects == ["strawberry"] and "'strawberry'" in check.detail


def test_both_reasons_are_listed_in_order() -> None:
    qa = CASES["RFOR"][0]
    check = check_reasoning(qa, reply("The peach keeps a dent after release, so it is real.", "fake"))
    assert check.reasons == list(REASONS) == ["other_object", "contradicts_answer"]


@pytest.mark.parametrize("think", [
    "This apple yields under the press, so it is highly deformable.",  # a question without names
    "The first object is a steel block, so it is highly deformable.",
    "Two tangerines were pressed, so it is highly deformable.",  # a corpus object, passed in below
    "Strawberries yield like this, so it is highly deformable.",  # plural (y → ies)
    "The wooden-block sample yields, so it is highly deformable.",  # a two-word name joined by a hyphen
])
def test_naming_an_object_the_question_does_not_mention_is_flagged(think: str) -> None:
    qa = CASES["TFA-hardness"][0]
    check = check_reasoning(qa, reply(think, "highly deformable"), object_vocabulary(["a tangerine"]))
    assert check.reasons == ["other_object"], check.detail


@pytest.mark.parametrize("key, think", [
    # videos, attributes, stages and materials are not objects
    ("SOI", "Video 2 and Video 3 feel tacky; the grip is strong during the slide, so the smoothest is the third "
            "object."),
    ("TFA-elasticity", "The surface springs back like rubber, a metal-free, fabric-soft feel with a wood-like "
                       "grain, so the elasticity of this object is strong elasticity."),
    # analogies, comparisons, negations, hyphen compounds and colours say nothing about what the object is
    ("TFA-hardness", "It squashes like a sponge and is softer than an apple but as firm as a ripe peach, so the "
                     "hardness of this object is moderately deformable."),
    ("TFA-hardness", "The orange tint of the gel widens; a sponge-like, banana-shaped imprint, not a strawberry "
                     "at all, so the hardness of this object is moderately deformable."),
    # the question's own objects, in any form: plural, real/fake, a shorter name of an OSC option
    ("RFOR", "Real bananas keep a dent and so does this banana, so the banana is therefore real."),
    ("OSC", "Video 1 is the sponge, Video 2 the fake banana and Video 3 the real apple. Therefore: 1-B, 2-A, 3-C."),
    ("TSA", "Frost needs something hard; Video 1 is rigid, so the first object is the better choice."),
])
def test_attributes_videos_and_analogies_are_not_flagged(key: str, think: str) -> None:
    qa, _, _ = CASES[key]
    check = check_reasoning(qa, reply(think, qa.answer), object_vocabulary(["a tangerine"]))
    assert check.flag is False, check.detail


@pytest.mark.parametrize("key, think", [
    # unmarked sentences are not conclusions: a cue sentence naming the other video
    ("SFD-which", "Video 1 presses in deeper than Video 2. The first object yields more."),
    # the opposite comparative: "the first is softer" is consistent with "the second is harder"
    ("SFD-which", "Video 1 yields and Video 2 stays rigid, so the first object is softer than the second."),
    ("SOI", "Video 1 feels tacky, so the first object is the roughest of the three."),
    # PC's relation is the first object's: a conclusion about the second is not read
    ("PC-more", "Video 2 yields under the press, so the second object is softer."),
    # yes/no conclusions are read only when they lead with yes/no
    ("SFD-yesno", "So no slip occurs in Video 1, and the first object feels firm."),
    # negated conclusions (but RFOR's) are not read; comparisons with a level are cut at "than"
    ("TFA-hardness", "So it is not extremely hard."),
    ("TFA-hardness", "So it is harder than highly deformable."),
    # TSA conclusions must speak of choice or suitability; OCSE conclusions must not be temporal
    ("TSA", "Video 2 yields under the press, so the second object would slip and bend on the ice."),
    ("OCSE", "The imprint first grows, so this segment comes right after pressing."),
])
def test_non_conclusions_are_not_read(key: str, think: str) -> None:
    qa, _, _ = CASES[key]
    assert conclusion_of(qa, think) is None
    check = check_reasoning(qa, reply(think, _other(qa)))  # even against another answer: nothing is read
    assert check.flag is None and not check.hallucinated, check.detail


def test_not_checkable_replies() -> None:
    qa = CASES["TFA-hardness"][0]
    no_think = check_reasoning(qa, reply(None, qa.answer))
    assert (no_think.checkable, no_think.flag) == (False, None) and "no reasoning" in no_think.detail
    empty = check_reasoning(qa, "<think>  </think><answer>extremely hard</answer>")
    assert empty.flag is None
    unread = check_reasoning(qa, reply("The imprint grows quickly and fades slowly.", qa.answer))
    assert unread.flag is None and "no readable conclusion" in unread.detail
    no_answer = check_reasoning(qa, reply("So the hardness is extremely hard.", "I am not sure"))
    assert no_answer.flag is None and "no readable answer" in no_answer.detail
    # a reply without answer tags: the text after </think> is its answer
    bare = check_reasoning(qa, "<think>So the hardness is extremely hard.</think> moderately deformable")
    assert bare.reasons == ["contradicts_answer"]


def test_last_readable_conclusion_counts() -> None:
    qa = CASES["TFA-hardness"][0]
    think = "Answer: extremely hard. The press shows a middling imprint. So the hardness is moderately deformable."
    assert check_reasoning(qa, reply(think, "moderately deformable")).flag is False
    assert check_reasoning(qa, reply(think, "extremely hard")).reasons == ["contradicts_answer"]


def test_combined_compares_only_attributes_read_on_both_sides() -> None:
    qa = CASES["TFA-combined"][0]
    partial = "The broad imprint belongs to a rigid surface, so I rate it extremely hard."
    assert check_reasoning(qa, reply(partial, COMBINED_TEXT)).flag is False
    assert check_reasoning(qa, reply(partial, COMBINED_TEXT.replace("extremely hard", "highly deformable"))).reasons \
        == ["contradicts_answer"]


def test_object_vocabulary_comes_from_the_catalogue() -> None:
    vocab = default_object_vocabulary()
    names = {n for group in vocab for n in group}
    assert {"apple", "banana", "strawberry", "peach", "orange", "kitchen sponge", "sponge", "rubber ball",
            "steel block"} <= names
    assert not names & {"rubber", "wood", "metal", "fabric", "real apple", "fake apple"}  # materials, verdicts
    assert name_forms("a sheet of sandpaper") == ["sheet of sandpaper", "sandpaper"]
    assert name_forms("A Fake Apple (variant 12)") == ["apple"]
    extra = object_vocabulary(["a tangerine", "a real apple"])
    assert frozenset({"tangerine"}) in extra and len(extra) == len(vocab) + 1  # the apple merges with its kind
    assert named_objects("Peaches, an orange tint and a Kitchen Sponge like a banana") == ["Peaches",
                                                                                          "Kitchen Sponge"]
    assert named_objects("like a banana", claims_only=False) == ["banana"]


def test_to_dict_is_json_ready() -> None:
    qa, think, other = CASES["OSC"]
    data = check_reasoning(qa, reply(think, other)).to_dict()
    assert data["hallucinated"] is True and data["reasons"] == ["contradicts_answer"]
    assert data["concluded"] == [1, 0, 2] and data["answered"] == [0, 1, 2]


def test_rules_teacher_replies_are_consistent_and_swapped_answers_are_caught(
        small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> None:
    """Every TouchCoT rules-teacher style: never flagged, always checkable; with another answer, always flagged."""
    from tacreasoner.cot.prepare import prepare_jobs
    from tacreasoner.cot.prompts import build_prompt
    from tacreasoner.cot.rules import STYLES, RulesTeacher
    from tacreasoner.tasks.bench import build_bench

    work = tmp_path_factory.mktemp("consistency")
    build_bench("sim", small_sim_dataset, work / "bench", seed=0, heldout_sensor="digit")
    jobs = prepare_jobs(work / "bench", "train", cache_dir=work / "cues")
    assert len({j.item.task for j in jobs}) >= 9
    for style in STYLES:
        teacher = RulesTeacher(seed=0, style=style)
        for job in jobs:
            text = teacher.generate_sync(job, build_prompt(job)).text
            check = check_reasoning(job.item, text)
            assert check.flag is False, f"{style} {job.item.id}: {check.detail}"
            swapped = text.replace(f"<answer>{job.item.answer}</answer>", f"<answer>{_other(job.item)}</answer>")
            assert check_reasoning(job.item, swapped).reasons == ["contradicts_answer"], f"{style} {job.item.id}"


def _other(qa: QAItem) -> str:
    """Another valid answer for the item (a different level, object, verdict, pairing or state)."""
    gold = dict(qa.gold)
    if qa.task == "TFA-combined":
        gold["levels"] = {a: (r + 1) % 3 for a, r in gold["levels"].items()}
    elif qa.task.startswith("TFA-"):
        gold["level"] = (gold["level"] + 1) % 3
    elif qa.task == "SFD" and gold["kind"] == "yesno":
        gold["value"] = not gold["value"]
    elif qa.task in ("SFD", "SOI"):
        gold["index"] = (gold["index"] + 1) % len(qa.videos)
    elif qa.task == "PC":
        gold["relation"] = "less" if gold["relation"] != "less" else "more"
    elif qa.task == "OSC":
        a = gold["assignment"]
        gold["assignment"] = [a[1], a[2], a[0]]
    elif qa.task == "RFOR":
        gold["real"] = not gold["real"]
    elif qa.task == "OCSE":
        gold["state"] = "holding" if gold["state"] != "holding" else "sliding"
    else:
        gold["letter"] = "B" if gold["letter"] == "A" else "A"
    return render_answer(qa.task, gold, qa.vocabulary)
