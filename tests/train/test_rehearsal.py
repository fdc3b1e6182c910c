"""Text rehearsal: each video of a multi-video TouchCoT item becomes its label + the words of its true level,
answered with the item's own reasoning; only training items; bad input named; pre-training takes it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from trainsetup import training_inputs

from tacreasoner.cot.rulebank import load_bank
from tacreasoner.tasks.bench import load_bench
from tacreasoner.train.rehearsal import REHEARSED_TASKS, rehearsal_dialogues


@pytest.fixture(scope="module")
def inputs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return training_inputs(small_sim_dataset, tmp_path_factory.mktemp("train_inputs_rehearsal"))


def _records(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def test_each_video_is_written_as_its_label_and_the_words_of_its_level(inputs) -> None:
    records = {r["output"]: r for r in _records(inputs["touchcot"]) if r["task"] in REHEARSED_TASKS}
    items = {i.id: i for i in load_bench(inputs["bench"], "train")[1]}
    descriptors = load_bank().data["descriptors"]
    result = rehearsal_dialogues(inputs["touchcot"], inputs["bench"], passes=2)
    assert result.items == len(records) > 0 and result.skipped == 0
    readings = [d for d in result.dialogues if d[1]["content"] not in records]
    assert len(result.dialogues) - len(readings) == 2 * result.items
    videos = sum(len(i.videos) for i in items.values() if i.task in ("SFD", "SOI"))
    assert len(readings) == 2 * videos > 0
    for user, assistant in readings:  # "How does Video k feel?" answered with the word after "Video k: "
        k = re.search(r"How does Video (\d) feel in \w+\?$", user["content"]).group(1)
        word = re.search(rf"Video {k}: ([\w -]+?)(?:\n|$)", user["content"]).group(1)
        assert assistant["content"] == f"<answer>{word}</answer>"
    checked = 0
    for user, assistant in (d for d in result.dialogues if d[1]["content"] in records):
        record = records[assistant["content"]]  # the item's own reasoning, unchanged
        item = items[record["item_id"]]
        assert "<tactile>" not in user["content"]
        labels = re.findall(r"Video (\d): ", user["content"])
        assert labels == [str(n) for n in range(1, len(item.videos) + 1)]
        if item.task != "OSC":  # one word per video: the descriptor of that video's level of the asked attribute
            attribute = item.meta["attribute"]
            for n, rank in enumerate(item.meta["ranks"], 1):
                said = re.search(rf"Video {n}: ([\w -]+?)(?:\n| then|,| and|$)", user["content"]).group(1)
                assert said in descriptors[attribute][rank], (user["content"], rank)
                checked += 1
    assert checked > 0


def test_stage1_video_readings_ask_for_one_video_of_each_comparison(inputs) -> None:
    from tacreasoner.train.data import load_examples

    items = [i for i in load_bench(inputs["bench"], "train")[1] if i.task in ("SFD", "SOI")]
    descriptors = load_bank().data["descriptors"]
    plain = load_examples(1, inputs["bench"])
    extended = load_examples(1, inputs["bench"], video_readings=True)
    added = extended[len(plain):]
    assert extended[: len(plain)] == plain and len(added) == sum(len(i.videos) for i in items) > 0
    by_id = {i.id: i for i in items}
    for example in added:
        item_id, video = example.key.split("#video")
        item, k = by_id[item_id], int(video)
        assert example.question.count("<tactile>") == len(item.videos) and f"Video {k} feel" in example.question
        assert example.target == f"<answer>{descriptors[item.meta['attribute']][item.meta['ranks'][k - 1]][0]}</answer>"
        assert len(example.videos) == len(item.videos)


def test_stage1_comparisons_add_the_train_comparisons_with_their_plain_verdicts(inputs) -> None:
    from tacreasoner.train.data import STAGE1_TASKS, load_examples

    train = load_bench(inputs["bench"], "train")[1]
    plain = load_examples(1, inputs["bench"])
    extended = load_examples(1, inputs["bench"], comparisons=True)
    assert {e.task for e in plain} <= set(STAGE1_TASKS)
    added = [e for e in extended if e.task in ("SFD", "SOI")]
    expected = {i.id: i for i in train if i.task in ("SFD", "SOI")}
    assert len(extended) == len(plain) + len(added) and {e.key for e in added} == set(expected) != set()
    for example in added:
        item = expected[example.key]
        assert example.target == f"<answer>{item.answer}</answer>" and len(example.videos) == len(item.videos) >= 2
        # the comparator's target: the video the question picks ("yes" to "is the first softer?" picks the first)
        ranks, gold = item.meta["ranks"], item.gold
        pick = (max if gold["direction"] in ("more", "most") else min)(range(len(ranks)), key=ranks.__getitem__)
        assert example.winner == pick
        assert example.attribute == gold["attribute"] and example.more == int(gold["direction"] in ("more", "most"))
    assert not any(e.task == "OSC" for e in extended)
    assert all(e.winner == -100 for e in plain)
    cot = load_examples(2, inputs["bench"], touchcot=inputs["touchcot"])
    by_key = {e.key: e.winner for e in extended}
    records = {r["id"]: r["item_id"] for r in _records(inputs["touchcot"])}
    compared = [e for e in cot if e.task in ("SFD", "SOI")]
    assert compared and all(e.winner == by_key[records[e.key]] for e in compared)
    assert all(e.attribute and e.more in (0, 1) for e in compared)
    from tacreasoner.train.data import Tokenized, comparison_targets

    rows = [Tokenized([], [], [], (), e.key, e.winner, e.attribute, e.more) for e in (compared[0], cot[0])]
    targets = comparison_targets(rows, ("not-an-attribute", compared[0].attribute))
    assert targets.tolist() == [[compared[0].winner, 1, compared[0].more], [-100, -100, -100]]
    assert all(e.winner == -100 for e in cot if e.task not in ("SFD", "SOI"))


def test_only_items_with_levels_are_rehearsed_and_bad_input_is_named(inputs, tmp_path: Path) -> None:
    records = _records(inputs["touchcot"])
    multi = next(r for r in records if r["task"] in REHEARSED_TASKS)
    unknown = dict(multi, item_id="not-in-the-benchmark")
    path = tmp_path / "cot.jsonl"
    path.write_text("\n".join(json.dumps(r) for r in [multi, unknown, records[0] | {"task": "TFA-hardness"}]))
    result = rehearsal_dialogues(path, inputs["bench"], passes=1)
    assert (result.items, result.skipped) == (1, 1)
    assert sum(d[1]["content"] == multi["output"] for d in result.dialogues) == 1
    path.write_text(json.dumps({**multi, "output": None}) + "\n")
    with pytest.raises(ValueError, match=r"cot\.jsonl:1: .*'output'"):
        rehearsal_dialogues(path, inputs["bench"])
    with pytest.raises(ValueError, match="passes must be at least 1"):
        rehearsal_dialogues(inputs["touchcot"], inputs["bench"], passes=0)


def test_pretraining_adds_the_rehearsal_and_checks_its_settings(inputs, tmp_path: Path) -> None:
    from tacreasoner.train.pretrain_llm import pretrain_llm

    run = {"steps": 2, "batch_size": 2, "seq_len": 512, "vocab_size": 400, "progress": False, "threads": 1,
           "model_overrides": {"hidden_size": 32, "num_hidden_layers": 1, "num_attention_heads": 2,
                               "num_key_value_heads": 1, "intermediate_size": 64},
           "corpus_options": {"n_compare": 20, "n_scenario": 10, "n_fact": 5, "n_eval": 2, "n_seen": 1,
                              "fact_passes": 1, "need_passes": 1}}
    with pytest.raises(ValueError, match=r"rehearsal\.bench: .* does not exist"):
        pretrain_llm(tmp_path / "a", rehearsal={"touchcot": inputs["touchcot"], "bench": tmp_path / "nope"}, **run)
    with pytest.raises(ValueError, match=r"rehearsal: unknown keys \['pases'\]"):
        pretrain_llm(tmp_path / "a", rehearsal={"touchcot": inputs["touchcot"], "bench": inputs["bench"],
                                                "pases": 3}, **run)
    out = pretrain_llm(tmp_path / "b", rehearsal={"touchcot": inputs["touchcot"], "bench": inputs["bench"],
                                                  "passes": 3}, **run)
    info = json.loads((out / "pretrain.json").read_text())
    expected = rehearsal_dialogues(inputs["touchcot"], inputs["bench"], passes=3)
    assert info["rehearsal"] == expected.stats() and info["rehearsal"]["dialogues"] > 0
    assert info["corpus"]["dialogues"] >= info["rehearsal"]["dialogues"]
