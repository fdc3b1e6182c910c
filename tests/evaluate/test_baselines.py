"""Model-free baselines: well-formed answers, majority from train, chance-level accuracy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tacreasoner.evaluate.baselines import answer_space, majority_answers, predict, write_predictions
from tacreasoner.tasks.bench import build_bench, load_bench
from tacreasoner.tasks.scoring import score_predictions


@pytest.fixture(scope="module")
def bench(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bench_baselines")
    build_bench("sim", small_sim_dataset, out, seed=1, heldout_sensor="digit")
    return out


def test_gold_answer_is_in_the_answer_space(bench: Path) -> None:
    for split in ("train", "test"):
        for item in load_bench(bench, split)[1]:
            space = answer_space(item)
            assert item.answer in space
            assert len(space) == len(set(space))


def test_random_baseline_scores_near_chance(bench: Path) -> None:
    items = load_bench(bench, "train")[1]
    records = score_predictions(items, {p["id"]: p["prediction"] for p in predict(items, "random", seed=0)}, "strict")
    assert not any(r["parse_failed"] for r in records)
    chance = np.mean([1 / len(answer_space(i)) for i in items])
    accuracy = np.mean([r["correct"] for r in records])
    assert abs(accuracy - chance) < 4 * np.sqrt(chance * (1 - chance) / len(items)) + 0.02


def test_majority_uses_the_most_frequent_train_answer(bench: Path, tmp_path: Path) -> None:
    train = load_bench(bench, "train")[1]
    test = load_bench(bench, "test")[1]
    majority = majority_answers(train)
    hardness = [i.answer for i in train if i.task == "TFA-hardness"]
    top = max(hardness.count(a) for a in set(hardness))
    tied = sorted(a for a in set(hardness) if hardness.count(a) == top)
    assert majority[("TFA-hardness", "vtv150k")] == tied[0]  # ties broken alphabetically
    preds = predict(test, "majority", train=train)
    by_id = {p["id"]: p for p in preds}
    for item in test:
        rec = by_id[item.id]
        if item.task == "TSA":
            assert rec["answer_source"] == "random"  # zero-shot: no train items to take a majority from
        elif item.task == "TFA-hardness":
            assert rec["prediction"].endswith(f"<answer>{majority[('TFA-hardness', 'vtv150k')]}</answer>")
    path = write_predictions(preds, tmp_path / "p.jsonl")
    assert len(path.read_text().splitlines()) == len(test)


def test_unknown_baseline() -> None:
    with pytest.raises(ValueError, match="unknown baseline"):
        predict([], "oracle")
