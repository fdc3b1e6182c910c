"""Object-level splits and the leakage check."""

from __future__ import annotations

from collections import Counter

import pytest

from tacreasoner.data.splits import LeakageError, check_no_leakage, object_level_split, split_counts

OBJECTS = [f"object_{i}" for i in range(40)]


def test_every_object_in_exactly_one_split_with_the_requested_sizes() -> None:
    split = object_level_split(OBJECTS)
    assert list(split) == OBJECTS
    assert Counter(split.values()) == {"train": 28, "val": 6, "test": 6}


def test_deterministic_and_independent_of_input_order() -> None:
    a = object_level_split(OBJECTS, seed=3)
    assert a == object_level_split(list(reversed(OBJECTS)), seed=3)
    assert a == object_level_split(OBJECTS + OBJECTS[:5], seed=3)  # duplicates (one per clip) are fine
    assert a != object_level_split(OBJECTS, seed=4)


def test_fixed_assignments_are_honoured() -> None:
    fixed = {"object_0": "val", "object_1": "unlabelled", "not_listed": "train"}
    split = object_level_split(OBJECTS, fixed=fixed)
    assert split["object_0"] == "val" and split["object_1"] == "unlabelled" and "not_listed" not in split
    assert Counter(v for k, v in split.items() if k not in fixed) == {"train": 26, "val": 6, "test": 6}


def test_custom_names_and_small_sets() -> None:
    split = object_level_split(["a", "b", "c"], fractions=(0.5, 0.5), names=("fit", "holdout"))
    assert set(split.values()) == {"fit", "holdout"}
    assert split_counts(5, (0.7, 0.15, 0.15)) == [3, 1, 1]  # every split gets an object when possible
    assert split_counts(0, (0.7, 0.15, 0.15)) == [0, 0, 0]


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"fractions": (0.7, 0.2, 0.2)}, "sum to 1"),
    ({"fractions": (1.2, -0.2, 0.0)}, ">= 0"),
    ({"fractions": (0.5, 0.5)}, "one per split"),
    ({"names": ("train", "train", "test")}, "distinct"),
])
def test_bad_arguments(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        object_level_split(OBJECTS, **kwargs)


def test_leakage_check_catches_a_planted_leak() -> None:
    split = object_level_split(OBJECTS)
    pairs = [(s, o) for o, s in split.items()]
    leaked = next(o for o, s in split.items() if s == "test")
    other = next(o for o, s in split.items() if s == "val")
    pairs += [("train", leaked), ("train", other)]
    with pytest.raises(LeakageError) as info:
        check_no_leakage(pairs)
    err = info.value
    assert isinstance(err, ValueError)
    assert err.leaks == {leaked: ["test", "train"], other: ["val", "train"]}
    assert "2 object(s)" in str(err) and leaked in str(err) and "test, train" in str(err)


def test_leakage_check_passes_a_clean_split() -> None:
    split = object_level_split(OBJECTS)
    pairs = [(s, o) for o, s in split.items() for _clip in range(3)]  # one pair per clip
    assert check_no_leakage(iter(pairs)) == split
    with pytest.raises(TypeError, match="pairs"):
        check_no_leakage(["train"])  # type: ignore[list-item]
