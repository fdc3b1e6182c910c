"""Object-level splits and the leakage check that guards them.

Splits are by object, never by clip: clips of one object look alike, so a model tested on an object
it trained on is graded on recall, not on touch. Public tactile-LLM code has leaked test objects
into training; :func:`check_no_leakage` exists so that fails loudly here.

The assignment is a pure function of (object id, seed): objects are ordered by a hash of both, so
it does not depend on NumPy's generator, the platform or the order the ids were listed in.
"""

from __future__ import annotations

import hashlib
from collections import defaultdict
from collections.abc import Hashable, Iterable, Mapping, Sequence

__all__ = ["LeakageError", "check_no_leakage", "object_level_split", "split_counts"]


class LeakageError(ValueError):
    """An object appears in more than one split; ``leaks`` maps each such object to its splits."""

    def __init__(self, leaks: Mapping[Hashable, Sequence[str]]) -> None:
        self.leaks = {obj: list(splits) for obj, splits in leaks.items()}
        lines = [f"  {obj!r}: {', '.join(map(str, splits))}" for obj, splits in self.leaks.items()]
        super().__init__(f"{len(self.leaks)} object(s) appear in more than one split (object-level leakage):\n"
                         + "\n".join(lines))


def split_counts(n: int, fractions: Sequence[float]) -> list[int]:
    """Objects per split: largest remainder, and at least one in every split with a positive fraction
    when there are enough objects (a 15 % test split of 5 objects gets 1, not 0)."""
    exact = [n * f for f in fractions]
    counts = [int(x) for x in exact]
    for i in sorted(range(len(exact)), key=lambda i: exact[i] - counts[i], reverse=True)[: n - sum(counts)]:
        counts[i] += 1
    positive = [i for i, f in enumerate(fractions) if f > 0]
    if n >= len(positive):
        for i in positive:
            if counts[i] == 0:
                donor = max(range(len(counts)), key=lambda j: counts[j])
                counts[donor] -= 1
                counts[i] += 1
    return counts


def object_level_split(object_ids: Iterable[Hashable], fractions: Sequence[float] = (0.7, 0.15, 0.15), seed: int = 0,
                       names: Sequence[str] = ("train", "val", "test"), *,
                       fixed: Mapping[Hashable, str] | None = None) -> dict[Hashable, str]:
    """Assign every object to exactly one split; deterministic for a given seed.

    ``fixed`` pins objects to a split (e.g. PhysiCLeAR's own train/val); its split names need not be
    in ``names``. The remaining objects are divided by ``fractions`` among themselves. Entries of
    ``fixed`` for objects not in ``object_ids`` are ignored.
    """
    names, fractions = list(names), [float(f) for f in fractions]
    if len(names) != len(fractions):
        raise ValueError(f"{len(fractions)} fractions for {len(names)} split names {names}; give one per split")
    if len(set(names)) != len(names):
        raise ValueError(f"split names must be distinct, got {names}")
    if any(f < 0 for f in fractions) or abs(sum(fractions) - 1.0) > 1e-6:
        raise ValueError(f"fractions must be >= 0 and sum to 1, got {fractions} (sum {sum(fractions):g})")
    objects = list(dict.fromkeys(object_ids))
    fixed = dict(fixed or {})
    out: dict[Hashable, str] = {obj: str(fixed[obj]) for obj in objects if obj in fixed}
    free = sorted((obj for obj in objects if obj not in fixed), key=lambda obj: _order_key(obj, seed))
    start = 0
    for name, count in zip(names, split_counts(len(free), fractions), strict=True):
        for obj in free[start:start + count]:
            out[obj] = name
        start += count
    return {obj: out[obj] for obj in objects}


def _order_key(obj: Hashable, seed: int) -> tuple[str, str]:
    text = f"{type(obj).__name__}:{obj}"
    return hashlib.sha256(f"{int(seed)}\x00{text}".encode()).hexdigest(), text


def check_no_leakage(assignments: Iterable[tuple[str, Hashable]]) -> dict[Hashable, str]:
    """Raise :class:`LeakageError` listing every object seen in more than one split (with the splits).

    ``assignments`` are (split, object id) pairs, e.g. one per clip or QA item. Returns object → split
    when clean, so a caller can reuse it.
    """
    seen: dict[Hashable, dict[str, None]] = defaultdict(dict)
    for pair in assignments:
        try:
            split, obj = pair
        except (TypeError, ValueError):
            raise TypeError(f"check_no_leakage expects (split, object_id) pairs, got {pair!r}") from None
        seen[obj][split] = None
    leaks = {obj: list(splits) for obj, splits in seen.items() if len(splits) > 1}
    if leaks:
        raise LeakageError(leaks)
    return {obj: next(iter(splits)) for obj, splits in seen.items()}
