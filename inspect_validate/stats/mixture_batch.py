"""ε_tot (37) of many small Gaussian mixtures at once: the groups of a comparison
("A vs B,C") over every combination of a sweep, each side a mixture of a few class
Gaussians. All rows are evaluated on grids together (vectorised over the rows), and
a row whose grid would be too fine (a component far narrower than the span) is left
to :func:`~inspect_validate.stats.kde_error.mixture_error`, one by one.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.stats.gaussian_error import _interval
from inspect_validate.stats.kde_error import GRID_STEP, mixture_error
from inspect_validate.stats.mixture import TAIL_REACH, Mixture

__all__ = ["gaussian_mixture_errors"]

DIP_MARGIN = 0.5
"""A dip of |log p₁ − log p₂| between grid points is searched exactly where the parabola
through it comes within this fraction of its lowest grid value of 0."""

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
        lo = np.min(cs, axis=1) - TAIL_REACH * np.max(ss, axis=1)
        hi = np.max(cs, axis=1) + TAIL_REACH * np.max(ss, axis=1)
        points = np.ceil((hi - lo) / (GRID_STEP * np.min(ss, axis=1))) + 1
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
    # Two crossings inside one cell leave no sign change on the grid (the paperboard's
    # kernel mixtures lost 2.5e-5 of an ε of 0.31 so): where |d| dips between two
    # neighbours of its own sign, the row is searched exactly (mixture_error finds and
    # splits such dips).
    a0, a1, a2 = np.abs(d[:-2]), np.abs(d[1:-1]), np.abs(d[2:])
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        # The parabola through the three |d| comes this close to 0 between them.
        low = a1 - (a2 - a0) ** 2 / (8.0 * (a0 - 2.0 * a1 + a2))
        dip = (
            (point_row[:-2] == point_row[2:])
            & (np.signbit(d[:-2]) == np.signbit(d[1:-1]))
            & (np.signbit(d[1:-1]) == np.signbit(d[2:]))
            & (a1 < a0)
            & (a1 < a2)
            & (low <= DIP_MARGIN * a1)
        )
    exact = np.unique(point_row[1:-1][dip])
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
    errors = np.minimum(0.5 * np.bincount(region_row, weights=mass, minlength=n), 0.5)
    for i in exact:
        errors[i] = mixture_error(Mixture(c1[i], w1[i], s1[i]), Mixture(c2[i], w2[i], s2[i]))
    return errors


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
