"""The acquisition model (chapter §2.5, (32)) in electrons and grey values, vectorised.

For a light l, optics o, camera c and one reflectance sample s of class k, the
mean number of photo-electrons in a pixel is

    μ_e = A·t_exp/(hc) · 1/(4N²) · ∫ E_l(λ)·R_ks(λ)·t_o(λ)·QE_c(λ)·λ dλ

(E_l the irradiance at the object, A the pixel area, N the f-number; a Lambertian
object of reflectance R imaged by an aberration-free lens, cos⁴ fall-off
neglected) — the chapter's (32) with its constant C made explicit so that
camera noise can be added. Grey values follow the EMVA 1288 model
(:mod:`inspect_validate.components.sensors`) and are clipped at saturation.

All combinations are computed at once: light×optics products form the rows of
one matrix, camera×sample products those of another, and one BLAS product gives
every μ_e — no Python loop over spectra or combinations. The engine is shared with
:func:`~inspect_validate.model.sweep` (which streams blocks of a sweep too large to
hold): :func:`prepare` puts the components on one grid (a :class:`Chain`), and
:func:`predict_block` predicts any block of its combinations; :func:`predict` is the
one block of them all.

Integration runs over the wavelengths where every component of a combination
is defined (outside its measured range a component is taken as absent, never
extrapolated). A combination that cannot be predicted — no wavelength where
light, optics and camera all respond, a class whose reflectance covers less than
99 % of that response (a file in µm, a class measured over 380–475 nm under a
590 nm LED), or no class reflecting anything the camera sees — is skipped with
its reason (:attr:`Prediction.skipped`); the rest of the sweep is kept. A
reflectance marked invalid (34) where the chain is sensitive is an error naming
the file: that is a measurement to repeat, not a candidate to skip.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.comparisons import Comparisons
from inspect_validate.components.lights import Light
from inspect_validate.components.optics import Optics
from inspect_validate.components.sensors import SensorModel, grey_value
from inspect_validate.constants import LONGEST_EXPOSURE_S, C, H
from inspect_validate.errors import InputError
from inspect_validate.separations import gaussian_separation
from inspect_validate.spectra import Spectrum

__all__ = [
    "MAX_REASONS",
    "PREDICT_MAX_BYTES",
    "Block",
    "Chain",
    "Combinations",
    "Exposure",
    "ObjectClass",
    "Prediction",
    "Signal",
    "nothing_predictable",
    "predict",
    "predict_block",
    "predict_chain",
    "prepare",
    "skipped_reasons",
]

_PRESENT = 1e-6  # a component is present where it exceeds this fraction of its peak
COVERAGE = 0.99
"""A class's reflectance must span this fraction of a combination's spectral response."""
MAX_REASONS = 20
"""Skipped combinations listed by name; the rest are counted."""


@dataclass(frozen=True)
class ObjectClass:
    """An object class: reflectance samples (their spread is the class's spectral variance)."""

    name: str
    reflectance: Spectrum


@dataclass(frozen=True)
class Exposure:
    """Exposure control.

    ``mode="auto"``: per combination, the exposure time that puts the brightest
    class's mean at ``target`` × saturation capacity (capped at ``max_time``, s).
    ``mode="fixed"``: ``time`` seconds for every combination (needs lights with
    an absolute irradiance).
    """

    mode: str = "auto"
    time: float | None = None
    target: float = 0.7
    max_time: float | None = None

    def __post_init__(self):
        if self.mode not in ("auto", "fixed"):
            raise InputError(f"exposure mode must be 'auto' or 'fixed', not {self.mode!r}")
        if self.mode == "fixed" and not (self.time and self.time > 0):
            raise InputError("a fixed exposure needs a positive 'time' in seconds")
        if not 0 < self.target <= 1:
            raise InputError("exposure target must be a fraction of saturation in (0, 1]")


@dataclass(frozen=True, eq=False, repr=False)  # a short repr: __repr__
class Combinations:
    """The light × optics × camera axes, the classes and the comparisons of a prediction
    or a ranking."""

    lights: tuple[str, ...]
    optics: tuple[str, ...]
    cameras: tuple[str, ...]
    classes: tuple[str, ...]
    comparison_set: Comparisons
    grid: np.ndarray
    if TYPE_CHECKING:  # the statistics every kind of result has (its own fields)
        mean: np.ndarray
        snr_db: np.ndarray
        error_gaussian: np.ndarray

    @property
    def comparisons(self) -> tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]:
        """Each comparison as ``(first names, second names)``, the order of the last axis."""
        return self.comparison_set.named

    @property
    def shape(self) -> tuple[int, int, int]:
        return len(self.lights), len(self.optics), len(self.cameras)

    def __repr__(self) -> str:
        lights, optics, cameras = self.shape
        return (
            f"<{type(self).__name__}: {lights} lights × {optics} optics × {cameras} cameras, "
            f"{len(self.classes)} classes ({', '.join(self.classes[:6])}), "
            f"{len(self.comparison_set.named)} comparisons; .table() for the numbers>"
        )

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.table())}</pre>"

    def table(self) -> str:
        """Each combination's class means and each comparison's SNR_dB and ε Gauss, as text."""
        from inspect_validate.text import format_error, render_table

        names = [f"{','.join(a)} vs {','.join(b)}" for a, b in self.comparisons]
        header = ["light", "optics", "camera"]
        header += [f"μ {c} [DN]" for c in self.classes]
        header += [f"{n} SNR_dB" for n in names] + [f"{n} ε" for n in names]
        rows = []
        for at, (li, oi, ci) in self._rows():
            rows.append(
                [self.lights[li], self.optics[oi], self.cameras[ci]]
                + [f"{m:.4g}" for m in self.mean[at]]
                + [f"{x:.2f}" for x in self.snr_db[at]]
                + [format_error(e) for e in self.error_gaussian[at]]
            )
        return render_table(header, rows)

    def _rows(self):
        """(where a combination's values are, its (light, optics, camera) indices)."""
        for at in np.ndindex(self.shape):
            yield at, at


@dataclass(frozen=True, eq=False, repr=False)  # a short repr: __repr__
class Prediction(Combinations):
    """Predicted statistics for every light × optics × camera combination.

    Arrays are indexed ``[light, optics, camera, ...]``; the last axis is the
    class (``mean``, ``variance``, ...) or the comparison (``snr_db``, ...).
    """

    exposure_time: np.ndarray  # s, (L, O, C)
    electrons: np.ndarray  # mean μ_e per class, (L, O, C, K)
    mean: np.ndarray  # DN, (L, O, C, K)
    variance: np.ndarray  # DN², (L, O, C, K)
    spectral_variance: np.ndarray  # DN², the part from the reflectance samples' spread
    saturated_fraction: np.ndarray  # (L, O, C, K)
    snr_db: np.ndarray  # (L, O, C, P)
    cnr_db: np.ndarray
    fisher_db: np.ndarray
    error_gaussian: np.ndarray
    log_error_gaussian: np.ndarray
    # Per reflectance sample, (L, O, C, S_total): photo-electrons μ_e before clipping, mean
    # DN, and the variance of its pixels, DN²: temporal and the sensor's fixed pattern
    # (``None`` in a sweep's blocks, which compute them for the rows they keep).
    sample_electrons: np.ndarray | None
    sample_mean: np.ndarray | None
    sample_variance: np.ndarray | None
    sample_class: np.ndarray  # class index of each sample, (S_total,)
    valid: np.ndarray  # (L, O, C) bool: False where the combination was skipped (values NaN)
    skipped: tuple[str, ...] = ()  # why combinations were skipped (at most 20 named, then a count)
    absolute: np.ndarray | None = None  # (L,) bool: the light's irradiance is known (times in s)


def _on_grid(spectra: list[Spectrum], grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values (first sample each) on the grid with 0 outside the range, and where defined."""
    values = np.stack([s.resample(grid)[0] for s in spectra])
    defined = np.isfinite(values)
    return np.where(defined, values, 0.0), defined


def _trapezoid_weights(grid: np.ndarray) -> np.ndarray:
    w = np.zeros_like(grid)
    d = np.diff(grid)
    w[:-1] += d / 2
    w[1:] += d / 2
    return w


@dataclass(frozen=True, eq=False)
class Chain:
    """A sweep's components on its grid: what every block of combinations shares."""

    components: tuple[list, list, list, list]  # lights, optics, cameras, classes
    comparisons: Comparisons
    exposure: Exposure
    grid: np.ndarray
    e: np.ndarray  # W·m⁻²·nm⁻¹ per light, (L, W)
    t: np.ndarray  # transmission / 4N², (O, W)
    q: np.ndarray  # e⁻ per (W/m²·s) per nm bin, QE·A·λ/(hc)·trapezoid weight, (C, W)
    r_mean: np.ndarray  # each class's mean reflectance, (K, W)
    r_centred: np.ndarray  # each sample less its class's mean, (S, W)
    sample_class: np.ndarray  # (S,)
    inside: np.ndarray  # where each class is measured, (K, W)
    present: tuple[np.ndarray, np.ndarray, np.ndarray]
    absolute: np.ndarray  # (L,)
    onehot: np.ndarray  # (S, K)
    per_class: np.ndarray  # (K,)
    sensor: dict[str, np.ndarray]  # gain, dark_noise, saturation, dark_offset, max_dn,
    # dark_current, dsnu, prnu: (C,)
    # Each class's share of each light over its region (mean factor m, relative spread
    # v: :mod:`~inspect_validate.characterization.field`), (L, K, 2); None: a point.
    field: np.ndarray | None = None
    # The frames' shading corrected by that field (each pixel's signal above dark divided
    # by its F): each class at the light's maximum, its noise and texture divided alike.
    field_corrected: bool = False
    # The share of each class's texture (its spectral spread) each light's frames keep
    # through the lens's blur (:func:`~inspect_validate.model.mtf.texture_share`), (L,);
    # None: a sharp lens.
    texture_share: np.ndarray | None = None
    _rows: dict = dataclasses.field(default_factory=dict, repr=False)  # the last cameras'

    @property
    def names(self) -> tuple[tuple[str, ...], ...]:
        """Names of the lights, optics, cameras and classes."""
        return tuple(tuple(x.name for x in c) for c in self.components)

    @property
    def shape(self) -> tuple[int, int, int]:
        lights, optics, cameras = (len(c) for c in self.components[:3])
        return lights, optics, cameras

    def scaled(self, factors: ArrayLike) -> Chain:
        """The chain with each light's irradiance times its factor, (L,): the signal is
        linear in the irradiance, so a calibration needs no new spectral integration."""
        factors = np.asarray(factors, dtype=np.float64)
        return dataclasses.replace(self, e=self.e * factors[:, None], _rows=self._rows)

    def camera_rows(self, cs: slice) -> tuple[np.ndarray, np.ndarray]:
        """The cameras ``cs`` times each class's mean reflectance, (c·K, W), and times each
        centred sample, (c·S, W): the right-hand sides of a block's products. Blocks that
        differ only in their lights and optics share them (kept for the last ``cs``)."""
        key = (cs.start, cs.stop)
        if key not in self._rows:
            q = self.q[cs][:, None, :]
            n_w = self.grid.size
            self._rows.clear()
            self._rows[key] = (
                (q * self.r_mean[None]).reshape(-1, n_w),
                (q * self.r_centred[None]).reshape(-1, n_w),
            )
        return self._rows[key]


def prepare(
    lights: Sequence[Light],
    optics: Sequence[Optics],
    cameras: Sequence[SensorModel],
    classes: Sequence[ObjectClass],
    *,
    exposure: Exposure,
    grid: np.ndarray,
    comparisons: Comparisons | None,
) -> Chain:
    """Validate the components and put them on the integration grid."""
    if len(classes) < 2:
        raise InputError("a scene needs at least two object classes to separate")
    grid = np.asarray(grid, float)
    weights = _trapezoid_weights(grid)

    e, _ = _on_grid([light.spd for light in lights], grid)
    absolute = np.array([light.irradiance is not None for light in lights])
    if exposure.mode == "fixed" and not absolute.all():
        bad = lights[int(np.argmin(absolute))]
        raise InputError(
            f"light {bad.name!r} ({bad.spd.source}) has only a relative SPD; give its irradiance "
            "(W/m²) or use 'exposure: auto'"
        )
    e *= _irradiance_scale(lights)[:, None]

    t, _ = _on_grid([o.transmission for o in optics], grid)
    t /= (4.0 * np.array([o.f_number for o in optics]) ** 2)[:, None]
    qe, _ = _on_grid([c.qe for c in cameras], grid)
    area = (np.array([c.pixel_pitch for c in cameras]) * 1e-6) ** 2
    q = qe * (area[:, None] * grid[None, :] * 1e-9 / (H * C)) * weights[None, :]

    refl = [cl.reflectance.resample(grid) for cl in classes]
    sample_class = np.concatenate([np.full(r.shape[0], k) for k, r in enumerate(refl)])
    r_all = np.concatenate(refl)
    # Outside its measured range a reflectance does not integrate, like every
    # component; NaN *inside* the range is a masked value (34) and must not count.
    inside = np.stack(
        [(grid >= c.reflectance.range[0]) & (grid <= c.reflectance.range[1]) for c in classes]
    )
    invalid = ~np.isfinite(r_all) & inside[sample_class]
    r_all = np.where(np.isfinite(r_all), r_all, 0.0)
    present = _present(e), _present(t), _present(q)
    _check_masked(classes, present, invalid, sample_class, grid)

    onehot = np.zeros((r_all.shape[0], len(classes)))
    onehot[np.arange(r_all.shape[0]), sample_class] = 1.0
    per_class = onehot.sum(axis=0)
    r_mean = (onehot.T @ r_all) / per_class[:, None]
    names = tuple(c.name for c in classes)
    comparisons = comparisons or Comparisons.of(names)
    if comparisons.classes != names:
        raise InputError(f"the comparisons are of classes {comparisons.classes}, not {names}")
    sensor = {
        f: np.array([getattr(c, f) for c in cameras], dtype=float)
        for f in (
            "gain",
            "dark_noise",
            "saturation",
            "dark_offset",
            "max_dn",
            "dark_current",
            "dsnu",
            "prnu",
        )
    }
    return Chain(
        components=(list(lights), list(optics), list(cameras), list(classes)),
        comparisons=comparisons,
        exposure=exposure,
        grid=grid,
        e=e,
        t=t,
        q=q,
        r_mean=r_mean,
        r_centred=r_all - r_mean[sample_class],
        sample_class=sample_class,
        inside=inside,
        present=present,
        absolute=absolute,
        onehot=onehot,
        per_class=per_class,
        sensor=sensor,
    )


PREDICT_MAX_BYTES = 2**31
"""Most memory :func:`predict` may hold for the per-sample arrays of every combination;
a larger scene is :func:`~inspect_validate.model.sweep`'s (blocks, best rows kept)."""


def predict(
    lights: list[Light],
    optics: list[Optics],
    cameras: list[SensorModel],
    classes: list[ObjectClass],
    *,
    exposure: Exposure = Exposure(),
    grid: np.ndarray,
    comparisons: Comparisons | None = None,
) -> Prediction:
    """Predict μ, σ², SNR_dB, CNR, Fisher ratio and ε Gauss for every combination.

    Every array holds every combination (about 1.5 kB each with 60 reflectance
    samples); a sweep too large for that is :func:`~inspect_validate.model.sweep`'s.

    Parameters
    ----------
    lights, optics, cameras : lists of components
    classes : list of ObjectClass
        At least two.
    exposure : Exposure, keyword-only
    grid : ndarray, keyword-only
        Integration wavelengths, nm (trapezoidal rule).
    comparisons : Comparisons, keyword-only, optional
        Which groups of classes to compare and how a group is weighted; default
        every pair and each class against the rest, equal weights.
    """
    combinations = len(lights) * len(optics) * len(cameras)
    samples = sum(c.reflectance.n_samples for c in classes)
    held = combinations * samples * 8 * 8  # the per-sample arrays and their intermediates
    if held > PREDICT_MAX_BYTES:
        raise InputError(
            f"{len(lights)} × {len(optics)} × {len(cameras)} = {combinations} combinations: "
            f"predicting them all at once would hold about {held / 2**30:.1f} GB of arrays "
            f"(above {PREDICT_MAX_BYTES / 2**30:.0f} GB) and take each group's mixture ε for "
            "every one; rank them with sweep (Scene.sweep(by=..., comparison=..., top=...), "
            "what 'inspect-validate predict' does), which keeps the best rows of each block"
        )
    return predict_chain(
        prepare(
            lights, optics, cameras, classes, exposure=exposure, grid=grid, comparisons=comparisons
        )
    )


def predict_chain(chain: Chain) -> Prediction:
    """:func:`predict` of a prepared chain: every combination, with the per-sample arrays.

    Raises
    ------
    InputError
        Where no combination can be predicted (each reason named).
    """
    everything = slice(None)
    block = predict_block(chain, everything, everything, everything)
    p = block.prediction
    if block.n_bad == p.valid.size:
        raise nothing_predictable(block.reasons, block.n_bad)
    mu_e, mean, var, _ = block.signal.samples(everything, everything, everything)
    blank = p.valid[..., None]
    return dataclasses.replace(
        p,
        sample_electrons=np.where(blank, mu_e, np.nan),
        sample_mean=np.where(blank, mean, np.nan),
        sample_variance=np.where(blank, var, np.nan),
    )


def nothing_predictable(reasons: Sequence[str], n_bad: int) -> InputError:
    """The error of a scene none of whose combinations can be predicted."""
    return InputError(
        "no combination of the scene can be predicted:\n  "
        + "\n  ".join(skipped_reasons(reasons, n_bad))
    )


def skipped_reasons(reasons: Sequence[str], n_bad: int) -> tuple[str, ...]:
    """The first :data:`MAX_REASONS` reasons, then how many more combinations were skipped."""
    listed = tuple(reasons[:MAX_REASONS])
    if n_bad > len(listed):
        return (*listed, f"... and {n_bad - len(listed)} more combinations")
    return listed


def _temporal(cam):
    """The camera fields :func:`grey_value` takes, from a chain's camera dict."""
    return cam["gain"], cam["dark_noise"], cam["dark_offset"]


def _fixed_pattern(mu_e, cam):
    """The spatial variance the sensor's non-uniformities add over a region, DN²:
    K²(DSNU² + PRNU²·μ_e²) (EMVA 1288, §8)."""
    return cam["gain"] ** 2 * (cam["dsnu"] ** 2 + (cam["prnu"] * mu_e) ** 2)


@dataclass(frozen=True, eq=False)
class Signal:
    """What a block's per-sample statistics are computed from."""

    class_rate: np.ndarray  # mean e⁻/s per class, (l, o, c, K)
    deviation: np.ndarray  # each sample's e⁻/s minus its class's, (l, o, c, S)
    exposure_time: np.ndarray  # s, (l, o, c), stand-ins where skipped
    sensor: dict[str, np.ndarray]  # the block's cameras, (c,)
    sample_class: np.ndarray  # (S,)

    def samples(
        self, li: Any, oi: Any, ci: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """μ_e (unclipped), clipped mean (DN), temporal variance (DN²) and fraction
        above saturation (``None``: nowhere near) of every reflectance sample of the
        combinations at block indices (or slices) ``li, oi, ci``."""
        rate = self.class_rate[li, oi, ci][..., self.sample_class]
        t = self.exposure_time[li, oi, ci][..., None]
        mu_e = (rate + self.deviation[li, oi, ci]) * t
        cam = {f: v[ci][..., None] for f, v in self.sensor.items()}
        mean, var = grey_value(mu_e + cam["dark_current"] * t, *_temporal(cam))
        # A sample's pixels spread by the non-uniformities too (clipped as if Gaussian).
        var = var + _fixed_pattern(mu_e, cam)
        return (mu_e, *_clipped_moments(mean, var, cam["max_dn"]))


@dataclass(frozen=True, eq=False)
class Block:
    """A block's prediction (no per-sample arrays: :meth:`Signal.samples`), skips and
    their reasons."""

    prediction: Prediction
    signal: Signal
    n_bad: int
    reasons: tuple[str, ...]


def predict_block(
    chain: Chain, ls: slice, os: slice, cs: slice, *, mixtures: Iterable[int] | None = None
) -> Block:
    """:func:`predict` of the lights ``ls`` × optics ``os`` × cameras ``cs`` of a chain,
    without the per-sample arrays (:meth:`Signal.samples` gives them).

    ``mixtures``: the group comparisons whose ε (a root search per combination)
    to compute; all by default (see :func:`~inspect_validate.separations.gaussian_separation`).

    One matrix product gives each sample's signal *relative to its class's mean*
    (reflectances centred before the product: the spectral spread (39) without
    the cancellation of a difference of large sums), a small one the class
    means. Until a combination nears saturation its grey values are affine in
    the signal, so its class statistics follow from these in closed form; only
    a combination whose brightest sample may be within 8σ of saturation is
    clipped sample by sample.
    """
    e, t, q = chain.e[ls], chain.t[os], chain.q[cs]
    cam = {f: v[cs] for f, v in chain.sensor.items()}
    onehot, per_class, sample_class = chain.onehot, chain.per_class, chain.sample_class
    n_l, n_o, n_c = e.shape[0], t.shape[0], q.shape[0]
    lo_rows = (e[:, None, :] * t[None, :, :]).reshape(n_l * n_o, chain.grid.size)
    mean_rows, centred_rows = chain.camera_rows(cs)
    class_rate = (lo_rows @ mean_rows.T).reshape(n_l, n_o, n_c, per_class.size)  # e⁻/s
    deviation = (lo_rows @ centred_rows.T).reshape(n_l, n_o, n_c, sample_class.size)
    spread = None
    if chain.field is not None:
        # A region at m of the light sees every sample at m (on average over its pixels)
        m = chain.field[ls][:, None, None, :, 0]
        class_rate = class_rate * m
        deviation = deviation * m[..., sample_class]
        spread = chain.field[ls][:, None, None, :, 1]

    lights, optics, cameras, classes = (
        c[s] for c, s in zip(chain.components, (ls, os, cs, slice(None)), strict=True)
    )
    pe, pt, pq = chain.present
    exposure = chain.exposure
    needed = None
    if exposure.mode == "auto" and not exposure.max_time:
        with np.errstate(divide="ignore", over="ignore"):
            needed = exposure.target * cam["saturation"][None, None, :] / class_rate.max(axis=-1)
    valid, n_bad, reasons = _feasible(
        lights,
        optics,
        cameras,
        classes,
        (pe[ls], pt[os], pq[cs]),
        q,
        lo_rows,
        chain.inside,
        class_rate,
        needed=needed,
    )
    if n_bad:
        # Skipped combinations are computed on a stand-in signal (kept finite so no
        # warning or NaN travels through the arithmetic) and blanked at the end.
        class_rate = np.where(valid[..., None], class_rate, 1.0)
        deviation = np.where(valid[..., None], deviation, 0.0)

    if exposure.mode == "auto":
        # The brightest class's *mean* at the target, as the chapter sets its exposure.
        t_exp = exposure.target * cam["saturation"][None, None, :] / class_rate.max(axis=-1)
        if exposure.max_time:
            t_exp = np.minimum(t_exp, exposure.max_time)
    else:
        t_exp = np.full((n_l, n_o, n_c), exposure.time)

    gain, dark, offset = (cam[f][None, None, :] for f in ("gain", "dark_noise", "dark_offset"))
    dark_e = cam["dark_current"][None, None, :] * t_exp  # e⁻ of dark current per exposure
    squares = np.square(deviation) @ onehot  # Σ (sample − class mean)², (e⁻/s)²
    signal = class_rate * t_exp[..., None]  # μ_e per class
    mean, variance = grey_value(
        signal + dark_e[..., None], gain[..., None], dark[..., None], offset[..., None]
    )
    spectral = (gain[..., None] * t_exp[..., None]) ** 2 * squares / np.maximum(per_class - 1, 1)
    blurred = 1.0 if chain.texture_share is None else chain.texture_share[ls][:, None, None, None]
    spectral = spectral * blurred
    # The spectral spread and the sensor's own fixed pattern: both spatial, independent.
    variance += spectral + _fixed_pattern(
        signal, {f: v[None, None, :, None] for f, v in cam.items()}
    )
    saturated = np.zeros_like(mean)

    # No sample is brighter than its class mean plus √Σ(deviation²): where even that
    # is 8σ below saturation, clipping changes nothing a double holds (Φc(8) ≈ 6e-16).
    brightest = ((class_rate + np.sqrt(squares)) * t_exp[..., None]).max(axis=-1) + dark_e
    top_mean, top_var = grey_value(brightest, gain, dark, offset)
    top_var = top_var + _fixed_pattern(brightest, {f: v[None, None, :] for f, v in cam.items()})
    gap = cam["max_dn"][None, None, :] - top_mean
    near = valid & ((gap <= 0) | (gap * gap <= 64.0 * top_var))
    per_sample = Signal(class_rate, deviation, t_exp, cam, sample_class)
    if near.any():
        idx = np.nonzero(near)
        _, sample_mean, sample_var, above = per_sample.samples(*idx)
        m = sample_mean @ onehot / per_class
        dev2 = (sample_mean - m[:, sample_class]) ** 2
        sp = (dev2 @ onehot) / np.maximum(per_class - 1, 1)
        if chain.texture_share is not None:
            sp = sp * chain.texture_share[ls][idx[0]][:, None]
        mean[idx], spectral[idx] = m, sp
        variance[idx] = sample_var @ onehot / per_class + sp
        if above is not None:
            saturated[idx] = above @ onehot / per_class

    if chain.field_corrected and chain.field is not None:
        # A pixel at F corrected to d + (x − d)/F: the signal back at the maximum, every
        # spatial and temporal deviation of it divided by F (shot noise's by √F of its
        # F·S; E[1/F²] over a region is 1/m² to the order of its spread, which is gone).
        m = chain.field[ls][:, None, None, :, 0]
        dark_level = offset[..., None] + gain[..., None] * dark_e[..., None]
        mean = dark_level + (mean - dark_level) / m
        variance = variance / (m * m)
        spectral = spectral / (m * m)
        # The signal the corrected frames show (a calibration scales it): the maximum's.
        signal = signal / m
        spread = None
    if spread is not None:
        # The field's spread over a region: a pixel at F of the light shows F·S, so the
        # region's variance gains Var[F]·S² = v·(m S)² (the texture's and noise's own
        # change with F is of the order of v itself: left out)
        variance = variance + spread * (gain[..., None] * signal) ** 2
    sep = gaussian_separation(mean, variance, chain.comparisons, valid=valid, mixtures=mixtures)

    def blank(a):
        """NaN where the combination was skipped."""
        if not n_bad:
            return a
        return np.where(valid.reshape(valid.shape + (1,) * (a.ndim - 3)), a, np.nan)

    prediction = Prediction(
        lights=tuple(lt.name for lt in lights),
        optics=tuple(o.name for o in optics),
        cameras=tuple(c.name for c in cameras),
        classes=tuple(c.name for c in classes),
        comparison_set=chain.comparisons,
        grid=chain.grid,
        exposure_time=blank(t_exp),
        electrons=blank(signal),
        mean=blank(mean),
        variance=blank(variance),
        spectral_variance=blank(spectral),
        saturated_fraction=blank(saturated),
        snr_db=blank(sep.snr_db),
        cnr_db=blank(sep.cnr_db),
        fisher_db=blank(sep.fisher_db),
        error_gaussian=blank(sep.error_gaussian),
        log_error_gaussian=blank(sep.log_error_gaussian),
        sample_electrons=None,
        sample_mean=None,
        sample_variance=None,
        sample_class=sample_class,
        valid=valid,
        skipped=skipped_reasons(reasons, n_bad),
        absolute=chain.absolute[ls],
    )
    return Block(prediction, per_sample, n_bad, reasons)


def _irradiance_scale(lights) -> np.ndarray:
    """Factor turning each SPD into W·m⁻²·nm⁻¹ at the object.

    An absolute light integrates to its ``irradiance`` over its ``band``; a
    relative one to 1 over its whole range (an arbitrary scale that auto
    exposure cancels; its exposure times are relative).
    """
    scale = np.empty(len(lights))
    for i, light in enumerate(lights):
        total = float(np.trapezoid(np.nan_to_num(light.spd.values[0]), light.spd.wavelengths))
        if not (np.isfinite(total) and total > 0):
            raise InputError(
                f"light {light.name!r}: the SPD is zero everywhere (or not finite)",
                source=light.spd.source,
            )
        if light.irradiance is None:
            scale[i] = 1.0 / total
            continue
        in_band = light.band_power()
        if not in_band > 0:
            raise InputError(
                f"light {light.name!r} emits nothing in its irradiance band "
                f"{light.band[0]:g}–{light.band[1]:g} nm (it spans {light.spd.range[0]:g}–"
                f"{light.spd.range[1]:g} nm); give irradiance_band: [lo, hi] where it emits",
                source=light.spd.source,
            )
        scale[i] = light.irradiance / in_band
    return scale


def _clipped_moments(mean, var, ceiling):
    """Mean, variance and exceedance of min(X, ceiling) for X ~ N(mean, var), elementwise.

    Only values within 8σ of the ceiling are touched: below that the clipping
    changes nothing a double can hold (Φc(8) ≈ 6e-16), and the closed forms
    would only add rounding. Where nothing is that near — the usual case — the
    inputs are returned as they are, with exceedance ``None`` (zero).
    """
    ceiling = np.broadcast_to(ceiling, mean.shape)
    # (ceiling − mean)² ≤ 64 σ² with mean < ceiling, or mean ≥ ceiling: no square root,
    # no division over the whole array.
    gap = ceiling - mean
    near = (gap <= 0) | (gap * gap <= 64.0 * var)
    if not near.any():
        return mean, var, None
    # Not scipy.special.ndtr: its import was 0.14 s of a 0.54 s predict (paperboard).
    from inspect_validate.stats.gaussian_error import normal_cdf_pair

    m, v, tail = mean.copy(), var.copy(), np.zeros_like(mean)
    mu, c = mean[near], ceiling[near]
    s = np.sqrt(var[near])
    z = (c - mu) / s
    cdf, upper = normal_cdf_pair(z)
    pdf = np.exp(-0.5 * z * z) / np.sqrt(2 * np.pi)
    first = mu * cdf - s * pdf + c * upper
    second = (mu**2 + s**2) * cdf - s * pdf * (mu + c) + c**2 * upper
    m[near], v[near], tail[near] = first, np.maximum(second - first**2, 0.0), upper
    return m, v, tail


def _present(a):
    return a > _PRESENT * a.max(axis=-1, keepdims=True)


def _feasible(
    lights, optics, cameras, classes, present, q, lo_rows, inside, class_rate, *, needed=None
):
    """Which combinations can be predicted, and why the others cannot.

    Model curves (Gaussian tails, logistic edges) are never exactly zero, so a
    component counts as present where it exceeds 1e-6 of its own peak. ``needed``: the
    automatic exposure each combination would need, s; longer than
    :data:`~inspect_validate.constants.LONGEST_EXPOSURE_S` is too dim (reflectances of
    1e-300 asked for 10³⁰⁰ s).

    Returns
    -------
    valid : ndarray of bool, shape (L, O, C)
    n_bad : int
        Combinations skipped.
    reasons : tuple of str
        Why, for the first :data:`MAX_REASONS` of them.
    """
    n_l, n_o, n_c, n_w = len(lights), len(optics), len(cameras), q.shape[-1]
    # Wavelengths where light, optics and camera are all present, counted per
    # combination by one product of indicator matrices: no (L, O, C, W) array,
    # which at 10⁶ combinations would take ~0.6 GB.
    pe, pt, pq = present
    light_optics = (pe[:, None, :] & pt[None, :, :]).reshape(-1, n_w).astype(np.float32)
    shared = (light_optics @ pq.T.astype(np.float32)).reshape(n_l, n_o, n_c) > 0
    # The chain's response e·t·q, in all and inside each class's measured range.
    total = (lo_rows @ q.T).reshape(n_l, n_o, n_c)
    covered = (lo_rows @ (q[:, None, :] * inside[None, :, :]).reshape(-1, n_w).T).reshape(
        n_l, n_o, n_c, len(classes)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        coverage = np.where(total[..., None] > 0, covered / total[..., None], 0.0)
    uncovered = coverage < COVERAGE
    dark = ~(class_rate.max(axis=-1) > 0)
    dim = np.zeros_like(dark) if needed is None else ~dark & ~(needed <= LONGEST_EXPOSURE_S)
    valid = shared & ~uncovered.any(axis=-1) & ~dark & ~dim
    reasons = []
    for li, oi, ci in np.argwhere(~valid)[:MAX_REASONS]:
        combo = f"{lights[li].name} × {optics[oi].name} × {cameras[ci].name}"
        if not shared[li, oi, ci]:
            parts = [lights[li].spd, optics[oi].transmission, cameras[ci].qe]
            why = (
                "no wavelength where light, optics and camera all respond ("
                + "; ".join(f"{p.name} {p.range[0]:g}–{p.range[1]:g} nm" for p in parts)
                + ")"
            )
        elif uncovered[li, oi, ci].any():
            k = int(np.argmax(uncovered[li, oi, ci]))
            r = classes[k].reflectance
            why = (
                f"class {classes[k].name!r} is measured over {r.range[0]:g}–{r.range[1]:g} nm "
                f"({r.source}), {100 * coverage[li, oi, ci, k]:.3g} % of where this chain responds "
                f"(at least {100 * COVERAGE:g} % needed)"
            )
        elif dim[li, oi, ci]:
            why = (
                f"the brightest class needs an exposure of {needed[li, oi, ci]:.3g} s to reach "
                f"the target (at most {LONGEST_EXPOSURE_S:g} s without exposure.max_time): too "
                "little light reaches the camera"
            )
        else:
            why = "no class reflects anything the camera sees"
        reasons.append(f"{combo}: {why}")
    return valid, int((~valid).sum()), tuple(reasons)


def _check_masked(classes, present, invalid, sample_class, grid):
    """No reflectance marked invalid (34) where some light, optics and camera all respond."""
    pe, pt, pq = present
    anywhere = pe.any(axis=0) & pt.any(axis=0) & pq.any(axis=0)
    bad = invalid & anywhere[None, :]
    if bad.any():
        s, _j = (int(x[0]) for x in np.nonzero(bad))
        cls = classes[int(sample_class[s])]
        span = grid[bad[s]]
        raise InputError(
            f"class {cls.name!r}: reflectance invalid (masked) at {span.min():g}–{span.max():g} nm, "
            "where the chain is sensitive; re-measure there or narrow the scene's wavelength range",
            source=cls.reflectance.source,
        )
