"""Tests for the numpy linear probe and object-level cross-validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tacreasoner.evaluate.probe import LinearProbe, ProbeResult, cross_validate_probe, group_kfold


def blobs(n_per_class: int = 40, n_classes: int = 3, dim: int = 5, sep: float = 8.0, seed: int = 0):
    """Well-separated Gaussian clusters, labelled with non-contiguous ints to test label mapping."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(n_classes, dim)) * sep
    y = np.repeat(np.arange(n_classes) * 7 - 3, n_per_class)
    X = np.repeat(centres, n_per_class, axis=0) + rng.normal(size=(n_classes * n_per_class, dim))
    return X, y


# ---------------------------------------------------------------------------------------------- LinearProbe


def test_separable_data_is_fit_perfectly() -> None:
    X, y = blobs()
    probe = LinearProbe().fit(X, y)
    assert probe.converged_
    assert probe.score(X, y) == 1.0
    assert set(probe.classes_.tolist()) == {-3, 4, 11}
    proba = probe.predict_proba(X)
    assert proba.shape == (len(y), 3)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)


def test_fit_is_deterministic() -> None:
    X, y = blobs(seed=3)
    a = LinearProbe().fit(X, y).predict_proba(X)
    b = LinearProbe().fit(X, y).predict_proba(X)
    np.testing.assert_array_equal(a, b)


def test_constant_column_does_not_produce_nan() -> None:
    X, y = blobs()
    X = np.column_stack([X, np.full(len(X), 5.0), np.zeros(len(X))])
    probe = LinearProbe().fit(X, y)
    assert np.all(np.isfinite(probe.coef_))
    assert np.all(np.isfinite(probe.predict_proba(X)))
    assert probe.score(X, y) == 1.0


def test_absent_class_is_never_predicted() -> None:
    X, y = blobs(n_classes=3)
    train = y != 11
    probe = LinearProbe().fit(X[train], y[train])
    assert 11 not in set(probe.predict(X).tolist())


def test_single_class_training_set() -> None:
    X, y = blobs(n_classes=1)
    probe = LinearProbe().fit(X, y)
    assert np.all(probe.predict(X) == y[0])


def test_input_validation() -> None:
    X, y = blobs()
    with pytest.raises(ValueError):
        LinearProbe().fit(X, y[:-1])
    with pytest.raises(ValueError):
        LinearProbe().fit(X[:, 0], y)
    X_nan = X.copy()
    X_nan[0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        LinearProbe().fit(X_nan, y)
    with pytest.raises(RuntimeError, match="not fitted"):
        LinearProbe().predict(X)
    with pytest.raises(ValueError, match="features"):
        LinearProbe().fit(X, y).predict(X[:, :2])


# ---------------------------------------------------------------------------------------------- group_kfold


@settings(max_examples=40, deadline=None)
@given(
    groups=st.lists(st.integers(0, 30), min_size=1, max_size=120),
    n_splits=st.integers(2, 8),
    seed=st.integers(0, 2**16),
)
def test_group_kfold_properties(groups: list[int], n_splits: int, seed: int) -> None:
    groups_arr = np.array(groups)
    n_groups = len(set(groups))
    if n_groups < n_splits:
        with pytest.raises(ValueError, match="groups"):
            group_kfold(groups_arr, n_splits, seed)
        return
    folds = group_kfold(groups_arr, n_splits, seed)
    assert len(folds) == n_splits
    all_test = np.concatenate([test for _, test in folds])
    np.testing.assert_array_equal(np.sort(all_test), np.arange(len(groups)))  # each index tested once
    groups_per_fold = []
    for train, test in folds:
        assert not set(groups_arr[train]) & set(groups_arr[test])
        np.testing.assert_array_equal(np.sort(np.concatenate([train, test])), np.arange(len(groups)))
        groups_per_fold.append(len(set(groups_arr[test])))
    assert max(groups_per_fold) - min(groups_per_fold) <= 1


def test_group_kfold_is_seeded() -> None:
    groups = np.repeat(np.arange(10), 3)
    a = group_kfold(groups, 3, seed=1)
    b = group_kfold(groups, 3, seed=1)
    assert all(np.array_equal(ta, tb) for (_, ta), (_, tb) in zip(a, b, strict=True))


def test_too_few_groups() -> None:
    with pytest.raises(ValueError, match="groups"):
        group_kfold(np.array([0, 0, 1, 1]), n_splits=3, seed=0)
    with pytest.raises(ValueError):
        group_kfold(np.arange(10), n_splits=1, seed=0)


# ------------------------------------------------------------------------------------- cross-validation


def test_cross_validate_separable() -> None:
    X, y = blobs(n_per_class=30)
    groups = np.arange(len(y)) // 3  # 3 samples per object
    res = cross_validate_probe(X, y, groups, n_splits=5, seed=0)
    assert isinstance(res, ProbeResult)
    assert res.accuracy == pytest.approx(1.0)
    assert res.balanced_accuracy == pytest.approx(1.0)
    assert res.n == len(y)
    assert res.chance == pytest.approx(1 / 3)
    assert res.classes == [-3, 4, 11]
    assert len(res.fold_accuracies) == 5
    assert np.array(res.confusion).sum() == len(y)
    assert np.trace(np.array(res.confusion)) == len(y)


def test_cross_validate_noise_labels_near_chance() -> None:
    rng = np.random.default_rng(0)
    n, n_classes = 600, 4
    X = rng.normal(size=(n, 8))
    y = rng.integers(0, n_classes, size=n)
    groups = np.arange(n) // 2
    res = cross_validate_probe(X, y, groups, n_splits=5, seed=0)
    assert abs(res.accuracy - 1 / n_classes) < 0.08
    assert abs(res.balanced_accuracy - 1 / n_classes) < 0.08
    assert res.chance == pytest.approx(0.25)


def test_majority_baseline_on_imbalanced_labels() -> None:
    rng = np.random.default_rng(1)
    y = np.where(rng.random(200) < 0.8, 2, 5)
    X = rng.normal(size=(200, 3))
    res = cross_validate_probe(X, y, groups=np.arange(200), n_splits=4, seed=0)
    assert res.majority_baseline == pytest.approx(np.mean(y == 2))
    assert 0.0 <= res.balanced_accuracy <= 1.0


def test_cross_validate_rejects_mismatched_groups() -> None:
    X, y = blobs()
    with pytest.raises(ValueError, match="groups"):
        cross_validate_probe(X, y, np.arange(len(y) - 1))
