"""Separation of two classes from their means and variances (chapter §3.3.1).

Three measures, each named wherever it is printed:

* ``snr`` / ``snr_db``: the chapter's SNR (35)–(36), ``|μ1 − μ2| / (σ1² + σ2²)``.
  It divides a difference of grey values by a sum of *variances*, so it is not
  dimensionless and changes with camera gain; it is kept because the chapter's
  Tables 3 and 4 use it.
* ``cnr_db``: contrast-to-noise ratio ``20·log10(|μ1 − μ2| / sqrt(σ1² + σ2²))``,
  dimensionless.
* ``fisher_db``: Fisher ratio ``10·log10((μ1 − μ2)² / (σ1² + σ2²))``; equal to
  ``cnr_db`` by construction, reported under its own name for readers who know it
  as such.

Degenerate cases (all functions are vectorised and never raise for them):

* equal means and non-zero variance: ratio 0, −inf dB;
* zero total variance and different means: ratio +inf, +inf dB;
* equal means and zero variance (two identical constant classes): the classes
  cannot be told apart, so the ratio is 0 and −inf dB.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["cnr_db", "fisher_db", "snr", "snr_db"]


def _ratio(mean1, var1, mean2, var2, *, power: float) -> np.ndarray:
    diff = np.abs(np.asarray(mean1, float) - np.asarray(mean2, float))
    var1, var2 = np.asarray(var1, float), np.asarray(var2, float)
    if np.any(var1 < 0) or np.any(var2 < 0):
        raise ValueError("variances must be non-negative")
    total = var1 + var2
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = diff / total**power
    return np.where(diff == 0, 0.0, ratio)


def snr(mean1: ArrayLike, var1: ArrayLike, mean2: ArrayLike, var2: ArrayLike) -> np.ndarray:
    """The chapter's SNR (35): ``|μ1 − μ2| / (σ1² + σ2²)`` in 1/DN.

    Parameters
    ----------
    mean1, mean2 : array_like
        Class means μ (38), DN.
    var1, var2 : array_like
        Class variances σ² (39), DN².
    """
    return _ratio(mean1, var1, mean2, var2, power=1.0)


def snr_db(mean1: ArrayLike, var1: ArrayLike, mean2: ArrayLike, var2: ArrayLike) -> np.ndarray:
    """The chapter's SNR_dB (36): ``20·log10(|μ1 − μ2| / (σ1² + σ2²))``, dB."""
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(snr(mean1, var1, mean2, var2))


def cnr_db(mean1: ArrayLike, var1: ArrayLike, mean2: ArrayLike, var2: ArrayLike) -> np.ndarray:
    """Contrast-to-noise ratio ``20·log10(|μ1 − μ2| / sqrt(σ1² + σ2²))``, dB."""
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(_ratio(mean1, var1, mean2, var2, power=0.5))


def fisher_db(mean1: ArrayLike, var1: ArrayLike, mean2: ArrayLike, var2: ArrayLike) -> np.ndarray:
    """Fisher ratio ``10·log10((μ1 − μ2)² / (σ1² + σ2²))``, dB (equals :func:`~inspect_validate.stats.cnr_db`)."""
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10(_ratio(mean1, var1, mean2, var2, power=0.5) ** 2)
