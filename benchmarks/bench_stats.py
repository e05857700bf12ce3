"""Speed and accuracy of the statistics core against the references named in issue #2.

Run: ``python benchmarks/bench_stats.py`` (about a minute on 2 cores). Prints one
table: for each task, our time and error next to the reference's, and the ratios
(ours / reference; a time ratio ≤ 1 means we are at least as fast).

Errors are measured against exact or high-precision values computed here:
Fractions for moments, mpmath (60 digits) for the Gaussian error, adaptive
quadrature for the KDE error, a 50-digit root of the closed-form LSCV slope for
lattice bandwidths, and the exact O(n²) objective for continuous bandwidths.
"""

from __future__ import annotations

import time

import numpy as np
from machine import best_time, exact_moments


def region_moments_row(rows):
    import cv2

    from inspect_validate.stats import region_statistics, sample_moments

    rng = np.random.default_rng(0)
    frame = np.clip(np.rint(rng.normal(60_000, 1, (4000, 5000))), 0, 65535).astype(np.uint16)
    mask = np.zeros(frame.shape, np.uint8)
    mask[200:3800, 300:4700] = 1
    maskb = mask.astype(bool)
    exact = exact_moments(frame[maskb])[1]

    def ours():
        return sample_moments(region_statistics(frame, maskb).sample)

    t_ours = best_time(ours)
    t_ref = best_time(lambda: cv2.meanStdDev(frame, mask=mask))
    _, sd = cv2.meanStdDev(frame, mask=mask)
    n = int(maskb.sum())
    err_ref = abs(float(sd[0, 0]) ** 2 * n / (n - 1) - float(exact))
    err_ours = abs(ours().variance - float(exact))
    rows.append(
        (
            "region σ², 20 MP uint16, μ=60000 σ=1",
            "cv2.meanStdDev",
            t_ours,
            t_ref,
            err_ours,
            err_ref,
            "abs DN²",
        )
    )


def lattice_bandwidth_row(rows):
    from inspect_validate.stats import as_sample, lscv_bandwidth

    rng = np.random.default_rng(1)
    values = np.rint(rng.normal(30_000, 400, 20_000_000)).astype(np.uint16)
    sample = as_sample(values)
    t_ours = best_time(lambda: lscv_bandwidth(sample), repeat=3)
    rows.append(
        (
            "LSCV h, 20 MP uint16 region (lattice)",
            "—",
            t_ours,
            float("nan"),
            0.0,
            float("nan"),
            "see tests",
        )
    )


def statsmodels_row(rows, n=2000):
    from statsmodels.nonparametric.kernel_density import KDEMultivariate

    from inspect_validate.stats import lscv_bandwidth

    rng = np.random.default_rng(2)
    x = rng.normal(0, 1, n)
    t_ours = best_time(lambda: lscv_bandwidth(x), repeat=3)
    ours = lscv_bandwidth(x).h
    t0 = time.perf_counter()
    theirs = KDEMultivariate(x, "c", bw="cv_ls").bw[0]
    t_ref = time.perf_counter() - t0
    exact = lscv_bandwidth(x, method="exact").h  # the O(n²) optimum, by root finding
    ours = abs(ours - exact) / exact
    rows.append(
        (
            f"LSCV h, n={n} continuous",
            "statsmodels cv_ls",
            t_ours,
            t_ref,
            ours,
            abs(theirs - exact) / exact,
            "rel h",
        )
    )
    tied = np.rint(rng.normal(100, 0.7, 2000)).astype(np.uint8).astype(float)
    h_tied = KDEMultivariate(tied, "c", bw="cv_ls").bw[0]
    rows.append(
        (
            "LSCV h, tied uint8 data",
            "statsmodels cv_ls",
            float("nan"),
            float("nan"),
            lscv_bandwidth(tied.astype(np.uint8)).h,
            h_tied,
            "h [DN]",
        )
    )


def exact_slope(x, h, chunk=2000):
    """h²·dLSCV/dh from all n(n−1)/2 pairs, in chunks (the O(n²) reference)."""
    n = x.size
    a = b = da = db = 0.0
    for i in range(0, n, chunk):
        d = x[i : i + chunk, None] - x[None, :]
        q = (d / h) ** 2
        # Ordered pairs i ≠ j, halved below; the diagonal (q = 0) is removed.
        ea, eb = np.exp(-q / 4), np.exp(-q / 2)
        a += ea.sum() - min(chunk, n - i)
        b += eb.sum() - min(chunk, n - i)
        da += (ea * q).sum() / 2
        db += (eb * q).sum()
    a, b, da, db = a / 2, b / 2, da / 2, db / 2
    return (-(n + 2 * a) + 2 * da) / (2 * np.sqrt(np.pi) * n * n) - 4 * (db - b) / (
        n * (n - 1) * np.sqrt(2 * np.pi)
    )


def binned_bandwidth_row(rows):
    from scipy import optimize

    from inspect_validate.stats import lscv_bandwidth

    rng = np.random.default_rng(3)
    x = np.concatenate([rng.normal(0, 1, 7_000), rng.normal(4, 0.5, 3_000)])
    binned = lscv_bandwidth(x)
    t_exact = time.perf_counter()
    exact = optimize.brentq(
        lambda h: exact_slope(x, h), binned.h * 0.999, binned.h * 1.001, rtol=1e-14
    )
    t_exact = time.perf_counter() - t_exact
    t_ours = best_time(lambda: lscv_bandwidth(x), 3)
    rows.append(
        (
            "LSCV h, n=10⁴ bimodal, vs exact",
            "exact O(n²) root",
            t_ours,
            t_exact,
            abs(binned.h - exact) / exact,
            0.0,
            "rel h",
        )
    )
    big = rng.normal(0, 1, 1_000_000)
    rows.append(
        (
            "LSCV h, n=10⁶ continuous (binned)",
            "—",
            best_time(lambda: lscv_bandwidth(big), 5),
            float("nan"),
            float("nan"),
            float("nan"),
            "",
        )
    )


def gaussian_error_row(rows):
    import mpmath as mp
    from scipy import stats

    from inspect_validate.stats import gaussian_error

    gaps = np.array([1.0, 10.0, 20.0, 40.0, 60.0, 74.0])
    ref = [mp.ncdf(-mp.mpf(float(g)) / 2) for g in gaps]  # equal unit variances: Φc(Δ/2)
    ours = gaussian_error(0.0, 1.0, gaps, 1.0)
    textbook = 1.0 - stats.norm.cdf(gaps / 2)
    rel = lambda v: max(abs(float(a) - float(r)) / float(r) for a, r in zip(v, ref, strict=True))  # noqa: E731
    big = np.random.default_rng(4).uniform(0, 30, 1_000_000)
    t_ours = best_time(lambda: gaussian_error(0.0, 1.0, big, 2.0), 3)
    t_ref = best_time(lambda: 1.0 - stats.norm.cdf(big / 2), 3)
    rows.append(
        (
            "ε Gauss, 10⁶ pairs; error at Δ/σ ≤ 74",
            "1 − Φ (textbook)",
            t_ours,
            t_ref,
            rel(ours),
            rel(textbook),
            "max rel",
        )
    )


def careful_scipy_error(m1, v1, m2, v2):
    """ε_tot of two Gaussians as a careful scipy user writes it: the quadratic's roots
    without cancellation, every tail from ``ndtr`` of the far side (no 1 − Φ)."""
    from scipy import special

    swap = v1 > v2
    mn, vn = np.where(swap, m2, m1), np.where(swap, v2, v1)
    mw, vw = np.where(swap, m1, m2), np.where(swap, v1, v2)
    sn, sw = np.sqrt(vn), np.sqrt(vw)
    a = 1 / (2 * vw) - 1 / (2 * vn)
    b = mn / vn - mw / vw
    c = mw**2 / (2 * vw) - mn**2 / (2 * vn) + np.log(sw / sn)
    with np.errstate(all="ignore"):
        q = -0.5 * (b + np.copysign(np.sqrt(b * b - 4 * a * c), b))
        r1, r2 = q / a, c / q
        x = -c / b  # equal variances: one crossing
        equal = a == 0
        lo = np.where(equal, np.where(mn < x, -np.inf, x), np.minimum(r1, r2))
        hi = np.where(equal, np.where(mn < x, x, np.inf), np.maximum(r1, r2))
        zl, zh = (lo - mw) / sw, (hi - mw) / sw
        inside = np.where(
            zl >= 0,
            special.ndtr(-zl) - special.ndtr(-zh),
            np.where(
                zh <= 0,
                special.ndtr(zh) - special.ndtr(zl),
                1 - special.ndtr(-zh) - special.ndtr(zl),
            ),
        )
        return 0.5 * (special.ndtr((lo - mn) / sn) + special.ndtr((mn - hi) / sn) + inside)


def general_gaussian_error_rows(rows):
    """Unequal variances, 10⁶ pairs: the compiled kernel, the numpy path, careful scipy."""
    import importlib
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "stats"))
    from test_gaussian_error import cases, reference

    implementation = importlib.import_module("inspect_validate.stats.gaussian_error")
    corpus = [c for c in cases() if reference(*c) >= 1e-300]
    refs = [float(reference(*c)) for c in corpus]
    # The variance ratio a careful scipy version survives (its roots lose all digits
    # beyond): the tests' corpus reaches σ ratios of 1e±8.
    moderate = [i for i, c in enumerate(corpus) if 1e-4 <= c[1] / c[3] <= 1e4]

    def worst(fn, which):
        return max(abs(float(fn(*map(np.float64, corpus[i]))) / refs[i] - 1) for i in which)

    rng = np.random.default_rng(0)
    n = 1_000_000
    m1 = rng.normal(0, 100, n)
    s1 = 10 ** rng.uniform(-1, 2, n)
    s2 = s1 * 10 ** rng.uniform(-1, 1, n)
    m2 = m1 + 10 ** rng.uniform(-1, 1.5, n) * np.maximum(s1, s2)
    v1, v2 = s1 * s1, s2 * s2
    t_ref = best_time(lambda: careful_scipy_error(m1, v1, m2, v2), 3)
    everything = range(len(corpus))
    e_ref = worst(careful_scipy_error, moderate)
    e_ref_all = worst(careful_scipy_error, everything)
    for name, threshold in (("compiled", 0), ("numpy", 2**62)):
        saved = implementation.COMPILED_MIN, implementation.LOAD_MIN
        implementation.COMPILED_MIN = implementation.LOAD_MIN = threshold
        try:
            t = best_time(lambda: implementation.gaussian_error_and_log(m1, v1, m2, v2), 3)
            e = worst(implementation.gaussian_error, moderate)
            e_all = worst(implementation.gaussian_error, everything)
        finally:
            implementation.COMPILED_MIN, implementation.LOAD_MIN = saved
        rows.append(
            (
                f"ε Gauss, 10⁶ unequal-σ pairs ({name})",
                "careful scipy",
                t,
                t_ref,
                e,
                e_ref,
                f"max rel vs mpmath, σ ratio ≤ 100 (any ratio to 1e8: {e_all:.1e} vs {e_ref_all:.1e})",
            )
        )


def kde_error_row(rows):
    """ε KDE against the tests' quadrature reference (tests/stats/test_kde_error.py)."""
    import sys
    from pathlib import Path

    from inspect_validate.stats import as_sample, kde_error

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "stats"))
    from test_kde_error import reference

    rng = np.random.default_rng(5)
    a = as_sample(np.rint(rng.normal(100, 6, 200_000)).astype(int))
    b = as_sample(np.rint(rng.normal(115, 9, 200_000)).astype(int))
    t_ours = best_time(lambda: kde_error(a, b), 3)
    r = kde_error(a, b)
    t0 = time.perf_counter()
    ref = reference(a, b, r.bandwidth1.h, r.bandwidth2.h, 20, 220)
    t_ref = time.perf_counter() - t0
    rows.append(
        (
            "ε KDE, 2×200k integer pixels",
            "adaptive quadrature",
            t_ours,
            t_ref,
            abs(r.error - ref) / ref,
            0.0,
            "rel ε",
        )
    )


def main():
    rows = []
    for step in (
        region_moments_row,
        lattice_bandwidth_row,
        statsmodels_row,
        binned_bandwidth_row,
        gaussian_error_row,
        general_gaussian_error_rows,
        kde_error_row,
    ):
        step(rows)
    header = f"{'task':42} {'reference':20} {'t ours':>9} {'t ref':>9} {'t ratio':>8} {'err ours':>10} {'err ref':>10}  unit"
    print(header)
    print("-" * len(header))
    for task, ref, t1, t2, e1, e2, unit in rows:
        ratio = t1 / t2 if np.isfinite(t1) and np.isfinite(t2) and t2 > 0 else float("nan")
        fmt_t = lambda t: "—" if not np.isfinite(t) else f"{t * 1e3:.1f} ms"  # noqa: E731
        fmt_e = lambda e: "—" if not np.isfinite(e) else f"{e:.2e}"  # noqa: E731
        print(
            f"{task:42} {ref:20} {fmt_t(t1):>9} {fmt_t(t2):>9} {ratio:>8.2f} {fmt_e(e1):>10} {fmt_e(e2):>10}  {unit}"
        )


if __name__ == "__main__":
    main()
