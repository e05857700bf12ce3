"""The best mix of a multi-channel controller's lights: drive levels that minimise the worst
comparison's ε (or maximise its CNR), with the camera's noise in the loop and no class
saturating.

Channel c at 100 % gives reflectance sample s ``E[c, s]`` photo-electrons at the
exposure (the acquisition model (32), linear in the light). At drive levels
w ∈ [0, 1]ᴺ a sample collects μ_e(s) = Σ_c w_c E[c, s], so class k has

    μ_k  = d + K m_kᵀ w                                  (linear in w)
    σ²_k = K² wᵀ C_k w  +  K² (σ_d² + m_kᵀ w) + 1/12      (spectral + temporal)

with m_k and C_k the mean and (unbiased) covariance of the class's samples'
per-channel responses, K the system gain (DN/e⁻), σ_d the dark noise (e⁻), d
the dark offset (DN); the spectral term is quadratic in w, the temporal (EMVA
1288) linear through the photon count. This is what ``predict`` computes for the
mixed light, before clipping. No class may saturate: every sample's mean stays
z·σ below the largest grey value, z the normal quantile of the allowed
saturated fraction, σ the temporal noise at that grey value — a linear
constraint on w.

The objective is the worst named comparison's ε_tot (37) — each side a mixture
of its classes' Gaussians, exact, with the exact gradient of
:func:`~inspect_validate.stats.kde_error.mixture_error_gradient` — or its
contrast-to-noise ratio CNR = |μ₁ − μ₂| / √(σ₁² + σ₂²), each side's μ and σ²
the moments of its classes' mixture (what ``predict`` reports as ``cnr_db``).
ε weighs the tails the classes overlap in; CNR only the first two moments, so
the two optima differ where a side's classes are far apart (a group) or their
spreads differ much. Either is minimised in log space (log ε, −log CNR) as an
epigraph problem (SLSQP) from several starts: each channel alone, all
channels equal, the Fisher direction S⁻¹Δm of each comparison (the
generalised-eigenvalue solution that maximises (wᵀΔm)²/wᵀSw), and seeded
random mixes, each scaled up to the saturation limit.

A catalogue of more than :data:`JOINT_MAX` lights is not optimised jointly (SLSQP's
dense steps grow as N³, and the many starts with N): the optimum uses a few lights
(at most about one per active comparison), so a working set is optimised —
the best lights alone at their saturation limit, and those whose first-order
slope from the best of them promises most — and then, column generation, every
light outside it whose slope says adding a little would lower the worst loss
joins it, until none does (:func:`first_order_slopes`). The result is then
optimal in first order over the whole catalogue.

At a fixed exposure the levels are bounded by 100 %. With the exposure free
(auto exposure) only the product of level and exposure time counts, so a
caller optimises with ``max_level`` the longest exposure over the given one
and rescales (:func:`~inspect_validate.mix_design.solve.solve`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.components.optics import Optics
    from inspect_validate.components.sensors import SensorModel
    from inspect_validate.model.acquisition import ObjectClass

__all__ = [
    "JOINT_MAX",
    "OBJECTIVES",
    "ChannelResponse",
    "Mix",
    "channel_response",
    "comparison_cnr",
    "comparison_errors",
    "comparison_losses",
    "first_order_slopes",
    "mix_moments",
    "optimise_mix",
    "single_losses",
]

OBJECTIVES = ("error", "cnr")  # minimise the worst ε_tot; maximise the worst CNR

_LOG_FLOOR = 1e-300  # ε below this is perfect separation for any purpose
_SCREEN_ITERATIONS = 8  # SLSQP iterations from every start before choosing which to polish
_POLISHED = 3  # distinct screened ends run to convergence
JOINT_MAX = 48
"""Most channels optimised jointly; a larger catalogue is screened (column generation)."""
_ADDED = 4  # channels joining the working set per round of column generation


@dataclass(frozen=True, eq=False)
class ChannelResponse:
    """Photo-electrons each channel gives each reflectance sample at 100 %, and the camera.

    Attributes
    ----------
    electrons : ndarray, (N, S)
        e⁻ per sample at 100 % drive and the exposure time, channels in the
        problem's order.
    sample_class : ndarray of int, (S,)
    sensor : SensorModel
        K (DN/e⁻), dark noise (e⁻), dark offset and largest grey value (DN).
    """

    electrons: np.ndarray
    sample_class: np.ndarray
    sensor: SensorModel

    @cached_property
    def class_statistics(self) -> tuple[np.ndarray, np.ndarray]:
        """Per class the mean response m_k (K, N) and its covariance C_k (K, N, N), e⁻."""
        n = self.electrons.shape[0]
        means, covs = [], []
        for k in range(int(self.sample_class.max()) + 1):
            e = self.electrons[:, self.sample_class == k]
            means.append(e.mean(axis=1))
            covs.append(np.cov(e, ddof=1).reshape(n, n) if e.shape[1] > 1 else np.zeros((n, n)))
        return np.array(means), np.array(covs)

    @cached_property
    def screened(self) -> dict:
        """:func:`single_losses` already computed, by its arguments."""
        return {}

    def subset(self, channels: Sequence[int]) -> ChannelResponse:
        """The response of ``channels`` (indices) only, its class statistics sliced, not
        recomputed."""
        idx = np.asarray(channels, dtype=int)
        sub = ChannelResponse(self.electrons[idx], self.sample_class, self.sensor)
        m, c = self.class_statistics
        sub.__dict__["class_statistics"] = (m[:, idx], c[:, idx][:, :, idx])
        return sub

    def signal(self, levels: ArrayLike) -> np.ndarray:
        """Each sample's mean signal K·μ_e above the dark offset at ``levels``, DN."""
        return self.sensor.gain * (np.asarray(levels, float) @ self.electrons)

    def ceiling(self, max_saturated: float) -> float:
        """Largest mean signal K·μ_e (DN above the offset) a sample may reach."""
        from scipy import special  # scipy.stats would add 0.4 s of import to this

        from inspect_validate.components.sensors import grey_value

        cam = self.sensor
        z = -float(special.ndtri(max_saturated))  # the normal's isf, as scipy.stats.norm
        top = cam.max_dn - cam.dark_offset
        _, variance = grey_value(top / cam.gain, cam.gain, cam.dark_noise, cam.dark_offset)
        return top - z * np.sqrt(variance)


def channel_response(
    channels: dict,
    optics: Optics,
    sensor: SensorModel,
    classes: Sequence[ObjectClass],
    *,
    grid: np.ndarray,
    exposure_time: float,
) -> ChannelResponse:
    """:class:`ChannelResponse` of scene lights (label → Light with its irradiance) through
    ``optics`` onto ``sensor`` at ``exposure_time`` s.

    Raises
    ------
    InputError
        A channel whose light the model cannot predict for these classes (a
        reflectance not measured where the light shines), naming the reason.
    """
    from inspect_validate.model import Exposure, predict

    lights = list(channels.values())
    p = predict(
        lights,
        [optics],
        [sensor],
        list(classes),
        exposure=Exposure("fixed", time=float(exposure_time)),
        grid=grid,
    )
    assert p.sample_electrons is not None  # a full prediction keeps its samples
    electrons = p.sample_electrons[:, 0, 0]
    bad = ~np.all(np.isfinite(electrons), axis=1)
    if bad.any():
        label = list(channels)[int(np.argmax(bad))]
        raise InputError(
            f"channel {label} ({lights[int(np.argmax(bad))].name}) cannot be predicted: "
            + "; ".join(p.skipped[:1])
        )
    return ChannelResponse(np.ascontiguousarray(electrons), np.asarray(p.sample_class), sensor)


def mix_moments(
    response: ChannelResponse, levels: ArrayLike, *, jacobian: bool = False
) -> tuple[np.ndarray, ...]:
    """Class means (DN) and variances (DN²) at drive ``levels`` (N,), before clipping;
    with ``jacobian`` also ∂μ/∂w and ∂σ²/∂w, (K, N) each."""
    from inspect_validate.components.sensors import grey_value

    cam = response.sensor
    w = np.asarray(levels, dtype=np.float64)
    m, c = response.class_statistics
    k2 = cam.gain**2
    mean, temporal = grey_value(m @ w, cam.gain, cam.dark_noise, cam.dark_offset)
    cw = c @ w  # (K, N)
    variance = k2 * (cw @ w) + temporal
    if not jacobian:
        return mean, variance
    return mean, variance, cam.gain * m, k2 * (2.0 * cw + m)


@overload
def comparison_errors(
    response: ChannelResponse,
    levels: ArrayLike,
    comparisons: Comparisons,
    *,
    gradient: Literal[False] = False,
) -> np.ndarray: ...
@overload
def comparison_errors(
    response: ChannelResponse,
    levels: ArrayLike,
    comparisons: Comparisons,
    *,
    gradient: Literal[True],
) -> tuple[np.ndarray, np.ndarray]: ...
def comparison_errors(
    response: ChannelResponse,
    levels: ArrayLike,
    comparisons: Comparisons,
    *,
    gradient: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """ε_tot (37) of every comparison at ``levels``, (P,); with ``gradient`` also ∂ε/∂w, (P, N).

    Comparisons of one class against one class are evaluated together in closed
    form (:func:`~inspect_validate.stats.gaussian_error.gaussian_error_gradient`);
    a group's side is a mixture of its classes' Gaussians.
    """
    from inspect_validate.stats.gaussian_error import gaussian_error_gradient
    from inspect_validate.stats.kde_error import mixture_error_gradient
    from inspect_validate.stats.mixture import Mixture

    mean, var, d_mean, d_var = mix_moments(response, levels, jacobian=True)
    sd = np.sqrt(var)
    d_sd = d_var / (2.0 * sd[:, None])  # ∂σ/∂w = ∂σ²/∂w / 2σ
    groups = [(list(g1), list(g2)) for g1, g2 in comparisons.groups]
    errors = np.empty(len(groups))
    grads = np.zeros((len(groups), np.size(levels)))
    single = [p for p, (g1, g2) in enumerate(groups) if len(g1) == len(g2) == 1]
    if single:
        i = np.array([groups[p][0][0] for p in single])
        j = np.array([groups[p][1][0] for p in single])
        e, _, dm1, ds1, dm2, ds2 = gaussian_error_gradient(mean[i], sd[i], mean[j], sd[j])
        errors[single] = e
        if gradient:
            grads[single] = (
                dm1[:, None] * d_mean[i]
                + ds1[:, None] * d_sd[i]
                + dm2[:, None] * d_mean[j]
                + ds2[:, None] * d_sd[j]
            )
    prior = comparisons.class_weights()
    for p, (g1, g2) in enumerate(groups):
        if p in single:
            continue
        mixed, dm1, ds1, dm2, ds2 = mixture_error_gradient(
            Mixture(mean[g1], prior[g1] / prior[g1].sum(), sd[g1]),
            Mixture(mean[g2], prior[g2] / prior[g2].sum(), sd[g2]),
        )
        errors[p] = mixed
        if gradient:
            for g, dm, ds in ((g1, dm1, ds1), (g2, dm2, ds2)):
                grads[p] += dm @ d_mean[g] + ds @ d_sd[g]
    return (errors, grads) if gradient else errors


@overload
def comparison_cnr(
    response: ChannelResponse,
    levels: ArrayLike,
    comparisons: Comparisons,
    *,
    gradient: Literal[False] = False,
) -> np.ndarray: ...
@overload
def comparison_cnr(
    response: ChannelResponse,
    levels: ArrayLike,
    comparisons: Comparisons,
    *,
    gradient: Literal[True],
) -> tuple[np.ndarray, np.ndarray]: ...
def comparison_cnr(
    response: ChannelResponse,
    levels: ArrayLike,
    comparisons: Comparisons,
    *,
    gradient: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """CNR |μ₁ − μ₂| / √(σ₁² + σ₂²) of every comparison at ``levels``, (P,), each side the
    moments of its classes' mixture; with ``gradient`` also ∂CNR/∂w, (P, N)."""
    mean, var, d_mean, d_var = mix_moments(response, levels, jacobian=True)
    prior = comparisons.class_weights()
    sides = []
    for s in (0, 1):
        # (P, K): each comparison's side s as normalised class weights
        pi = np.zeros((len(comparisons.groups), mean.size))
        for p, pair in enumerate(comparisons.groups):
            g = list(pair[s])
            pi[p, g] = prior[g] / prior[g].sum()
        m = pi @ mean
        dev = mean[None, :] - m[:, None]
        v = pi @ var + (pi * dev**2).sum(axis=1)  # Σπσ² + Σπ(μ − μ̄)², no cancellation
        # ∂v = Σπ∂σ² + 2Σπ(μ − μ̄)∂μ (the ∂μ̄ term sums to 0)
        sides.append((m, v, pi @ d_mean, pi @ d_var + 2.0 * (pi * dev) @ d_mean))
    (m1, v1, dm1, dv1), (m2, v2, dm2, dv2) = sides
    diff, total = m1 - m2, v1 + v2  # total ≥ 2/12 DN²: quantisation noise
    cnr = np.abs(diff) / np.sqrt(total)
    if not gradient:
        return cnr
    grad = np.sign(diff)[:, None] * (dm1 - dm2) / np.sqrt(total)[:, None] - 0.5 * (cnr / total)[
        :, None
    ] * (dv1 + dv2)
    return cnr, grad


def comparison_losses(
    response: ChannelResponse,
    levels: ArrayLike,
    comparisons: Comparisons,
    *,
    objective: str = "error",
    gradient: bool = False,
) -> Any:
    """What :func:`optimise_mix` minimises per comparison, (P,): log ε_tot, or −log CNR;
    with ``gradient`` also its ∂/∂w, (P, N)."""
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, not {objective!r}")
    quantity = comparison_errors if objective == "error" else comparison_cnr
    if not gradient:
        return _loss(objective, quantity(response, levels, comparisons))
    values, g = quantity(response, levels, comparisons, gradient=True)
    # d log(v + floor) = dv / (v + floor); d −log max(r, floor) = −dr / max(r, floor)
    # (equal means: CNR 0, its gradient 0 too if for every w)
    scale = values + _LOG_FLOOR if objective == "error" else -np.maximum(values, _LOG_FLOOR)
    return _loss(objective, values), g / scale[:, None]


def _loss(objective: str, values):
    """log ε (floored: ε = 0 is perfect, not −inf) or −log CNR (CNR 0 floored)."""
    if objective == "error":
        return np.log(values + _LOG_FLOOR)
    return -np.log(np.maximum(values, _LOG_FLOOR))


@dataclass(frozen=True, eq=False)
class Mix:
    """The optimal drive levels and what they give.

    Attributes
    ----------
    levels : ndarray, (N,)
        Drive level of each channel, 0–1 (may exceed 1 with ``max_level``).
    errors, cnr : ndarray, (P,)
        ε_tot and CNR (a ratio, not dB) of every comparison at ``levels``.
    objective_kind : str
        What was optimised: ``"error"`` (the worst ε) or ``"cnr"`` (the worst CNR).
    worst : int
        Index of the comparison the objective is about (highest ε, lowest CNR).
    starts : int
        Local optimisations run.
    """

    levels: np.ndarray
    errors: np.ndarray
    cnr: np.ndarray
    objective_kind: str
    worst: int
    starts: int

    @property
    def objective(self) -> float:
        """The worst comparison's ε_tot, or its CNR."""
        values = self.errors if self.objective_kind == "error" else self.cnr
        return float(values[self.worst])

    @property
    def loss(self) -> float:
        """What was minimised (log ε or −log CNR of the worst comparison): lower is better
        whatever the objective."""
        return float(_loss(self.objective_kind, self.objective))


def optimise_mix(
    response: ChannelResponse,
    comparisons: Comparisons,
    *,
    objective: str = "error",
    max_saturated: float = 1e-3,
    max_level: float = 1.0,
    random_starts: int = 4,
    seed: int = 0,
    starts: Sequence[np.ndarray] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Mix:
    """Drive levels in [0, ``max_level``]ᴺ that minimise the worst comparison's ε_tot (or
    maximise its CNR), no class saturating (see the module's description).

    Parameters
    ----------
    response : ChannelResponse
    comparisons : Comparisons
        Those whose worst ε (CNR) is optimised (every one the objective should see).
    objective : {"error", "cnr"}, keyword-only
    max_saturated : float, keyword-only
        Allowed saturated fraction of a sample's pixels (sets z of the ceiling).
    max_level : float, keyword-only
        Upper bound of each level: 1 at a fixed exposure; larger stands for a
        longer exposure (the caller rescales).
    random_starts : int, keyword-only
        Seeded random mixes besides the structured starts.
    starts : sequence of array_like, keyword-only, optional
        Start from these levels only, each run until log ε moves by less than
        1e-6 (a screening), instead of the structured and random starts: a warm
        start from a neighbouring problem.
    progress : callable, keyword-only, optional
        ``progress(message)`` at each round of a screened catalogue (more than
        :data:`JOINT_MAX` channels).

    Raises
    ------
    InputError
        The camera's noise alone saturates, or no channel gives any signal.
    """
    from scipy import optimize

    n = response.electrons.shape[0]
    if n > JOINT_MAX and not starts:
        return _screened(
            response,
            comparisons,
            objective=objective,
            max_saturated=max_saturated,
            max_level=max_level,
            random_starts=random_starts,
            seed=seed,
            progress=progress,
        )
    a = response.sensor.gain * response.electrons.T  # (S, N): DN per sample per unit level
    ceiling = response.ceiling(max_saturated)
    if not ceiling > 0:
        raise InputError(
            "the camera's temporal noise alone saturates more than the allowed fraction "
            f"({max_saturated:g}) at any signal: allow more, or use a camera with more headroom"
        )

    def scaled(w):
        """``w`` scaled up (or down) to the saturation limit and the level bounds."""
        w = np.clip(np.asarray(w, float), 0.0, None)
        if not w.max() > 0:
            return None
        w = w / w.max()  # a start of subnormal levels (a Fisher direction) would overflow
        peak = float(response.signal(w).max())
        if not peak > 0:
            return None
        # min() after: ceiling / peak is inf for a channel of subnormal signal.
        with np.errstate(over="ignore"):
            return w * min(float(ceiling) / peak, max_level)

    warm = bool(starts)
    if not warm:
        starts = _structured_starts(response, comparisons, random_starts, seed)
    # SLSQP works in u = w / unit, unit the level at which a channel alone reaches the
    # ceiling: a very bright channel's levels of 1e-6 and signals of 1e8 DN per unit
    # level would leave it ill-conditioned (it stepped to NaN).
    peaks = a.max(axis=0)
    with np.errstate(over="ignore", divide="ignore"):
        unit = np.clip(ceiling / peaks, 1e-300, max_level)  # no signal: inf → max_level
    kept = [w for w in (scaled(x) for x in starts or ()) if w is not None]
    # Starts that scale to the same mix (every start of a single channel) are run once.
    starts = list(np.unique(np.round(np.divide(kept, unit), 12), axis=0) * unit) if kept else []
    if not starts:
        raise InputError("no channel gives any signal on these classes")

    cache: dict[bytes, tuple] = {}

    def losses(u):
        key = u.tobytes()
        if key not in cache:  # SLSQP asks for a constraint's value and Jacobian apart
            cache.clear()
            f, g = comparison_losses(
                response, u * unit, comparisons, objective=objective, gradient=True
            )
            cache[key] = (f, g * unit)
        return cache[key]

    def epigraph(x):
        return x[-1], np.r_[np.zeros(n), 1.0]

    relative = a * unit / ceiling  # (S, N): each sample's share of the ceiling per unit u
    constraints = [
        {
            "type": "ineq",  # t − loss_p(w) ≥ 0
            "fun": lambda x: x[-1] - losses(x[:-1])[0],
            "jac": lambda x: np.c_[-losses(x[:-1])[1], np.ones(len(comparisons.groups))],
        },
        {
            "type": "ineq",  # 1 − K·E_sᵀ w / ceiling ≥ 0 for every sample
            "fun": lambda x: 1.0 - relative @ x[:-1],
            "jac": lambda x: np.c_[-relative, np.zeros(a.shape[0])],
        },
    ]
    bounds = [(0.0, max_level / u) for u in unit] + [(None, None)]

    def run(w0, maxiter, ftol: float = 1e-12):
        x0 = np.r_[w0 / unit, losses(w0 / unit)[0].max()]
        res = optimize.minimize(
            epigraph,
            x0,
            jac=True,
            method="SLSQP",
            bounds=bounds,
            constraints=constraints,
            options={"maxiter": maxiter, "ftol": ftol},
        )
        w = np.clip(res.x[:-1] * unit, 0.0, max_level)
        if response.signal(w).max() > ceiling * (1 + 1e-9):
            w = scaled(w)  # SLSQP may end a hair outside; pull back onto the limit
        return w, comparison_losses(response, w, comparisons, objective=objective)

    def worst(result):
        return result[1].max()

    if warm:
        # A screening: the loss to 1e-6 ranks neighbouring problems; the chosen are polished.
        w, loss = min((run(w0, 60, 1e-6) for w0 in starts), key=worst)
    else:
        # A few iterations from every start find the basins; only the best few distinct
        # ends are run to convergence (most of a run's evaluations are its last digits).
        screened = sorted((run(w0, _SCREEN_ITERATIONS) for w0 in starts), key=worst)
        ends = np.unique(np.round([w / unit for w, _ in screened], 3), axis=0, return_index=True)[1]
        polished = [run(screened[i][0], 200) for i in sorted(ends)[:_POLISHED]]
        w, loss = min([*polished, screened[0]], key=worst)
    return Mix(
        levels=w,
        errors=comparison_errors(response, w, comparisons),
        cnr=comparison_cnr(response, w, comparisons),
        objective_kind=objective,
        worst=int(np.argmax(loss)),
        starts=len(starts),
    )


def first_order_slopes(
    response: ChannelResponse,
    levels: ArrayLike,
    comparisons: Comparisons,
    *,
    objective: str = "error",
    band: float = float(np.log(2.0)),
    at_limit: bool = True,
) -> np.ndarray:
    """How the worst loss (log ε, −log CNR) moves per unit of each channel's level added
    at ``levels`` (N,); negative: adding the channel helps. With ``at_limit`` the mix is
    scaled down to keep its brightest sample's signal (the saturation limit binds);
    without, the light is added as it is. Taken as the largest over the comparisons
    within ``band`` of the worst loss (the worst may switch to them; at a tie a channel
    must help each)."""
    w = np.asarray(levels, float)
    f, g = comparison_losses(response, w, comparisons, objective=objective, gradient=True)
    active = f >= f.max() - band
    if not at_limit:
        return g[active].max(axis=0)
    signal = response.signal(w)
    brightest = int(np.argmax(signal))
    scale = response.sensor.gain * response.electrons[:, brightest] / max(signal[brightest], 1e-300)
    return (g[active] - np.outer(g[active] @ w, scale)).max(axis=0)


def single_losses(
    response: ChannelResponse,
    comparisons: Comparisons,
    *,
    objective: str = "error",
    max_saturated: float,
    max_level: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Each channel alone at its saturation limit (where one light's ε is lowest: more
    light, less relative noise): its level (N,) and every comparison's loss (N, P)."""
    key = (id(comparisons), objective, max_saturated, max_level)
    if key in response.screened:  # solve and the screened optimiser both ask
        return response.screened[key]
    peaks = response.sensor.gain * response.electrons.max(axis=1)
    ceiling = response.ceiling(max_saturated)
    with np.errstate(divide="ignore"):
        levels = np.where(peaks > 0, np.minimum(ceiling / peaks, max_level), 0.0)
    losses = np.array(
        [
            comparison_losses(
                response.subset([c]), levels[c : c + 1], comparisons, objective=objective
            )
            for c in range(len(levels))
        ]
    )
    response.screened[key] = levels, losses
    return levels, losses


def _screened(response, comparisons, *, progress=None, **options) -> Mix:
    """:func:`optimise_mix` of a large catalogue by column generation (module notes)."""
    n = response.electrons.shape[0]
    objective = options["objective"]
    _, alone = single_losses(
        response,
        comparisons,
        objective=objective,
        max_saturated=options["max_saturated"],
        max_level=options["max_level"],
    )
    if progress:
        progress(f"screened {n} lights alone")
    # The best lights for each comparison alone, then the best for the worst of them.
    per = max(2, JOINT_MAX // (2 * alone.shape[1]))
    screened = {int(c) for p in range(alone.shape[1]) for c in np.argsort(alone[:, p])[:per]}
    for c in np.argsort(alone.max(axis=1)):
        if len(screened) >= JOINT_MAX:
            break
        screened.add(int(c))
    work = sorted(screened)
    mix = optimise_mix(response.subset(work), comparisons, **options)
    starts = mix.starts
    for _round in range(n):  # ends: lights join only while they lower the loss
        w = np.zeros(n)
        w[work] = mix.levels
        # Candidates: the lights whose addition would lower a tied worst comparison's
        # loss, were there room under the saturation limit (at a tie one light rarely
        # helps all; and the optimiser makes room by lowering the right others, which
        # a first-order slope with the whole mix scaled down misses). Tried, not trusted.
        f = comparison_losses(response, w, comparisons, objective=objective)
        tied = np.flatnonzero(f >= f.max() - 1e-3)
        joining = set()
        for p in [*tied, None]:
            keep = tied if p is None else [p]
            which = comparisons.subset([comparisons.labels[i] for i in keep])
            slopes = first_order_slopes(
                response, w, which, objective=objective, band=np.inf, at_limit=False
            )
            slopes[work] = np.inf
            joining |= {int(c) for c in np.argsort(slopes)[:_ADDED] if slopes[c] < -1e-9}
        if progress:
            progress(f"working set of {len(work)} lights, worst {mix.objective:.3g}")
        if not joining:
            break
        grown = sorted(set(work) | joining)
        if len(grown) > JOINT_MAX:  # lights the optimum left at 0 make room
            kept = [c for c, level in zip(work, mix.levels, strict=True) if level > 0]
            grown = sorted(set(kept) | joining)
        warm = np.array([w[c] for c in grown])
        # From where the last optimum was, and afresh: the grown set may have a better
        # basin than the one the warm start sits in (seen on 60 LEDs: 1.0e-3 warm, 7.8e-4).
        trials = [
            optimise_mix(response.subset(grown), comparisons, starts=[warm], **options),
            optimise_mix(response.subset(grown), comparisons, **options),
        ]
        starts += sum(t.starts for t in trials)
        trial = min(trials, key=lambda t: t.loss)
        if trial.loss >= mix.loss - 1e-9:
            break  # no candidate lowers the worst loss: done
        work, mix = grown, trial
    w = np.zeros(n)
    w[work] = mix.levels
    return Mix(
        levels=w,
        errors=comparison_errors(response, w, comparisons),
        cnr=comparison_cnr(response, w, comparisons),
        objective_kind=objective,
        worst=mix.worst,
        starts=starts,
    )


def _structured_starts(response, comparisons, random_starts, seed):
    """Each channel alone, the equal mix, each comparison's Fisher direction (±) and
    seeded random mixes (unscaled)."""
    n = response.electrons.shape[0]
    starts = [np.eye(n)[c] for c in range(n)] + [np.ones(n)]
    m, c = response.class_statistics
    for g1, g2 in comparisons.groups:
        # Fisher direction of the two sides' mean responses: S⁻¹Δm, each sign.
        d = m[list(g1)].mean(axis=0) - m[list(g2)].mean(axis=0)
        s = c[list(g1)].mean(axis=0) + c[list(g2)].mean(axis=0)
        ridge = 1e-9 * np.trace(s) / n
        # Classes without spread: every direction has S-norm 0, Δm itself is as good.
        direction = np.linalg.solve(s + ridge * np.eye(n), d) if ridge > 0 else d
        if np.all(np.isfinite(direction)):
            starts += [direction, -direction]
    rng = np.random.default_rng(seed)
    starts += list(rng.dirichlet(np.ones(n), size=random_starts))
    return starts
