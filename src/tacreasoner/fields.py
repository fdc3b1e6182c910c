"""Strict ``from_dict``: a mapping with a key the dataclass lacks is an error (a typo must not pass silently)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from typing import Any, Literal

__all__ = ["reject_unknown_fields"]


def reject_unknown_fields(cls: Any, data: Iterable[Any], what: str, *,
                          known: Literal["sorted", "declared"] | None = None) -> None:
    """Raise ``ValueError(f"{what} {unknown}")`` when ``data`` has keys that are not fields of dataclass ``cls``.

    ``unknown`` is the sorted list of offending keys. With ``known``, the message goes on with
    ``"; known: a, b, …"``: the field names sorted, or in their declared order. Fields with ``init=False`` (caches
    a class computes for itself) are not known: ``cls(**data)`` would fail on them with a TypeError.
    """
    names = [f.name for f in dataclasses.fields(cls) if f.init]
    unknown = sorted(set(data) - set(names))
    if not unknown:
        return
    message = f"{what} {unknown}"
    if known is not None:
        message += f"; known: {', '.join(sorted(names) if known == 'sorted' else names)}"
    raise ValueError(message)
