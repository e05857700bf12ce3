"""Nonparametric classification error: ε_tot (37) of two Gaussian kernel densities (41).

Each class density is a Gaussian mixture: one kernel of bandwidth h (LSCV,
:mod:`inspect_validate.stats.bandwidth`) per lattice point, weighted by its
count (integer data), or per value (continuous data; linearly binned at h/2000
above 2¹⁴ values). With equal priors

    ε_tot = ½ ∫ min(p̂1, p̂2) dx,

computed without quadrature error: the crossings of p̂1 and p̂2 are located on a
grid of log-densities (binned by FFT where that is certain of the sign, exact near
the crossings; a pair of crossings inside one cell where the difference dips toward
0) and refined by root finding inside the bracketing cells, and between crossings
the mass of the lower density is summed in closed form from the kernels' normal
CDFs (stable interval probabilities, so tiny errors keep their relative accuracy).
Several comparisons among the same classes (:func:`mixture_errors`) share one grid
and each class's binned density.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.stats.bandwidth import MAX_BINS, Bandwidth, lscv_bandwidth
from inspect_validate.stats.gaussian_error import _interval
from inspect_validate.stats.sample import LatticeSample, Sample, as_sample

__all__ = [
    "KdeError",
    "Mixture",
    "kde_error",
    "kernel_density",
    "kernel_mixture",
    "misclassified_regions",
    "mixture_error",
    "mixture_error_gradient",
    "mixture_errors",
]

_EXACT_POINTS_MAX = 2**14
_BIN_FRACTION = 2000
_GRID_STEP = 0.25  # grid spacing for finding crossings, in units of the smaller h
_TAIL_REACH = 40.0  # kernels are negligible beyond 40 h
_WINDOW_MIN = 256  # components above which a kernel density is summed in windows
_WINDOW_REACH = 20.0  # in h, beyond the nearest component
_WINDOW_WIDTHS_MAX = 16  # distinct kernel widths (classes in a group) summed part by part
_WINDOW_CHUNK = 64  # grid points per window (16 h at the crossing grid's step)
_LOG_SQRT_2PI = 0.5 * np.log(2.0 * np.pi)
_BINNED_FLOOR = 1e-10  # a tilt's FFT is used above this fraction of its maximum
_BINNED_MARGIN = 0.5  # nats: a binned log-density difference trusted for its sign
_TILT_STEP = 6.0  # kernel widths between the peaks of successive tilts
_BINNED_ELEMENTS_MAX = 2**22  # tilts × FFT size (32 MB an array), else the exact grid
_DIP_HALVINGS = 30  # a dip's extremum to 2⁻³⁰ of two grid cells (crossings are polished after)


@dataclass(frozen=True)
class Mixture:
    """A Gaussian mixture: component means μ (DN), weights (summing to 1 within the
    mixture) and standard deviations σ (DN, one for all or one per component; 0: a
    point mass)."""

    centres: np.ndarray
    weights: np.ndarray
    sigmas: np.ndarray

    def __init__(self, centres: ArrayLike, weights: ArrayLike, sigmas: ArrayLike) -> None:
        c = np.asarray(centres, float)
        object.__setattr__(self, "centres", c)
        object.__setattr__(self, "weights", np.asarray(weights, float))
        object.__setattr__(self, "sigmas", np.broadcast_to(np.asarray(sigmas, float), c.shape))


@dataclass(frozen=True)
class KdeError:
    """ε_tot of two kernel density estimates, with the bandwidths used."""

    error: float
    bandwidth1: Bandwidth
    bandwidth2: Bandwidth


def kernel_mixture(sample: Sample, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Kernel centres (DN) and weights (summing to 1) of the density estimate (41)."""
    if not isinstance(sample, LatticeSample):
        sample = as_sample(sample)
    if isinstance(sample, LatticeSample):
        keep = sample.counts > 0
        return sample.points[keep], sample.counts[keep] / sample.n
    x = np.asarray(sample, dtype=np.float64)
    if h > 0.0 and x.size <= _EXACT_POINTS_MAX:
        return x, np.full(x.size, 1.0 / x.size)
    lo, hi = x.min(), x.max()
    step = h / _BIN_FRACTION
    if h == 0.0 or (hi - lo) / step > MAX_BINS:
        # A point mass per distinct value (h = 0: a constant float class), or, where
        # bins by span would not fit, one kernel per distinct value (sorting).
        values, counts = np.unique(x, return_counts=True)
        return values, counts / x.size
    from inspect_validate.stats._binning_kernels import linear_bin

    w, _, _ = linear_bin(x, lo, step, int(np.ceil((hi - lo) / step)) + 2)
    keep = w > 0
    return lo + np.flatnonzero(keep) * step, w[keep] / x.size


def kernel_density(sample: Sample, h: float, x: ArrayLike) -> np.ndarray:
    """The kernel density estimate (41) of ``sample`` with bandwidth ``h`` > 0 at grey values
    ``x``, 1/DN (what ε KDE integrates; for plots against a histogram)."""
    if not h > 0.0:
        raise ValueError(f"the bandwidth must be positive, not {h}")
    centres, weights = kernel_mixture(sample, h)
    parts = _density_parts(centres, weights, np.full(centres.size, float(h)))
    return np.exp(_log_density(x, parts))


def _density_parts(centres, weights, sigma) -> list:
    """A mixture as parts summed separately by :func:`_log_density`.

    Many components of one width (a kernel density, or each class of a group's
    mixture of kernel densities) form a part evaluated in windows: each chunk
    of x sums only the components within ``d0 + 20 h`` of it, d0 the distance
    to the nearest component. The rest weigh less than e^{-200} relative to
    that nearest one (for weights ≥ 1e-70), so the sum is exact in float64 and
    its cost no longer grows as components × grid points. Anything else (a few
    Gaussians of their own widths) is one part summed in full.
    """
    # With return_counts np.unique does not import numpy.ma to look for a mask (7 ms).
    widths = np.unique(sigma, return_counts=True)[0]
    if centres.size <= _WINDOW_MIN or widths.size > _WINDOW_WIDTHS_MAX:
        return [(centres, np.log(weights) - np.log(sigma), sigma)]
    parts = []
    for h in widths:
        sel = sigma == h
        parts.append((centres[sel], np.log(weights[sel]) - np.log(h), float(h)))
    return parts


def _log_density(x, parts):
    """log p(x) of a mixture given by :func:`_density_parts`, for an array of x."""
    flat = np.ravel(np.asarray(x, dtype=np.float64))
    logs = []
    for centres, log_w, sigma in parts:
        out = np.empty(flat.shape)
        _summed(_log_density_all, flat, [out], centres, log_w, sigma)
        logs.append(out)
    total = logs[0] if len(logs) == 1 else np.logaddexp.reduce(np.stack(logs), axis=0)
    return total.reshape(np.shape(x)) - _LOG_SQRT_2PI


def _summed(kernel, x, outs, centres, log_w, sigma) -> None:
    """``kernel(x, *outs, centres, log_w, sigma)`` over a part's components: in full for a
    few components or one width each, else over the components near each chunk of x
    (sorted centres; the rest weigh nothing a double keeps, :func:`_density_parts`)."""
    if np.ndim(sigma) or centres.size <= _WINDOW_MIN:
        kernel(x, *outs, centres, log_w, sigma)
        return
    order = np.argsort(x, kind="stable")
    xs = x[order]
    j = np.clip(np.searchsorted(centres, xs), 1, centres.size - 1)
    d0 = np.minimum(np.abs(xs - centres[j - 1]), np.abs(xs - centres[j]))
    values = [np.empty(xs.shape) for _ in outs]
    for part in _chunks(xs, sigma):
        reach = d0[part].max() + _WINDOW_REACH * sigma
        lo = np.searchsorted(centres, xs[part][0] - reach, side="left")
        hi = np.searchsorted(centres, xs[part][-1] + reach, side="right")
        kernel(xs[part], *(v[part] for v in values), centres[lo:hi], log_w[lo:hi], sigma)
    for out, v in zip(outs, values, strict=True):
        out[order] = v


def _chunks(xs, h):
    """Slices of sorted ``xs`` of at most :data:`_WINDOW_CHUNK` points spanning at most
    16 h each: a chunk's window is its span plus the reach, so scattered points (the
    crossings of two ragged densities, hundreds of h apart) are not summed over the
    components between them."""
    if not xs.size:
        return
    span = _WINDOW_CHUNK * 0.25 * h  # 64 points of the crossing grid's step
    cell = np.floor((xs - xs[0]) / span)
    starts = np.flatnonzero(np.diff(cell, prepend=-1.0))
    ends = np.append(starts[1:], xs.size)
    for start, end in zip(starts.tolist(), ends.tolist(), strict=True):
        for i in range(start, end, _WINDOW_CHUNK):
            yield slice(i, min(i + _WINDOW_CHUNK, end))


def _log_density_all(flat, out, centres, log_w, sigma) -> None:
    """Unnormalised log-density of every component at every point, in memory-bounded chunks."""
    if centres.size == 0:  # a window with no component in reach: a density of 0
        out[: flat.size] = -np.inf
        return
    chunk = max(1, 2**22 // max(1, centres.size))
    for i in range(0, flat.size, chunk):
        z = (flat[i : i + chunk, None] - centres[None, :]) / sigma
        v = log_w - 0.5 * z * z
        # logsumexp by hand: scipy's costs ~0.1 ms a call in the root searches' scalar calls.
        top = v.max(axis=1)
        safe = np.where(np.isfinite(top), top, 0.0)
        out[i : i + chunk] = safe + np.log(np.exp(v - safe[:, None]).sum(axis=1))


def kde_error(sample1: Sample, sample2: Sample, *, quantum: float | None = None) -> KdeError:
    """ε_tot (37) between the LSCV kernel density estimates of two samples.

    Parameters
    ----------
    sample1, sample2 : LatticeSample or array_like
        Grey values of the two classes, DN.
    quantum : float, keyword-only, optional
        Quantisation step, the bandwidth floor (see
        :func:`~inspect_validate.stats.bandwidth.lscv_bandwidth`).

    Returns
    -------
    KdeError
    """
    bw1 = lscv_bandwidth(sample1, quantum=quantum)
    bw2 = lscv_bandwidth(sample2, quantum=quantum)
    c1, w1 = kernel_mixture(sample1, bw1.h)
    c2, w2 = kernel_mixture(sample2, bw2.h)
    return KdeError(mixture_error(Mixture(c1, w1, bw1.h), Mixture(c2, w2, bw2.h)), bw1, bw2)


def mixture_error(first: Mixture, second: Mixture) -> float:
    """ε_tot (37) = ½∫min(p1, p2) of two Gaussian mixtures, equal priors.

    Components of zero width are point masses (a class clipped to one grey
    value): ½∫min(p1, p2) then adds, at every value where *both* have a point
    mass, the smaller of the two; a point mass against a density contributes
    nothing (the density gives a single value zero probability).

    Parameters
    ----------
    first, second : Mixture
        The two classes' (or groups') mixtures (σ ≥ 0).
    """
    c1, w1, s1 = first.centres, first.weights, first.sigmas
    c2, w2, s2 = second.centres, second.weights, second.sigmas
    atom1, atom2 = s1 == 0, s2 == 0
    total = 0.0
    if atom1.any() and atom2.any():
        a1 = _point_masses(c1[atom1], w1[atom1])
        a2 = _point_masses(c2[atom2], w2[atom2])
        total += sum(min(w, a2[x]) for x, w in a1.items() if x in a2)
    spread1, spread2 = ~atom1, ~atom2
    if spread1.any() and spread2.any():
        # The densities' part: ε of the mixtures without their point masses (weights as
        # they are).
        total += 2.0 * _densities_error(
            Mixture(c1[spread1], w1[spread1], s1[spread1]),
            Mixture(c2[spread2], w2[spread2], s2[spread2]),
        )
    return min(0.5 * total, 0.5)  # the parts' masses may sum to 1 + 1 ulp


#: Grid points per row that :func:`gaussian_mixture_errors` evaluates at once; rows that
#: need more (a component far narrower than the span) are searched one by one.
_BATCH_GRID_MAX = 16384
#: Grid points of all rows evaluated together (each costs the components' count in 8 B).
_BATCH_POINTS = 2**20


def gaussian_mixture_errors(
    centres1: ArrayLike,
    weights1: ArrayLike,
    sigmas1: ArrayLike,
    centres2: ArrayLike,
    weights2: ArrayLike,
    sigmas2: ArrayLike,
) -> np.ndarray:
    """ε_tot (37) of many pairs of small Gaussian mixtures at once: row i compares the
    mixture (centres1[i], weights1[i], sigmas1[i]) with (centres2[i], …), each (N, K₁) and
    (N, K₂), weights summing to 1 in a row.

    The same as :func:`mixture_error` row by row, vectorised over the rows: the
    densities' difference is evaluated on a grid a quarter of the row's narrowest σ
    apart, over ±40 of the widest σ beyond the outermost centres (where the densities
    can cross), its sign changes polished by bisection to 2⁻⁴⁰ of a cell, and ε summed
    from the lower density's exact mass (normal CDF differences, accurate in the
    tails) between successive crossings. Rows with a point mass (σ = 0) or needing a
    grid finer than :data:`_BATCH_GRID_MAX` points go to :func:`mixture_error`.
    The spectral analysis's groups (a class against the rest, at each wavelength) are
    hundreds of such rows; one at a time they cost about 1 ms each.

    Returns
    -------
    ndarray, (N,)
    """
    c1, w1, s1 = (np.atleast_2d(np.asarray(a, float)) for a in (centres1, weights1, sigmas1))
    c2, w2, s2 = (np.atleast_2d(np.asarray(a, float)) for a in (centres2, weights2, sigmas2))
    s1, s2 = np.broadcast_to(s1, c1.shape), np.broadcast_to(s2, c2.shape)
    n = c1.shape[0]
    out = np.empty(n)
    if n == 0:
        return out
    cs, ss = np.concatenate([c1, c2], axis=1), np.concatenate([s1, s2], axis=1)
    with np.errstate(all="ignore"):
        lo = np.min(cs, axis=1) - _TAIL_REACH * np.max(ss, axis=1)
        hi = np.max(cs, axis=1) + _TAIL_REACH * np.max(ss, axis=1)
        points = np.ceil((hi - lo) / (_GRID_STEP * np.min(ss, axis=1))) + 1
    batch = (np.min(ss, axis=1) > 0) & np.isfinite(points) & (points <= _BATCH_GRID_MAX)
    batch &= np.all(np.isfinite(cs), axis=1)
    for i in np.flatnonzero(~batch):
        out[i] = mixture_error(Mixture(c1[i], w1[i], s1[i]), Mixture(c2[i], w2[i], s2[i]))
    rows = np.flatnonzero(batch)
    # Rows in chunks of at most _BATCH_POINTS grid points in all (memory stays bounded).
    chunk = np.cumsum(points[rows]) // _BATCH_POINTS
    for part in np.unique(chunk):
        selected = rows[chunk == part]
        out[selected] = _batch_errors(c1[selected], w1[selected], s1[selected], c2[selected],
                                      w2[selected], s2[selected], lo[selected], hi[selected],
                                      points[selected])  # fmt: skip
    return out


def _batch_errors(c1, w1, s1, c2, w2, s2, lo, hi, points) -> np.ndarray:
    """:func:`gaussian_mixture_errors` of rows all of which take the grid (every σ > 0,
    ``points`` grid points each from ``lo`` to ``hi``)."""
    n = c1.shape[0]
    # In each row's own units (the widest σ), from its lower end: the arithmetic stays
    # normal whatever the grey values' scale. Each row gets the grid points it needs,
    # all rows' points in one flat array.
    unit = np.maximum(s1.max(axis=1), s2.max(axis=1))[:, None]
    u1, v1 = (c1 - lo[:, None]) / unit, s1 / unit
    u2, v2 = (c2 - lo[:, None]) / unit, s2 / unit
    count = points.astype(np.int64)
    step = (hi - lo) / unit[:, 0] / (count - 1)
    point_row = np.repeat(np.arange(n), count)
    grid = (np.arange(point_row.size) - np.repeat(np.cumsum(count) - count, count)) * step[
        point_row
    ]
    d = _difference_at(grid, point_row, u1, v1, w1, u2, v2, w2)
    change = (np.signbit(d[:-1]) != np.signbit(d[1:])) & (point_row[:-1] == point_row[1:])
    j = np.flatnonzero(change)
    r = point_row[j]
    left, right = grid[j], grid[j + 1]
    f_left = np.signbit(d[j])
    for _ in range(40):  # bisection: a crossing to 2⁻⁴⁰ of its cell
        mid = 0.5 * (left + right)
        f_mid = np.signbit(_difference_at(mid, r, u1, v1, w1, u2, v2, w2))
        same = f_mid == f_left
        left, right = np.where(same, mid, left), np.where(same, right, mid)
    # The crossings come row by row, each row's in order (cells of the flat grid): with
    # −∞ and +∞ around each row's, successive edges bound its regions.
    crossings = np.bincount(r, minlength=n)
    edge_row = np.repeat(np.arange(n), crossings + 2)
    at = np.arange(edge_row.size) - np.repeat(
        np.cumsum(crossings + 2) - (crossings + 2), crossings + 2
    )
    edges = np.full(edge_row.size, np.inf)
    edges[at == 0] = -np.inf
    edges[(at > 0) & (at <= crossings[edge_row])] = 0.5 * (left + right)
    inside = edge_row[:-1] == edge_row[1:]
    a, b, region_row = edges[:-1][inside], edges[1:][inside], edge_row[:-1][inside]
    # A probe inside each region: its middle, or a point beyond the finite end.
    probe = np.where(
        np.isfinite(a) & np.isfinite(b),
        0.5 * (a + b),
        np.where(np.isfinite(a), a + 1.0, np.where(np.isfinite(b), b - 1.0, 0.0)),
    )
    first_lower = _difference_at(probe, region_row, u1, v1, w1, u2, v2, w2) <= 0
    mass = np.where(
        first_lower,
        _masses(a, b, region_row, u1, v1, w1),
        _masses(a, b, region_row, u2, v2, w2),
    )
    return np.minimum(0.5 * np.bincount(region_row, weights=mass, minlength=n), 0.5)


def _difference_at(x, row, u1, v1, a1, u2, v2, a2):
    """log p₁(x) − log p₂(x) at points x (P,) of rows ``row`` (P,): its sign is that of
    p₁ − p₂, and it stays finite where both densities underflow (a narrow component
    hundreds of σ away from a point)."""

    def log_density(u, v, a):
        z = (x[:, None] - u[row]) / v[row]
        with np.errstate(divide="ignore"):
            terms = np.log(a[row]) - np.log(v[row]) - 0.5 * z * z
        top = np.max(terms, axis=1)
        return top + np.log(np.sum(np.exp(terms - top[:, None]), axis=1))

    return log_density(u1, v1, a1) - log_density(u2, v2, a2)


def _masses(a, b, row, u, v, w):
    """Σ w·(Φ((b − u)/v) − Φ((a − u)/v)) of the components of rows ``row``."""
    za, zb = (a[:, None] - u[row]) / v[row], (b[:, None] - u[row]) / v[row]
    zero = np.zeros(za.size)
    value, _ = _interval(za.ravel(), zero, zb.ravel(), zero)
    return np.sum(w[row] * value.reshape(za.shape), axis=1)


def mixture_errors(
    mixtures: Sequence[tuple[np.ndarray, np.ndarray, float]]
    | Mapping[int, tuple[np.ndarray, np.ndarray, float]],
    comparisons: Sequence[Sequence[tuple[Sequence[int], ArrayLike]]],
) -> np.ndarray:
    """ε_tot (37) of several comparisons among one set of classes' kernel density
    estimates (41), each side a weighted mixture of classes.

    The same as :func:`mixture_error` of each comparison's concatenated components,
    but the classes share one crossing grid (a quarter of the narrowest bandwidth
    apart, over all of them) on which each class's binned density is computed once,
    not once in every comparison it is in (a 5 MP frame's three classes, their pairs
    and each against the rest: 3 FFT passes instead of 15). Sides are summed from
    their classes' log-densities; the sign near crossings, the polishing and the
    masses are exact as in :func:`mixture_error`. A comparison whose own grid would
    have fewer than half the shared grid's points (its classes far narrower or
    wider apart than the others) is computed by :func:`mixture_error` instead.

    Parameters
    ----------
    mixtures : sequence or mapping of (ndarray, ndarray, float)
        Indexed by class: its kernel centres (DN) and weights (:func:`kernel_mixture`) and its
        bandwidth h ≥ 0, DN (0: point masses).
    comparisons : sequence of ((sequence of int, array_like), (sequence of int, array_like))
        Each side's class indices into ``mixtures`` and their shares of the side (> 0,
        summing to 1).

    Returns
    -------
    ndarray
        ε of each comparison.
    """
    used = sorted({k for sides in comparisons for g, _ in sides for k in g})
    spread = [k for k in used if mixtures[k][2] > 0]
    classes, parts, binned, grid = {}, {}, {}, None
    if spread:
        # One frame for all: units of the widest kernel, as in _lower_regions.
        shift = min(float(np.min(mixtures[k][0])) for k in spread)
        unit = max(float(mixtures[k][2]) for k in spread)
        for k in spread:
            c, w, h = mixtures[k]
            o = np.argsort(c, kind="stable")
            classes[k] = (
                (np.asarray(c, float)[o] - shift) / unit,
                np.asarray(w, float)[o],
                h / unit,
            )
        grid = _crossing_grid(
            np.array([x for u, _, _ in classes.values() for x in (u[0], u[-1])]),
            np.array([v for _, _, v in classes.values()]),
        )
        # One part of one width a class, small ones too: binnable, and summed in full
        # by _log_density where small.
        parts = {k: [(u, np.log(w) - np.log(v), v)] for k, (u, w, v) in classes.items()}

    def own_points(own) -> int:
        ends = np.array([x for k in own for x in (classes[k][0][0], classes[k][0][-1])])
        return _crossing_span(ends, np.array([classes[k][2] for k in own]))[2]

    errors = np.empty(len(comparisons))
    for i, sides in enumerate(comparisons):
        own = [k for g, _ in sides for k in g]
        if any(mixtures[k][2] <= 0 for k in own) or 2 * own_points(own) < _size(grid):
            # A constant class (point masses, as mixture_error takes them), or classes
            # whose own grid is less than half the shared one (finer or longer for
            # others' sake): searched on their own grid.
            errors[i] = mixture_error(*(_side(mixtures, g, share) for g, share in sides))
            continue
        side_parts: list[list] = []
        side_binned: list[np.ndarray | None] = []
        for g, share in sides:
            log_share = np.log(np.asarray(share, float))
            side_parts.append(
                [
                    (u, lw + ls, v)
                    for k, ls in zip(g, log_share, strict=True)
                    for u, lw, v in parts[k]
                ]
            )
            for k in g:
                if k not in binned:
                    binned[k] = _binned_log_density(grid, parts[k])
            if any(binned[k] is None for k in g):
                side_binned.append(None)
                continue
            logs = [binned[k] + ls for k, ls in zip(g, log_share, strict=True)]
            with np.errstate(invalid="ignore"):  # NaN (not held by any tilt) stays NaN
                side_binned.append(np.logaddexp.reduce(np.stack(logs), axis=0))
        p1, p2 = side_parts
        d = _grid_difference(grid, p1, p2, binned=side_binned)
        (u1, w1, v1), (u2, w2, v2) = (
            (m.centres, m.weights, m.sigmas)
            for m in (_side(classes, g, share) for g, share in sides)
        )
        xtol = 1e-13 * max(v1.max(), v2.max())
        crossings = _crossings(grid, d, p1, p2, xtol)
        limits = _by_lower(_labelled_regions(crossings, p1, p2, u1, v1, u2, v2))
        total = sum(
            float(np.sum(w * _region_masses(ends, u, v)))
            for ends, u, v, w in zip(limits, (u1, u2), (v1, v2), (w1, w2), strict=True)
            if ends
        )
        errors[i] = min(0.5 * total, 0.5)  # the regions' masses may sum to 1 + 1 ulp
    return errors


def _size(grid: np.ndarray | None) -> int:
    """Points of the shared grid (none without a class of spread)."""
    return 0 if grid is None else grid.size


def _side(mixtures, classes, shares) -> Mixture:
    """One side of a comparison as one mixture: its classes' (centres, weights, h)
    concatenated, each class's weights times its share, a σ per component."""
    members = [mixtures[k] for k in classes]
    return Mixture(
        np.concatenate([c for c, _, _ in members]),
        np.concatenate([w * share for (_, w, _), share in zip(members, shares, strict=True)]),
        np.concatenate([np.full(np.size(c), float(h)) for c, _, h in members]),
    )


def mixture_error_gradient(
    first: Mixture, second: Mixture
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """ε_tot (37) of two Gaussian mixtures (every σ > 0) and its gradient.

    ε = ½ Σ_regions ∫ p_lower over the regions between the densities' crossings.
    Moving a crossing moves mass between two densities that are equal there, so
    only the integrands change: ∂ε/∂μ_i = ½ w_i (φ(z_a) − φ(z_b)) / σ_i and
    ∂ε/∂σ_i = ½ w_i (z_a φ(z_a) − z_b φ(z_b)) / σ_i over the regions where the
    component's density is the lower one (z = (x − μ_i)/σ_i at the region's ends).

    Returns
    -------
    error : float
    d_centres1, d_sigma1, d_centres2, d_sigma2 : ndarray
        ∂ε/∂μ and ∂ε/∂σ of each component, in the order given.
    """
    return _densities_error(first, second, gradient=True)


def misclassified_regions(
    first: Mixture, second: Mixture
) -> tuple[tuple[list[tuple[float, float]], np.ndarray], ...]:
    """Where each of two Gaussian mixtures (every σ > 0) is the lower density — the
    intervals whose values of that side the Bayes rule assigns to the other side —
    and each component's probability mass there.

    Returns
    -------
    (regions1, masses1), (regions2, masses2)
        Per side: the intervals (a, b), DN (a may be −inf, b +inf), and for each of
        its components, in the order given, the mass of N(centre, σ²) in them.
    """
    order, cs, ws, ss = _sorted_components(first, second)
    out = []
    for side, regions in enumerate(_split_regions(cs, ws, ss)):
        masses = np.zeros(cs[side].size)
        if regions:
            masses[order[side]] = _region_masses(regions, cs[side], ss[side])
        out.append((regions, masses))
    return tuple(out)


def _sorted_components(first: Mixture, second: Mixture):
    """Both mixtures' components as float arrays sorted by centre, and the orders that
    sort them: (orders, centres, weights, sigmas), each a pair."""
    c = [first.centres, second.centres]
    w = [first.weights, second.weights]
    s = [first.sigmas, second.sigmas]
    if not all(np.all(si > 0) for si in s):
        raise ValueError("a mixture's regions need every component's σ > 0")
    order = [np.argsort(ci, kind="stable") for ci in c]
    return order, *([x[o] for x, o in zip(arr, order, strict=True)] for arr in (c, w, s))


def _split_regions(cs, ws, ss) -> tuple[list, list]:
    """The regions where side 1's density is the lower one, and those where side 2's
    is (sorted components). A measurement asks for each comparison's twice — for ε Gauss
    and for the counted error — and the crossing search is most of either: the last few
    are kept (a bounded memo: a long ``watch`` grows no cache)."""
    key = np.concatenate([np.asarray(a, np.float64).ravel() for a in (*cs, *ws, *ss)])
    return _regions_of(key.tobytes(), (len(cs[0]), len(cs[1])))


@functools.lru_cache(maxsize=32)
def _regions_of(key: bytes, sizes: tuple[int, int]) -> tuple[list, list]:
    values = np.frombuffer(key, np.float64)
    ends = np.cumsum([0, *sizes, *sizes, *sizes])
    c1, c2, w1, w2, s1, s2 = (values[a:b] for a, b in itertools.pairwise(ends))
    return _by_lower(_lower_regions(c1, s1, c2, s2, w1, w2))


def _by_lower(labelled) -> tuple[list, list]:
    """(a, b, density 1 is the lower) triples as the regions where side 1's density is
    the lower one, and those where side 2's is."""
    regions: tuple[list, list] = ([], [])
    for a, b, lower_is_1 in labelled:
        regions[0 if lower_is_1 else 1].append((a, b))
    return regions


_MASS_REACH = 40.0  # in σ: N(0, 1) holds less than the smallest double beyond


def _region_masses(regions, centres, sigmas, *, gradient: bool = False):
    """Per component N(centre, σ²), its mass in the ``regions`` (sorted, disjoint), and
    with ``gradient`` Σ (φ(z_a) − φ(z_b))·√(2π) and Σ (z_a φ(z_a) − z_b φ(z_b))·√(2π)
    over them (z = (end − centre)/σ).

    Each component is taken with the regions within :data:`_MASS_REACH` σ of it only:
    the rest hold nothing a double keeps. (Summing every region for every component
    cost regions × components: minutes for two classes of 65,536 distinct grey values
    whose densities cross hundreds of times.)
    """
    a, b = np.array(regions, dtype=np.float64).reshape(-1, 2).T
    n = centres.size
    first = np.searchsorted(b, centres - _MASS_REACH * sigmas, side="right")
    last = np.searchsorted(a, centres + _MASS_REACH * sigmas, side="left")
    counts = np.maximum(last - first, 0)
    component = np.repeat(np.arange(n), counts)
    starts = np.cumsum(counts) - counts
    region = first[component] + np.arange(component.size) - starts[component]
    mu, sg = centres[component], sigmas[component]
    za, zb = (a[region] - mu) / sg, (b[region] - mu) / sg
    zero = np.zeros(za.size)
    value, _ = _interval(za, zero, zb, zero)
    mass = np.bincount(component, weights=value, minlength=n)
    if not gradient:
        return mass
    pa, pb = np.exp(-0.5 * za * za), np.exp(-0.5 * zb * zb)
    # φ(±∞) and z·φ(z) at ±∞ are 0.
    za_pa = np.where(np.isfinite(za), za, 0.0) * pa
    zb_pb = np.where(np.isfinite(zb), zb, 0.0) * pb
    d_phi = np.bincount(component, weights=pa - pb, minlength=n)
    d_zphi = np.bincount(component, weights=za_pa - zb_pb, minlength=n)
    return mass, d_phi, d_zphi


def _densities_error(first: Mixture, second: Mixture, *, gradient: bool = False):
    """ε of two mixtures of components with σ > 0 (:func:`mixture_error_gradient`'s value,
    and with ``gradient`` its gradient)."""
    order, cs, ws, ss = _sorted_components(first, second)
    grads = [[np.zeros(ci.size), np.zeros(ci.size)] for ci in cs]
    total = 0.0
    for side, limits in enumerate(_split_regions(cs, ws, ss)):
        if not limits:
            continue
        mu, wt, sg = cs[side], ws[side], ss[side]
        if not gradient:
            total += float(np.sum(wt * _region_masses(limits, mu, sg)))
            continue
        mass, d_phi, d_zphi = _region_masses(limits, mu, sg, gradient=True)
        total += float(np.sum(wt * mass))
        k = wt / (sg * np.sqrt(2.0 * np.pi))
        d_mu, d_sigma = grads[side]
        d_mu[order[side]] += k * d_phi
        d_sigma[order[side]] += k * d_zphi
    error = min(0.5 * total, 0.5)  # the regions' masses may sum to 1 + 1 ulp
    if not gradient:
        return error
    (g1m, g1s), (g2m, g2s) = grads
    return error, 0.5 * g1m, 0.5 * g1s, 0.5 * g2m, 0.5 * g2s


def _lower_regions(c1, s1, c2, s2, w1, w2):
    """(a, b, density 1 is the lower) for the regions between the crossings of two
    mixtures of components with σ > 0 (sorted by centre), in the units given."""
    # ε is invariant under x → (x − a)/b; working in units of the widest kernel
    # keeps the crossings' arithmetic normal where grey values are tiny or huge.
    shift, unit = min(c1[0], c2[0]), max(s1.max(), s2.max())
    u1, v1, u2, v2 = (c1 - shift) / unit, s1 / unit, (c2 - shift) / unit, s2 / unit
    p1, p2 = _density_parts(u1, w1, v1), _density_parts(u2, w2, v2)
    if u1.size == 1 and u2.size == 1:
        crossings = _gaussian_crossings(u1[0], v1[0], u2[0], v2[0])
    else:
        grid = _crossing_grid(np.concatenate([u1, u2]), np.concatenate([v1, v2]))
        crossings = _crossings(grid, _grid_difference(grid, p1, p2), p1, p2, 1e-13)
    for a, b, lower_is_1 in _labelled_regions(crossings, p1, p2, u1, v1, u2, v2):
        yield shift + unit * a, shift + unit * b, lower_is_1


def _labelled_regions(crossings, p1, p2, u1, v1, u2, v2):
    """(a, b, density 1 is the lower) for the regions between ``crossings``."""
    edges = np.concatenate([[-np.inf], crossings, [np.inf]])
    regions = list(itertools.pairwise(edges))
    probes = np.concatenate([_probe(a, b, u1, u2, v1.max(), v2.max()) for a, b in regions])
    lower = _log_density(probes, p1) <= _log_density(probes, p2)
    for (a, b), lower_is_1 in zip(regions, lower, strict=True):
        yield a, b, bool(lower_is_1)


def _point_masses(centres, weights) -> dict[float, float]:
    masses: dict[float, float] = {}
    for x, w in zip(centres.tolist(), weights.tolist(), strict=True):
        masses[x] = masses.get(x, 0.0) + w
    return masses


def _probe(a, b, c1, c2, h1, h2):
    """A point inside (a, b) at which to compare the densities."""
    if np.isfinite(a) and np.isfinite(b):
        return np.array([0.5 * (a + b)])
    hmax = max(h1, h2)
    if np.isfinite(a):
        return np.array([a + hmax])
    if np.isfinite(b):
        return np.array([b - hmax])
    return np.array([0.5 * (np.median(c1) + np.median(c2))])


def _gaussian_crossings(m1, s1, m2, s2) -> np.ndarray:
    """Where N(m1, s1²) = N(m2, s2²): the real roots of a x² + b x + c = 0, sorted."""
    a = 1.0 / s1**2 - 1.0 / s2**2
    b = -2.0 * (m1 / s1**2 - m2 / s2**2)
    c = m1**2 / s1**2 - m2**2 / s2**2 + 2.0 * np.log(s1 / s2)
    if abs(a) <= 1e-12 * max(1.0 / s1**2, 1.0 / s2**2):  # equal widths: one crossing
        return np.array([-c / b]) if b != 0 else np.array([])
    disc = b * b - 4.0 * a * c
    if disc < 0:
        return np.array([])
    q = -0.5 * (b + np.copysign(np.sqrt(disc), b))  # no cancellation
    roots = [q / a] + ([c / q] if q != 0 else [])
    return np.sort(np.array(roots, dtype=float))


def _polish(lo, hi, f_lo, p1, p2, xtol):
    """Roots of log p1 − log p2 in the brackets (lo, hi), all at once: Newton steps
    where they stay inside the bracket, bisection where not."""
    lo, hi = lo.copy(), hi.copy()
    x = 0.5 * (lo + hi)
    active = np.ones(x.shape, dtype=bool)
    for _ in range(200):
        f, g = _slope(x[active], p1, p2)
        xa, la, ha = x[active], lo[active], hi[active]
        same = np.sign(f) == np.sign(f_lo[active])
        la, ha = np.where(same, xa, la), np.where(same, ha, xa)
        with np.errstate(all="ignore"):
            newton = xa - f / g
        inside = np.isfinite(newton) & (newton >= la) & (newton <= ha)
        step = np.where(inside, newton, 0.5 * (la + ha))
        # A converged root stays put: at rounding level f's sign is noise.
        done = (f == 0) | (np.abs(step - xa) <= xtol) | (ha - la <= xtol)
        x[active] = np.where(f == 0, xa, step)
        lo[active], hi[active] = la, ha
        active[active] = ~done
        if not active.any():
            break
    return x


def _log_density_slope(x, parts):
    """log p(x) (unnormalised as in :func:`_log_density`) and d log p / dx.

    Each part is summed as :func:`_log_density` sums it (:func:`_summed`: a root search
    over two classes of 65,536 distinct grey values summed every component at every step,
    minutes), and the parts are combined by their weights.
    """
    x = np.asarray(x, dtype=np.float64)
    logs, slopes = [], []
    for centres, log_w, sigma in parts:
        log_p, slope = np.empty(x.shape), np.empty(x.shape)
        _summed(_log_density_slope_all, x, [log_p, slope], centres, log_w, sigma)
        logs.append(log_p)
        slopes.append(slope)
    if len(logs) == 1:
        return logs[0], slopes[0]
    logs_, slopes_ = np.stack(logs), np.stack(slopes)
    total = np.logaddexp.reduce(logs_, axis=0)
    return total, (np.exp(logs_ - total) * slopes_).sum(axis=0)


def _log_density_slope_all(x, log_p, slope, centres, log_w, sigma) -> None:
    """log p and its slope at ``x`` summing every component given, into the outputs."""
    z = (x[:, None] - centres[None, :]) / sigma
    v = log_w - 0.5 * z * z
    top = v.max(axis=1, keepdims=True)
    e = np.exp(v - top)
    total = e.sum(axis=1)
    log_p[:] = top[:, 0] + np.log(total)
    slope[:] = (e * np.broadcast_to(-z / sigma, z.shape)).sum(axis=1) / total


def _grid_difference(grid, p1, p2, *, binned=None):
    """log p1 − log p2 on a regular ``grid``: binned where that is certain of the sign,
    exact (:func:`_log_density`) elsewhere.

    The binned densities (:func:`_binned_log_density`) cost a few FFTs instead of grid
    points × nearby components. Their error is binning's bias, about
    t(1 − t)(g/σ)² z²/2 at z kernel widths from the peak of the tilt used (g the grid
    step, at most 0.25 of the narrowest σ; z ≤ 3 with tilts 6σ apart): at most 0.16
    nats on the 5 MP benchmark frame's mixtures. Only where the binned difference is
    at least :data:`_BINNED_MARGIN` nats from 0 is its sign taken; every other grid
    point, the crossings' neighbours among them, is evaluated exactly. So the brackets,
    and the crossings polished in them, are those of the exact grid. ``binned``: the two
    binned log-densities on ``grid`` where they are known already (None: not binned).
    """
    if binned is None:
        binned = [_binned_log_density(grid, parts) for parts in (p1, p2)]
    if binned[0] is None or binned[1] is None:
        return _log_density(grid, p1) - _log_density(grid, p2)
    d = binned[0] - binned[1]
    exact = ~(np.abs(d) >= _BINNED_MARGIN)  # NaN (not held by any tilt) included
    if exact.any():
        x = grid[exact]
        d[exact] = _log_density(x, p1) - _log_density(x, p2)
    return d


def _binned_log_density(grid, parts):
    """log p (as :func:`_log_density`) of linearly binned ``parts`` on the regular ``grid``,
    NaN where no tilt (below) holds it above :data:`_BINNED_FLOOR` of its maximum; None
    when a part has a width per component (no single kernel to convolve with) or its
    tilts would exceed :data:`_BINNED_ELEMENTS_MAX` (classes hundreds of kernel widths
    apart, where the grid is long and the exact sums near each point are few).

    Each part's components are put on their two neighbouring grid points (linear
    binning) and convolved with the kernel sampled on the grid by FFT. An FFT is
    accurate only relative to its largest value, so the tails, which decide small
    errors, are computed tilted: e^{θ(x − x0)} p(x) = Σ_i w_i e^{θ(c_i − x0)} ·
    K(x − c_i) e^{θ(x − c_i)}, reweighted components convolved with the kernel shifted
    by θσ², whose peak lies out in the tail. Tilts θ = k · _TILT_STEP / σ place peaks
    about every 6σ out to the grid's ends; each grid point takes the tilt that holds it
    highest relative to that tilt's maximum, and the tilts are transformed together.
    """
    step = (grid[-1] - grid[0]) / (grid.size - 1)
    x0 = 0.5 * (grid[0] + grid[-1])
    logs = []
    for centres, log_w, sigma in parts:
        if np.ndim(sigma):
            return None
        pos = (centres - grid[0]) / step
        j = np.clip(np.floor(pos).astype(np.int64), 0, grid.size - 2)
        t = pos - j
        beyond = max(centres.min() - grid[0], grid[-1] - centres.max()) / sigma
        tilts = int(np.ceil(beyond / _TILT_STEP)) + 1
        reach = min(int(np.ceil((tilts * _TILT_STEP + _TAIL_REACH) * sigma / step)), grid.size - 1)
        u = np.arange(-reach, reach + 1) * step
        size = 1 << int(np.ceil(np.log2(grid.size + u.size - 1)))
        if (2 * tilts + 1) * size > _BINNED_ELEMENTS_MAX:
            return None  # classes far apart: the exact windowed sums are cheaper
        theta = np.arange(-tilts, tilts + 1)[:, None] * (_TILT_STEP / sigma)  # (tilts, 1)
        a = log_w + theta * (centres - x0)
        a_max = a.max(axis=1, keepdims=True)
        w = np.exp(a - a_max)
        rows = np.arange(theta.size)[:, None] * grid.size + j  # flat (tilt, grid point)
        binned = np.bincount(rows.ravel(), (w * (1.0 - t)).ravel(), theta.size * grid.size)
        binned += np.bincount(rows.ravel() + 1, (w * t).ravel(), theta.size * grid.size)
        lk = theta * u - 0.5 * (u / sigma) ** 2
        lk_max = lk.max(axis=1, keepdims=True)
        spectrum = np.fft.rfft(binned.reshape(theta.size, grid.size), size)
        spectrum *= np.fft.rfft(np.exp(lk - lk_max), size)
        full = np.fft.irfft(spectrum, size)
        tilted = full[:, reach : reach + grid.size]
        with np.errstate(divide="ignore", invalid="ignore"):
            # The FFT rounds relative to a tilt's largest value, which may lie off the grid.
            relative = np.log(tilted / full.max(axis=1, keepdims=True))
            floor = np.log(_BINNED_FLOOR)
            k = np.argmax(np.where(relative > floor, relative, -np.inf), axis=0)
            at = np.arange(grid.size)
            value = np.log(tilted[k, at]) + a_max[k, 0] + lk_max[k, 0] - theta[k, 0] * (grid - x0)
        logs.append(np.where(relative[k, at] > floor, value, np.nan))
    if len(logs) > 1:
        with np.errstate(invalid="ignore"):  # NaN (not held by any tilt) stays NaN
            return np.logaddexp.reduce(np.stack(logs), axis=0) - _LOG_SQRT_2PI
    return logs[0] - _LOG_SQRT_2PI


def _crossing_grid(centres, sigmas) -> np.ndarray:
    """The regular grid :func:`_crossings` looks for sign changes on: a quarter of the
    narrowest kernel apart, reaching 40 of the widest beyond the outermost components
    (at most 2¹⁸ + 1 points)."""
    return np.linspace(*_crossing_span(centres, sigmas))


def _crossing_span(centres, sigmas) -> tuple[float, float, int]:
    """:func:`_crossing_grid`'s ends and number of points."""
    step = _GRID_STEP * sigmas.min()
    lo = centres.min() - _TAIL_REACH * sigmas.max()
    hi = centres.max() + _TAIL_REACH * sigmas.max()
    return lo, hi, int(min(np.ceil((hi - lo) / step), 2**18)) + 1


def _crossings(grid, d, p1, p2, xtol) -> np.ndarray:
    """The crossings of two mixtures' log-densities bracketed by the sign changes of their
    difference ``d`` on ``grid`` (:func:`_grid_difference`) or split by its dips
    (:func:`_dip_brackets`), polished to ``xtol``."""
    sign = np.sign(d)
    idx = np.flatnonzero(sign[:-1] * sign[1:] < 0)
    # Every bracket is polished at once; for large mixtures in groups of brackets that keep
    # the (brackets × components) arrays near 32 MB.
    per = max(1, 2**22 // sum(c.size for c, _, _ in p1 + p2))
    at = _dips(d)
    dips = [_dip_brackets(grid, d, p1, p2, at[i : i + per]) for i in range(0, at.size, per)]
    lo = np.concatenate([grid[idx], *(b[0] for b in dips)])
    hi = np.concatenate([grid[idx + 1], *(b[1] for b in dips)])
    f_lo = np.concatenate([d[idx], *(b[2] for b in dips)])
    roots = [
        x
        for i in range(0, lo.size, per)
        for x in _polish(lo[i : i + per], hi[i : i + per], f_lo[i : i + per], p1, p2, xtol)
    ]
    roots += list(grid[np.flatnonzero(sign == 0)])
    return np.sort(np.array(roots, dtype=float))


def _dips(d) -> np.ndarray:
    """Grid points where |d| has a local minimum below :data:`_BINNED_MARGIN` between
    neighbours of its sign: where two crossings may lie within a cell of each other."""
    a, s = np.abs(d), np.sign(d)
    inner = (a[1:-1] < a[:-2]) & (a[1:-1] <= a[2:]) & (a[1:-1] < _BINNED_MARGIN)
    inner &= (s[1:-1] != 0) & (s[:-2] == s[1:-1]) & (s[1:-1] == s[2:])
    return np.flatnonzero(inner) + 1


def _dip_brackets(grid, d, p1, p2, i):
    """Brackets (lo, hi, d at lo) of the crossing pairs at the dips ``i`` (:func:`_dips`),
    which the grid's sign changes miss: d's extremum between the dip's neighbours is
    found (a root of its slope, by bisection); where d has the other sign there, each
    side of it holds one crossing."""
    s = np.sign(d[i])
    lo, hi = grid[i - 1], grid[i + 1]
    # Toward 0 from sign s, d's slope passes from −s to s.
    turn = (np.sign(_slope(lo, p1, p2)[1]) == -s) & (np.sign(_slope(hi, p1, p2)[1]) == s)
    i, s, lo, hi = i[turn], s[turn], lo[turn], hi[turn]
    for _ in range(_DIP_HALVINGS if i.size else 0):
        mid = 0.5 * (lo + hi)
        before = np.sign(_slope(mid, p1, p2)[1]) == -s
        lo, hi = np.where(before, mid, lo), np.where(before, hi, mid)
    x = 0.5 * (lo + hi)
    dx = _slope(x, p1, p2)[0]
    split = np.sign(dx) == -s
    i, x, dx = i[split], x[split], dx[split]
    return (
        np.concatenate([grid[i - 1], x]),
        np.concatenate([x, grid[i + 1]]),
        np.concatenate([d[i - 1], dx]),
    )


def _slope(x, p1, p2):
    """log p1 − log p2 at ``x`` and its slope."""
    f1, g1 = _log_density_slope(x, p1)
    f2, g2 = _log_density_slope(x, p2)
    return f1 - f2, g1 - g2
