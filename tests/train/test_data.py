"""The batch plan: resumable (pure in seed and step), an epoch sees every example once, and length grouping
trades padding for mixing, which batch_purity and padding_fraction measure."""

from __future__ import annotations

import random

import pytest

from tacreasoner.train.data import batch_plan, batch_purity, padding_fraction


def _epoch(lengths: list[int], batch: int, epoch: int, **kw) -> list[list[int]]:
    per_epoch = len(lengths) // batch
    return [batch_plan(lengths, batch, epoch * per_epoch + s, seed=3, **kw) for s in range(per_epoch)]


def _two_tasks(n: int = 512) -> tuple[list[int], list[str]]:
    """Task A prompts are short, task B's long, with overlap: length says the task most of the time."""
    rng = random.Random(0)
    labels = [rng.choice("AB") for _ in range(n)]
    lengths = [rng.randint(100, 220) if t == "A" else rng.randint(180, 300) for t in labels]
    return lengths, labels


@pytest.mark.parametrize("group", [False, True])
def test_an_epoch_uses_every_example_once_and_the_plan_is_a_pure_function(group: bool) -> None:
    lengths, _ = _two_tasks()
    epoch = _epoch(lengths, 8, 0, group_by_length=group)
    assert sorted(i for b in epoch for i in b) == list(range(len(lengths)))
    assert _epoch(lengths, 8, 0, group_by_length=group) == epoch  # a resumed run sees the same batches
    assert _epoch(lengths, 8, 1, group_by_length=group) != epoch  # epochs are reshuffled


def test_grouping_pads_less_but_sorts_batches_by_task() -> None:
    lengths, labels = _two_tasks()
    plain = _epoch(lengths, 8, 0, group_by_length=False)
    grouped = _epoch(lengths, 8, 0, group_by_length=True)
    small = _epoch(lengths, 8, 0, group_by_length=True, group_batches=4)
    assert padding_fraction(lengths, grouped) < padding_fraction(lengths, small) < padding_fraction(lengths, plain)
    assert batch_purity(grouped, labels) > batch_purity(small, labels) > batch_purity(plain, labels)
    assert batch_purity(grouped, labels) > 0.85 and batch_purity(plain, labels) < 0.75
    assert _epoch(lengths, 8, 0, group_by_length=True, group_batches=1) == plain


def test_tiny_data_fills_one_batch_and_bad_arguments_are_refused() -> None:
    assert sorted(set(batch_plan([5, 6, 7], 8, 0, 0, False))) == [0, 1, 2]
    with pytest.raises(ValueError, match="no training examples"):
        batch_plan([], 8, 0, 0, False)
    with pytest.raises(ValueError, match="group_batches"):
        batch_plan([5], 8, 0, 0, True, group_batches=0)


def test_purity_and_padding_measures() -> None:
    assert batch_purity([[0, 1], [2, 3]], ["a", "a", "a", "b"]) == pytest.approx(0.75)
    assert padding_fraction([2, 4, 4, 4], [[0, 1], [2, 3]]) == pytest.approx(2 / 16)


def test_repeat_tasks_repeats_the_named_tasks_in_place() -> None:
    from tacreasoner.train.data import Tokenized, repeat_tasks

    def example(key: str, task: str) -> Tokenized:
        return Tokenized([1], [1], [1], (), key, task=task)

    examples = [example("a", "SFD"), example("b", "OSC"), example("c", "RFOR")]
    assert [e.key for e in repeat_tasks(examples, {"OSC": 3})] == ["a", "b", "b", "b", "c"]
    assert repeat_tasks(examples, None) == examples


def _examples(tasks: str) -> list:
    from tacreasoner.train.data import TrainExample

    return [TrainExample(key=f"{t}{i}", task=t, question="q", target="a", videos=()) for i, t in enumerate(tasks)]


def test_left_out_examples_are_counted_per_task_and_losing_a_whole_task_is_an_error() -> None:
    from tacreasoner.train.data import TooLong, left_out_by_task

    examples = _examples("AABBB")
    assert left_out_by_task(examples, [], 320) == {}
    assert left_out_by_task(examples, [TooLong("B2", "B", 400)], 320) == {"B": 1}
    with pytest.raises(ValueError, match=r"max_length=320 leaves out every example of A \(the longest is 496 tokens"
                                         r"\): raise data.max_length to at least 496"):
        left_out_by_task(examples, [TooLong("A0", "A", 496), TooLong("A1", "A", 330), TooLong("B2", "B", 400)], 320)
