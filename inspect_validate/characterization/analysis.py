"""EMVA 1288 (release 4.0, linear model) from an exposure series of frame pairs.

For every point i of the series, two frames lit (A, B) and two dark at the same
exposure, over the analysed region of N pixels (§6):

    μ_y   = (μ_A + μ_B) / 2
    σ²_y  = Σ (y_A − y_B)² / (2N) − (μ_A − μ_B)² / 2      (temporal: the pair's difference)

and likewise μ_y.dark, σ²_y.dark. Then

* system gain K: the slope through the origin of σ²_y − σ²_y.dark on μ_y − μ_y.dark
  (photon transfer), over the points up to 70 % of the saturation signal;
* saturation: the point where σ²_y peaks (searched from the bright end, as the
  ``emva1288`` package does); capacity μ_e.sat = (μ_y.sat − μ_y.dark) / K;
* temporal dark noise: σ²_y.dark at zero exposure (the intercept of σ²_y.dark on the
  exposure time, with three or more exposures; not below 0.24 DN², where the
  quantisation noise dominates), σ_d = √(σ²_y.dark − 1/12) / K;
* dark current: the slope of μ_y.dark on the exposure time, / K (e⁻/s);
* linearity error: a line with offset through μ_y − μ_y.dark against the exposure
  (∝ the irradiation at a fixed light) between 5 % and 95 % of saturation; LE is
  half the spread of the relative deviations (%);
* DSNU and PRNU from stacks of L frames in the dark and at about 50 %: the spatial
  variance of the mean image less the temporal part left in it,
  s²_y = s²_y.measured − σ²_y.stack / L; DSNU = s_y.dark / K (e⁻),
  PRNU = √(s²_y.50 − s²_y.dark) / (μ_y.50 − μ_y.dark);
* SNR = (μ_y − μ_y.dark) / σ_y per point; dynamic range μ_e.sat / (σ_y.dark / K + ½).

Every value comes with its standard error: the fits' from their residuals, the
spatial ones from the sampling error of a variance over N pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.components.sensors import QUANTISATION_VARIANCE

__all__ = ["Characterization", "Pair", "Stack", "analyse", "pair_statistics", "stack_statistics"]

DARK_VARIANCE_FLOOR = 0.24  # DN², below it the quantisation dominates (emva1288 uses it too)


@dataclass(frozen=True)
class Pair:
    """Mean and temporal variance of a pair of frames over the region, DN and DN²."""

    mean: float
    variance: float


@dataclass(frozen=True)
class Stack:
    """A stack of L frames over the region: mean (DN), mean temporal variance (DN²),
    spatial variance of the mean image less its temporal part (DN²), its mean image."""

    mean: float
    temporal: float
    spatial: float
    frames: int
    pixels: int
    image: np.ndarray = field(repr=False)


def pair_statistics(a: np.ndarray, b: np.ndarray) -> Pair:
    """μ_y and σ²_y of two frames over their pixels (EMVA 1288 §6.2)."""
    a, b = np.asarray(a, np.float64).ravel(), np.asarray(b, np.float64).ravel()
    mu_a, mu_b = a.mean(), b.mean()
    d = a - b
    return Pair(0.5 * (mu_a + mu_b), float(d @ d) / (2 * d.size) - 0.5 * (mu_a - mu_b) ** 2)


def stack_statistics(frames: np.ndarray) -> Stack:
    """The spatial components of a stack (L, …) of frames over their pixels (§8.2)."""
    y = np.asarray(frames, np.float64).reshape(frames.shape[0], -1)
    n = y.shape[0]
    image = y.mean(axis=0)
    temporal = float(y.var(axis=0, ddof=1).mean())
    spatial = float(image.var(ddof=1)) - temporal / n
    return Stack(
        float(image.mean()), temporal, spatial, n, image.size, image.reshape(frames.shape[1:])
    )


def _through_origin(x, y):
    """Slope of y = k x and its standard error."""
    k = float(x @ y / (x @ x))
    r = y - k * x
    se = math.sqrt(float(r @ r) / max(len(x) - 1, 1) / float(x @ x)) if len(x) > 1 else math.nan
    return k, se


def _line(x, y):
    """Slope and intercept of y = a x + b with their standard errors (None below 3 points)."""
    if len(x) < 3 or np.ptp(x) == 0:
        return None
    (a, b), cov = np.polyfit(x, y, 1, cov="unscaled")
    r = y - (a * x + b)
    s2 = float(r @ r) / (len(x) - 2)
    return float(a), float(b), math.sqrt(s2 * cov[0, 0]), math.sqrt(s2 * cov[1, 1])


def locate_saturation(variance: np.ndarray) -> int:
    """Where σ²_y peaks: walked from the bright end, past noise spikes, as emva1288 does."""
    peak, index = -math.inf, 0
    for i in range(len(variance) - 1, -1, -1):
        if variance[i] >= peak or variance[abs(i - 1)] >= peak:
            peak, index = variance[i], i
        elif variance[i] < peak and variance[abs(i - 1)] < peak:
            break
    return index


@dataclass(frozen=True)
class Characterization:
    """The camera's EMVA 1288 parameters, each with its standard error (``…_se``).

    Units: K DN/e⁻; dark noise, saturation capacity and DSNU e⁻; dark current e⁻/s;
    PRNU and linearity error relative (0.01 = 1 %); dark offset DN; dynamic range a
    ratio. ``exposure_us`` and the per-point arrays are the series as measured.
    """

    gain: float
    gain_se: float
    dark_noise: float
    dark_noise_se: float
    saturation: float
    saturation_se: float
    saturation_reached: bool
    dark_offset: float
    dark_current: float
    dark_current_se: float
    linearity_error: float
    dsnu: float
    dsnu_se: float
    prnu: float
    prnu_se: float
    dynamic_range: float
    responsivity: float  # e⁻ per µs of exposure at the series' light (relative QE)
    bit_depth: int
    exposure_us: np.ndarray = field(repr=False)
    mean: np.ndarray = field(repr=False)
    variance: np.ndarray = field(repr=False)
    dark_mean: np.ndarray = field(repr=False)
    dark_variance: np.ndarray = field(repr=False)
    fit_points: int = 0
    saturation_index: int = 0
    dark_image: np.ndarray | None = field(default=None, repr=False)
    bright_image: np.ndarray | None = field(default=None, repr=False)
    qe_scale: float = math.nan
    """Measured responsivity / the model's for a white target: the camera's QE (times the
    lens transmission) relative to the declared curves; NaN where the light's irradiance
    is not stated."""
    qe_scale_se: float = math.nan
    """The standard error of :attr:`qe_scale` (from the responsivity's)."""
    responsivity_se: float = math.nan
    """The standard error of :attr:`responsivity` (the slope's and K's, combined)."""

    @property
    def snr(self) -> np.ndarray:
        """(μ_y − μ_y.dark) / σ_y at each point of the series."""
        return (self.mean - self.dark_mean) / np.sqrt(np.maximum(self.variance, 1e-300))

    @property
    def dynamic_range_db(self) -> float:
        return 20 * math.log10(self.dynamic_range) if self.dynamic_range > 0 else math.nan

    def datasheet(self) -> dict:
        """The values and their standard errors, JSON-ready, with units."""
        return {
            "system_gain": {"value": self.gain, "se": self.gain_se, "unit": "DN/e-"},
            "dark_noise": {"value": self.dark_noise, "se": self.dark_noise_se, "unit": "e-"},
            "saturation_capacity": {
                "value": self.saturation,
                "se": self.saturation_se,
                "unit": "e-",
                "reached": self.saturation_reached,
            },
            "dark_offset": {"value": self.dark_offset, "unit": "DN"},
            "dark_current": {
                "value": self.dark_current,
                "se": self.dark_current_se,
                "unit": "e-/s",
            },
            "linearity_error": {"value": self.linearity_error, "unit": "relative"},
            "dsnu": {"value": self.dsnu, "se": self.dsnu_se, "unit": "e-"},
            "prnu": {"value": self.prnu, "se": self.prnu_se, "unit": "relative"},
            "dynamic_range": {"value": self.dynamic_range, "db": self.dynamic_range_db},
            "responsivity": {"value": self.responsivity, "unit": "e-/us"},
            "quantum_efficiency_scale": {
                "value": self.qe_scale,
                "note": "measured / the scene's QE curve (times the lens transmission): "
                "absolute where the illumination's irradiance is stated, else null",
            },
            "bit_depth": self.bit_depth,
            "photon_transfer_points": self.fit_points,
        }


def analyse(
    exposure_us: ArrayLike,
    bright: list[Pair],
    dark: list[Pair],
    *,
    bright_stack: Stack | None = None,
    dark_stack: Stack | None = None,
    bits: int,
) -> Characterization:
    """The EMVA 1288 parameters of an exposure series (module docstring).

    Parameters
    ----------
    exposure_us : array_like
        Exposure of each point, µs (or, for an LED-level series, the level in %: the
        abscissa of the linearity fit and of the dark signal).
    bright, dark : list of Pair
        :func:`pair_statistics` of the lit and the dark pair at each point.
    bright_stack, dark_stack : Stack, keyword-only, optional
        :func:`stack_statistics` at about 50 % and in the dark; DSNU and PRNU need them.
    bits : int, keyword-only
        The frames' bit depth (saturation at 2^bits − 1).
    """
    t = np.asarray(exposure_us, np.float64)
    order = np.argsort(t, kind="stable")
    t = t[order]
    mu = np.array([bright[i].mean for i in order])
    var = np.array([bright[i].variance for i in order])
    mu_d = np.array([dark[i].mean for i in order])
    var_d = np.array([dark[i].variance for i in order])
    signal, noise = mu - mu_d, var - var_d

    sat = locate_saturation(var)
    reached = sat < len(t) - 1 or mu[sat] >= 0.95 * (2**bits - 1)
    top = 0.7 * signal[sat]
    use = np.flatnonzero((signal > 0) & (signal <= top) & (np.arange(len(t)) <= sat))
    if use.size < 2:
        use = np.flatnonzero(signal > 0)[:2]
    k, k_se = _through_origin(signal[use], noise[use])

    fit = _line(t, var_d)
    if fit is not None:
        s2_dark, s2_dark_se = fit[1], fit[3]
    else:
        s2_dark, s2_dark_se = float(var_d[0]), float(var_d[0]) * math.sqrt(2 / 1000)
    s2_dark = max(s2_dark, DARK_VARIANCE_FLOOR)
    sigma_d = math.sqrt(s2_dark - QUANTISATION_VARIANCE) / k
    sigma_d_se = sigma_d * math.hypot(
        0.5 * s2_dark_se / (s2_dark - QUANTISATION_VARIANCE), k_se / k
    )

    mean_fit = _line(t, mu_d)
    dark_current = dark_current_se = math.nan
    dark_offset = float(mu_d[0])
    if mean_fit is not None:
        dark_current, dark_current_se = mean_fit[0] * 1e6 / k, mean_fit[2] * 1e6 / k
        dark_offset = mean_fit[1]

    saturation = signal[sat] / k
    saturation_se = saturation * k_se / k

    lin = (signal >= 0.05 * signal[sat]) & (signal <= 0.95 * signal[sat])
    linearity = math.nan
    line = _line(t[lin], signal[lin])
    if line is not None:
        expected = line[0] * t[lin] + line[1]
        deviation = (signal[lin] - expected) / expected
        linearity = float(0.5 * (deviation.max() - deviation.min()))

    slope, slope_se = _through_origin(t[use], signal[use])  # DN per µs below saturation
    responsivity_se = (slope / k) * math.hypot(slope_se / slope, k_se / k) if slope else math.nan

    dsnu = dsnu_se = prnu = prnu_se = math.nan
    if dark_stack is not None:
        s2 = max(dark_stack.spatial, 0.0)
        dsnu = math.sqrt(s2) / k
        dsnu_se = dsnu * math.hypot(1 / math.sqrt(2 * (dark_stack.pixels - 1)), k_se / k)
        if bright_stack is not None:
            s2_light = max(bright_stack.spatial - s2, 0.0)
            level = bright_stack.mean - dark_stack.mean
            prnu = math.sqrt(s2_light) / level if level > 0 else math.nan
            # Each spatial variance over N pixels has the sampling error s²·√(2/(N−1));
            # PRNU ∝ √(s²_50 − s²_dark): half the relative error of their difference.
            spread = math.hypot(
                bright_stack.spatial * math.sqrt(2 / (bright_stack.pixels - 1)),
                s2 * math.sqrt(2 / (dark_stack.pixels - 1)),
            )
            prnu_se = 0.5 * prnu * spread / s2_light if s2_light > 0 else math.nan
    dynamic_range = saturation / (math.sqrt(s2_dark) / k + 0.5)
    return Characterization(
        gain=k,
        gain_se=k_se,
        dark_noise=sigma_d,
        dark_noise_se=sigma_d_se,
        saturation=saturation,
        saturation_se=saturation_se,
        saturation_reached=bool(reached),
        dark_offset=dark_offset,
        dark_current=dark_current,
        dark_current_se=dark_current_se,
        linearity_error=linearity,
        dsnu=dsnu,
        dsnu_se=dsnu_se,
        prnu=prnu,
        prnu_se=prnu_se,
        dynamic_range=dynamic_range,
        responsivity=slope / k,
        responsivity_se=responsivity_se,
        bit_depth=bits,
        exposure_us=t,
        mean=mu,
        variance=var,
        dark_mean=mu_d,
        dark_variance=var_d,
        fit_points=int(use.size),
        saturation_index=int(sat),
        dark_image=None if dark_stack is None else dark_stack.image,
        bright_image=None if bright_stack is None else bright_stack.image,
    )
