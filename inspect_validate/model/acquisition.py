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
extrapolated); a combination with no such wavelength, or a reflectance marked
invalid where the rest of the chain is sensitive, is an error naming the file.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np
from scipy import special

from inspect_validate.components.cameras import Camera
from inspect_validate.components.lights import Light
from inspect_validate.components.optics import Optics
from inspect_validate.constants import C, H
from inspect_validate.errors import InputError
from inspect_validate.spectra import Spectrum
from inspect_validate.stats import cnr_db, fisher_db, gaussian_error_and_log, snr_db

__all__ = ["Exposure", "ObjectClass", "Prediction", "predict"]

QUANTISATION_VARIANCE = 1.0 / 12.0  # DN²
_PRESENT = 1e-6  # a component is present where it exceeds this fraction of its peak


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
    comparisons: tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]
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
    """
    if len(classes) < 2:
        raise InputError("a scene needs at least two object classes to separate")
    grid = np.asarray(grid, float)
    weights = _trapezoid_weights(grid)

    e, _e_def = _on_grid([light.spd for light in lights], grid)
    relative = [light.irradiance is None for light in lights]
    if exposure.mode == "fixed" and any(relative):
        bad = lights[relative.index(True)]
        raise InputError(
            f"light {bad.name!r} ({bad.spd.source}) has only a relative SPD; give its irradiance "
            "(W/m²) or use 'exposure: auto'"
        )
    # Absolute lights: scale to the stated irradiance; relative ones to 1 W/m².
    totals = np.array(
        [np.trapezoid(np.nan_to_num(lt.spd.values[0]), lt.spd.wavelengths) for lt in lights]
    )
    if np.any(totals <= 0):
        bad = lights[int(np.argmin(totals))]
        raise InputError("the light's SPD is zero everywhere", source=bad.spd.source)
    e *= (np.array([lt.irradiance or 1.0 for lt in lights]) / totals)[:, None]

    t, _t_def = _on_grid([o.transmission for o in optics], grid)
    t /= (4.0 * np.array([o.f_number for o in optics]) ** 2)[:, None]
    qe, _q_def = _on_grid([c.qe for c in cameras], grid)
    area = (np.array([c.pixel_pitch for c in cameras]) * 1e-6) ** 2
    q = qe * (area[:, None] * grid[None, :] * 1e-9 / (H * C)) * weights[None, :]

    refl = [cl.reflectance.resample(grid) for cl in classes]
    sample_class = np.concatenate([np.full(r.shape[0], k) for k, r in enumerate(refl)])
    r_all = np.concatenate(refl)
    # Outside its measured range a reflectance does not integrate, like every
    # component; NaN *inside* the range is a masked value (34) and must not count.
    inside = np.concatenate(
        [
            np.broadcast_to(
                (grid >= cl.reflectance.range[0]) & (grid <= cl.reflectance.range[1]), r.shape
            )
            for cl, r in zip(classes, refl, strict=True)
        ]
    )
    invalid = ~np.isfinite(r_all) & inside
    r_all = np.where(np.isfinite(r_all), r_all, 0.0)

    _check_overlap(lights, optics, cameras, classes, e, t, q, invalid, sample_class, grid)

    n_l, n_o, n_c, n_s = len(lights), len(optics), len(cameras), r_all.shape[0]
    lo_rows = (e[:, None, :] * t[None, :, :]).reshape(n_l * n_o, grid.size)
    cs_rows = (q[:, None, :] * r_all[None, :, :]).reshape(n_c * n_s, grid.size)
    rate = (lo_rows @ cs_rows.T).reshape(n_l, n_o, n_c, n_s)  # e⁻/s per sample

    k_count = len(classes)
    onehot = np.zeros((n_s, k_count))
    onehot[np.arange(n_s), sample_class] = 1.0
    per_class = onehot.sum(axis=0)
    class_rate = rate @ onehot / per_class  # mean e⁻/s per class

    cam = {
        f: np.array([getattr(c, f) for c in cameras])
        for f in ("gain", "dark_noise", "saturation", "dark_offset")
    }
    max_dn = np.array([c.max_dn for c in cameras])
    if exposure.mode == "auto":
        brightest = class_rate.max(axis=-1)
        with np.errstate(divide="ignore"):
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
    groups = [((a,), (b,)) for a, b in combinations(range(k_count), 2)]
    if k_count >= 3:
        groups += [((i,), tuple(j for j in range(k_count) if j != i)) for i in range(k_count)]
    m1, v1, m2, v2 = (
        np.stack(x, axis=-1)
        for x in zip(*(_group_moments(mean, variance, g1, g2) for g1, g2 in groups), strict=True)
    )
    eps, log_eps = gaussian_error_and_log(m1, v1, m2, v2)
    return Prediction(
        lights=tuple(lt.name for lt in lights),
        optics=tuple(o.name for o in optics),
        cameras=tuple(c.name for c in cameras),
        classes=names,
        comparisons=tuple(
            (tuple(names[i] for i in g1), tuple(names[i] for i in g2)) for g1, g2 in groups
        ),
        grid=grid,
        exposure_time=t_exp,
        electrons=class_rate * t_exp[..., None],
        mean=mean,
        variance=variance,
        spectral_variance=spectral,
        saturated_fraction=saturated,
        snr_db=snr_db(m1, v1, m2, v2),
        cnr_db=cnr_db(m1, v1, m2, v2),
        fisher_db=fisher_db(m1, v1, m2, v2),
        error_gaussian=eps,
        log_error_gaussian=log_eps,
        sample_electrons=mu_e,
        sample_mean=clip_mean,
        sample_variance=clip_var,
        sample_class=sample_class,
    )


def _group_moments(mean, variance, g1, g2):
    """Moments of one class or of the equal-weight union of several."""

    def union(g):
        m = mean[..., list(g)]
        v = variance[..., list(g)]
        return m.mean(axis=-1), v.mean(axis=-1) + m.var(axis=-1)

    (a, b), (c, d) = union(g1), union(g2)
    return a, b, c, d


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


def _check_overlap(lights, optics, cameras, classes, e, t, q, invalid, sample_class, grid):
    """Every combination must integrate over some wavelength; no invalid reflectance where it counts.

    Model curves (Gaussian tails, logistic edges) are never exactly zero, so a
    component counts as present where it exceeds 1e-6 of its own peak.
    """

    def present(a):
        return a > _PRESENT * a.max(axis=-1, keepdims=True)

    # Wavelengths where light, optics and camera are all present, counted per
    # combination by one product of indicator matrices: no (L, O, C, W) array,
    # which at 10⁶ combinations would take ~0.6 GB.
    pe, pt, pq = present(e), present(t), present(q)
    light_optics = (pe[:, None, :] & pt[None, :, :]).reshape(-1, grid.size).astype(np.float32)
    shared = (light_optics @ pq.T.astype(np.float32)).reshape(
        len(lights), len(optics), len(cameras)
    )
    sensitive = shared > 0
    if not sensitive.all():
        li, oi, ci = (int(x[0]) for x in np.nonzero(~sensitive))
        parts = [lights[li].spd, optics[oi].transmission, cameras[ci].qe]
        raise InputError(
            "no wavelength where light, optics and camera all transmit: "
            + "; ".join(f"{p.name} {p.range[0]:g}–{p.range[1]:g} nm ({p.source})" for p in parts)
        )
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
