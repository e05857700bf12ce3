"""The normal and Student's t quantiles against scipy.special (ndtri, stdtrit), the
reference they replace on verify's start-up path."""

import math

import numpy as np
import pytest
from scipy.special import ndtri, stdtrit

from inspect_validate.stats.quantiles import normal_quantile, student_quantile

TAILS = np.concatenate([np.logspace(-300, -13, 30), np.logspace(-12, np.log10(0.999), 80)])


def _close(got, want):
    """1e-12 relative, or 1e-15 absolute where the quantile is near 0 (tails near ½)."""
    return abs(got - want) <= max(1e-12 * abs(want), 1e-15)


def test_the_normal_quantile_is_scipys_to_1e_12():
    assert all(_close(normal_quantile(q), -ndtri(q)) for q in TAILS)
    assert normal_quantile(0.0) == math.inf and normal_quantile(1.0) == -math.inf
    with pytest.raises(ValueError):
        normal_quantile(1.5)


@pytest.mark.parametrize("df", [1, 2, 3, 4, 5, 7, 10, 19, 30, 99, 100, 200])
def test_the_student_quantile_is_scipys_to_1e_12(df):
    """Whole ν ≤ 200 are summed here, tails 1e-12–0.999 (the far tails of ν = 1 and 2 in
    closed form, the others by the series from the far side)."""
    tails = TAILS[TAILS >= 1e-12]
    bad = [(q, student_quantile(q, df), -stdtrit(df, q)) for q in tails]
    assert [b for b in bad if not _close(b[1], b[2])] == []


@pytest.mark.parametrize("df", [2.5, 201, 1e6, math.inf])
def test_other_degrees_of_freedom_agree_too(df):
    """A fractional or large ν goes to scipy; inf is the normal quantile."""
    for q in (1e-9, 1e-3, 0.05, 0.5, 0.9):
        want = -ndtri(q) if math.isinf(df) else -stdtrit(df, q)
        assert _close(student_quantile(q, df), want)
