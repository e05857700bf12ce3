"""Kendall's τ_b against scipy.stats.kendalltau (the independent reference), to 1e-12."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from inspect_validate.stats import kendall_tau


def reference(x, y) -> float:
    return float(stats.kendalltau(x, y).statistic)


@pytest.mark.parametrize("seed", range(20))
def test_equals_scipy_with_ties(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 40))
    # Few distinct values: many ties in both sequences.
    x = rng.integers(0, 5, n).astype(float)
    y = x + rng.integers(-2, 3, n)
    want = reference(x, y)
    got = kendall_tau(x, y)
    assert (math.isnan(got) and math.isnan(want)) or got == pytest.approx(want, abs=1e-12)


values = st.floats(allow_nan=False, width=64) | st.sampled_from([-math.inf, math.inf, 0.0])


@given(st.lists(st.tuples(values, values), min_size=2, max_size=25))
def test_property_equals_scipy(pairs):
    x, y = map(np.array, zip(*pairs, strict=True))
    want, got = reference(x, y), kendall_tau(x, y)
    assert (math.isnan(got) and math.isnan(want)) or got == pytest.approx(want, abs=1e-12)
    assert math.isnan(got) or -1.0 <= got <= 1.0


@pytest.mark.parametrize(
    ("x", "y", "want"),
    [
        ([1.0, 2.0, 3.0], [3.0, 2.0, 1.0], -1.0),
        ([-math.inf, -math.inf, 1.0], [1.0, 2.0, 3.0], reference([-1, -1, 1], [1, 2, 3])),
        ([1.0, 1.0, 1.0], [1.0, 2.0, 3.0], math.nan),  # a constant sequence
        ([1.0, math.nan, 3.0], [1.0, 2.0, 3.0], math.nan),
        ([1.0], [2.0], math.nan),
    ],
)
def test_degenerate_cases_as_scipy(x, y, want):
    got = kendall_tau(x, y)
    assert (math.isnan(got) and math.isnan(want)) or got == pytest.approx(want, abs=1e-12)


def test_unequal_lengths_are_refused():
    with pytest.raises(ValueError, match="one length"):
        kendall_tau([1, 2, 3], [1, 2])


def test_a_tied_ranking_says_its_tau_is_undefined():
    """Reports said "Kendall τ nan" when every prediction was equal."""
    from inspect_validate.verification.results import RankingAgreement

    def agreement(tau):
        return RankingAgreement("A vs B", "snr_db", {}, {}, "x", "x", True, tau)

    assert agreement(0.6667).tau_text == "Kendall τ 0.67"
    assert agreement(float("nan")).tau_text == "Kendall τ undefined (a ranking tied throughout)"
