"""A fraction of runs with its 95 % interval: the Wilson score interval.

The fraction of balanced runs is k / N, with the 95 % Wilson score interval (Wilson 1927;
Agresti & Coull 1998)::

    centre = (k + z^2/2) / (N + z^2),  half = z sqrt(k (N - k) / N + z^2/4) / (N + z^2),

z = 1.959963984540054 (the 0.975 quantile of the normal distribution). It stays within
[0, 1] and keeps close to its nominal coverage down to a few runs and at fractions of 0 and
1, where the Wald interval collapses to a point.
"""

from __future__ import annotations

import math

__all__ = ['Z95', 'wilson']

Z95 = 1.959963984540054
"""The 0.975 quantile of the standard normal distribution (two-sided 95 %)."""


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Return the Wilson score interval (low, high) of k successes in n trials (NaN for n = 0)."""
    if n < 1:
        return (math.nan, math.nan)
    denom = n + z * z
    centre = (k + z * z / 2.0) / denom
    half = z * math.sqrt(k * (n - k) / n + z * z / 4.0) / denom
    # at k = 0 and k = n the interval ends at 0 and 1 exactly (round-off would leave 1 - 1e-16)
    low = 0.0 if k == 0 else max(0.0, centre - half)
    high = 1.0 if k == n else min(1.0, centre + half)
    return (low, high)
