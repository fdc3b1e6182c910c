"""Tests for the TouchCoT training files: selection, object-level split, file shapes, stats report."""

from __future__ import annotations

import json

import pytest

from tacreasoner.cot.filter import filter_samples
from tacreasoner.cot.format import assign_splits, write_training_files
from tacreasoner.jsonl import iter_jsonl
from tacreasoner.tasks.schema import VideoRef
from tests.cot.cot_samples import good_sample, make_item, make_sample

USAGE = {"prompt_tokens": 120, "completion_tokens": 80, "cost_usd": 0.0005}


def _pool():
    """Many objects, some shared between items (as in a real benchmark), all tasks but TSA, plus rejects."""
    samples = []
    for i in range(12):
        samples.append(good_sample("TFA-hardness", seed=i, objects=[f"obj{i % 8}"]))
        samples[-1].usage = dict(USAGE)
    for i in range(6):
        samples.append(good_sample("SFD", seed=i, objects=[f"obj{i}", f"obj{(i + 3) % 8}"]))
        samples.append(good_sample("OSC", seed=i, objects=[f"obj{i}", f"obj{i + 1}", f"obj{(i + 5) % 8}"]))
        samples.append(good_sample("OCSE", seed=i, objects=[f"obj{(i + 2) % 8}"]))
        samples.append(good_sample("RFOR", seed=i, objects=[f"fruit{i}"]))
        samples.append(good_sample("TFA-combined", seed=i, objects=[f"obj{(i + 4) % 8}"]))
    wrong = make_sample(make_item("TFA-hardness", item_id="wrong", objects=["obj1"]), key="wrong", seed=77)
    wrong.output = wrong.output.replace("<answer>highly deformable", "<answer>extremely hard")
    samples.append(wrong)
    filter_samples(samples)
    return samples


def test_writes_only_accepted_and_not_reviewer_rejected(tmp_path):
    samples = _pool()
    vetoed = next(s for s in samples if s.task == "OCSE")
    vetoed.review = "reject"  # a reviewer reject even without re-filtering keeps it out
    result = write_training_files(samples, tmp_path)
    written = [r["id"] for p in (result.train_path, result.val_path) for _, r in iter_jsonl(p)]
    assert "wrong" not in written and vetoed.key not in written
    assert len(written) == len(samples) - 2 == result.n_train + result.n_val
    assert result.stats["excluded"] == {"not_accepted": 1, "reviewer_reject": 1, "tasks": {}}


def test_split_by_object_has_no_leakage_and_is_deterministic(tmp_path):
    samples = _pool()
    a = write_training_files(samples, tmp_path / "a", val_fraction=0.25, seed=3)
    write_training_files(samples, tmp_path / "b", val_fraction=0.25, seed=3)
    for name in ("touchcot_train.jsonl", "touchcot_val.jsonl", "touchcot_train_llava.json", "stats.json",
                 "stats.md", "lengths.png"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    train = [r for _, r in iter_jsonl(a.train_path)]
    val = [r for _, r in iter_jsonl(a.val_path)]
    assert train and val
    train_objects = {o for r in train for o in r["objects"]}
    # Every val sample holds an object that no train sample holds.
    for r in val:
        assert set(r["objects"]) - train_objects, r
    assert a.stats["objects"]["val"] >= 1
    assert a.stats["val_mixed"] == sum(1 for r in val if set(r["objects"]) & train_objects)
    assert sum(a.stats["per_task"][t]["val"] for t in a.stats["per_task"]) == len(val) == a.n_val
    too_many = len(val) > 0.5 * (len(val) + len(train))
    assert any("val holds" in w for w in a.stats["warnings"]) == too_many


def test_val_split_items_pin_their_objects(tmp_path):
    samples = [good_sample("RFOR", seed=i, objects=[f"fruit{i}"]) for i in range(6)]
    pinned = good_sample("TFA-hardness", seed=1, objects=["fruit0"], split="val")
    samples.append(pinned)
    filter_samples(samples)
    splits = assign_splits(samples, val_fraction=0.0)
    assert splits[pinned.key] == "val" and splits["RFOR-0"] == "val"
    assert all(splits[s.key] == "train" for s in samples if "fruit0" not in s.objects)


def test_test_split_and_missing_objects_are_errors(tmp_path):
    sample = good_sample("RFOR", split="test")
    filter_samples([sample])
    with pytest.raises(ValueError, match="test-split"):
        write_training_files([sample], tmp_path)
    sample = good_sample("RFOR")
    filter_samples([sample])
    sample.objects = []
    with pytest.raises(ValueError, match="'objects' is empty"):
        write_training_files([sample], tmp_path)
    with pytest.raises(ValueError, match="val_fraction"):
        assign_splits([], val_fraction=1.0)


def test_zero_shot_task_is_excluded(tmp_path):
    tsa = make_item("TSA", {"letter": "B", "scenario": "scraping_ice", "needs": {"hardness": "high"}}, item_id="tsa")
    sample = make_sample(tsa, "During pressing the second imprint barely spreads, holding shows no relaxation and "
                         "after release no residual remains. So option B fits.", key="tsa")
    samples = [sample, good_sample("RFOR")]
    filter_samples(samples)
    assert sample.accepted
    result = write_training_files(samples, tmp_path)
    assert result.n_train + result.n_val == 1
    assert result.stats["excluded"]["tasks"] == {"TSA": 1}
    assert any("TSA" in w for w in result.stats["warnings"])


def test_record_and_llava_shapes(tmp_path):
    samples = _pool()
    result = write_training_files(samples, tmp_path, val_fraction=0.3)
    records = {r["id"]: r for p in (result.train_path, result.val_path) for _, r in iter_jsonl(p)}
    s = next(s for s in samples if s.task == "OSC")
    r = records[s.key]
    assert set(r) >= {"id", "task", "question", "videos", "answer", "output", "objects", "teacher", "model",
                      "prompt_version", "created", "cues"}
    assert r["question"].count("<tactile>") == len(r["videos"]) == 3
    assert r["answer"] == s.gold_answer and r["output"] == s.output
    assert r["output"].startswith("<think>") and r["output"].endswith("</answer>")

    llava = json.loads(result.train_llava_path.read_text()) + json.loads(result.val_llava_path.read_text())
    assert len(llava) == len(records)
    for rec in llava:
        assert set(rec) <= {"id", "videos", "conversations", "segments"}
        human, gpt = rec["conversations"]
        assert (human["from"], gpt["from"]) == ("human", "gpt")
        assert human["value"].count("<video>") == len(rec["videos"]) and "<tactile>" not in human["value"]
        assert gpt["value"] == records[rec["id"]]["output"]
    ocse = next(rec for rec in llava if records[rec["id"]]["task"] == "OCSE")
    assert ocse["segments"] == [[4, 10]]
    assert all(isinstance(p, str) for rec in llava for p in rec["videos"])


def test_llava_video_without_path_uses_clip_id(tmp_path):
    sample = make_sample(make_item("RFOR", item_id="np", videos=[VideoRef("clip-np")]), key="np", seed=4,
                         variant="RFOR")
    filter_samples([sample])
    result = write_training_files([sample], tmp_path)
    llava = json.loads(result.train_llava_path.read_text())
    assert llava[0]["videos"] == ["clip-np"] and "segments" not in llava[0]


def test_stats_report_and_plot(tmp_path):
    samples = _pool()
    result = write_training_files(samples, tmp_path)
    stats = json.loads(result.stats_path.read_text())
    assert stats == json.loads(json.dumps(result.stats))
    assert stats["usage"] == {"completion_tokens": 960, "cost_usd": 0.006, "prompt_tokens": 1440}
    assert stats["teachers"] == {"rules": len(samples) - 1}
    assert stats["prompt_versions"] == {"touchcot-v1": len(samples) - 1}
    assert stats["filter"]["tasks"]["TFA-hardness"]["reasons"] == {"wrong_answer": 1, "contradiction": 1}
    assert stats["filter"]["tasks"]["TFA-hardness"]["classes"]["highly deformable"]["accepted"] == 12
    assert set(stats["think_words"]) == {"TFA-hardness", "SFD", "OSC", "OCSE", "RFOR", "TFA-combined"}
    md = result.stats_md_path.read_text()
    for text in ("## Per task", "## Per class", "## Rejection reasons", "wrong_answer", "touchcot-v1",
                 "prompt_tokens", "## Reasoning length", "| TFA-hardness |"):
        assert text in md, text
    assert result.lengths_path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in result.files.values()) == sorted(p.name for p in tmp_path.iterdir())


def test_empty_input_still_writes_files(tmp_path):
    result = write_training_files([], tmp_path)
    assert result.n_train == result.n_val == 0
    assert result.train_path.read_text() == "" and json.loads(result.val_llava_path.read_text()) == []
    assert result.lengths_path.exists() and result.stats_md_path.exists()


def test_warns_when_multi_object_items_inflate_val(tmp_path):
    # Every object is in three OSC items, so the one val object (10 %) sends 3 of 10 samples (30 %) to val.
    samples = [good_sample("OSC", seed=i, objects=[f"o{i}", f"o{(i + 1) % 10}", f"o{(i + 2) % 10}"])
               for i in range(10)]
    filter_samples(samples)
    result = write_training_files(samples, tmp_path, val_fraction=0.1)
    assert (result.n_train, result.n_val) == (7, 3)
    assert result.stats["val_mixed"] == 3
    assert any("val holds 30.0%" in w for w in result.stats["warnings"])
