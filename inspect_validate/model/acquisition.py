"""The acquisition model (chapter §2.5, (32)) in electrons and grey values, vectorised.

For a light l, optics o, camera c and one reflectance sample s of class k, the
mean number of photo-electrons in a pixel is

    μ_e = A·t_exp/(hc) · 1/(4N²) · ∫ E_l(λ)·R_ks(λ)·t_o(λ)·QE_c(λ)·λ dλ

(E_l the irradiance at the object, A the pixel area, N the f-number; a Lambertian
object of reflectance R imaged by an aberration-free lens, cos⁴ fall-off
neglected) — the chapter's (32) with its constant C made explicit so that
camera noise can be added (SPEC §1). Grey values follow the EMVA 1288 model
(:mod:`inspect_validate.components.cameras`) and are clipped at saturation.

All combinations are computed at once: light×optics products form the rows of
one matrix, camera×sample products those of another, and one BLAS product gives
every μ_e — no Python loop over spectra or combinations.

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

from dataclasses import dataclass

import numpy as np
from scipy import special

from inspect_validate.comparisons import Comparisons, gaussian_separation
from inspect_validate.components.cameras import Camera
from inspect_validate.components.lights import Light
from inspect_validate.components.optics import Optics
from inspect_validate.constants import C, H
from inspect_validate.errors import InputError
from inspect_validate.spectra import Spectrum

__all__ = ["Exposure", "ObjectClass", "Prediction", "predict"]

QUANTISATION_VARIANCE = 1.0 / 12.0  # DN²
_PRESENT = 1e-6  # a component is present where it exceeds this fraction of its peak
COVERAGE = 0.99
"""A class's reflectance must span this fraction of a combination's spectral response."""
_MAX_REASONS = 20  # skipped combinations listed by name; the rest are counted


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


@dataclass(frozen=True, eq=False)
class Prediction:
    """Predicted statistics for every light × optics × camera combination.

    Arrays are indexed ``[light, optics, camera, ...]``; the last axis is the
    class (``mean``, ``variance``, ...) or the comparison (``snr_db``, ...).
    """

    lights: tuple[str, ...]
    optics: tuple[str, ...]
    cameras: tuple[str, ...]
    classes: tuple[str, ...]
    comparison_set: Comparisons
    grid: np.ndarray
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
    sample_electrons: (
        np.ndarray
    )  # mean μ_e per reflectance sample, before clipping, (L, O, C, S_total)
    sample_mean: np.ndarray  # DN per reflectance sample, (L, O, C, S_total)
    sample_variance: np.ndarray  # temporal DN² per sample, (L, O, C, S_total)
    sample_class: np.ndarray  # class index of each sample, (S_total,)
    valid: np.ndarray  # (L, O, C) bool: False where the combination was skipped (values NaN)
    skipped: tuple[str, ...] = ()  # why combinations were skipped (at most 20 named, then a count)
    absolute: np.ndarray | None = None  # (L,) bool: the light's irradiance is known (times in s)

    @property
    def comparisons(self) -> tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]:
        """Each comparison as ``(first names, second names)``, the order of the last axis."""
        return self.comparison_set.named

    @property
    def shape(self) -> tuple[int, int, int]:
        return len(self.lights), len(self.optics), len(self.cameras)


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


def predict(
    lights: list[Light],
    optics: list[Optics],
    cameras: list[Camera],
    classes: list[ObjectClass],
    *,
    exposure: Exposure = Exposure(),
    grid: np.ndarray,
    comparisons: Comparisons | None = None,
) -> Prediction:
    """Predict μ, σ², SNR_dB, CNR, Fisher ratio and ε Gauss for every combination.

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

    n_l, n_o, n_c, n_s = len(lights), len(optics), len(cameras), r_all.shape[0]
    lo_rows = (e[:, None, :] * t[None, :, :]).reshape(n_l * n_o, grid.size)
    present = _present(e), _present(t), _present(q)
    _check_masked(classes, present, invalid, sample_class, grid)
    cs_rows = (q[:, None, :] * r_all[None, :, :]).reshape(n_c * n_s, grid.size)
    rate = (lo_rows @ cs_rows.T).reshape(n_l, n_o, n_c, n_s)  # e⁻/s per sample

    k_count = len(classes)
    onehot = np.zeros((n_s, k_count))
    onehot[np.arange(n_s), sample_class] = 1.0
    per_class = onehot.sum(axis=0)
    class_rate = rate @ onehot / per_class  # mean e⁻/s per class

    valid, skipped = _feasible(
        lights, optics, cameras, classes, present, q, lo_rows, inside, class_rate
    )
    # Skipped combinations are computed on a stand-in rate (kept finite so no
    # warning or NaN travels through the arithmetic) and blanked at the end.
    rate = np.where(valid[..., None], rate, 1.0)
    class_rate = np.where(valid[..., None], class_rate, 1.0)

    cam = {
        f: np.array([getattr(c, f) for c in cameras])
        for f in ("gain", "dark_noise", "saturation", "dark_offset")
    }
    max_dn = np.array([c.max_dn for c in cameras])
    if exposure.mode == "auto":
        brightest = class_rate.max(axis=-1)
        t_exp = exposure.target * cam["saturation"][None, None, :] / brightest
        if exposure.max_time:
            t_exp = np.minimum(t_exp, exposure.max_time)
    else:
        t_exp = np.full((n_l, n_o, n_c), exposure.time)

    mu_e = rate * t_exp[..., None]
    gain = cam["gain"][None, None, :, None]
    mean_s = cam["dark_offset"][None, None, :, None] + gain * mu_e
    var_s = gain**2 * (cam["dark_noise"][None, None, :, None] ** 2 + mu_e) + QUANTISATION_VARIANCE
    clip_mean, clip_var, above = _clipped_moments(mean_s, var_s, max_dn[None, None, :, None])

    mean = clip_mean @ onehot / per_class
    # Spectral spread: unbiased variance (39) of the samples' means within each class.
    dev2 = (clip_mean - mean @ onehot.T) ** 2
    spectral = (dev2 @ onehot) / np.maximum(per_class - 1, 1)
    variance = clip_var @ onehot / per_class + spectral
    saturated = above @ onehot / per_class

    names = tuple(c.name for c in classes)
    comparisons = comparisons or Comparisons.of(names)
    if comparisons.classes != names:
        raise InputError(f"the comparisons are of classes {comparisons.classes}, not {names}")
    sep = gaussian_separation(mean, variance, comparisons, valid=valid)

    def blank(a):
        """NaN where the combination was skipped."""
        return np.where(valid.reshape(valid.shape + (1,) * (a.ndim - 3)), a, np.nan)

    return Prediction(
        lights=tuple(lt.name for lt in lights),
        optics=tuple(o.name for o in optics),
        cameras=tuple(c.name for c in cameras),
        classes=names,
        comparison_set=comparisons,
        grid=grid,
        exposure_time=blank(t_exp),
        electrons=blank(class_rate * t_exp[..., None]),
        mean=blank(mean),
        variance=blank(variance),
        spectral_variance=blank(spectral),
        saturated_fraction=blank(saturated),
        snr_db=blank(sep.snr_db),
        cnr_db=blank(sep.cnr_db),
        fisher_db=blank(sep.fisher_db),
        error_gaussian=blank(sep.error_gaussian),
        log_error_gaussian=blank(sep.log_error_gaussian),
        sample_electrons=blank(mu_e),
        sample_mean=blank(clip_mean),
        sample_variance=blank(clip_var),
        sample_class=sample_class,
        valid=valid,
        skipped=skipped,
        absolute=absolute,
    )


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
    would only add rounding.
    """
    ceiling = np.broadcast_to(ceiling, mean.shape)
    sd = np.sqrt(var)
    a = (ceiling - mean) / sd
    m, v, tail = mean.copy(), var.copy(), np.zeros_like(mean)
    near = a <= 8.0
    if near.any():
        mu, s, c, z = mean[near], sd[near], ceiling[near], a[near]
        cdf, upper, pdf = (
            special.ndtr(z),
            special.ndtr(-z),
            np.exp(-0.5 * z * z) / np.sqrt(2 * np.pi),
        )
        first = mu * cdf - s * pdf + c * upper
        second = (mu**2 + s**2) * cdf - s * pdf * (mu + c) + c**2 * upper
        m[near], v[near], tail[near] = first, np.maximum(second - first**2, 0.0), upper
    return m, v, tail


def _present(a):
    return a > _PRESENT * a.max(axis=-1, keepdims=True)


def _feasible(lights, optics, cameras, classes, present, q, lo_rows, inside, class_rate):
    """Which combinations can be predicted, and why the others cannot.

    Model curves (Gaussian tails, logistic edges) are never exactly zero, so a
    component counts as present where it exceeds 1e-6 of its own peak.

    Returns
    -------
    valid : ndarray of bool, shape (L, O, C)
    reasons : tuple of str
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
    valid = shared & ~uncovered.any(axis=-1) & ~dark
    reasons = []
    for li, oi, ci in np.argwhere(~valid)[:_MAX_REASONS]:
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
        else:
            why = "no class reflects anything the camera sees"
        reasons.append(f"{combo}: {why}")
    n_bad = int((~valid).sum())
    if n_bad > _MAX_REASONS:
        reasons.append(f"... and {n_bad - _MAX_REASONS} more combinations")
    if not valid.any():
        raise InputError("no combination of the scene can be predicted:\n  " + "\n  ".join(reasons))
    return valid, tuple(reasons)


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
