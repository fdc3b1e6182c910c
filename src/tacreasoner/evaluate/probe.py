"""Linear probe (multinomial logistic regression) and object-level cross-validation.

Benchmarks measure how linearly decodable a property is from frozen embeddings. The probe is plain
numpy + L-BFGS so results do not depend on sklearn versions, and it is deterministic (zero
initialisation, no randomness) so reported numbers are reproducible.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize
from scipy.special import logsumexp, softmax

__all__ = ["LinearProbe", "ProbeResult", "cross_validate_probe", "group_kfold"]


class LinearProbe:
    """Multinomial logistic regression on standardised features with an L2 penalty on the weights.

    ``l2`` multiplies ``0.5 * ||W||²`` added to the *mean* cross-entropy, so its strength does not
    change with the number of training samples. The bias is not penalised.
    """

    def __init__(self, l2: float = 1e-2, max_iter: int = 500) -> None:
        if l2 < 0:
            raise ValueError(f"l2 must be >= 0, got {l2}")
        if max_iter < 1:
            raise ValueError(f"max_iter must be >= 1, got {max_iter}")
        self.l2 = float(l2)
        self.max_iter = int(max_iter)

    def fit(self, X: np.ndarray, y: np.ndarray) -> LinearProbe:
        """Learn the scaler and weights; labels may be any sortable values (stored in ``classes_``)."""
        X, y = _check_xy(X, y)
        self.classes_, y_idx = np.unique(y, return_inverse=True)
        self.mean_ = X.mean(axis=0)
        std = X.std(axis=0)
        self.scale_ = np.where(std > 0, std, 1.0)  # constant columns would otherwise divide by zero
        Z = self._standardise(X)
        self.coef_, self.intercept_, self.converged_ = _fit_softmax(
            Z, y_idx, len(self.classes_), self.l2, self.max_iter
        )
        return self

    def predict_proba(self, X: np.ndarray) -> np.ndarray:
        """Class probabilities, columns ordered as ``classes_``."""
        return softmax(self._logits(X), axis=1)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Most probable class; classes absent from the training set are never returned."""
        logits = self._logits(X)
        return self.classes_[np.argmax(logits, axis=1)]

    def score(self, X: np.ndarray, y: np.ndarray) -> float:
        """Accuracy."""
        X, y = _check_xy(X, y)
        return float(np.mean(self.predict(X) == y))

    def _standardise(self, X: np.ndarray) -> np.ndarray:
        return (X - self.mean_) / self.scale_

    def _logits(self, X: np.ndarray) -> np.ndarray:
        if not hasattr(self, "coef_"):
            raise RuntimeError("LinearProbe is not fitted; call fit(X, y) first")
        X = _check_x(X)
        if X.shape[1] != self.coef_.shape[0]:
            raise ValueError(f"X has {X.shape[1]} features, the probe was fitted on {self.coef_.shape[0]}")
        return self._standardise(X) @ self.coef_ + self.intercept_


def _check_x(X: np.ndarray) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2:
        raise ValueError(f"X must be 2-D (n_samples × n_features), got shape {X.shape}")
    if not np.all(np.isfinite(X)):
        raise ValueError("X contains NaN or infinite values")
    return X


def _check_xy(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    X = _check_x(X)
    y = np.asarray(y)
    if y.ndim != 1 or len(y) != len(X):
        raise ValueError(f"y must be 1-D with {len(X)} labels, got shape {y.shape}")
    if len(y) == 0:
        raise ValueError("need at least one sample")
    return X, y


def _fit_softmax(
    Z: np.ndarray, y_idx: np.ndarray, n_classes: int, l2: float, max_iter: int
) -> tuple[np.ndarray, np.ndarray, bool]:
    """Minimise mean cross-entropy + 0.5·l2·||W||² with L-BFGS from a zero start (deterministic).

    Also returns whether L-BFGS converged, so benchmarks can flag under-trained probes.
    """
    n, d = Z.shape
    onehot = np.zeros((n, n_classes))
    onehot[np.arange(n), y_idx] = 1.0

    def loss_grad(theta: np.ndarray) -> tuple[float, np.ndarray]:
        W = theta[: d * n_classes].reshape(d, n_classes)
        b = theta[d * n_classes :]
        logits = Z @ W + b
        lse = logsumexp(logits, axis=1)
        loss = float(np.mean(lse - np.sum(logits * onehot, axis=1)) + 0.5 * l2 * np.sum(W * W))
        err = (np.exp(logits - lse[:, None]) - onehot) / n
        grad_w = Z.T @ err + l2 * W
        return loss, np.concatenate([grad_w.ravel(), err.sum(axis=0)])

    if n_classes == 1:  # nothing to separate; the single class always wins
        return np.zeros((d, 1)), np.zeros(1), True
    theta0 = np.zeros(d * n_classes + n_classes)
    res = minimize(loss_grad, theta0, jac=True, method="L-BFGS-B", options={"maxiter": max_iter})
    return res.x[: d * n_classes].reshape(d, n_classes), res.x[d * n_classes :], bool(res.success)


# ------------------------------------------------------------------------------------ cross-validation


def group_kfold(groups: np.ndarray, n_splits: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Object-level folds: all samples of a group share one test fold, so no object leaks into training.

    Groups are shuffled with ``seed`` and dealt round-robin, so fold sizes differ by at most one
    group (not balanced by sample count). Indices in each (train, test) pair are sorted.
    """
    groups = np.asarray(groups)
    if groups.ndim != 1:
        raise ValueError(f"groups must be 1-D, got shape {groups.shape}")
    if n_splits < 2:
        raise ValueError(f"n_splits must be >= 2, got {n_splits}")
    unique, inverse = np.unique(groups, return_inverse=True)
    if len(unique) < n_splits:
        raise ValueError(f"need at least n_splits={n_splits} distinct groups, got {len(unique)}")
    order = np.random.default_rng(seed).permutation(len(unique))
    fold_of_group = np.empty(len(unique), dtype=np.int64)
    fold_of_group[order] = np.arange(len(unique)) % n_splits
    fold_of_sample = fold_of_group[inverse]
    return [
        (np.flatnonzero(fold_of_sample != k), np.flatnonzero(fold_of_sample == k)) for k in range(n_splits)
    ]


@dataclass(frozen=True)
class ProbeResult:
    """Pooled cross-validated probe metrics; compare ``accuracy`` against both baselines."""

    accuracy: float
    balanced_accuracy: float
    majority_baseline: float
    chance: float
    n: int
    fold_accuracies: list[float]
    confusion: list[list[int]]  # rows: true class, columns: predicted class, both ordered as `classes`
    classes: list[Any]


def cross_validate_probe(
    X: np.ndarray,
    y: np.ndarray,
    groups: np.ndarray,
    n_splits: int = 5,
    seed: int = 0,
    l2: float = 1e-2,
) -> ProbeResult:
    """Group k-fold linear probe; predictions are pooled over folds before computing metrics."""
    X, y = _check_xy(X, y)
    groups = np.asarray(groups)
    if groups.shape != y.shape:
        raise ValueError(f"groups must have shape {y.shape}, got {groups.shape}")
    pred = np.empty_like(y)
    majority = np.empty_like(y)
    fold_acc: list[float] = []
    for train, test in group_kfold(groups, n_splits, seed):
        probe = LinearProbe(l2=l2).fit(X[train], y[train])
        pred[test] = probe.predict(X[test])
        majority[test] = _majority(y[train])
        fold_acc.append(float(np.mean(pred[test] == y[test])))
    classes = np.unique(y)
    confusion = _confusion(y, pred, classes)
    return ProbeResult(
        accuracy=float(np.mean(pred == y)),
        balanced_accuracy=_balanced_accuracy(confusion),
        majority_baseline=float(np.mean(majority == y)),
        chance=1.0 / len(classes),
        n=len(y),
        fold_accuracies=fold_acc,
        confusion=confusion.tolist(),
        classes=classes.tolist(),
    )


def _majority(y: np.ndarray) -> object:
    """Most frequent label; ties go to the smallest label so the baseline is deterministic."""
    values, counts = np.unique(y, return_counts=True)
    return values[np.argmax(counts)]


def _confusion(y: np.ndarray, pred: np.ndarray, classes: np.ndarray) -> np.ndarray:
    # Predictions always come from training labels, which are a subset of `classes`.
    t = np.searchsorted(classes, y)
    p = np.searchsorted(classes, pred)
    out = np.zeros((len(classes), len(classes)), dtype=np.int64)
    np.add.at(out, (t, p), 1)
    return out


def _balanced_accuracy(confusion: np.ndarray) -> float:
    """Mean per-class recall: robust to class imbalance, unlike plain accuracy."""
    support = confusion.sum(axis=1)
    return float(np.mean(np.diag(confusion) / support))
