"""Checks as statistical decisions: the family-wise false-alarm rate shared among the
checks, each limit from its quantile, and the drift check's prediction interval, which
must hold its rate whatever the spread and however few the repeats."""

import math

import numpy as np
import pytest
from scipy import stats

from inspect_validate.verification.checks import (
    at_least,
    at_most,
    count_tests,
    decide,
    normal_equivalent,
    quantile,
    rate_of_k,
)
from inspect_validate.verification.golden import Spread
from inspect_validate.verification.golden_checks import (
    detectable_change,
    prediction_sd,
    repeats_needed,
    widening,
)


def test_k_and_the_rate_are_the_two_sided_normal_convention():
    assert rate_of_k(3.0) == pytest.approx(2 * stats.norm.sf(3.0), rel=1e-12)
    assert normal_equivalent(0.0027) == pytest.approx(stats.norm.isf(0.00135), rel=1e-12)
    assert quantile(0.01, df=4) == pytest.approx(stats.t.isf(0.005, 4), rel=1e-10)
    assert quantile(0.01, sided=1) == pytest.approx(stats.norm.isf(0.01), rel=1e-12)


def test_decide_shares_the_rate_and_sets_each_limit_by_its_basis():
    """Three checks share the rate (Bonferroni: 0.0027 / 3 each); the fixed one keeps its
    limit and spends none of it; a tolerance moves outward by z·SE (one-sided); a
    statistical drift check is t_{df}·SD (two-sided) around 0."""
    checks = decide(
        [
            at_least("sep", "separation", -6.9, -7.0, "dB", basis="tolerance", standard_error=0.1),
            at_most("sat", "saturation", 0.0, 0.1, "%"),
            at_most("agree", "agreement", 1.3, 1.0, "dB", basis="tolerance", standard_error=0.1),
            at_most(
                "drift",
                "drift",
                0.5,
                0.0,
                "DN",
                basis="statistical",
                standard_error=0.1,
                df=4,
                sided=2,
            ),
        ],
        0.0027,
    )
    sep, sat, agree, drift = checks
    share = 0.0027 / 3
    assert count_tests(checks) == 3 and sat.false_alarm is None and sat.limit == 0.1
    assert sep.false_alarm == agree.false_alarm == drift.false_alarm == pytest.approx(share)
    z = stats.norm.isf(share)
    assert sep.limit == pytest.approx(-7.0 - z * 0.1) and sep.passed
    assert agree.limit == pytest.approx(1.0 + z * 0.1) and agree.passed  # 1.3 < 1.33
    assert drift.limit == pytest.approx(stats.t.isf(share / 2, 4) * 0.1)
    assert drift.passed == (0.5 <= drift.limit)
    assert [c.basis for c in checks] == ["tolerance", "fixed", "tolerance", "statistical"]


def test_a_statistical_check_without_a_spread_does_not_run_and_fails():
    (c,) = decide(
        [at_most("drift", "drift", 0.1, 0.0, "DN", basis="statistical", standard_error=math.nan)],
        0.0027,
    )
    assert not c.passed and not c.ran and c.verdict == "NOT RUN" and "no spread" in c.detail


def test_a_ranking_predicted_closer_than_the_frames_resolve_is_too_close_to_call():
    """A predicted gap within the margin: TOO CLOSE, which fails nothing (even where the
    measured order is the other); a gap beyond it with the order reversed beyond the
    margin fails."""
    close = at_most(
        "rank",
        "ranking",
        0.2,
        0.0,
        "dB",
        basis="statistical",
        standard_error=0.05,
        predicted_gap=0.1,
    )
    far = at_most(
        "rank",
        "ranking",
        0.5,
        0.0,
        "dB",
        basis="statistical",
        standard_error=0.05,
        predicted_gap=2.0,
    )
    (c,) = decide([close], 0.0027)
    assert c.undecided and c.passed and c.verdict == "TOO CLOSE"
    (f,) = decide([far], 0.0027)
    assert (
        not f.undecided and not f.passed and f.limit == pytest.approx(stats.norm.isf(0.0027) * 0.05)
    )


@pytest.mark.parametrize(
    ("repeats", "tau", "se_new", "exact"),
    [
        (3, 0.0, 1.0, False),
        (5, 0.0, 1.0, False),
        (5, 0.0, 3.0, False),
        (12, 5.0, 1.0, True),
        (3, 10.0, 1.0, True),
    ],
)
def test_the_drift_prediction_interval_holds_its_rate(repeats, tau, se_new, exact):
    """An unchanged station: n repeats of standard error SE₀ = 1 that also vary between
    captures by τ, and a new value of standard error ``se_new`` (> SE₀: fewer frames than
    the training). 20,000 draws at α = 5 %. Where the repeats vary by much more than
    their noise the interval is the classic one, and the observed rate lies within its
    binomial 99.9 % interval around 5 % (±0.4 %); where they vary by their noise alone,
    the spread is floored at SE₀ (repeats cannot vary less than their noise), which only
    widens it: never above the rate (with 2 degrees of freedom far below it: the t
    interval's false alarms come from the small spreads the floor removes)."""
    rng = np.random.default_rng(repeats + int(tau))
    alpha, draws, se0 = 0.05, 20_000, 1.0
    train = rng.normal(0.0, math.hypot(tau, se0), (draws, repeats))
    new = rng.normal(0.0, math.hypot(tau, se_new), draws)
    q = quantile(alpha, df=repeats - 1)
    outside = 0
    for row, x in zip(train, new, strict=True):
        spread = Spread(values=list(row), standard_errors=[se0] * repeats)
        outside += abs(x - spread.mean) > q * prediction_sd(spread, se_new)
    lo, hi = stats.binom.interval(0.999, draws, alpha)
    assert outside <= hi, outside / draws
    if exact:
        assert lo <= outside, outside / draws


def test_the_widening_is_t_over_z_and_the_repeats_needed_reach_it():
    share = 0.0027 / 20
    assert widening(5, share) == pytest.approx(
        stats.t.isf(share / 2, 4) * math.sqrt(1.2) / stats.norm.isf(share / 2), rel=1e-9
    )
    assert widening(1, share) == math.inf
    n = repeats_needed(share)
    assert widening(n, share) <= 2.0 < widening(n - 1, share)


def test_the_detectable_change_is_caught_with_95_percent():
    """A shift of detectable_change(spread) is caught 95 % of the time (Monte Carlo over
    new values, the golden fixed: ±1 %)."""
    spread = Spread(values=[0.0, 1.0, -1.0, 0.5, -0.5], standard_errors=[0.8] * 5)
    share = 0.001
    delta = detectable_change(spread, share)
    sd = prediction_sd(spread, 0.8)
    limit = quantile(share, df=4) * sd
    rng = np.random.default_rng(0)
    # the new value's own spread is the part of the interval that is not the mean's
    new = delta + rng.normal(0.0, sd, 200_000)
    assert np.mean(np.abs(new - spread.mean) > limit) == pytest.approx(0.95, abs=0.01)
