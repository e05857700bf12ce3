"""ε_tot (37) of many small Gaussian mixtures at once: the groups of a comparison
("A vs B,C") over every combination of a sweep, each side a mixture of a few class
Gaussians. All rows are evaluated on grids together (vectorised over the rows), and
a row whose grid would be too fine (a component far narrower than the span) is left
to :func:`~inspect_validate.stats.kde_error.mixture_error`, one by one.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.stats.gaussian_error import error_interval
from inspect_validate.stats.kde_error import GRID_STEP, mixture_error
from inspect_validate.stats.mixture import TAIL_REACH, Mixture
from inspect_validate.stats.roots import narrow_brackets

__all__ = ["class_mixture_errors", "gaussian_mixture_errors", "stacked_mixtures"]

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
    apart, over :data:`NEAR_REACH` of the widest σ beyond the outermost centres, its
    sign changes polished to 2⁻²⁴ of a cell by safeguarded Newton steps, and ε summed from the lower
    density's exact mass (normal CDF differences, accurate in the tails) between
    successive crossings. ε is stationary in a crossing's place (the two densities are
    equal there): a crossing off by δ moves ε by about ½·|p₁′ − p₂′|·δ², below 10⁻¹⁴ of ε
    at 2⁻²⁴ of a cell for classes up to 20 σ apart. A crossing beyond the grid's ends
    would move ε by at most the mass beyond them of the side counted there; a row where
    that bound is not 10⁻¹³ of ε is searched again out to
    :data:`~inspect_validate.stats.mixture.TAIL_REACH` σ, as the one-at-a-time search
    does. Rows with a point mass (σ = 0) or needing a grid finer than
    :data:`_BATCH_GRID_MAX` points go to :func:`mixture_error`. The spectral analysis's
    groups (a class against the rest, at each wavelength) are hundreds of such rows;
    one at a time they cost about 1 ms each.

    Returns
    -------
    ndarray, (N,)
    """
    c1, w1, s1 = (np.atleast_2d(np.asarray(a, float)) for a in (centres1, weights1, sigmas1))
    c2, w2, s2 = (np.atleast_2d(np.asarray(a, float)) for a in (centres2, weights2, sigmas2))
    s1, s2 = np.broadcast_to(s1, c1.shape), np.broadcast_to(s2, c2.shape)
    return _pair_errors((c1, w1, s1), (c2, w2, s2), np.arange(c1.shape[0]))


def _pair_errors(side1, side2, rows: np.ndarray, *, near: bool = True) -> np.ndarray:
    """:func:`gaussian_mixture_errors` of rows ``rows`` of the sides' (centres, weights,
    sigmas), (N, K) each; ``near=False`` starts at the whole reach (rows known to need it)."""
    (c1, w1, s1), (c2, w2, s2) = sides = side1, side2
    out = np.empty(c1.shape[0])
    for reach in (NEAR_REACH, TAIL_REACH) if near else (TAIL_REACH,):
        grid = _row_grids(*sides, reach=reach, rows=rows)
        for i in rows[~grid.batch]:
            out[i] = mixture_error(_mixture(c1[i], w1[i], s1[i]), _mixture(c2[i], w2[i], s2[i]))
        rows = rows[grid.batch]
        out[rows], bound = _chunked_errors(*sides, grid.select(grid.batch), rows)
        # Rows whose ε the grid's ends could move by more than 10⁻¹³ of it.
        rows = rows[_moved(out[rows], bound)] if reach < TAIL_REACH else rows[:0]
    return out


def _moved(errors: np.ndarray, log_bound: np.ndarray) -> np.ndarray:
    """Where a crossing beyond the grid could move ε by more than 10⁻¹³ of it."""
    with np.errstate(divide="ignore"):
        return log_bound > np.log(errors) + math.log(1e-13)


def class_mixture_errors(
    mixtures: Sequence[tuple[ArrayLike, ArrayLike, ArrayLike]],
    comparisons: Sequence[Sequence[tuple[Sequence[int], ArrayLike]]],
) -> np.ndarray:
    """ε_tot (37) of several comparisons among one set of classes' kernel density
    estimates (41), in many rows at once (the spectral analysis's wavelengths).

    Row i is :func:`~inspect_validate.stats.kde_error.mixture_errors` of the classes'
    row i, vectorised over the rows as :func:`gaussian_mixture_errors` is, with one
    grid a row for all comparisons: each class's log-density is evaluated on it once
    and each side summed from its classes' (three classes, their pairs and each
    against the rest: 3 classes' evaluations instead of 15).

    Parameters
    ----------
    mixtures : sequence of (array_like, array_like, array_like)
        Indexed by class: its kernel centres and weights, (N, S_k), each row's weights
        summing to 1, and its bandwidth in each row, (N,) > 0.
    comparisons : sequence of ((sequence of int, array_like), (sequence of int, array_like))
        Each side's class indices into ``mixtures`` and their shares of the side (> 0,
        summing to 1).

    Returns
    -------
    ndarray, (P, N)
        ε of each comparison in each row.
    """
    classes = []
    for c, w, h in mixtures:
        c, w = np.atleast_2d(np.asarray(c, float)), np.atleast_2d(np.asarray(w, float))
        classes.append((c, w, np.broadcast_to(np.asarray(h, float).reshape(-1, 1), c.shape)))
    n = classes[0][0].shape[0] if classes else 0
    out = np.full((len(comparisons), n), np.nan)

    def side(g, shares) -> tuple[np.ndarray, ...]:
        """One side's classes as one mixture (centres, weights, σ), (N, Σ S_k)."""
        scale = dict(zip(g, np.asarray(shares, float), strict=True))
        return tuple(
            np.concatenate([classes[k][j] * (scale[k] if j == 1 else 1.0) for k in g], axis=1)
            for j in range(3)
        )

    # All comparisons as rows of one batch (row p·N + i), each side padded to its widest
    # with components of weight 0: one pass of the searches for all.
    pairs = [[side(g, shares) for g, shares in pair] for pair in comparisons]
    side1, side2 = (stacked_mixtures([pair[j] for pair in pairs]) for j in (0, 1))
    used = sorted({k for pair in comparisons for g, _ in pair for k in g})
    if n == 0 or not used:
        return out
    union = tuple(np.concatenate([classes[k][j] for k in used], axis=1) for j in range(3))
    rows = np.arange(n)
    grid = _row_grids(union, reach=NEAR_REACH, rows=rows)
    batch = rows[grid.batch]
    grid = grid.select(grid.batch)
    flat = out.reshape(-1)
    count = len(comparisons)
    bound = np.full(flat.size, np.inf)
    # A chunk's points are evaluated once for every comparison.
    for here in _chunks(grid.points * count):
        chunk_rows, chunk_grid = batch[here], grid.select(here)
        x, point_row = _flat_grid(chunk_grid)
        lo, unit = chunk_grid.lo[:, None], chunk_grid.unit[:, None]
        log_density = {}
        for k in used:
            c, w, h = (a[chunk_rows] for a in classes[k])
            log_density[k] = _log_density(x, point_row, (c - lo) / unit, h / unit, w)
        d = []
        for pair in comparisons:
            with np.errstate(divide="ignore"):
                sums = [
                    np.logaddexp.reduce(
                        [
                            log_density[k] + np.log(s)
                            for k, s in zip(g, np.asarray(shares, float), strict=True)
                        ],
                        axis=0,
                    )
                    for g, shares in pair
                ]
            d.append(sums[0] - sums[1])
        stacked_rows = (np.arange(count)[:, None] * n + chunk_rows).reshape(-1)
        flat[stacked_rows], bound[stacked_rows] = _batch_errors(
            tuple(a[stacked_rows] for a in side1),
            tuple(a[stacked_rows] for a in side2),
            chunk_grid.tiled(count),
            d=np.concatenate(d),
        )
    # The rows the shared grid could not take, and those whose ε its reach could move by
    # more than 10⁻¹³ of it, as pairs of mixtures (the latter out to TAIL_REACH).
    grid_taken = np.zeros((count, n), bool)
    grid_taken[:, batch] = True
    taken = grid_taken.reshape(-1)
    far = np.flatnonzero(taken & _moved(flat, bound))
    for again, near in ((np.flatnonzero(~taken), True), (far, False)):
        if again.size:
            flat[again] = _pair_errors(side1, side2, again, near=near)[again]
    return out


def stacked_mixtures(sides: Sequence[tuple[np.ndarray, ...]]) -> tuple[np.ndarray, ...]:
    """Mixtures (centres, weights, σ), each (N, K_p), as rows of one (P·N, max K_p), for
    :func:`gaussian_mixture_errors` of several comparisons at once: padded with
    components of weight 0 (at the first centre, of the first σ), which it leaves out."""
    width = max(c.shape[1] for c, _, _ in sides)
    out = []
    for j in range(3):
        parts = []
        for side in sides:
            a = side[j]
            fill = np.zeros_like(a[:, :1]) if j == 1 else a[:, :1]
            parts.append(np.concatenate([a, np.repeat(fill, width - a.shape[1], axis=1)], axis=1))
        out.append(np.concatenate(parts, axis=0))
    return tuple(out)


def _mixture(centres, weights, sigmas) -> Mixture:
    """One row as a :class:`Mixture`, without the padding's components of weight 0."""
    keep = weights > 0
    return Mixture(centres[keep], weights[keep], sigmas[keep])


NEAR_REACH = 10.0
"""Widest σ beyond the outermost centres that the first grid spans."""


@dataclass(frozen=True)
class _RowGrids:
    """Each row's grid: ``points`` from ``lo`` to ``hi`` (in ``unit``, a row's widest σ);
    ``batch`` where the grid is usable (every σ > 0, finite, not too many points)."""

    lo: np.ndarray
    hi: np.ndarray
    unit: np.ndarray
    points: np.ndarray
    batch: np.ndarray

    def select(self, keep: np.ndarray | slice) -> _RowGrids:
        return _RowGrids(*(a[keep] for a in (self.lo, self.hi, self.unit, self.points, self.batch)))

    def tiled(self, count: int) -> _RowGrids:
        """The same grids for ``count`` blocks of rows, one after the other."""
        return _RowGrids(
            *(np.tile(a, count) for a in (self.lo, self.hi, self.unit, self.points, self.batch))
        )


def _row_grids(*sides, reach: float, rows: np.ndarray) -> _RowGrids:
    """The grids of rows ``rows`` of the sides' (centres, weights, sigmas), spanning the
    centres and ``reach`` widest σ beyond, a :data:`GRID_STEP` of the narrowest apart."""
    cs = np.concatenate([side[0][rows] for side in sides], axis=1)
    ss = np.concatenate([side[2][rows] for side in sides], axis=1)
    widest, narrowest = np.max(ss, axis=1), np.min(ss, axis=1)
    with np.errstate(all="ignore"):
        lo = np.min(cs, axis=1) - reach * widest
        hi = np.max(cs, axis=1) + reach * widest
        points = np.ceil((hi - lo) / (GRID_STEP * narrowest)) + 1
    batch = (narrowest > 0) & np.isfinite(points) & (points <= _BATCH_GRID_MAX)
    batch &= np.all(np.isfinite(cs), axis=1)
    return _RowGrids(lo, hi, widest, points, batch)


def _chunks(points: np.ndarray) -> list[slice]:
    """Runs of consecutive rows with at most :data:`_BATCH_POINTS` grid points in all
    (a row with more alone). Not np.unique: it imports numpy.ma, 6 ms of a command."""
    chunk = np.cumsum(points) // _BATCH_POINTS
    edges = [0, *(np.flatnonzero(np.diff(chunk)) + 1).tolist(), chunk.size]
    return [slice(a, b) for a, b in itertools.pairwise(edges) if b > a]


def _chunked_errors(
    side1, side2, grid: _RowGrids, rows: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_batch_errors` of rows ``rows`` in chunks of at most :data:`_BATCH_POINTS`
    grid points in all (memory stays bounded)."""
    out, bound = np.empty(rows.size), np.empty(rows.size)
    for here in _chunks(grid.points):
        out[here], bound[here] = _batch_errors(
            tuple(a[rows[here]] for a in side1),
            tuple(a[rows[here]] for a in side2),
            grid.select(here),
        )
    return out, bound


def _batch_errors(
    side1: tuple, side2: tuple, grid: _RowGrids, d=None
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`gaussian_mixture_errors` of rows all of which take their grid, each side
    (centres, weights, sigmas); ``d``, the difference on the flat grid if already
    evaluated. Returns ε and the log of a bound on what a crossing beyond the grid's
    ends could move it by (−∞ where the row was searched without a grid)."""
    (c1, w1, s1), (c2, w2, s2) = side1, side2
    n = c1.shape[0]
    # In each row's own units (the widest σ), from its lower end: the arithmetic stays
    # normal whatever the grey values' scale. Each row gets the grid points it needs,
    # all rows' points in one flat array.
    lo, unit = grid.lo, grid.unit[:, None]
    u1, v1 = (c1 - lo[:, None]) / unit, s1 / unit
    u2, v2 = (c2 - lo[:, None]) / unit, s2 / unit
    x, point_row = _flat_grid(grid)
    if d is None:
        d = _difference_at(x, point_row, u1, v1, w1, u2, v2, w2)
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
    exact = np.flatnonzero(np.bincount(point_row[1:-1][dip], minlength=n))
    change = (np.signbit(d[:-1]) != np.signbit(d[1:])) & (point_row[:-1] == point_row[1:])
    j = np.flatnonzero(change)
    r = point_row[j]
    left, right = narrow_brackets(
        x[j], x[j + 1], d[j], d[j + 1],
        lambda at, k: _difference_and_slope(at, r[k], u1, v1, w1, u2, v2, w2),
        tolerance=np.ldexp(x[j + 1] - x[j], -24), slope=True,
    )  # fmt: skip
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
    with np.errstate(invalid="ignore"):  # −∞ + ∞ where a row has no crossing
        probe = np.where(
            np.isfinite(a) & np.isfinite(b),
            0.5 * (a + b),
            np.where(np.isfinite(a), a + 1.0, np.where(np.isfinite(b), b - 1.0, 0.0)),
        )
    first_lower = _difference_at(probe, region_row, u1, v1, w1, u2, v2, w2) <= 0
    mass = np.empty(a.size)
    for lower, (u, v, w) in ((first_lower, (u1, v1, w1)), (~first_lower, (u2, v2, w2))):
        mass[lower] = _masses(a[lower], b[lower], region_row[lower], u, v, w)
    errors = np.minimum(0.5 * np.bincount(region_row, weights=mass, minlength=n), 0.5)
    # A crossing beyond the grid's ends goes unseen: the end region then counts its side's
    # mass out to infinity where the other side's is lower, ε off by at most that side's
    # mass beyond the end. Its log, from Q(z) ≤ φ(z)/z (z > 1; else 1).
    one_first, one_last = np.ones(n, bool), np.ones(n, bool)
    one_first[region_row[a == -np.inf]] = first_lower[a == -np.inf]
    one_last[region_row[b == np.inf]] = first_lower[b == np.inf]
    top = ((grid.hi - grid.lo) / grid.unit)[:, None]  # the grid's upper end; its lower is 0
    bound = np.logaddexp(
        np.where(one_first, _log_tail(u1 / v1, w1), _log_tail(u2 / v2, w2)),
        np.where(one_last, _log_tail((top - u1) / v1, w1), _log_tail((top - u2) / v2, w2)),
    )
    for i in exact:
        errors[i] = mixture_error(_mixture(c1[i], w1[i], s1[i]), _mixture(c2[i], w2[i], s2[i]))
        bound[i] = -np.inf  # searched without a grid
    return errors, bound


def _log_tail(t: np.ndarray, w: np.ndarray) -> np.ndarray:
    """An upper bound of log Σ w·Q(t), (N,): the mass of a row's components (weights
    ``w``, (N, K)) beyond an end ``t`` of their σ from their centres, from
    Q(t) ≤ φ(t)/t where t > 1, else 1."""
    with np.errstate(divide="ignore"):
        log_q = np.where(
            t > 1.0, -0.5 * t * t - np.log(np.maximum(t, 1.0) * math.sqrt(2.0 * math.pi)), 0.0
        )
        return np.logaddexp.reduce(np.log(w) + log_q, axis=1)


def _flat_grid(grid: _RowGrids) -> tuple[np.ndarray, np.ndarray]:
    """All rows' grid points in one array (each in its row's units from its ``lo``) and
    the row of each."""
    count = grid.points.astype(np.int64)
    step = (grid.hi - grid.lo) / grid.unit / (count - 1)
    point_row = np.repeat(np.arange(count.size), count)
    x = (np.arange(point_row.size) - np.repeat(np.cumsum(count) - count, count)) * step[point_row]
    return x, point_row


def _difference_at(x, row, u1, v1, a1, u2, v2, a2):
    """log p₁(x) − log p₂(x) at points x (P,) of rows ``row`` (P,): its sign is that of
    p₁ − p₂, and it stays finite where both densities underflow (a narrow component
    hundreds of σ away from a point)."""
    return _log_density(x, row, u1, v1, a1) - _log_density(x, row, u2, v2, a2)


def _difference_and_slope(x, row, u1, v1, a1, u2, v2, a2):
    """:func:`_difference_at` and its derivative in x (Newton's steps on the crossings)."""
    d1, s1 = _log_density(x, row, u1, v1, a1, slope=True)
    d2, s2 = _log_density(x, row, u2, v2, a2, slope=True)
    return d1 - d2, s1 - s2


def _log_density(x, row, u, v, a, *, slope=False):
    """log Σ a·φ((x − u)/v)/v at points x (P,) of rows ``row`` (P,), u, v, a (rows, K);
    with ``slope``, also its derivative in x, Σ a·φ·(u − x)/v² / Σ a·φ."""
    with np.errstate(divide="ignore"):
        inverse = 1.0 / v
        scale = np.log(a) + np.log(inverse)  # per component, not per point
    # Components along the first axis: the reductions over them run along the points,
    # vectorised, where (P, K) reduced a few values a point (half the time).
    columns = [np.ascontiguousarray(q.T) for q in (u, inverse, scale)]
    terms = np.take(columns[0], row, axis=1)
    np.subtract(x, terms, out=terms)
    terms *= np.take(columns[1], row, axis=1)
    if slope:
        pull = terms * np.take(columns[1], row, axis=1)  # (x − u)/v², per component
    terms *= terms
    terms *= -0.5
    terms += np.take(columns[2], row, axis=1)
    top = np.max(terms, axis=0)
    terms -= top
    np.exp(terms, out=terms)
    total = np.sum(terms, axis=0)
    value = top + np.log(total)
    if not slope:
        return value
    with np.errstate(invalid="ignore"):  # 0·∞ of a component of weight 0 far away
        pull *= terms
    return value, -np.nansum(pull, axis=0) / total


def _masses(a, b, row, u, v, w):
    """Σ w·(Φ((b − u)/v) − Φ((a − u)/v)) of the components of rows ``row``."""
    za, zb = (a[:, None] - u[row]) / v[row], (b[:, None] - u[row]) / v[row]
    zero = np.zeros(za.size)
    value, _ = error_interval(za.ravel(), zero, zb.ravel(), zero)
    return np.sum(w[row] * value.reshape(za.shape), axis=1)
