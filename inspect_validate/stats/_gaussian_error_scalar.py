"""ε_tot (37) of one pair of Gaussians, and the special functions it needs, on floats:
:mod:`~inspect_validate.stats.gaussian_error`'s algorithm element by element.

Plain Python on :mod:`math` and numpy's ufuncs, so it runs without numba (the
array code's erfcx interpolates :func:`erfcx` from here) and is compiled as it stands by
:mod:`~inspect_validate.stats._gaussian_error_kernel` for large arrays. The
double-double helpers and the crossings are the numpy implementation's too; the
rest mirrors it step by step (its masks are branches here), so the two agree to
rounding; the tests hold them to 2e-14 relative (their logs to 2e-15), and both to
mpmath at 1e-13.

Special functions: the tails need erfcx(x) and Φ for x ≥ 0 only. erfcx(x) is
exp(x²)·erfc(x) with x² carried as a double-double (erfc is the C library's,
≈3e-16 relative down to 1e-300), and beyond x = 12 its asymptotic series (12
terms: the first omitted, (25)!!/(2x²)¹³, is below 1e-19). Φ(x) for x ≥ 0 is
1 − ½·erfc(x/√2), without cancellation (the subtracted part is at most ½).

Uncompiled, a function here raises where numba's numpy error model returns inf or
NaN (``math.exp`` of a large argument, ``math.log(0)``); only :func:`erfcx`, which
cannot, is called uncompiled.
"""

import math

import numpy as np

_SPLITTER = 134217729.0  # 2**27 + 1, Dekker's split
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
_SQRT_2PI = math.sqrt(2.0 * math.pi)
_SQRT2 = math.sqrt(2.0)
_LAMBDA = math.sqrt(2.0 / math.pi)
_LOG2 = math.log(2.0)
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(20)
LINEAR_FLOOR = 1e-300
"""Below, ε's terms near the subnormal range lose digits: ε is taken from its log."""
_ASYMPTOTIC_FROM = 12.0
_ASYMPTOTIC_TERMS = 12


# From here to gaussian_crossings, arithmetic and numpy's ufuncs only: numba compiles them on
# floats, and the numpy implementation uses them as they stand on arrays.


def two_sum(a, b):
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _split(a):
    t = _SPLITTER * a
    hi = t - (t - a)
    return hi, a - hi


def two_prod(a, b):
    p = a * b
    ah, al = _split(a)
    bh, bl = _split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def two_square(a):
    p = a * a
    ah, al = _split(a)
    return p, ((ah * ah - p) + 2.0 * ah * al) + al * al


def dd_sqrt(v):
    hi = np.sqrt(v)
    p, e = two_square(hi)
    return hi, ((v - p) - e) / (2.0 * hi)


def dd_div(nh, nl, dh, dl):
    q = nh / dh
    p, e = two_prod(q, dh)
    return q, (((nh - p) - e) + nl - q * dl) / dh


def gaussian_crossings(d, vn, vw):
    """Where N(μ_n, σ_n²) and N(μ_w, σ_w²) cross, σ_n ≤ σ_w, along t = ±(x − μ_n)/σ_n
    pointing from μ_n to μ_w (μ_w at t = d ≥ 0): t_near towards μ_w, without
    cancellation, and t_far, −inf (or NaN) as the variances become equal (no
    division by σ_w² − σ_n² in t_near)."""
    r2 = vn / vw
    k = (vw - vn) / vw
    q = (vw - vn) / vn
    # ln(σ_w²/σ_n²): log1p keeps its digits as the variances near each other; a ratio
    # past 10³⁰⁰ (a subnormal σ_n²) would overflow it, and there the logs' difference
    # is exact enough. (Arithmetic, not np.where: numba compiles this on floats.)
    apart = q > 1e300
    big_l = np.log1p(np.minimum(q, 1e300)) * (1 - apart) + (np.log(vw) - np.log(vn)) * apart
    sqrt_disc = np.sqrt(r2 * d * d + k * big_l)
    t_near = (r2 * d * d + big_l) / (sqrt_disc + r2 * d)
    return t_near, -(r2 * d + sqrt_disc) / k


def _logaddexp(x, y):
    """numpy's logaddexp for scalars (−inf with −inf gives −inf)."""
    if x == y:
        return x + _LOG2
    d = x - y
    if d > 0:
        return x + math.log1p(math.exp(-d))
    if d <= 0:
        return y + math.log1p(math.exp(d))
    return d  # NaN


def _maximum(a, b):
    """numpy's maximum: NaN if either is NaN."""
    if a != a or b != b:
        return math.nan
    return a if a > b else b


def _minimum(a, b):
    """numpy's minimum: NaN if either is NaN."""
    if a != a or b != b:
        return math.nan
    return a if a < b else b


def erfcx(x):
    """exp(x²)·erfc(x) for x ≥ 0 (and +inf → 0)."""
    if x < _ASYMPTOTIC_FROM:
        p, e = two_square(x)
        return math.exp(p) * (1.0 + e) * math.erfc(x)
    return erfcx_asymptotic(x)


def erfcx_asymptotic(x):
    """erfcx(x) for x ≥ 12: 1/(x√π) · Σ (−1)ⁿ (2n−1)!! / (2x²)ⁿ, 12 terms. Arithmetic only,
    so it serves arrays as it stands; +inf gives 0 (2x² overflowing beyond 1e154 is
    harmless: the terms vanish), NaN gives NaN."""
    u = 1.0 / (2.0 * x * x)
    term = 1.0
    total = 1.0
    for n in range(1, _ASYMPTOTIC_TERMS + 1):
        term = term * (-(2.0 * n - 1.0) * u)
        total = total + term
    return total / (x * math.sqrt(math.pi))


def lower_tail(x):
    """Φ(x) and log Φ(x) for x ≥ 0 (or NaN): 1 − ½·erfc(x/√2), without cancellation."""
    tail = 0.5 * math.erfc(x / _SQRT2)
    return 1.0 - tail, math.log1p(-tail)


def upper_tail(z, lo, logs):
    """Q(z) = P(Z > z) and log Q(z) for z + lo (double-double); the log only where
    ``logs`` (else 0: ε's log is taken from ε itself unless ε underflows)."""
    if z > 0.0:
        p, e = two_square(z)
        if not math.isfinite(e):
            e = 0.0
        scaled = 0.5 * erfcx(z / _SQRT2)
        shift = 0.0 if lo == 0.0 else lo * 0.5 / (_SQRT_2PI * scaled)
        log_q = math.log(scaled) - 0.5 * p - 0.5 * e - shift if logs else 0.0
        q = scaled * math.exp(-0.5 * p) * (1.0 - 0.5 * e)
        return (q if shift == 0.0 else q * math.exp(-shift)), log_q
    # z ≤ 0 (or NaN): Q(z) = Φ(−z) ≥ ½.
    q, log_q = lower_tail(-z)
    shift = 0.0 if lo == 0.0 else math.exp(-0.5 * z * z - _LOG_SQRT_2PI - log_q) * lo
    return q * math.exp(-shift), log_q - shift


def _log_tail_ratio(ah, al, bh, bl):
    """log(Q(b)/Q(a)) for 0 ≤ a ≤ b."""
    ea_, eb_ = erfcx(ah / _SQRT2), erfcx(bh / _SQRT2)
    pa, ea = two_square(ah)
    pb, eb = two_square(bh)
    sq, se = two_sum(pb, -pa)
    diff_sq = sq + (se + (eb - ea))
    shift = (0.0 if bl == 0.0 else _LAMBDA / eb_ * bl) - (0.0 if al == 0.0 else _LAMBDA / ea_ * al)
    if not math.isfinite(bh):
        return -math.inf
    return math.log(eb_ / ea_) - 0.5 * diff_sq - shift


def error_interval(ah, al, bh, bl, nodes, weights, logs):
    """Φ(b) − Φ(a) and its log (where ``logs``, else 0) for a < b as double-doubles."""
    width = (bh - ah) + (bl - al)
    reach = _maximum(1.0, _maximum(abs(ah), abs(bh)))
    if math.isfinite(width) and width * reach < 1.0:
        # φ(a)·∫₀ʷ exp(−a s − s²/2) ds by Gauss–Legendre.
        j = 0.0
        for i in range(nodes.size):
            s = 0.5 * width * (1.0 + nodes[i])
            j += weights[i] * math.exp(-ah * s - 0.5 * s * s)
        j *= 0.5 * width
        p, e = two_square(ah)
        low = 0.5 * e + ah * al
        value = math.exp(-0.5 * p) * math.exp(-low) * j / _SQRT_2PI
        return value, -0.5 * p - low - _LOG_SQRT_2PI + math.log(j) if logs else 0.0
    if ah < 0.0 and bh > 0.0:
        middle = 1.0 - upper_tail(bh, bl, False)[0] - upper_tail(-ah, -al, False)[0]
        return middle, math.log(middle) if logs else 0.0
    if ah >= 0.0:
        near_h, near_l, far_h, far_l = ah, al, bh, bl
    else:
        near_h, near_l, far_h, far_l = -bh, -bl, -ah, -al
    q_near, log_q_near = upper_tail(near_h, near_l, logs)
    ratio = -math.expm1(_log_tail_ratio(near_h, near_l, far_h, far_l))
    return q_near * ratio, log_q_near + math.log(ratio) if logs else 0.0


def _wide(t, snh, snl, dh, dl, swh, swl):
    """Class w's argument (t·σ_n − Δ)/σ_w as a double-double."""
    ph, pl = two_prod(t, snh)
    sh, sl = two_sum(ph, -dh)
    uh, ul = dd_div(sh, sl + (pl + t * snl) - dl, swh, swl)
    if not math.isfinite(t):
        return t, 0.0
    return uh, ul if math.isfinite(ul) else 0.0


def _one(m1, v1, m2, v2, nodes, weights):
    """ε_tot and log ε_tot of one pair, as :func:`~inspect_validate.stats.gaussian_error_and_log`
    returns them: log ε from ε where ε ≥ 1e-300, ε from log ε below (where the parts
    are summed as logs, a second pass)."""
    if v1 > v2:
        mn, vn, mw, vw = m2, v2, m1, v1
    else:
        mn, vn, mw, vw = m1, v1, m2, v2
    identical = mn == mw and vn == vw
    if vn == 0.0 or identical:
        fixed = 0.5 if identical else 0.0
        return fixed, math.log(fixed) if fixed > 0 else -math.inf
    dh, dl = two_sum(mw, -mn)
    if dh < 0.0:
        dh, dl = -dh, -dl
    snh, snl = dd_sqrt(vn)
    swh, swl = dd_sqrt(vw)
    t_near, t_far = gaussian_crossings(dh / snh, vn, vw)
    if not math.isfinite(t_far):
        t_far = -math.inf
    fh, fl = _wide(t_far, snh, snl, dh, dl, swh, swl)
    nh, nl = _wide(t_near, snh, snl, dh, dl, swh, swl)
    eps, _ = _parts(t_near, t_far, fh, fl, nh, nl, nodes, weights, False)
    if eps >= LINEAR_FLOOR:
        return eps, math.log(eps)
    _, log_eps = _parts(t_near, t_far, fh, fl, nh, nl, nodes, weights, True)
    return math.exp(log_eps), log_eps


def _parts(t_near, t_far, fh, fl, nh, nl, nodes, weights, logs):
    """ε from its three parts (class n beyond each crossing, class w between them), and
    where ``logs`` its log from theirs."""
    above, log_above = upper_tail(t_near, 0.0, logs)
    below, log_below = upper_tail(-t_far, 0.0, logs)
    inside, log_inside = error_interval(fh, fl, nh, nl, nodes, weights, logs)
    # The three parts' rounding may pass ½ by an ulp where the classes all but coincide.
    eps = _minimum(0.5 * (below + above + inside), 0.5)
    if not logs:
        return eps, 0.0
    return eps, _minimum(_logaddexp(_logaddexp(log_below, log_above), log_inside) - _LOG2, -_LOG2)


prange = range
"""numba's ``prange`` where :mod:`~inspect_validate.stats._gaussian_error_kernel` compiles
:func:`error_and_log`."""


def error_and_log(m1, v1, m2, v2, eps, log_eps):
    """ε_tot and log ε_tot of every pair (1-d float64 arrays, finite, variances ≥ 0), as
    :func:`~inspect_validate.stats.gaussian_error_and_log` returns them.

    Here, not in the kernel's module, so that numba's cache of the compiled loop is
    keyed on this file: an edit of any function it calls recompiles it (a loop cached
    beside the kernel's module kept calling the functions as they were when cached).

    A pair it cannot take is left NaN (for the numpy implementation, which checks and
    rescales): not finite, a negative variance, or variances outside 1e±150 (where its
    products overflow or lose digits to subnormals), or means apart by more than 10¹⁴⁰ σ.
    """
    for i in prange(m1.size):
        if _usual(m1[i], v1[i], m2[i], v2[i]):
            eps[i], log_eps[i] = _one(m1[i], v1[i], m2[i], v2[i], _GL_NODES, _GL_WEIGHTS)
        else:
            eps[i], log_eps[i] = math.nan, math.nan


def _usual(m1, v1, m2, v2):
    """Whether :func:`_one` takes the pair as it stands (NaN and inf are not usual)."""
    ranged = (v1 == 0.0 or 1e-150 <= v1 <= 1e150) and (v2 == 0.0 or 1e-150 <= v2 <= 1e150)
    return ranged and abs(m1 - m2) <= 1e140 * math.sqrt(_maximum(v1, v2))
