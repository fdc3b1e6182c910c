"""Binomial confidence intervals, for every part that reports an accuracy over a few hundred items.

A leaf at the package root (it needs only ``math``), so any part may report an interval without importing the
evaluation.
The Wilson interval keeps good coverage at small n and near 0 or 1, unlike the normal approximation.
"""

from __future__ import annotations

import math

__all__ = ["wilson_interval"]


def wilson_interval(k: float, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion ``k / n`` (95% for the default ``z``).

    ``k`` may be fractional (a mean count over seeds). ``n == 0`` carries no information: (0, 1).
    """
    if n < 0 or k < 0 or k > n:
        raise ValueError(f"need 0 <= k <= n, got k={k}, n={n}")
    if n == 0:
        return 0.0, 1.0
    p = k / n
    z2 = z * z
    denom = 1.0 + z2 / n
    centre = (p + z2 / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / denom
    # At k = 0 (k = n) the bound is exactly 0 (1); say so rather than return rounding noise.
    lo = 0.0 if k == 0 else max(0.0, centre - half)
    hi = 1.0 if k == n else min(1.0, centre + half)
    return lo, hi
