"""Tests for the TouchCoT filter: each reject reason, contradiction reading, stage synonyms, dedup, stats."""

from __future__ import annotations

import pytest

from tacreasoner.cot.filter import (
    FilterConfig,
    acceptance_stats,
    conclusion,
    filter_samples,
    item_of,
    jaccard,
    missing_stages,
    shingles,
    stages_mentioned,
)
from tests.cot.cot_samples import GOLDS, good_sample, make_item, make_sample, varied_think

TASKS = list(GOLDS)
GOOD_HARDNESS_THINK = ("During pressing the contact area grows quickly to 0.41 of the pad and the imprint is broad. "
                       "While holding, the imprint keeps spreading. After release the gel recovers at once.")


def run(*samples, **config):
    return filter_samples(list(samples), FilterConfig(**config))


@pytest.mark.parametrize("task", TASKS)
def test_good_samples_are_accepted(task):
    sample = good_sample(task)
    result = run(sample)
    assert sample.accepted is True, (sample.reject_reasons, sample.meta["filter"], sample.output)
    assert sample.reject_reasons == []
    assert result.accepted == [sample]


@pytest.mark.parametrize("task", TASKS)
def test_consistent_conclusion_is_read(task):
    sample = good_sample(task)
    run(sample)
    assert "conclusion" in sample.meta["filter"], sample.output


@pytest.mark.parametrize("output", [
    "<answer>highly deformable</answer>",  # no think block
    "<think>" + GOOD_HARDNESS_THINK + "</think>highly deformable",  # no answer block
    "Sure! <think>" + GOOD_HARDNESS_THINK + "</think><answer>highly deformable</answer>",  # text outside
    "<think>" + GOOD_HARDNESS_THINK + "</think><answer>highly deformable</answer><answer>x</answer>",  # two answers
    "<think>" + GOOD_HARDNESS_THINK + "<answer>highly deformable</answer>",  # unclosed think
])
def test_format_reject(output):
    sample = make_sample(make_item("TFA-hardness"), output=output)
    run(sample)
    assert sample.accepted is False
    assert sample.reject_reasons == ["format"]


def test_wrong_answer():
    sample = make_sample(make_item("TFA-hardness"), GOOD_HARDNESS_THINK, "moderately deformable")
    run(sample)
    assert sample.reject_reasons == ["wrong_answer"]
    # A free-text answer that only lenient scoring reads is wrong under the strict scorer.
    sample = make_sample(make_item("TFA-hardness"), GOOD_HARDNESS_THINK, "It is highly deformable")
    run(sample)
    assert sample.reject_reasons == ["wrong_answer"]


def test_missing_stages():
    think = ("During pressing the contact area grows quickly to 0.41 of the pad and the imprint is broad. "
             "While holding, the imprint keeps spreading, which fits a compliant body throughout.")
    sample = make_sample(make_item("TFA-hardness"), think)
    run(sample)
    assert sample.reject_reasons == ["missing_stages"]
    assert sample.meta["filter"]["missing_stages"] == ["release"]
    sample = make_sample(make_item("TFA-hardness"), think)
    run(sample, require_stages=False)
    assert sample.accepted is True


@pytest.mark.parametrize(("text", "stage"), [
    ("the pad was pressed into the object", "press"), ("a deep indentation forms", "press"),
    ("during loading the area grows", "press"), ("the gel compresses", "press"),
    ("in the dwell nothing moves", "hold"), ("it is held still", "hold"), ("holding steady", "hold"),
    ("the sensor slid sideways", "slide"), ("shear tilts the gel", "slide"), ("stick-slip appears", "slide"),
    ("a twist of the wrist", "rotate"), ("torsion shows at the rim", "rotate"), ("rotating slowly", "rotate"),
    ("after lift-off the gel recovers", "release"), ("lift off is quick", "release"),
    ("during unloading the area shrinks", "release"), ("once released", "release"),
])
def test_stage_synonyms(text, stage):
    assert stage in stages_mentioned(text)
    assert missing_stages(text.upper(), [stage]) == []


def test_stage_words_that_do_not_count():
    assert "press" not in stages_mentioned("the pressure stays constant")
    assert stages_mentioned("during unloading the area shrinks") == ["release"]  # not a "loading"
    assert missing_stages("nothing here", ["press", "dynamic"]) == ["press", "dynamic"]
    assert missing_stages("a dynamically varying contact", ["dynamic"]) == []


def test_contradiction_rejected_and_consistent_accepted():
    item = make_item("TFA-hardness")  # gold: highly deformable
    bad = make_sample(item, GOOD_HARDNESS_THINK + " So the object is extremely hard.", "highly deformable", key="bad")
    good = make_sample(item, GOOD_HARDNESS_THINK + " So the object is highly deformable.", "highly deformable",
                       key="good")
    run(bad, good)
    assert bad.reject_reasons == ["contradiction"]
    assert bad.meta["filter"]["conclusion"] == "the object is extremely hard."
    assert bad.meta["filter"]["conclusion_parsed"] == 2
    assert good.accepted is True


def test_last_readable_conclusion_wins():
    item = make_item("TFA-hardness")
    # An earlier conclusion is overruled by a later one; an unreadable last one falls back to the earlier.
    later = make_sample(item, GOOD_HARDNESS_THINK + " At first, so it seems, extremely hard. Therefore it is highly "
                        "deformable.", key="later")
    fallback = make_sample(item, GOOD_HARDNESS_THINK + " So the object is extremely hard. Thus I answer now.",
                           key="fallback")
    none = make_sample(item, GOOD_HARDNESS_THINK + " The imprint speaks for itself.", key="none")
    negated = make_sample(item, GOOD_HARDNESS_THINK + " So it is not extremely hard.", key="negated")
    run(later, fallback, none, negated, dedup_threshold=1.0)
    assert later.accepted and none.accepted and negated.accepted
    assert fallback.reject_reasons == ["contradiction"]


@pytest.mark.parametrize(("task", "clause", "contradicts"), [
    ("SFD", "Therefore the first object is harder than the second.", True),
    ("SFD", "Therefore the second object is harder than the first.", False),
    ("SFD-yesno", "So no, the first object is softer.", True),
    ("SFD-yesno", "So there is no doubt about the first object.", False),  # "no" as a determiner is not read
    ("OSC", "Therefore video 1 is A, video 2 is B and video 3 is C.", True),
    ("OSC", "Therefore video 1 is B, video 2 is A and video 3 is C.", False),
    ("RFOR", "Hence the fruit is not real.", True),
    ("RFOR", "Hence it is a genuine fruit.", False),
    ("OCSE", "Therefore the sensor is rotating here.", True),
    ("OCSE", "The overall rotating motion is tiny.", False),  # "overall" as an adjective is no conclusion
    ("TFA-combined", "Overall, the object is highly deformable.", True),
    ("TFA-combined", "Overall, it shows strong friction.", False),  # partial but consistent
])
def test_contradiction_per_task(task, clause, contradicts):
    item = make_item(task)
    sample = make_sample(item, varied_think(["press", "hold", "slide", "release"], clause, 5),
                         stages=["press"], variant=task)
    run(sample)
    assert ("contradiction" in sample.reject_reasons) is contradicts, (sample.reject_reasons, sample.meta["filter"])


def test_conclusion_helper():
    item = make_item("TFA-hardness")
    assert conclusion(item, "Pressing is quick. Hence, highly deformable.") == ("highly deformable.", 0)
    assert conclusion(item, "Pressing is quick and so far nothing is extremely hard") is None


def test_length_limits():
    item = make_item("TFA-hardness")
    short = make_sample(item, "Pressing, holding, release: highly deformable.", key="short")
    long = make_sample(item, GOOD_HARDNESS_THINK + " Extra detail." * 300, key="long")
    long_answer = make_sample(item, GOOD_HARDNESS_THINK, "highly deformable" + " " * 5 + "x" * 300, key="la")
    run(short, long, long_answer)
    assert short.reject_reasons == ["too_short"]
    assert long.reject_reasons == ["too_long"]
    assert "too_long" in long_answer.reject_reasons


def test_near_duplicates_keep_first():
    item = make_item("TFA-hardness")
    first = make_sample(item, GOOD_HARDNESS_THINK + " So the object is highly deformable.", key="a")
    copy = make_sample(item, GOOD_HARDNESS_THINK.replace("0.41", "0.42") + " So the object is highly deformable.",
                       key="b")
    other = good_sample("TFA-hardness", seed=3)
    other_task = make_sample(make_item("RFOR", item_id="r"), GOOD_HARDNESS_THINK + " Hence the fruit is real.",
                             key="c", stages=["press"])
    other_task_copy = make_sample(make_item("RFOR", item_id="r2"), GOOD_HARDNESS_THINK + " Hence the fruit is real.",
                                  key="d", stages=["press"])
    result = run(first, copy, other, other_task, other_task_copy)
    assert first.accepted and other.accepted and other_task.accepted
    assert copy.reject_reasons == ["near_duplicate"]
    assert copy.meta["filter"]["duplicate_of"] == "a"
    assert copy.meta["filter"]["similarity"] >= 0.9
    assert other_task_copy.reject_reasons == ["near_duplicate"]  # within RFOR: a copy of c
    assert result.stats["reasons"] == {"near_duplicate": 2}


def test_dedup_off_keeps_repeats_but_not_other_failures():
    item = make_item("TFA-hardness")
    think = GOOD_HARDNESS_THINK + " So the object is highly deformable."
    same = [make_sample(item, think, key=k) for k in "abc"]
    wrong = make_sample(item, think, "extremely hard", key="wrong")
    result = run(*same, wrong, dedup=False)
    assert all(s.accepted for s in same) and len(result.accepted) == 3
    assert wrong.reject_reasons == ["wrong_answer", "contradiction"]
    run(*same)
    assert [s.reject_reasons for s in same] == [[], ["near_duplicate"], ["near_duplicate"]]


def test_dedup_compares_with_accepted_only():
    item = make_item("TFA-hardness")
    think = GOOD_HARDNESS_THINK + " So the object is highly deformable."
    wrong = make_sample(item, think, "extremely hard", key="wrong")
    right = make_sample(item, think, key="right")
    run(wrong, right)
    assert wrong.reject_reasons == ["wrong_answer", "contradiction"]
    assert right.accepted is True


def test_many_varied_samples_are_not_duplicates():
    samples = [good_sample("TFA-hardness", seed=i) for i in range(40)]
    result = run(*samples)
    assert len(result.accepted) == 40


def test_shingles_and_jaccard():
    a, b = shingles("Hello  World"), shingles("hello world")
    assert jaccard(a, b) == 1.0
    assert jaccard(shingles("abcdefgh"), shingles("zyxwvuts")) == 0.0
    assert shingles("hi").size == 1
    assert (shingles("deterministic text") == shingles("deterministic text")).all()


def test_item_of_requires_consistent_item():
    sample = good_sample("TFA-hardness")
    assert item_of(sample).gold == GOLDS["TFA-hardness"]
    del sample.meta["item"]
    with pytest.raises(ValueError, match=r"meta\['item'\] is missing"):
        filter_samples([sample])
    sample = good_sample("TFA-hardness")
    sample.gold_answer = "extremely hard"
    with pytest.raises(ValueError, match="'gold_answer'"):
        item_of(sample)


def test_reviewer_reject_survives_refiltering():
    sample = good_sample("OCSE")
    sample.review = "reject"
    run(sample)
    assert sample.reject_reasons == ["reviewer_reject"]


def test_config_validation():
    with pytest.raises(ValueError, match="unknown key"):
        FilterConfig.from_dict({"min_think_char": 3})
    with pytest.raises(ValueError, match="dedup_threshold"):
        FilterConfig(dedup_threshold=0)
    assert FilterConfig.from_dict({"min_think_chars": 10}).min_think_chars == 10


def _hardness(level: int, i: int, wrong: bool):
    gold = {"attribute": "hardness", "level": level}
    item = make_item("TFA-hardness", gold, item_id=f"h{level}-{i}")
    sample = make_sample(item, key=f"h{level}-{i}", seed=100 * level + i)
    if wrong:
        sample.output = sample.output.replace(f"<answer>{item.answer}", "<answer>moderately deformable"
                                              if level != 1 else "<answer>extremely hard")
    return sample


def test_stats_per_task_and_class_with_skew_warning():
    # Hardness: level 0 all accepted, level 2 all rejected as wrong → accepted are 100 % level 0 (vs 50 %).
    samples = [_hardness(0, i, wrong=False) for i in range(4)] + [_hardness(2, i, wrong=True) for i in range(4)]
    samples += [good_sample("OCSE", seed=i) for i in range(3)]
    result = run(*samples)
    stats = result.stats
    assert (stats["total"], stats["accepted"], stats["rejected"]) == (11, 7, 4)
    hard = stats["tasks"]["TFA-hardness"]
    assert hard["acceptance_rate"] == 0.5
    assert hard["classes"]["highly deformable"]["share_all"] == 0.5
    assert hard["classes"]["highly deformable"]["share_accepted"] == 1.0
    assert hard["classes"]["extremely hard"]["reasons"]["wrong_answer"] == 4
    assert hard["classes"]["extremely hard"]["acceptance_rate"] == 0.0
    assert stats["tasks"]["OCSE"]["classes"]["sliding"]["accepted"] == 3
    assert any("TFA-hardness" in w and "extremely hard" in w for w in result.warnings)
    assert not any(w.startswith("OCSE") for w in result.warnings)


def test_no_skew_warning_when_rejections_are_balanced():
    samples = [_hardness(level, i, wrong=i == 0) for level in (0, 2) for i in range(4)]
    assert acceptance_stats(filter_samples(samples).samples)["warnings"] == []


def test_combined_classes_are_per_attribute():
    samples = [good_sample("TFA-combined", seed=i) for i in range(2)]
    stats = run(*samples).stats
    classes = stats["tasks"]["TFA-combined"]["classes"]
    assert classes["hardness: extremely hard"]["total"] == 2
    assert classes["friction: strong friction"]["share_all"] == 1.0
