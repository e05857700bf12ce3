"""Nonparametric classification error: ε_tot (37) of two Gaussian kernel densities (41).

Each class density is a Gaussian mixture (:mod:`inspect_validate.stats.mixture`:
one kernel of bandwidth h per lattice point or value). With equal priors

    ε_tot = ½ ∫ min(p̂1, p̂2) dx,

computed without quadrature error: the crossings of p̂1 and p̂2 are located on a
grid of log-densities (binned by FFT where that is certain of the sign, exact near
the crossings; a pair of crossings inside one cell where the difference dips toward
0) and refined by root finding inside the bracketing cells, and between crossings
the mass of the lower density is summed in closed form from the kernels' normal
CDFs (stable interval probabilities, so tiny errors keep their relative accuracy).
Several comparisons among the same classes (:func:`mixture_errors`) share one grid
and each class's binned density; many small mixtures at once are
:mod:`inspect_validate.stats.mixture_batch`'s.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.stats.bandwidth import Bandwidth, lscv_bandwidth
from inspect_validate.stats.gaussian_error import error_interval
from inspect_validate.stats.mixture import (
    TAIL_REACH,
    Mixture,
    binned_log_density,
    density_parts,
    kernel_mixture,
    log_density,
    log_density_slope,
)
from inspect_validate.stats.sample import Sample

__all__ = [
    "GRID_STEP",
    "KdeError",
    "kde_error",
    "misclassified_regions",
    "mixture_error",
    "mixture_error_gradient",
    "mixture_errors",
]

GRID_STEP = 0.25  # grid spacing for finding crossings, in units of the smaller h


_BINNED_MARGIN = 0.5  # nats: a binned log-density difference trusted for its sign


_DIP_HALVINGS = 30  # a dip's extremum to 2⁻³⁰ of two grid cells (crossings are polished after)


@dataclass(frozen=True)
class KdeError:
    """ε_tot of two kernel density estimates, with the bandwidths used."""

    error: float
    bandwidth1: Bandwidth
    bandwidth2: Bandwidth


def kde_error(sample1: Sample, sample2: Sample, *, quantum: float | None = None) -> KdeError:
    """ε_tot (37) between the LSCV kernel density estimates of two samples.

    Parameters
    ----------
    sample1, sample2 : LatticeSample or array_like
        Grey values of the two classes, DN.
    quantum : float, keyword-only, optional
        Quantisation step, the bandwidth floor (see
        :func:`~inspect_validate.stats.lscv_bandwidth`).

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
        # by log_density where small.
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
            assert grid is not None  # the classes of a comparison here are spread ones
            for k in g:
                if k not in binned:
                    binned[k] = binned_log_density(grid, parts[k])
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
    value, _ = error_interval(za, zero, zb, zero)
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
    p1, p2 = density_parts(u1, w1, v1), density_parts(u2, w2, v2)
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
    lower = log_density(probes, p1) <= log_density(probes, p2)
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


def _grid_difference(grid, p1, p2, *, binned=None):
    """log p1 − log p2 on a regular ``grid``: binned where that is certain of the sign,
    exact (:func:`log_density`) elsewhere.

    The binned densities (:func:`binned_log_density`) cost a few FFTs instead of grid
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
        binned = [binned_log_density(grid, parts) for parts in (p1, p2)]
    if binned[0] is None or binned[1] is None:
        return log_density(grid, p1) - log_density(grid, p2)
    d = binned[0] - binned[1]
    exact = ~(np.abs(d) >= _BINNED_MARGIN)  # NaN (not held by any tilt) included
    if exact.any():
        x = grid[exact]
        d[exact] = log_density(x, p1) - log_density(x, p2)
    return d


def _crossing_grid(centres, sigmas) -> np.ndarray:
    """The regular grid :func:`_crossings` looks for sign changes on: a quarter of the
    narrowest kernel apart, reaching 40 of the widest beyond the outermost components
    (at most 2¹⁸ + 1 points)."""
    return np.linspace(*_crossing_span(centres, sigmas))


def _crossing_span(centres, sigmas) -> tuple[float, float, int]:
    """:func:`_crossing_grid`'s ends and number of points."""
    step = GRID_STEP * sigmas.min()
    lo = centres.min() - TAIL_REACH * sigmas.max()
    hi = centres.max() + TAIL_REACH * sigmas.max()
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
    f1, g1 = log_density_slope(x, p1)
    f2, g2 = log_density_slope(x, p2)
    return f1 - f2, g1 - g2
