"""Two-sided normal tolerance intervals against published tables, an adaptive
quadrature of the same integral written independently with scipy, Howe's closed-form
approximation, and the promise itself simulated over many samples."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, optimize, stats

from inspect_validate.stats.tolerance_interval import (
    chi2_tail,
    tolerance_confidence,
    tolerance_factor,
)


@pytest.mark.parametrize("df", [1, 2, 3, 4, 5, 9, 40, 199, 200, 201, 2.5])
def test_the_chi_square_tail_is_scipys(df):
    x = np.concatenate([np.linspace(0.0, 5 * df + 50, 400), [1e-9, 0.5, 1e3]])
    assert np.allclose(chi2_tail(x, df), stats.chi2.sf(x, df), rtol=1e-11, atol=1e-300)


@pytest.mark.parametrize(
    ("n", "content", "table"),
    # Two-sided factors at 95 % confidence, to two decimals (Gilbert, *Statistical
    # Methods for Environmental Pollution Monitoring*, as tabulated in Berthouex &
    # Brown, *Statistics for Environmental Engineers*, Table 21.1).
    [
        (4, 0.90, 5.37),
        (5, 0.99, 6.60),
        (10, 0.95, 3.39),
        (10, 0.99, 4.44),
        (20, 0.90, 2.32),
        (40, 0.95, 2.45),
        (60, 0.99, 3.07),
    ],
)
def test_the_factor_matches_the_published_table(n, content, table):
    assert tolerance_factor(n=n, content=content, confidence=0.95) == pytest.approx(
        table, abs=0.006
    )


def _confidence_by_quadrature(k, n, content, df):
    """The same integral, by scipy's adaptive quadrature and a bracketed root for r."""
    alpha = 1.0 - content

    def r(x):
        return optimize.brentq(
            lambda r: stats.norm.sf(x + r) + stats.norm.sf(r - x) - alpha, 0, x + 60, xtol=1e-14
        )

    def f(x):
        return stats.chi2.sf(df * r(x) ** 2 / k**2, df) * math.exp(-n * x * x / 2)

    value, _ = integrate.quad(f, 0, 12 / math.sqrt(n), epsabs=1e-13, epsrel=1e-12, limit=200)
    return math.sqrt(2 * n / math.pi) * value


@pytest.mark.parametrize(
    ("k", "n", "content", "df"),
    [
        (10.0, 5, 1 - 1.1e-4, 4),  # a drift check of 5 repeats at the shipped share
        (20.0, 3, 0.999, 2),
        (5.0, 4.0, 0.999, 39),  # a batch of 10 parts against 40 golden parts
        (4.5, 120, 1 - 5e-5, 119),
        (30.0, 2, 0.99, 1),
        (5.0, 0.5, 0.99, 9),
    ],
)
def test_the_confidence_agrees_with_adaptive_quadrature(k, n, content, df):
    assert tolerance_confidence(k, n=n, content=content, df=df) == pytest.approx(
        _confidence_by_quadrature(k, n, content, df), abs=1e-9
    )


@pytest.mark.parametrize("n", [10, 30, 100])
def test_howes_approximation_is_close(n):
    """Howe (1969): k ≈ z_{(1+P)/2} √((n − 1)(1 + 1/n) / χ²_{n−1, 1−γ}), within 1 % of
    the exact factor for n ≥ 10 at these levels (0.7 % above it at n = 10)."""
    content, confidence = 0.999, 0.95
    howe = stats.norm.isf((1 - content) / 2) * math.sqrt(
        (n - 1) * (1 + 1 / n) / stats.chi2.ppf(1 - confidence, n - 1)
    )
    exact = tolerance_factor(n=n, content=content, confidence=confidence)
    assert exact == pytest.approx(howe, rel=0.01)


def test_the_factor_and_the_confidence_are_inverse_and_monotone():
    k = tolerance_factor(n=7, content=0.9999, confidence=0.9)
    assert tolerance_confidence(k, n=7, content=0.9999) == pytest.approx(0.9, abs=1e-10)
    assert tolerance_factor(n=7, content=0.9999, confidence=0.99) > k
    assert tolerance_factor(n=70, content=0.9999, confidence=0.9) < k
    assert tolerance_confidence(0.0, n=7, content=0.9) == 0.0
    assert tolerance_confidence(math.inf, n=7, content=0.9) == 1.0
    with pytest.raises(ValueError):
        tolerance_factor(n=5, content=0.9, confidence=1.0)


@pytest.mark.parametrize(
    ("n", "df", "content"),
    [(0, 3, 0.9), (5, 0, 0.9), (1, None, 0.9), (5, None, 0.0), (5, None, 1.0), (-1, 3, 0.9)],
)
def test_an_interval_without_a_spread_or_a_share_is_refused(n, df, content):
    """No centre (n = 0), no degrees of freedom (df = 0, one value), no share or all of
    it: ValueError naming the values, from the factor and the confidence alike."""
    for call in (
        lambda: tolerance_factor(n=n, content=content, confidence=0.9, df=df),
        lambda: tolerance_confidence(2.0, n=n, content=content, df=df),
    ):
        with pytest.raises(ValueError, match=rf"need n > 0, df > 0 and 0 < content < 1, got {n}"):
            call()


@pytest.mark.parametrize(("n", "m"), [(5, 1), (40, 10)])
def test_the_interval_holds_its_content_with_its_confidence(n, m):
    """The promise itself: over 20,000 samples of n values, the share of samples whose
    interval x̄ ± k s misses more than 1 − P of new values (new means of m values,
    the batch of the running line, where m > 1) is 1 − γ, within its binomial 99.9 %
    interval."""
    content, confidence, draws = 0.999, 0.9, 20_000
    rng = np.random.default_rng(n)
    sample = rng.normal(0.0, 1.0, (draws, n))
    centre, s = sample.mean(axis=1), sample.std(axis=1, ddof=1)
    # a new mean of m values has σ 1/√m: the interval's spread is s/√m, its centre the
    # mean of n/m such means
    k = tolerance_factor(n=n / m, content=content, confidence=confidence, df=n - 1)
    half, sd_new = k * s / math.sqrt(m), 1 / math.sqrt(m)
    missed = stats.norm.sf((half - centre) / sd_new) + stats.norm.sf((half + centre) / sd_new)
    short = int(np.sum(missed > 1 - content))
    lo, hi = stats.binom.interval(0.999, draws, 1 - confidence)
    assert lo <= short <= hi, short / draws


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(2, 400),
    batch=st.sampled_from([1, 4, 40]),
    tail=st.floats(1e-10, 0.5),
    confidence=st.floats(0.5, 0.9999),
)
def test_any_factor_is_finite_and_gives_its_confidence(n, batch, tail, confidence):
    """Extreme but valid inputs (a share down to 1e-10, 400 repeats, batch means of more
    parts than the golden file has): a finite factor that gives back its confidence and
    grows with it."""
    centre = n / batch
    k = tolerance_factor(n=centre, content=1 - tail, confidence=confidence, df=n - 1)
    assert math.isfinite(k) and k > 0
    assert tolerance_confidence(k, n=centre, content=1 - tail, df=n - 1) == pytest.approx(
        confidence, abs=1e-8
    )
    assert (
        tolerance_factor(
            n=centre, content=1 - tail, confidence=min(confidence + 1e-4, 0.99995), df=n - 1
        )
        >= k
    )
