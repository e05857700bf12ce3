"""ε_tot (37) of two kernel density estimates, against brute-force quadrature (1e-8 relative)."""

import importlib
import itertools

import numpy as np
import pytest
from scipy import integrate

from inspect_validate.stats import as_sample, gaussian_error, kde_error
from inspect_validate.stats.kde_error import mixture_error, mixture_errors
from inspect_validate.stats.mixture import Mixture, kernel_mixture


def reference(s1, s2, h1, h2, lo, hi):
    """ε_tot of the kernel densities of samples ``s1`` and ``s2`` with bandwidths ``h1``,
    ``h2`` (DN), by adaptive quadrature of ½ min(p̂1, p̂2) over 400 panels of [lo, hi]
    (rel. tol. 1e-12), each panel split where p̂1 = p̂2 (found by brentq on a 0.01-wide
    scan of log p̂1 − log p̂2), so that every piece is smooth: the min's kinks otherwise
    cost quad its accuracy (1e-10 at n = 20000). The benchmarks' reference too
    (benchmarks/bench_stats.py)."""
    from scipy import optimize, special

    c1, w1 = kernel_mixture(s1, h1)
    c2, w2 = kernel_mixture(s2, h2)

    def p(x, c, w, h):
        return np.sum(w * np.exp(-0.5 * ((x - c) / h) ** 2)) / (h * np.sqrt(2 * np.pi))

    def log_ratio(x):
        x = np.asarray(x, dtype=float)[..., np.newaxis]

        def log_p(c, w, h):
            return special.logsumexp(-0.5 * ((x - c) / h) ** 2, b=w, axis=-1) - np.log(h)

        return log_p(c1, w1, h1) - log_p(c2, w2, h2)

    grid = np.arange(lo, hi, 0.01)
    signs = np.sign(log_ratio(grid))
    crossings = [
        optimize.brentq(log_ratio, grid[i], grid[i + 1], xtol=1e-14, rtol=1e-15)
        for i in np.flatnonzero(signs[:-1] * signs[1:] < 0)
    ]
    edges = np.union1d(np.linspace(lo, hi, 400), crossings)
    return 0.5 * sum(
        integrate.quad(
            lambda x: min(p(x, c1, w1, h1), p(x, c2, w2, h2)),
            u,
            v,
            epsabs=0,
            epsrel=1e-12,
            limit=200,
        )[0]
        for u, v in itertools.pairwise(edges)
    )


@pytest.mark.parametrize("gap", [12.0, 35.0])
def test_matches_quadrature(gap):
    rng = np.random.default_rng(13)
    a = as_sample(np.rint(rng.normal(100, 6, 4000)).astype(int))
    b = as_sample(np.rint(rng.normal(100 + gap, 9, 5000)).astype(int))
    r = kde_error(a, b)
    ref = reference(a, b, r.bandwidth1.h, r.bandwidth2.h, 20, 260)
    assert r.error == pytest.approx(ref, rel=1e-8)


def test_continuous_samples():
    rng = np.random.default_rng(14)
    a, b = rng.normal(0, 1, 800), rng.gamma(3.0, 1.0, 900)
    r = kde_error(a, b)
    ref = reference(a, b, r.bandwidth1.h, r.bandwidth2.h, -12, 30)
    assert r.error == pytest.approx(ref, rel=1e-8)


def test_approaches_gaussian_error_for_large_gaussian_samples():
    rng = np.random.default_rng(15)
    a, b = rng.normal(0, 1, 200_000), rng.normal(2.5, 1.5, 200_000)
    r = kde_error(a, b)
    assert r.error == pytest.approx(float(gaussian_error(0, 1, 2.5, 2.25)), rel=0.02)


def test_symmetric_and_identical():
    rng = np.random.default_rng(16)
    a = np.rint(rng.normal(50, 4, 3000)).astype(int)
    b = np.rint(rng.normal(58, 4, 3000)).astype(int)
    assert kde_error(a, b).error == pytest.approx(kde_error(b, a).error, rel=1e-12)
    assert kde_error(a, a).error == pytest.approx(0.5, rel=1e-12)


def test_windowed_density_equals_the_full_sum():
    # Many components (the windowed path) with gaps wider than the window, weights
    # down to 1e-60 and points far in both tails: the sum over each window must
    # equal the sum over every component (float64 relative accuracy).
    from inspect_validate.stats.mixture import _log_density_all, density_parts, log_density

    rng = np.random.default_rng(3)
    centres = np.sort(np.concatenate([rng.normal(0, 3, 600), rng.normal(400, 1, 300), [900.0]]))
    weights = rng.uniform(0, 1, centres.size) * 10.0 ** rng.integers(-60, 0, centres.size)
    weights /= weights.sum()
    x = np.concatenate([np.linspace(-200, 1100, 5000), rng.uniform(-50, 950, 300)])
    h = 0.7
    full = np.empty(x.size)
    _log_density_all(x, full, centres, np.log(weights) - np.log(h), h)
    parts = density_parts(centres, weights, np.full(centres.size, h))
    windowed = log_density(x, parts) + 0.5 * np.log(2 * np.pi)
    np.testing.assert_allclose(windowed, full, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("scale", [1.0, 1e-300, 5e-324 * 2**10, 1e280])
def test_mixture_error_is_invariant_to_the_grey_value_unit(scale):
    # ε depends on the densities' shapes only; subnormal or huge units (a fuzzer's float
    # frames) must give the same number as DN, not a failed root search.
    c1, c2 = np.array([0.0, 3.0, 4.0]), np.array([2.0, 5.0])
    w1, w2 = np.array([0.5, 0.3, 0.2]), np.array([0.6, 0.4])
    expected = mixture_error(Mixture(c1, w1, 1.0), Mixture(c2, w2, 1.5))
    got = mixture_error(
        Mixture(c1 * scale + 7 * scale, w1, scale), Mixture(c2 * scale + 7 * scale, w2, 1.5 * scale)
    )
    assert got == pytest.approx(expected, rel=1e-6 if scale < 1e-300 else 1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_small_mixtures_match_quadrature(seed):
    # A group comparison: a few Gaussians of their own widths against one or two more
    # (the crossings by vectorised Newton steps inside the grid's brackets).
    rng = np.random.default_rng(seed)
    n1, n2 = rng.integers(1, 4, 2)
    c1, c2 = rng.normal(0, 4, n1), rng.normal(2, 4, n2)
    s1, s2 = np.exp(rng.normal(0, 0.5, n1)), np.exp(rng.normal(0, 0.5, n2))
    w1, w2 = rng.dirichlet(np.ones(n1)), rng.dirichlet(np.ones(n2))

    def p(x, c, w, s):
        return np.sum(w * np.exp(-0.5 * ((x - c) / s) ** 2) / s) / np.sqrt(2 * np.pi)

    edges = np.linspace(-40, 40, 400)
    ref = 0.5 * sum(
        integrate.quad(
            lambda x: min(p(x, c1, w1, s1), p(x, c2, w2, s2)), a, b, epsabs=0, epsrel=1e-12
        )[0]
        for a, b in itertools.pairwise(edges)
    )
    assert mixture_error(Mixture(c1, w1, s1), Mixture(c2, w2, s2)) == pytest.approx(ref, rel=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_binned_grid_takes_only_signs_it_is_sure_of(seed, monkeypatch):
    """The binned log-densities against exact ones on the crossing search's grid: within
    half the margin wherever a tilt holds them, so every sign taken from them is the
    exact one; and ε KDE equal to the all-exact grid's bit for bit. Mixtures: lattice
    classes of unequal widths and distances (ε from about 0.4 down to underflow), one
    against a group of two; classes far apart fall back to the exact grid."""
    import importlib

    k = importlib.import_module("inspect_validate.stats.kde_error")
    rng = np.random.default_rng(seed)
    sd = rng.uniform(20, 400, 3)
    gap = rng.choice([0.5, 3.0, 40.0])
    samples = [np.round(rng.normal(i * gap * sd.max(), s, 5000)) for i, s in enumerate(sd)]
    mixtures = []
    for x in samples:
        h = k.lscv_bandwidth(x).h
        c, w = k.kernel_mixture(x, h)
        mixtures.append((c, w, np.full(c.size, h)))
    group = [np.concatenate(z) for z in zip(mixtures[1], mixtures[2], strict=True)]
    group[1] = group[1] / 2
    for (c1, w1, s1), (c2, w2, s2) in [(mixtures[0], mixtures[1]), (mixtures[0], group)]:
        shift, unit = min(c1.min(), c2.min()), max(s1.max(), s2.max())
        u1, v1, u2, v2 = (c1 - shift) / unit, s1 / unit, (c2 - shift) / unit, s2 / unit
        o1, o2 = np.argsort(u1, kind="stable"), np.argsort(u2, kind="stable")
        p1 = k.density_parts(u1[o1], w1[o1], v1[o1])
        p2 = k.density_parts(u2[o2], w2[o2], v2[o2])
        grid = k._crossing_grid(np.concatenate([u1, u2]), np.concatenate([v1, v2]))
        b1, b2 = k.binned_log_density(grid, p1), k.binned_log_density(grid, p2)
        if b1 is None or b2 is None:
            # Classes 40 σ apart: their tilts would pass the element budget (a 57000 DN
            # gap took 3 s and 660 MB binned, 0.3 s and 60 MB exact), so the grid is exact.
            assert gap == 40.0
        else:
            exact = k.log_density(grid, p1) - k.log_density(grid, p2)
            held = np.isfinite(b1 - b2)
            assert held.mean() > 0.95
            assert np.max(np.abs(b1 - b2 - exact)[held]) < 0.5 * k._BINNED_MARGIN
        eps = k.mixture_error(Mixture(c1, w1, s1), Mixture(c2, w2, s2))
        with monkeypatch.context() as m:
            m.setattr(
                k, "_grid_difference", lambda g, a, b: k.log_density(g, a) - k.log_density(g, b)
            )
            assert k.mixture_error(Mixture(c1, w1, s1), Mixture(c2, w2, s2)) == eps


def test_two_crossings_within_one_grid_cell_are_both_found():
    """log p1 − log p2 rises to +η = 1e-3 nats between two grid points and falls back: two
    crossings 0.06 apart inside a cell of 0.25 (units of σ), no sign change on the grid.
    Both are found (the dip between the cell's neighbours is split at d's maximum) and
    agree with brentq's to 1e-12. Before, which of such pairs were found depended on
    where the grid happened to fall; a 4-class lattice scene lost 4e-6 of one ε."""
    import importlib

    from scipy.optimize import brentq, minimize_scalar

    k = importlib.import_module("inspect_validate.stats.kde_error")
    p2 = [(np.array([-1.5, 1.6]), np.log([0.5, 0.5]), 1.0)]

    def d(x, shift):
        p1 = [(np.zeros(2), np.log([0.5, 0.5]) + shift, 1.0)]
        return k.log_density(np.atleast_1d(x), p1) - k.log_density(np.atleast_1d(x), p2)

    peak = minimize_scalar(lambda x: -d(x, 0.0)[0], bracket=(-0.5, 0.5), tol=1e-12).x
    shift = 1e-3 - d(peak, 0.0)[0]
    p1 = [(np.zeros(2), np.log([0.5, 0.5]) + shift, 1.0)]
    grid = peak + 0.125 + 0.25 * np.arange(-170, 170)
    on_grid = d(grid, shift)
    assert np.all(on_grid < 0)  # the grid alone sees no crossing
    roots = k._crossings(grid, on_grid, p1, p2, 1e-13)
    expected = [
        brentq(lambda x: d(x, shift)[0], peak - 0.1, peak, xtol=1e-15),
        brentq(lambda x: d(x, shift)[0], peak, peak + 0.1, xtol=1e-15),
    ]
    assert 0.05 < expected[1] - expected[0] < 0.07
    np.testing.assert_allclose(roots, expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", range(8))
def test_shared_grid_errors_equal_each_comparisons_own(seed, monkeypatch):
    """mixture_errors (one grid and one binned density a class for all comparisons) against
    mixture_error of each comparison's concatenated components (its own grid): pairs and
    one-against-the-rest of 3–5 classes (lattice and float, unequal widths and
    distances, a constant class now and then, unequal shares), to 1e-12 relative. Some
    comparisons of every draw take the shared grid (the others, a constant class or
    classes whose own grid is far smaller, fall back to mixture_error)."""
    import importlib

    module = importlib.import_module("inspect_validate.stats.kde_error")
    fallbacks = []
    monkeypatch.setattr(
        module, "mixture_error", lambda *a: fallbacks.append(1) or mixture_error(*a)
    )
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 6))
    mixtures = []
    for _ in range(n):
        sd, mu = rng.uniform(2, 60), rng.uniform(0, 150)
        kind = rng.choice(["lattice", "float", "constant"], p=[0.6, 0.3, 0.1])
        if kind == "constant":
            x = np.full(50, np.round(mu))
        elif kind == "float":
            x = rng.normal(mu, sd, int(rng.integers(100, 3000)))
        else:
            x = np.round(rng.normal(mu, sd, int(rng.integers(500, 20000))))
        h = 0.0 if kind == "constant" else k_lscv(x)
        mixtures.append((*kernel_mixture(x, h if h > 0 else 1.0), h))
    comparisons = [[([a], [1.0]), ([b], [1.0])] for a, b in itertools.combinations(range(n), 2)]
    for a in range(n):
        rest = [b for b in range(n) if b != a]
        comparisons.append([([a], [1.0]), (rest, rng.dirichlet(np.ones(len(rest))))])
    shared = mixture_errors(mixtures, comparisons)
    assert len(fallbacks) < len(comparisons)
    for got, sides in zip(shared, comparisons, strict=True):
        args = [
            Mixture(
                np.concatenate([mixtures[j][0] for j in g]),
                np.concatenate([mixtures[j][1] * s for j, s in zip(g, share, strict=True)]),
                np.concatenate([np.full(mixtures[j][0].size, mixtures[j][2]) for j in g]),
            )
            for g, share in sides
        ]
        assert got == pytest.approx(mixture_error(*args), rel=1e-12, abs=1e-300)


def k_lscv(x):
    from inspect_validate.stats import lscv_bandwidth

    return lscv_bandwidth(x).h


def test_the_regions_are_found_once_and_the_memo_stays_bounded():
    # A measurement asks for each comparison's regions for ε Gauss and for the counted
    # error: the second asks the memo; a long-running watch asks for ever new ones, and
    # the memo keeps only the last few.
    k = importlib.import_module("inspect_validate.stats.kde_error")  # the module, not ε KDE

    args = (Mixture([10.0, 30.0], [0.5, 0.5], [2.0, 3.0]), Mixture([20.0], [1.0], [4.0]))
    k._regions_of.cache_clear()
    first = k.misclassified_regions(*args)
    error = mixture_error(*args)
    info = k._regions_of.cache_info()
    assert (info.misses, info.hits) == (1, 1)
    for (r0, m0), (r1, m1) in zip(first, k.misclassified_regions(*args), strict=True):
        assert r0 == r1
        np.testing.assert_array_equal(m0, m1)
    assert error == mixture_error(*args)
    for shift in range(100):
        mixture_error(Mixture([10.0 + shift], [1.0], [2.0]), Mixture([20.0], [1.0], [4.0]))
    assert k._regions_of.cache_info().currsize <= k._regions_of.cache_info().maxsize == 32


def test_windowed_sums_equal_the_sums_over_every_component():
    """The root search's slopes and the regions' masses sum, per component, only what
    lies within reach (they summed every component everywhere: minutes on two classes
    of 65,536 distinct grey values). Against the full sums in scipy: 1e-12."""
    from scipy import special

    from inspect_validate.stats.kde_error import _region_masses
    from inspect_validate.stats.mixture import density_parts, log_density_slope

    rng = np.random.default_rng(11)
    h = 3.0
    centres = np.sort(rng.uniform(0, 5000, 4000))
    weights = rng.uniform(0.5, 1.5, centres.size)
    weights /= weights.sum()
    parts = density_parts(centres, weights, np.full(centres.size, h))
    x = np.concatenate([rng.uniform(-50, 5050, 300), [2500.0, 2500.1]])
    log_p, slope = log_density_slope(x, parts)
    z = (x[:, None] - centres) / h
    terms = np.log(weights) - np.log(h) - 0.5 * z * z
    np.testing.assert_allclose(log_p, special.logsumexp(terms, axis=1), rtol=1e-12)
    share = special.softmax(terms, axis=1)
    np.testing.assert_allclose(slope, (share * -z / h).sum(axis=1), rtol=1e-9, atol=1e-12)

    edges = np.sort(rng.uniform(0, 5000, 81))
    regions = [(-np.inf, edges[0])] + [
        (a, b) for a, b in zip(edges[1::2], edges[2::2], strict=True)
    ]
    regions.append((edges[-1] + 1, np.inf))
    sigmas = rng.uniform(1, 30, centres.size)
    mass, d_phi, d_zphi = _region_masses(regions, centres, sigmas, gradient=True)
    a, b = np.array(regions).T
    za, zb = (a[:, None] - centres) / sigmas, (b[:, None] - centres) / sigmas
    expected = (special.ndtr(zb) - special.ndtr(za)).sum(axis=0)
    np.testing.assert_allclose(mass, expected, rtol=1e-12, atol=1e-15)
    pa, pb = np.exp(-0.5 * za**2), np.exp(-0.5 * zb**2)
    np.testing.assert_allclose(d_phi, (pa - pb).sum(axis=0), rtol=1e-12, atol=1e-15)
    zpa = np.where(np.isfinite(za), za, 0) * pa
    zpb = np.where(np.isfinite(zb), zb, 0) * pb
    np.testing.assert_allclose(d_zphi, (zpa - zpb).sum(axis=0), rtol=1e-12, atol=1e-15)
