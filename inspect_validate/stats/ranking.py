"""Agreement of two rankings: Kendall's τ_b of predicted against measured.

``verify`` ranks a handful of illuminations; scipy.stats.kendalltau gives the same
number but importing scipy.stats took 0.4 s of a 1.85 s ``verify`` of the shipped station.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["kendall_tau"]


def kendall_tau(x: ArrayLike, y: ArrayLike) -> float:
    """Kendall's τ_b of two equally long sequences, ties counted as in τ_b.

    τ_b = Σ_{i<j} sgn(xᵢ − xⱼ)·sgn(yᵢ − yⱼ) / √(Σ_{i<j} sgn(xᵢ − xⱼ)² · Σ_{i<j} sgn(yᵢ − yⱼ)²).

    Parameters
    ----------
    x, y : array_like, shape (n,)
        Values in any unit (±inf are ordered, equal infinities tied).

    Returns
    -------
    float
        In [−1, 1]; NaN when either sequence holds a NaN or is constant, or n < 2
        (as scipy.stats.kendalltau). O(n²): meant for tens of values.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(f"x and y must be 1-D of one length, got {x.shape} and {y.shape}")
    if x.size < 2 or np.isnan(x).any() or np.isnan(y).any():
        return float("nan")
    # Comparisons rather than differences: inf − inf would be NaN, inf vs inf is a tie.
    sx = (x[:, None] > x).astype(np.int64) - (x[:, None] < x)
    sy = (y[:, None] > y).astype(np.int64) - (y[:, None] < y)
    upper = np.triu_indices(x.size, 1)
    sx, sy = sx[upper], sy[upper]
    denominator = np.sqrt(float(np.count_nonzero(sx)) * float(np.count_nonzero(sy)))
    return float(np.dot(sx, sy) / denominator) if denominator else float("nan")
