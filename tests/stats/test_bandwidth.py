"""LSCV bandwidth (42)-(43): brute-force quadrature, an mpmath root, statsmodels, ties."""

import itertools

import mpmath as mp
import numpy as np
import pytest
from scipy import integrate

from inspect_validate.errors import InputError
from inspect_validate.stats import as_sample, lscv_bandwidth, lscv_objective, pair_counts
from inspect_validate.stats.bandwidth import lscv_bandwidths


def brute_force_lscv(x, h):
    """(42) term by term: ∫p̂² by adaptive quadrature, leave-one-out sum directly."""
    n = x.size

    def p(t):
        return np.exp(-0.5 * ((t - x) / h) ** 2).sum() / (n * h * np.sqrt(2 * np.pi))

    edges = np.concatenate([[x.min() - 14 * h], np.unique(x), [x.max() + 14 * h]])
    integral = sum(
        integrate.quad(lambda t: p(t) ** 2, a, b, epsabs=0, epsrel=1e-13)[0]
        for a, b in itertools.pairwise(edges)
    )
    d = x[:, None] - x[None, :]
    k = np.exp(-0.5 * (d / h) ** 2) / (h * np.sqrt(2 * np.pi))
    np.fill_diagonal(k, 0.0)
    return integral - 2.0 * (k.sum(axis=1) / (n - 1)).mean()


@pytest.mark.parametrize("kind", ["exact", "lattice"])
def test_objective_matches_quadrature(kind):
    rng = np.random.default_rng(7)
    if kind == "exact":
        x = rng.normal(0, 1, 200)
        pairs = pair_counts(x, exact=True)
        hs = [0.05, 0.2, 1.0]
    else:
        x = np.rint(rng.normal(50, 8, 300))
        pairs = pair_counts(as_sample(x.astype(int)))
        hs = [1.0, 2.5, 6.0]
    for h in hs:
        assert lscv_objective(pairs, h)[0] == pytest.approx(brute_force_lscv(x, h), rel=1e-12)


def test_lattice_bandwidth_is_the_exact_optimum():
    rng = np.random.default_rng(8)
    sample = as_sample(np.rint(rng.normal(1000, 40, 50_000)).astype(np.uint16))
    bw = lscv_bandwidth(sample)
    assert bw.method == "lattice" and not bw.at_floor
    pairs = pair_counts(sample)
    lags = [mp.mpf(float(v)) for v in pairs.lags]
    counts = [mp.mpf(float(c)) for c in pairs.pairs]
    n = mp.mpf(pairs.n)

    def slope(h):  # h² dLSCV/dh in 50-digit arithmetic
        a = b = da = db = 0
        for lag, c in zip(lags, counts, strict=True):
            q = (lag / h) ** 2
            ea, eb = c * mp.exp(-q / 4), c * mp.exp(-q / 2)
            a, b, da, db = a + ea, b + eb, da + ea * q / 2, db + eb * q
        return (-(n + 2 * a) + 2 * da) / (2 * mp.sqrt(mp.pi) * n * n) - 4 * (db - b) / (
            n * (n - 1) * mp.sqrt(2 * mp.pi)
        )

    with mp.workdps(50):
        exact = mp.findroot(slope, mp.mpf(bw.h))
    assert bw.h == pytest.approx(float(exact), rel=1e-12)


def test_statsmodels_cv_ls_agrees_within_its_own_accuracy():
    from statsmodels.nonparametric.kernel_density import KDEMultivariate

    rng = np.random.default_rng(9)
    x = rng.normal(0, 1, 300)
    ours = lscv_bandwidth(x)
    theirs = KDEMultivariate(x, "c", bw="cv_ls").bw[0]
    assert ours.method == "exact"
    # statsmodels optimises with fmin at a loose tolerance (~1e-3 relative, issue #2).
    assert ours.h == pytest.approx(theirs, rel=5e-3)
    assert lscv_objective(pair_counts(x, exact=True), ours.h) <= lscv_objective(
        pair_counts(x, exact=True), theirs
    )


def test_binned_matches_exact_for_continuous_data():
    rng = np.random.default_rng(10)
    x = np.concatenate([rng.normal(0, 1, 1500), rng.normal(4, 0.5, 1500)])
    exact = lscv_bandwidth(x[:2000], method="exact")
    binned = lscv_bandwidth(x[:2000], method="binned")
    assert exact.method == "exact" and binned.method == "binned"
    assert binned.h == pytest.approx(exact.h, rel=1e-6)


def test_tied_integer_data_sit_on_the_floor_and_say_so():
    rng = np.random.default_rng(11)
    x = np.rint(rng.normal(100, 0.7, 20_000)).astype(np.uint8)  # ~5 grey levels
    bw = lscv_bandwidth(x)
    assert bw.at_floor and bw.h == 1.0 and bw.floor == 1.0
    # Without the floor the tied data collapse: the objective keeps falling as h → 0.
    pairs = pair_counts(as_sample(x))
    assert lscv_objective(pairs, 0.05) < lscv_objective(pairs, 0.2) < lscv_objective(pairs, 1.0)


def test_never_below_one_grey_level_after_dark_subtraction():
    rng = np.random.default_rng(12)
    codes = rng.integers(0, 40, 5000)  # lattice of 1/4 DN
    bw = lscv_bandwidth(as_sample(codes, denominator=4))
    assert bw.h >= 1.0


def test_degenerate_inputs():
    with pytest.raises(InputError, match="at least 2"):
        lscv_bandwidth(np.array([3]))
    bw = lscv_bandwidth(np.array([7, 7, 7, 7]))
    assert bw.at_floor and bw.h == 1.0
    # A constant float class (e.g. clipped, read as float) is a point mass, not an error.
    bw = lscv_bandwidth(np.array([0.5, 0.5, 0.5]))
    assert bw.at_floor and bw.h == 0.0


@pytest.mark.parametrize("exponent", [-1070, -640, -100, 100, 640])
def test_lscv_is_scale_invariant_down_to_values_whose_variance_underflows(exponent):
    """Values spread over 1e-191 (the fuzz corpus's frame): their variance underflows to 0,
    and the bandwidth was the quantum, ε KDE then NaN. Searched at a power of two, the
    bandwidth scales with the data (to the search's tolerance, 1e-6)."""
    x = np.random.default_rng(3).standard_normal(400)
    reference = lscv_bandwidth(x)
    scaled = lscv_bandwidth(x * 2.0**exponent)
    assert scaled.h == pytest.approx(reference.h * 2.0**exponent, rel=1e-6) and not scaled.at_floor


@pytest.mark.parametrize("quantum", [0.0, 1e-3, 0.2])
def test_columns_at_once_are_each_column_alone(quantum):
    """lscv_bandwidths against lscv_bandwidth column by column, to 1e-13 relative: normal,
    heavy-tailed and bimodal columns, a constant one, integers (the lattice path), and a
    column of 600 values (the binned path), with and without a floor."""
    rng = np.random.default_rng(int(quantum * 1000))
    x = rng.normal(0, 1, (30, 12)) * rng.uniform(0.01, 10, 12)
    x[:, 0] = rng.standard_t(2, 30)
    x[:, 1] = np.r_[rng.normal(0, 1, 15), rng.normal(8, 1, 15)]
    x[:, 2] = 3.25
    x[:, 3] = rng.integers(0, 20, 30)
    got = lscv_bandwidths(x, quantum=quantum)
    for k in range(x.shape[1]):
        want = lscv_bandwidth(x[:, k], quantum=quantum)
        assert got[k].h == pytest.approx(want.h, rel=1e-13), k
        assert got[k].at_floor == want.at_floor, k
    wide = rng.normal(0, 1, (600, 2))
    assert [b.h for b in lscv_bandwidths(wide, quantum=quantum)] == [
        lscv_bandwidth(wide[:, k], quantum=quantum).h for k in range(2)
    ]
