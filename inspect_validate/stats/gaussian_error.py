"""Exact classification error (37) of two Gaussian classes with equal priors.

With densities N(μ1, σ1²) and N(μ2, σ2²) (40), the Bayes error

    ε_tot = ½ ∫ min(p1, p2) dx

splits at the (up to two) points where the densities cross. Let class *n* be the
narrower one: it wins between the crossings x_lo < x_hi, class *w* outside, so

    ε_tot = ½ [P_n(X < x_lo) + P_n(X > x_hi) + P_w(x_lo < X < x_hi)].

Accuracy (≤ 1e-13 relative for every ε ≥ 1e-300, checked against mpmath in the
tests), obtained by:

* crossings from a cancellation-free form of the quadratic (no division by
  σ_w² − σ_n², so equal and nearly equal variances are stable). ε is stationary
  in the decision boundary (dε/dx = ½(p_w − p_n) = 0 at a crossing), so ordinary
  double precision suffices for the crossing points themselves;
* the standardised arguments z = (x − μ)/σ carried in double-double and the
  remaining low part applied as a first-order correction through the hazard
  function — at ε ≈ 1e-300 (z ≈ 37) one rounding in z alone would cost 1.5e-13;
* tails from erfcx and Φ of the far side (no 1 − Φ), differences of tails
  through ``expm1`` of log-tails, and narrow intervals (extreme variance ratios)
  by Gauss–Legendre quadrature of φ(a)·∫₀ʷ exp(−a·s − s²/2) ds.

Below ε ≈ 1e-300 use :func:`log_gaussian_error`, which stays finite far beyond
(log ε ≈ −1e300 is fine).

For large arrays (see :data:`COMPILED_MIN`, :data:`LOAD_MIN`) the same steps run
element by element in a compiled kernel
(:mod:`inspect_validate.stats._gaussian_error_kernel`).

The one special function, erfcx(x) = exp(x²)·erfc(x) for x ≥ 0, is evaluated on
arrays without :mod:`scipy.special`, whose import (0.2 s, most of it numpy.f2py
pulled in by its array-API layer) would be most of a ``measure`` command's run
time: piecewise polynomials on [0, 12), interpolating the C library's erfc at
Chebyshev nodes (:func:`_erfcx_table`), and the asymptotic series beyond. Against
mpmath it is within 7.8e-16 relative (scipy's erfcx: 8.9e-16), at 1.3× scipy's time.
"""

from __future__ import annotations

import functools
import importlib
import sys
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.stats import _gaussian_error_scalar as _scalar

# The double-double helpers and the crossings are the scalar code's: arithmetic and
# ufuncs only, they work on arrays as they stand.
from inspect_validate.stats._gaussian_error_scalar import (
    dd_div,
    dd_sqrt,
    gaussian_crossings,
    two_prod,
    two_square,
    two_sum,
)

__all__ = [
    "gaussian_error",
    "gaussian_error_and_log",
    "gaussian_error_gradient",
    "log_gaussian_error",
]

_LOG_SQRT_2PI = _scalar._LOG_SQRT_2PI
_GL_NODES, _GL_WEIGHTS = _scalar._GL_NODES, _scalar._GL_WEIGHTS
_KERNEL = "inspect_validate.stats._gaussian_error_kernel"
_LINEAR_FLOOR = _scalar.LINEAR_FLOOR
COMPILED_MIN = 2**14
"""Pairs from which the compiled kernel (the same algorithm in one pass, 4× faster
on 2 cores) evaluates ε once it is loaded."""
LOAD_MIN = 2**19
"""Pairs in one call that pay for loading the kernel (numba's import and cache load,
≈0.3 s, 0.5 s from a cold disk; numpy takes 0.68 µs a pair, the kernel 0.16 µs). A
caller with more work ahead in smaller calls (a sweep's blocks) loads it itself:
:func:`load_kernel`."""


def gaussian_error(
    mean1: ArrayLike, var1: ArrayLike, mean2: ArrayLike, var2: ArrayLike
) -> np.ndarray:
    """Bayes classification error ε_tot (37) of two Gaussian classes, equal priors.

    Parameters
    ----------
    mean1, mean2 : array_like
        Class means μ (38), DN.
    var1, var2 : array_like
        Class variances σ² (39), DN². Broadcast together with the means.

    Returns
    -------
    ndarray
        ε_tot in [0, ½]. ½ for identical classes; 0 when one class has zero
        variance and the other does not, or both are constant and differ.
        Underflows below ≈1e-308: use :func:`~inspect_validate.stats.log_gaussian_error` there.
    """
    return gaussian_error_and_log(mean1, var1, mean2, var2)[0]


def gaussian_error_and_log(
    mean1: ArrayLike, var1: ArrayLike, mean2: ArrayLike, var2: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`gaussian_error` and :func:`log_gaussian_error` from one evaluation."""
    eps, log_eps = _error(mean1, var1, mean2, var2)
    return eps[()], log_eps[()]


def log_gaussian_error(
    mean1: ArrayLike, var1: ArrayLike, mean2: ArrayLike, var2: ArrayLike
) -> np.ndarray:
    """Natural logarithm of :func:`~inspect_validate.stats.gaussian_error`, accurate where ε underflows."""
    return gaussian_error_and_log(mean1, var1, mean2, var2)[1]


def gaussian_error_gradient(
    mean1: ArrayLike, sd1: ArrayLike, mean2: ArrayLike, sd2: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """ε_tot (37) of two Gaussian classes, its log, and its gradient, element-wise.

    ε = ½ [P_n(outside (x_lo, x_hi)) + P_w(inside)], n the narrower class, the
    limits its crossings with the wider w. A crossing moves mass between two
    densities that are equal there, so only the integrands move:

        ∂ε/∂μ_n = ½ (φ(z_hi) − φ(z_lo)) / σ_n,   ∂ε/∂σ_n = ½ (z φ(z)|_hi − z φ(z)|_lo) / σ_n,

    and the same with the opposite sign for w (z = (x − μ)/σ of that class, φ the
    standard normal density, 0 at an infinite limit). The gradient is in plain
    double precision (its use is a direction, not a digit); ε and log ε are
    :func:`gaussian_error_and_log`'s.

    Parameters
    ----------
    mean1, mean2 : array_like
        Class means, DN.
    sd1, sd2 : array_like
        Class standard deviations σ, DN (> 0 for a gradient; 0 gives zeros).

    Returns
    -------
    error, log_error, d_mean1, d_sd1, d_mean2, d_sd2 : ndarray
        Broadcast shape of the inputs.
    """
    m1, s1, m2, s2 = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (mean1, sd1, mean2, sd2))
    )
    eps, log_eps = gaussian_error_and_log(m1, s1 * s1, m2, s2 * s2)
    swap = s1 > s2
    mn, sn = np.where(swap, m2, m1), np.where(swap, s2, s1)
    mw, sw = np.where(swap, m1, m2), np.where(swap, s1, s2)
    flat = (sn == 0.0) | ((mn == mw) & (sn == sw))
    sn, sw = np.where(flat, 1.0, sn), np.where(flat, 2.0, sw)
    with np.errstate(all="ignore"):
        sign = np.where(mw < mn, -1.0, 1.0)
        t_near, t_far = gaussian_crossings(np.abs(mw - mn) / sn, sn * sn, sw * sw)
        x_near, x_far = mn + sign * t_near * sn, mn + sign * t_far * sn
        x_far = np.where(np.isfinite(t_far), x_far, -sign * np.inf)
        lo, hi = np.minimum(x_near, x_far), np.maximum(x_near, x_far)

        def ends(mean, sd):
            out = []
            for x in (lo, hi):
                z = (x - mean) / sd
                finite = np.isfinite(z)
                pdf = np.where(finite, np.exp(-0.5 * z * z) / np.sqrt(2.0 * np.pi), 0.0)
                out += [pdf, np.where(finite, z, 0.0) * pdf]
            return out

        n_lo, nz_lo, n_hi, nz_hi = ends(mn, sn)
        w_lo, wz_lo, w_hi, wz_hi = ends(mw, sw)
        dmn, dsn = 0.5 * (n_hi - n_lo) / sn, 0.5 * (nz_hi - nz_lo) / sn
        dmw, dsw = 0.5 * (w_lo - w_hi) / sw, 0.5 * (wz_lo - wz_hi) / sw
    dmn, dsn, dmw, dsw = (np.where(flat, 0.0, g) for g in (dmn, dsn, dmw, dsw))
    return (
        eps,
        log_eps,
        np.where(swap, dmw, dmn),
        np.where(swap, dsw, dsn),
        np.where(swap, dmn, dmw),
        np.where(swap, dsn, dsw),
    )


_ERFCX_WIDTH = 1.0 / 16.0  # a power of two: interval index and local variable exact
_ERFCX_DEGREE = 8


@functools.cache
def _erfcx_table() -> tuple[np.ndarray, np.ndarray]:
    """Midpoints and monomial coefficients (by power, then interval) of erfcx on [0, 12).

    192 intervals of width 1/16, each a degree-8 polynomial in u = (x − mid)·32 ∈
    [−1, 1] through the scalar erfcx at 9 Chebyshev nodes; what is left of the
    interpolation error is below the node values' and Horner's rounding (erfcx's
    derivatives grow like those of exp(x²): width 1/4 at degree 7 leaves 1e-11).
    Built on first use (0.9 ms).
    """
    k = np.arange(_ERFCX_DEGREE + 1)
    nodes = np.cos(np.pi * (k + 0.5) / (_ERFCX_DEGREE + 1))
    mid = (np.arange(round(_scalar._ASYMPTOTIC_FROM / _ERFCX_WIDTH)) + 0.5) * _ERFCX_WIDTH
    values = _ERFCX(mid[:, np.newaxis] + 0.5 * _ERFCX_WIDTH * nodes).astype(float)
    coefficients = np.linalg.solve(np.vander(nodes, increasing=True), values.T)
    return mid, np.ascontiguousarray(coefficients)


def _erfcx(x):
    """erfcx(x) = exp(x²)·erfc(x) of an array of x ≥ 0 (+inf gives 0, NaN gives NaN)."""
    x = np.asarray(x, dtype=float)
    out = np.empty(x.shape)
    near = x < _scalar._ASYMPTOTIC_FROM
    if near.any():
        xn = x[near]
        mid, coefficients = _erfcx_table()
        i = (xn * (1.0 / _ERFCX_WIDTH)).astype(np.intp)
        u = (xn - mid.take(i)) * (2.0 / _ERFCX_WIDTH)
        r = coefficients[-1].take(i)
        for c in coefficients[-2::-1]:
            r *= u
            r += c.take(i)
        out[near] = r
    far = ~near
    if far.any():
        with np.errstate(over="ignore", invalid="ignore"):
            out[far] = _scalar.erfcx_asymptotic(x[far])
    return out


def _lower_tail(x):
    """Φ(x) and log Φ(x) of an array of x ≥ 0: 1 − ½·erfc(x/√2), the subtracted tail
    at most ½ (no cancellation), erfc(x/√2) = erfcx(x/√2)·exp(−x²/2) with x² exact."""
    with np.errstate(all="ignore"):
        p, e = two_square(x)
        e = np.where(np.isfinite(e), e, 0.0)
        tail = 0.5 * _erfcx(x / np.sqrt(2.0)) * np.exp(-0.5 * p) * (1.0 - 0.5 * e)
    return 1.0 - tail, np.log1p(-tail)


def normal_cdf_pair(z: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Φ(z) and Φ(−z) of a 1-d array, each to full relative precision, without
    scipy.special: Q(−z) and Q(z) by :func:`upper_tail`."""
    z = np.asarray(z, dtype=float)
    zero = np.zeros_like(z)
    return upper_tail(-z, zero)[0], upper_tail(z, zero)[0]


_ERFCX = np.frompyfunc(_scalar.erfcx, 1, 1)


def _branches(cases, *args):
    """Evaluate ``fn(*args[mask])`` only where each mask holds; assemble (value, log).

    ``cases`` is a sequence of (mask, fn) with disjoint masks covering every
    element; each branch's cost is paid only by its own elements.
    """
    value = np.empty(args[0].shape)
    log_value = np.empty(args[0].shape)
    for mask, fn in cases:
        if mask.any():
            value[mask], log_value[mask] = fn(*(a[mask] for a in args))
    return value, log_value


def upper_tail(zh: np.ndarray, zl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Q(z) = P(Z > z) and log Q(z) for z = zh + zl (1-d arrays).

    For z > 0, Q = ½·erfcx(z/√2)·exp(−z²/2) with z² formed exactly: scipy's
    ``ndtr`` is only good to ≈2e-13 relative near its underflow, erfcx to 5e-16.
    For z ≤ 0, Q(z) = Φ(−z) ≥ ½.
    The low part zl enters to first order through the hazard φ/Q.
    """

    def positive(z, lo):
        p, e = two_square(z)
        e = np.where(np.isfinite(e), e, 0.0)
        scaled = 0.5 * _erfcx(z / np.sqrt(2.0))
        shift = np.where(lo == 0.0, 0.0, lo * 0.5 / (np.sqrt(2.0 * np.pi) * scaled))
        log_q = np.log(scaled) - 0.5 * p - 0.5 * e - shift
        return scaled * np.exp(-0.5 * p) * (1.0 - 0.5 * e) * np.exp(-shift), log_q

    def negative(z, lo):
        q, log_q = _lower_tail(-z)
        hazard = np.exp(-0.5 * z * z - _LOG_SQRT_2PI - log_q)
        shift = np.where(lo == 0.0, 0.0, hazard * lo)
        return q * np.exp(-shift), log_q - shift

    with np.errstate(all="ignore"):
        pos = zh > 0.0
        return _branches(((pos, positive), (~pos, negative)), zh, zl)


def _log_tail_ratio(ah, al, bh, bl):
    """log(Q(b)/Q(a)) for 0 ≤ a ≤ b, without forming the two large log-tails.

    log Q(z) = log(½·erfcx(z/√2)) − z²/2, so the ratio needs only the erfcx
    ratio and b² − a², which is formed from exact squares.
    """
    with np.errstate(all="ignore"):
        ea_, eb_ = _erfcx(ah / np.sqrt(2.0)), _erfcx(bh / np.sqrt(2.0))
        pa, ea = two_square(ah)
        pb, eb = two_square(bh)
        sq, se = two_sum(pb, -pa)
        diff_sq = sq + (se + (eb - ea))
        lam = np.sqrt(2.0 / np.pi)
        shift = np.where(bl == 0.0, 0.0, lam / eb_ * bl) - np.where(al == 0.0, 0.0, lam / ea_ * al)
        ratio = np.log(eb_ / ea_) - 0.5 * diff_sq - shift
        return np.where(np.isfinite(bh), ratio, -np.inf)


def error_interval(
    ah: np.ndarray, al: np.ndarray, bh: np.ndarray, bl: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Φ(b) − Φ(a) and its log for a < b given as double-doubles (a may be −inf, b +inf)."""

    def narrow(ah, al, bh, bl):
        # φ(a)·∫₀ʷ exp(−a s − s²/2) ds; the integrand varies by less than e^1.5.
        w = ((bh - ah) + (bl - al))[:, np.newaxis]
        s = 0.5 * w * (1.0 + _GL_NODES)
        j = 0.5 * w[:, 0] * np.sum(_GL_WEIGHTS * np.exp(-ah[:, None] * s - 0.5 * s * s), axis=1)
        p, e = two_square(ah)
        low = 0.5 * e + ah * al
        value = np.exp(-0.5 * p) * np.exp(-low) * j / np.sqrt(2.0 * np.pi)
        return value, -0.5 * p - low - _LOG_SQRT_2PI + np.log(j)

    def tails(ah, al, bh, bl):
        # Both in the upper tail: Q(a) − Q(b); both in the lower: Q(−b) − Q(−a).
        upper = ah >= 0.0
        near_h, near_l = np.where(upper, ah, -bh), np.where(upper, al, -bl)
        far_h, far_l = np.where(upper, bh, -ah), np.where(upper, bl, -al)
        q_near, log_q_near = upper_tail(near_h, near_l)
        ratio = -np.expm1(_log_tail_ratio(near_h, near_l, far_h, far_l))
        return q_near * ratio, log_q_near + np.log(ratio)

    def straddle(ah, al, bh, bl):
        # Across zero and not narrow: the mass is ≥ 0.19, no cancellation.
        middle = 1.0 - upper_tail(bh, bl)[0] - upper_tail(-ah, -al)[0]
        return middle, np.log(middle)

    with np.errstate(all="ignore"):
        width = (bh - ah) + (bl - al)
        reach = np.maximum(1.0, np.maximum(np.abs(ah), np.abs(bh)))
        is_narrow = np.isfinite(width) & (width * reach < 1.0)
        is_straddle = ~is_narrow & (ah < 0.0) & (bh > 0.0)
        is_tails = ~is_narrow & ~is_straddle
        cases = ((is_narrow, narrow), (is_straddle, straddle), (is_tails, tails))
        return _branches(cases, ah, al, bh, bl)


def load_kernel() -> Callable[..., None]:
    """Load the compiled kernel (ε of pairs from :data:`COMPILED_MIN` on) and return it."""
    return importlib.import_module(_KERNEL).error_and_log


def _error(mean1, var1, mean2, var2):
    arrays = (np.asarray(a, dtype=float) for a in (mean1, var1, mean2, var2))
    m1, v1, m2, v2 = np.broadcast_arrays(*arrays)
    shape = m1.shape
    m1, v1, m2, v2 = (np.ascontiguousarray(a).ravel() for a in (m1, v1, m2, v2))
    if m1.size >= LOAD_MIN or (m1.size >= COMPILED_MIN and _KERNEL in sys.modules):
        eps, log_eps = np.empty(m1.size), np.empty(m1.size)
        load_kernel()(m1, v1, m2, v2, eps, log_eps)
        # NaN where the kernel left a pair to numpy: not finite, a negative variance, or
        # outside the range where its products neither overflow nor lose digits to
        # subnormals (variances of 1e-315 or 1e300), which numpy takes rescaled.
        left = np.flatnonzero(np.isnan(eps))
        if left.size:
            eps[left], log_eps[left] = _numpy_error(m1[left], v1[left], m2[left], v2[left])
        return eps.reshape(shape), log_eps.reshape(shape)
    eps, log_eps = _numpy_error(m1, v1, m2, v2)
    return eps.reshape(shape), log_eps.reshape(shape)


def _numpy_error(m1, v1, m2, v2):
    """ε and log ε of pairs of 1-d arrays, the algorithm in numpy's array passes."""
    if not all(np.all(np.isfinite(a)) for a in (m1, v1, m2, v2)):
        raise ValueError("means and variances must be finite")
    if np.any(v1 < 0) or np.any(v2 < 0):
        raise ValueError("variances must be non-negative")
    swap = v1 > v2
    mn, vn = np.where(swap, m2, m1), np.where(swap, v2, v1)
    mw, vw = np.where(swap, m1, m2), np.where(swap, v1, v2)
    identical = (mn == mw) & (vn == vw)
    with np.errstate(all="ignore"):
        # Work along the axis t = ±(x − μ_n)/σ_n that points from μ_n to μ_w;
        # μ_w sits at t = d ≥ 0, Δ = |μ_w − μ_n| as a double-double.
        dh, dl = two_sum(mw, -mn)
        sign = np.where(dh < 0.0, -1.0, 1.0)
        dh, dl = sign * dh, sign * dl
        # ε depends on lengths in units of σ only: scaled by a power of two that brings
        # σ_w near 1 (exact, so usual inputs give the same bits), subnormal variances
        # (1e-315) and huge ones keep their digits. Δ may overflow to inf: apart by more
        # than any double, which the tails below take as ε = 0.
        k = np.frexp(vw)[1] // 2
        vn, vw = np.ldexp(vn, -2 * k), np.ldexp(vw, -2 * k)
        dh, dl = np.ldexp(dh, -k), np.ldexp(dl, -k)
        dl = np.where(np.isfinite(dh), dl, 0.0)
    degenerate = (vn == 0.0) | identical  # σ_n below σ_w by 2⁻¹⁰⁷⁴: a point mass
    # Placeholders keep the arithmetic finite where the answer is set directly.
    vn = np.where(degenerate, 1.0, vn)
    vw = np.where(degenerate, 2.0, vw)
    with np.errstate(all="ignore"):
        snh, snl = dd_sqrt(vn)
        swh, swl = dd_sqrt(vw)
        t_near, t_far = gaussian_crossings(dh / snh, vn, vw)
        t_far = np.where(np.isfinite(t_far), t_far, -np.inf)

        # The crossings are *defined* as the exact points t·σ_n, so class n's
        # arguments are exact; class w's u = (t·σ_n − Δ)/σ_w in double-double.
        def wide(t):
            ph, pl = two_prod(t, snh)
            sh, sl = two_sum(ph, -dh)
            uh, ul = dd_div(sh, sl + (pl + t * snl) - dl, swh, swl)
            finite = np.isfinite(t)
            return np.where(finite, uh, t), np.where(finite & np.isfinite(ul), ul, 0.0)

        zero = np.zeros_like(t_near)
        above, log_above = upper_tail(t_near, zero)
        below, log_below = upper_tail(-t_far, zero)
        inside, log_inside = error_interval(*wide(t_far), *wide(t_near))

        # The three parts' rounding may pass ½ by an ulp where the classes all but coincide.
        eps = np.minimum(0.5 * (below + above + inside), 0.5)
        log_eps = np.minimum(
            np.logaddexp(np.logaddexp(log_below, log_above), log_inside) - np.log(2.0),
            -_scalar._LOG2,
        )
        # Apart by more than 10¹⁵⁰ σ_w: d² overflows in the crossings. ε underflows long
        # before; its log is the exponent at the crossing, −½(Δ/(σ_n + σ_w))².
        far = ~(dh / swh <= 1e150)
        eps = np.where(far, 0.0, eps)
        log_eps = np.where(far, -0.5 * np.square(dh / (snh + swh)), log_eps)
        fixed = np.where(identical, 0.5, 0.0)
        eps = np.where(degenerate, fixed, eps)
        log_eps = np.where(degenerate, np.log(fixed), log_eps)
        # Each from the other where it is the accurate one (as the compiled kernel does).
        linear = eps >= _LINEAR_FLOOR
        return np.where(linear, eps, np.exp(log_eps)), np.where(linear, np.log(eps), log_eps)
