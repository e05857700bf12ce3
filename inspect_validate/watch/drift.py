"""Drift of a running station from its golden statistics: EWMA control charts, one per
monitored quantity, and the likely cause from the pattern of what drifted.

Each quantity x (a class's μ and σ² per illumination, a comparison's SNR_dB and
log₁₀ ε) is standardised by its golden mean μ₀ and spread σ₀, and smoothed. σ₀ is the
trained repeats' standard deviation s, floored at their own standard error (repeats
cannot vary less than their noise; a golden file of version 1, which has none, is
floored at fixed fractions instead). Comparisons whose golden SNR_dB is below the drift
floor (``snr_floor_db``, −20 dB) are not charted: the dB of classes that are not
separated are the log of a near-zero difference, noise without a drift to show.

    z_t = λ x_t + (1 − λ) z_{t−1},  z_0 = μ₀

It alarms when |z_t − μ₀| > L σ₀ √(λ/(2 − λ) · (1 − (1 − λ)^{2t})).

**The limit L.** μ₀ and σ₀ are estimates from n repeats: the chart's target is off by
δ ~ N(0, σ²/n) and its spread by w = σ₀/σ ~ √(χ²_{n−1}/(n−1)), for as long as the
golden file is used. L is chosen so that the long-run false-alarm rate, averaged over
the golden files a station could have trained (E[1/ARL(L·w, shift δ)], by quadrature
over δ and w; the ARL of a chart by the Markov-chain approximation of Brook & Evans
(1972)), is 1/(m × the family's ARL) for each of m charts — a Bonferroni split,
conservative for correlated charts (:func:`design_limit`). The same golden file's
drift checks in ``verify`` are prediction intervals on the same footing
(:mod:`inspect_validate.verification.golden`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from collections.abc import Sequence

    from inspect_validate.verification.diagnosis import Change, Sensor
    from inspect_validate.verification.golden import Golden
    from inspect_validate.verification.parts import Parts
    from inspect_validate.verification.results import Verification

__all__ = [
    "FAMILY_ARL",
    "LAMBDA",
    "Chart",
    "DriftMonitor",
    "DriftState",
    "SeriesKey",
    "chart_repeats_needed",
    "design_limit",
    "ewma_arl",
    "ewma_limit",
    "series_of",
    "series_of_parts",
]

LAMBDA = 0.2  # weight of the newest cycle: detects shifts of ~1 σ₀ within about 10 cycles
FAMILY_ARL = 1000.0  # in-control cycles between false alarms of the whole family
# Floors of σ₀ where the golden file records no standard errors (version 1): relative
# for μ and σ², absolute for dB and decades of ε.
_FLOOR = {"mean": 2e-3, "variance": 0.02, "snr_db": 0.05, "log_error": 0.05, "focus": 0.02}
_FLOOR.update(x=0.05, y=0.05, angle=0.005)  # a part's position: px, px, degrees
_FLOOR.update(slope_x=1e-4, slope_y=1e-4)  # the light's field over the parts: per 100 px
_DESIGN_STATES = 81  # Markov-chain states of the ARLs the design averages (±1 % of 201's)
_DESIGN_NODES = 12  # quadrature nodes per tail and dimension (target error, spread)

SeriesKey = tuple  # (illumination, "class" | "comparison", name, quantity)


def ewma_arl(
    limit: ArrayLike, *, lam: float = LAMBDA, shift: ArrayLike = 0.0, states: int = 201
) -> float | np.ndarray:
    """Average run length of an asymptotic-limit EWMA chart of unit-variance normal data
    whose mean is ``shift`` σ off target (Brook & Evans' Markov chain, ``states`` states
    across the in-control band ± ``limit`` σ_z), from the target. ``limit`` and ``shift``
    may be arrays (broadcast together): one ARL each."""
    from scipy.special import ndtr  # the normal CDF; scipy.stats would add 0.4 s of import

    band, mean = np.broadcast_arrays(np.asarray(limit, float), np.asarray(shift, float))
    scale = math.sqrt(lam / (2.0 - lam))  # σ_z of unit data
    # A band of no width alarms at once, and one whose edge lies more than 9 σ_z beyond
    # the chart's mean never does (an ARL past 1e17): either would make the chain's
    # matrix singular in floating point.
    never = band - np.abs(mean) / scale > 9.0
    band = np.clip(band, 1e-3, np.abs(mean) / scale + 9.0)
    h = band[..., None, None] * scale
    width = 2.0 * h / states
    k = np.arange(states) + 0.5
    centres = -h + width * k[None, :]  # (..., 1, S)
    # From state i, z' = (1 − λ) c_i + λ x falls in state j with x ~ N(shift, 1).
    lo = (centres - width / 2) - (1 - lam) * np.swapaxes(centres, -1, -2)
    hi = lo + width
    s = mean[..., None, None]
    q = ndtr(hi / lam - s) - ndtr(lo / lam - s)
    with np.errstate(all="ignore"):
        arl = np.linalg.solve(np.eye(states) - q, np.ones((*band.shape, states, 1)))
    out = np.where(never, np.inf, arl[..., states // 2, 0])
    return float(out) if out.ndim == 0 else out


@lru_cache(maxsize=64)
def ewma_limit(arl: float, *, lam: float = LAMBDA) -> float:
    """The L (in σ_z) whose in-control ARL is ``arl`` cycles, target and spread known."""
    from scipy.optimize import brentq

    return float(brentq(lambda x: math.log(ewma_arl(x, lam=lam)) - math.log(arl), 0.5, 8.0))


@lru_cache(maxsize=64)
def design_limit(arl: float, repeats: int, *, lam: float = LAMBDA, batch: int = 1) -> float:
    """The L (in σ₀-units of σ_z) whose false-alarm rate, averaged over the golden files
    of ``repeats`` repeats a station could train, is 1/``arl`` per cycle (module
    description); :func:`ewma_limit` for a known target and spread (``repeats`` < 2).
    A chart of the mean of ``batch`` parts a cycle against ``repeats`` golden parts has
    σ₀ = s/√batch, so its target's error is δ√(n/batch) ~ N(0, 1) in those units.

    The average is a quadrature over the target's error δ√n ~ N(0, 1) and the spread's
    w² = χ²_{n−1}/(n − 1), both in probability: at the small rates a family of charts
    needs, the rare golden files (a spread estimated far too small, a target far off)
    carry most of it, so the nodes are Gauss–Legendre in log₁₀ of the tail probability,
    10⁻¹⁴ … ½ (≈ 10⁻¹⁴ of the mass left out). Each node's rate is 1/ARL(L·w, shift δ)
    by the Markov chain (81 states).
    """
    from numpy.polynomial.legendre import leggauss
    from scipy.optimize import brentq
    from scipy.special import gammaincinv, ndtri

    if repeats < 2:
        return ewma_limit(arl, lam=lam)
    n, df = repeats, repeats - 1
    x, wx = leggauss(_DESIGN_NODES)
    log_p = 7.0 * (x + 1.0) - 14.0  # log₁₀ p in [−14, 0]
    p = 10.0**log_p
    mass = wx * 7.0 * math.log(10.0) * p  # dp over the nodes
    # spread: w at the lower-tail probability p (small w alarm most); the upper half of
    # the distribution by its own nodes (1 − p), each side weighted by its mass
    low = np.sqrt(2.0 * gammaincinv(df / 2.0, p / 2.0) / df)
    high = np.sqrt(2.0 * gammaincinv(df / 2.0, 1.0 - p / 2.0) / df)
    spread = np.concatenate([low, high])
    spread_w = np.concatenate([mass, mass]) / 2.0
    # target error: |δ|√n at the two-sided tail probability p (the rate is even in δ)
    shifts = -ndtri(p / 2.0) * math.sqrt(batch / n)
    d, w = np.meshgrid(shifts, spread, indexing="ij")
    weight = np.outer(mass, spread_w)
    weight /= weight.sum()

    def log_rate(limit: float) -> float:
        arl_nodes = ewma_arl(limit * w, lam=lam, shift=d, states=_DESIGN_STATES)
        # Past ~1e15 cycles the chain's solve loses its digits: such a node never alarms.
        arl_nodes = np.where(np.isfinite(arl_nodes) & (arl_nodes > 0), arl_nodes, np.inf)
        rate = float(np.sum(weight / np.maximum(arl_nodes, 1.0)))
        return math.log(max(rate, 1e-300)) + math.log(arl)

    lo = ewma_limit(arl, lam=lam)  # a known target and spread: the least L can be
    hi = lo
    while log_rate(hi) > 0:
        hi *= 1.25
        if hi > 200:
            return math.inf  # no limit reaches the rate: too few repeats
    return float(brentq(log_rate, lo, hi, xtol=1e-3)) if hi > lo else lo


def chart_repeats_needed(arl: float, factor: float) -> int:
    """The fewest repeats whose :func:`design_limit` at ``arl`` is at most ``factor`` ×
    :func:`ewma_limit` (bisection: a few designs)."""
    known = ewma_limit(arl)
    lo, hi = 2, 8
    while design_limit(arl, hi) > factor * known:
        lo, hi = hi, hi * 2
        if hi > 4096:
            return hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if design_limit(arl, mid) > factor * known else (lo, mid)
    return hi


@dataclass
class Chart:
    """One quantity's EWMA chart: target, spread, smoothed value and cycles seen."""

    target: float
    sigma: float
    ewma: float
    n: int = 0

    def update(self, x: float, *, limit: float, lam: float = LAMBDA) -> tuple[float, float, bool]:
        """Add cycle value ``x``; the smoothed value, the half-width of the band, alarm."""
        if math.isfinite(x):
            self.ewma = lam * x + (1 - lam) * self.ewma
            self.n += 1
        half = self.half_width(limit=limit, lam=lam)
        return self.ewma, half, self.n > 0 and abs(self.ewma - self.target) > half

    def half_width(self, *, limit: float, lam: float = LAMBDA) -> float:
        """Half-width of the band after the cycles seen."""
        return limit * self.sigma * math.sqrt(lam / (2 - lam) * (1 - (1 - lam) ** (2 * self.n)))

    def severity(self, *, limit: float) -> float:
        """|EWMA − target| in half-widths of the band (beyond 1: alarm)."""
        half = self.half_width(limit=limit)
        return abs(self.ewma - self.target) / half if half > 0 else 0.0


def series_of(verification: Verification) -> dict[SeriesKey, float]:
    """The monitored values of one cycle's verification."""
    values = {}
    for ill, m in verification.measurements.items():
        for c in m.classes:
            values[ill, "class", c.name, "mean"] = c.mean
            values[ill, "class", c.name, "variance"] = c.variance
        for comp in m.comparisons:
            values[ill, "comparison", comp.label, "snr_db"] = comp.snr_db
            values[ill, "comparison", comp.label, "log_error"] = float(
                _log_error(comp.error_gaussian)
            )
    return values


def series_of_parts(
    parts: Parts, illumination: str, *, dark_offset: float = 0.0
) -> dict[SeriesKey, float]:
    """The monitored values of one cycle's batch of parts on the running line (under
    ``illumination``): each quantity's mean over the parts measured (NaN for none), and
    each class's field slopes (:func:`~inspect_validate.verification.parts.parts_field`,
    of the signal above ``dark_offset``)."""
    measured = parts.measured
    ms = [p.measurement for p in measured]
    values: dict[SeriesKey, float] = {}

    def mean(xs) -> float:
        return float(np.mean(xs)) if len(xs) else math.nan

    for k, c in enumerate(ms[0].classes if ms else ()):
        values[illumination, "class", c.name, "mean"] = mean([m.classes[k].mean for m in ms])
        values[illumination, "class", c.name, "variance"] = mean(
            [m.classes[k].variance for m in ms]
        )
        values[illumination, "class", c.name, "focus"] = mean([p.focus[c.name] for p in measured])
    for j, comp in enumerate(ms[0].comparisons if ms else ()):
        values[illumination, "comparison", comp.label, "snr_db"] = mean(
            [m.comparisons[j].snr_db for m in ms]
        )
        values[illumination, "comparison", comp.label, "log_error"] = mean(
            _log_error(np.array([m.comparisons[j].error_gaussian for m in ms]))
        )
    for i, q in enumerate(("x", "y", "angle")):
        values[illumination, "pose", "part", q] = mean([p.position[i] for p in measured])
    from inspect_validate.verification.parts import parts_field

    for name, (slope, _) in parts_field(measured, dark_offset=dark_offset).items():
        values[illumination, "field", name, "slope_x"] = float(slope[0])
        values[illumination, "field", name, "slope_y"] = float(slope[1])
    return values


def _log_error(error):
    """log₁₀ ε, the charted form of ε (0 floored: perfect separation is not −inf)."""
    return np.log10(np.maximum(error, 1e-300))


def golden_targets(
    golden: Golden, *, snr_floor_db: float = -20.0, batch: int = 1, dark_offset: float = 0.0
) -> dict[SeriesKey, tuple[float, float]]:
    """(μ₀, σ₀) of every quantity the golden file holds worth charting (module
    description); of a production golden file also each class's focus measure, the
    parts' position and the field's slopes (:func:`_field_targets`), and with ``batch``
    parts a cycle σ₀ of their mean (s/√batch).
    Comparisons are charted where verify checks their drift (:func:`~inspect_validate.
    verification.golden_checks.above_floor`, at 3 spreads)."""
    from inspect_validate.verification.golden_checks import above_floor

    targets = {}

    def put(key, spread, quantity) -> None:
        v = np.array([np.nan if x is None else x for x in spread.values], float)
        se = spread.standard_error
        if quantity == "log_error":
            v = _log_error(v)
            se = math.nan  # not recorded: the fixed floor
        v = v[np.isfinite(v)]
        if not v.size:
            return
        mu = float(v.mean())
        sd = float(v.std(ddof=1)) if v.size > 1 else 0.0
        if math.isfinite(se):
            floor = se
        else:
            relative = quantity in ("mean", "variance", "focus")
            floor = _FLOOR[quantity] * (abs(mu) if relative else 1.0)
        targets[key] = (mu, max(sd, floor, 1e-12) / math.sqrt(batch))

    for ill, g in golden.illuminations.items():
        for name, cls in g.classes.items():
            put((ill, "class", name, "mean"), cls.mean, "mean")
            put((ill, "class", name, "variance"), cls.variance, "variance")
            if cls.focus is not None:
                put((ill, "class", name, "focus"), cls.focus, "focus")
        if g.pose is not None:
            for q, spread in (("x", g.pose.x), ("y", g.pose.y), ("angle", g.pose.angle)):
                put((ill, "pose", "part", q), spread, q)
            _field_targets(targets, ill, g, golden.repeats, batch, dark_offset)
        for label, comp in g.comparisons.items():
            if not above_floor(comp.snr_db, snr_floor_db):
                continue
            put((ill, "comparison", label, "snr_db"), comp.snr_db, "snr_db")
            put((ill, "comparison", label, "log_error"), comp.error_gaussian, "log_error")
    return targets


def _field_targets(targets, ill, g, n: int, batch: int, dark_offset: float) -> None:
    """(μ₀, σ₀) of each class's field slopes: the golden parts' slopes, and a batch's
    spread about them, the golden slopes' standard error times √(n/batch) (a slope's
    standard error goes as 1/√parts)."""
    from inspect_validate.verification.parts import golden_field

    for name, (slope, se) in golden_field(g, dark_offset=dark_offset).items():
        for q, s0, e0 in zip(("slope_x", "slope_y"), slope, se, strict=True):
            if math.isfinite(s0) and math.isfinite(e0):
                sd = max(e0 * math.sqrt(n / max(batch, 1)), _FLOOR[q])
                targets[ill, "field", name, q] = (float(s0), sd)


@dataclass(frozen=True)
class DriftState:
    """One cycle's charts: per quantity (value, smoothed, low, high), the alarmed keys and
    the likely cause."""

    points: dict = field(default_factory=dict)
    alarms: tuple = ()
    cause: str | None = None

    @property
    def drifting(self) -> bool:
        return bool(self.alarms)


class DriftMonitor:
    """The EWMA charts of a station against its golden file, restartable from history.

    Parameters
    ----------
    golden : Golden
    dark_offset : float
        DN the means sit on without light (relative changes are of the signal above it).
    snr_floor_db : float, keyword-only
        Comparisons below it in the golden file are not charted.
    family_arl : float, keyword-only
        In-control cycles between false alarms of all charts together.
    batch : int, keyword-only
        Production: parts a cycle, whose means are charted against the golden parts'.
    sensor : Sensor, keyword-only, optional
        The camera's EMVA values, to tell a light from a gain in a drift's cause (None: a
        station of frames alone, the two one cause).
    """

    def __init__(
        self,
        golden: Golden,
        *,
        dark_offset: float,
        snr_floor_db: float = -20.0,
        family_arl: float = FAMILY_ARL,
        batch: int = 1,
        sensor: Sensor | None = None,
    ) -> None:
        from inspect_validate.errors import InputError
        from inspect_validate.verification.golden_checks import GOOD_WIDENING, MAX_WIDENING

        self.targets = golden_targets(
            golden, snr_floor_db=snr_floor_db, batch=batch, dark_offset=dark_offset
        )
        self.sensor = sensor
        self.bench = golden.mode == "bench"  # the same samples each cycle, not other parts
        self.dark_offset = float(dark_offset)
        arl = family_arl * max(len(self.targets), 1)
        self.limit = design_limit(arl, golden.repeats, batch=batch)
        known = ewma_limit(arl)
        if not self.limit <= MAX_WIDENING * known:
            wide = "wider than any" if math.isinf(self.limit) else f"{self.limit / known:.0f} ×"
            raise InputError(
                f"{golden.repeats} repeats are too few for {len(self.targets)} drift charts at "
                f"one false alarm in {family_arl:g} cycles: their bands would be {wide} as "
                f"wide as a well-known spread sets. Train with --repeats "
                f"{chart_repeats_needed(arl, MAX_WIDENING)} or more "
                f"({chart_repeats_needed(arl, GOOD_WIDENING)} for bands within "
                f"{GOOD_WIDENING:g} ×)"
            )
        self.charts = {k: Chart(mu, sd, mu) for k, (mu, sd) in self.targets.items()}

    def restore(self, key: SeriesKey, *, ewma: float, n: int) -> None:
        """Continue a chart where an earlier run left it."""
        if key in self.charts:
            self.charts[key].ewma, self.charts[key].n = float(ewma), int(n)

    def update(self, values: dict[SeriesKey, float]) -> DriftState:
        points, alarms = {}, []
        for key, x in values.items():
            chart = self.charts.get(key)
            if chart is None:
                continue  # not in the golden file (validate_golden refuses that up front)
            ewma, half, alarm = chart.update(x, limit=self.limit)
            points[key] = (x, ewma, chart.target - half, chart.target + half)
            if alarm:
                alarms.append(key)
        return DriftState(points, tuple(alarms), self.cause(alarms) if alarms else None)

    def changes(self) -> tuple[Change, ...]:
        """The smoothed charts as changes against golden (their standard errors the
        EWMA's own spread): each class's μ (of the signal above the dark offset), σ² and
        focus measure relative, the parts' position in px and °."""
        from inspect_validate.verification.diagnosis import Change

        out = []
        for (ill, kind, name, q), chart in self.charts.items():
            se = chart.half_width(limit=self.limit) / self.limit
            if kind == "pose":
                out.append(Change(None, q, chart.ewma - chart.target, se, illumination=ill))
                continue
            if kind != "class":
                continue  # contrast follows from the classes' μ and σ²
            base = chart.target - (self.dark_offset if q == "mean" else 0.0)
            mean = self.charts.get((ill, kind, name, "mean"))
            if base > 0 and mean is not None:
                variance = self.charts.get((ill, kind, name, "variance"))
                focus = self.charts.get((ill, kind, name, "focus"))
                out.append(
                    Change(name, q, (chart.ewma - chart.target) / base, se / base,
                           mean.target - self.dark_offset,
                           variance.target if variance else math.nan,
                           focus.target if focus else math.nan, ill)
                )  # fmt: skip
        return tuple(out)

    def cause(self, alarms: Sequence[SeriesKey]) -> str:
        """The likely cause of ``alarms``: the diagnosis
        (:func:`~inspect_validate.verification.diagnosis.diagnose_changes`) of the smoothed
        charts (:meth:`changes`), sized by the EWMA. ``watch`` names a cycle's own change
        where the cycle shows one, read as ``verify`` reads it; this reading is for a
        drift too slow for one cycle to show."""
        from inspect_validate.verification.diagnosis import diagnose_changes

        text = diagnose_changes(self.changes(), sensor=self.sensor, bench=self.bench).text
        if text is not None:
            return f"{text} (smoothed over the last cycles)"
        return "drift of " + ", ".join(" ".join(k[::2]) for k in alarms[:3])
