"""Two-sided normal tolerance intervals: limits that hold for the one sample they come from.

A prediction interval x̄ ± t s √(1 + 1/n) holds a new value with probability 1 − α
*averaged over samples*: a sample whose s came out small sets limits that fail more
often than α, one whose s came out large less. A (content P, confidence γ) tolerance
interval x̄ ± k s holds at least a share P of the population *with probability γ over
the sample*: for all but 1 − γ of the samples, the share of new values outside it is at
most 1 − P.

The factor k is exact (Odeh & Owen, *Tables for Normal Tolerance Limits*, 1980;
Krishnamoorthy & Mathew, *Statistical Tolerance Regions*, 2009, eq. 2.3.5): with the
centre x̄ ~ N(μ, σ²/n) and s² ~ σ² χ²_ν / ν independent,

    γ(k) = √(2/π) ∫₀^∞ P(χ²_ν > ν r(u/√n)² / k²) e^{−u²/2} du,

where r(x) is the half-width, in σ, of the interval centred x σ off μ that holds the
share P: Φ(x + r) − Φ(x − r) = P. Here ``n`` need not be whole and ν need not be
n − 1: a batch mean of m values checked against the mean of n has its centre known to
n/m of its own spread. The integral is a 96-node Gauss–Legendre sum (u ≤ 10, where the
weight is below 2·10⁻²²), agreeing with an adaptive quadrature to 1e-9
(tests/stats/test_tolerance_interval.py). Without scipy on the import path, as
:mod:`.quantiles`: the χ² tail of whole ν ≤ 200 is its finite sum
(Abramowitz & Stegun 26.4.4–5).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from inspect_validate.stats.quantiles import normal_quantile

__all__ = ["chi2_tail", "tolerance_confidence", "tolerance_factor"]

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(96)
_U = 5.0 * (_NODES + 1.0)  # [0, 10]
_W = 5.0 * _WEIGHTS * math.sqrt(2.0 / math.pi) * np.exp(-0.5 * _U * _U)
_EXACT_DF_MAX = 200


def chi2_tail(x: np.ndarray | float, df: float) -> np.ndarray:
    """P(χ²_df > x), elementwise.

    Parameters
    ----------
    x : array_like
        Points, ≥ 0.
    df : float
        Degrees of freedom, > 0. Whole df ≤ 200 are summed in closed form; others go to
        :func:`scipy.special.chdtrc`.

    Examples
    --------
    >>> float(chi2_tail(2.0, 2))  # e^{−1}
    0.36787944117144233
    """
    x = np.asarray(x, dtype=float)
    if df != int(df) or df > _EXACT_DF_MAX or df < 1:
        from scipy.special import chdtrc

        return np.asarray(chdtrc(df, x), dtype=float)
    y = 0.5 * np.maximum(x, 0.0)
    m = int(df) // 2
    if int(df) % 2 == 0:  # e^{−y} Σ_{j<m} y^j / j!
        term = np.exp(-y)
        total = term.copy()
        for j in range(1, m):
            term = term * y / j
            total += term
        return np.minimum(total, 1.0)
    root = np.sqrt(y)  # erfc(√y) + e^{−y} Σ_{j=1}^{m} y^{j−½} / Γ(j + ½)
    total = np.array([math.erfc(v) for v in root.ravel()]).reshape(root.shape)
    term = np.exp(-y) * root * (2.0 / math.sqrt(math.pi))
    for j in range(1, m + 1):
        total += term
        term = term * y / (j + 0.5)
    return np.minimum(total, 1.0)


def _normal_tail(t: np.ndarray) -> np.ndarray:
    return np.array([0.5 * math.erfc(v / math.sqrt(2.0)) for v in t.ravel()]).reshape(t.shape)


@lru_cache(maxsize=64)
def _half_widths(n: float, content: float) -> np.ndarray:
    """r(u/√n) at the quadrature nodes (module description), in σ."""
    alpha = 1.0 - content
    x = _U / math.sqrt(n)
    # Q(r + x) + Q(r − x) = α is convex and falling in r; Newton's method from
    # r = x + z(α), where it is above α, climbs to the root without overshooting.
    r = x + normal_quantile(alpha)
    for _ in range(60):
        f = _normal_tail(r + x) + _normal_tail(r - x) - alpha
        slope = np.exp(-0.5 * (r + x) ** 2) + np.exp(-0.5 * (r - x) ** 2)
        step = f / (slope / math.sqrt(2.0 * math.pi))
        r = r + step
        if np.all(np.abs(step) <= 1e-13 * r):
            break
    return r


def _validate(n: float, df: float, content: float) -> None:
    if not (n > 0 and df > 0 and 0.0 < content < 1.0):
        raise ValueError(f"need n > 0, df > 0 and 0 < content < 1, got {n}, {df}, {content}")


def tolerance_confidence(k: float, *, n: float, content: float, df: float | None = None) -> float:
    """The confidence γ of the two-sided tolerance interval x̄ ± k s: the probability,
    over the sample, that it holds at least the share ``content`` of the population
    (module description).

    Parameters
    ----------
    k : float
        The factor, in sample standard deviations s.
    n : float, keyword-only
        How many of the population's values the centre x̄ is the mean of.
    content : float, keyword-only
        The share P of the population the interval is to hold, in (0, 1).
    df : float, optional, keyword-only
        Degrees of freedom of s (default n − 1).

    Returns
    -------
    float
        γ in [0, 1].
    """
    df = n - 1.0 if df is None else df
    _validate(n, df, content)
    if not k > 0:
        return 0.0
    if math.isinf(k):
        return 1.0
    r = _half_widths(float(n), float(content))
    return float(np.clip(np.dot(_W, chi2_tail(df * (r / k) ** 2, df)), 0.0, 1.0))


@lru_cache(maxsize=256)
def tolerance_factor(
    *, n: float, content: float, confidence: float, df: float | None = None
) -> float:
    """The factor k of the two-sided (``content``, ``confidence``) tolerance interval
    x̄ ± k s (module description): exact, the root of :func:`tolerance_confidence`.

    Parameters
    ----------
    n : float
        How many values the centre x̄ is the mean of.
    content : float
        The share P of the population held, in (0, 1).
    confidence : float
        The probability γ over the sample, in (0, 1).
    df : float, optional
        Degrees of freedom of s (default n − 1).

    Returns
    -------
    float

    Examples
    --------
    >>> round(tolerance_factor(n=10, content=0.99, confidence=0.95), 3)
    4.437
    """
    df = n - 1.0 if df is None else df
    _validate(n, df, content)
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"a confidence is in (0, 1), got {confidence!r}")

    def excess(k: float) -> float:
        return tolerance_confidence(k, n=n, content=content, df=df) - confidence

    # A start, not an approximation: the normal quantile times √(1 + 1/n) (Howe's without
    # its χ² factor); then bracket and narrow on log k, where the answer comes from.
    lo = hi = normal_quantile((1.0 - content) / 2.0) * math.sqrt(1.0 + 1.0 / n)
    while excess(lo) > 0:
        lo /= 1.5
    while excess(hi) < 0:
        hi *= 1.5
        if hi > 1e12:
            return math.inf
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if excess(mid) < 0:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * hi:
            break
    return 0.5 * (lo + hi)
