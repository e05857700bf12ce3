"""Light sources (chapter §2.1): blackbody, CIE illuminants, LEDs, measured SPDs.

A :class:`Light` is a spectral power distribution plus, optionally, its absolute
irradiance at the object, stated over a band (380–780 nm unless given): what a
radiometer with a flat response over that band reads. Relative SPDs suffice when
the exposure is set automatically (the scale cancels, and exposure times are then
relative too); a fixed exposure time needs the irradiance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.constants import K_B, C, H
from inspect_validate.errors import InputError
from inspect_validate.spectra import Spectrum, SpectrumKind

__all__ = [
    "Light",
    "blackbody",
    "cie_daylight",
    "cie_illuminant",
    "led",
    "ohno_led_spd",
    "phosphor_white_led",
    "planck",
]

DEFAULT_GRID = np.arange(300.0, 1801.0, 1.0)  # nm, for model spectra


@dataclass(frozen=True)
class Light:
    """A light source.

    Attributes
    ----------
    name : str
    spd : Spectrum
        Spectral power distribution, one sample.
    irradiance : float or None
        Irradiance at the object integrated over ``band``, W/m²; None when only
        the relative SPD is known.
    band : (float, float)
        The wavelengths ``irradiance`` is stated over, nm (default 380–780 nm).
    """

    name: str
    spd: Spectrum
    irradiance: float | None = None
    band: tuple[float, float] = (380.0, 780.0)

    def __post_init__(self):
        if self.irradiance is not None and not (
            np.isfinite(self.irradiance) and self.irradiance > 0
        ):
            raise InputError(
                f"light {self.name!r}: irradiance must be a positive number of W/m², "
                f"not {self.irradiance!r}"
            )
        lo, hi = self.band
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
            raise InputError(f"light {self.name!r}: irradiance band {self.band} is not [lo, hi] nm")

    def band_power(self) -> float:
        """∫ SPD dλ over ``band`` (trapezoidal, in the SPD's own units × nm)."""
        wl, v = self.spd.wavelengths, np.nan_to_num(self.spd.values[0])
        lo, hi = max(self.band[0], wl[0]), min(self.band[1], wl[-1])
        if lo >= hi:
            return 0.0
        inside = (wl > lo) & (wl < hi)
        x = np.concatenate([[lo], wl[inside], [hi]])
        return float(np.trapezoid(np.interp(x, wl, v), x))


def planck(wavelength: ArrayLike, temperature: ArrayLike) -> np.ndarray:
    """Blackbody spectral radiance u(λ, T) (2), W·sr⁻¹·m⁻²·nm⁻¹.

    Written as 2hc²/λ⁵ · e^{−x} / (1 − e^{−x}) with x = hc/(λkT), which neither
    overflows nor divides 0 by 0 for short wavelengths or low temperatures:
    it underflows gracefully to 0.

    Parameters
    ----------
    wavelength : array_like
        nm, > 0.
    temperature : array_like
        K, > 0.
    """
    lam = np.asarray(wavelength, dtype=float) * 1e-9
    t = np.asarray(temperature, dtype=float)
    if np.any(lam <= 0) or np.any(t <= 0):
        raise ValueError("wavelength and temperature must be positive")
    # λkT underflows to 0 below about 1e-290 K: x = inf, and the radiance is 0.
    with np.errstate(over="ignore", under="ignore", divide="ignore"):
        x = H * C / (lam * K_B * t)
        return 2.0 * H * C**2 / lam**5 * np.exp(-x) / -np.expm1(-x) * 1e-9


def blackbody(
    temperature: float, *, grid: np.ndarray = DEFAULT_GRID, irradiance: float | None = None
) -> Light:
    """An incandescent/thermal source at ``temperature`` K (Planck (2))."""
    spd = Spectrum(
        grid,
        planck(grid, temperature),
        SpectrumKind.SPD,
        f"blackbody {temperature:g} K",
        "model: Planck (2)",
    )
    return Light(spd.name, spd, irradiance)


# The root in (½, 1) of g + 2g⁵ = 3/2, where the Ohno LED is at half its peak. A
# constant rather than brentq at first use, whose scipy.optimize import was a fifth of
# a predict on the paperboard scene. tests/components/test_components.py checks it against brentq
# and mpmath.
_G_HALF = 0.8086092632090856


def ohno_led_spd(wavelength: ArrayLike, peak: float, fwhm: float) -> np.ndarray:
    """Ohno (2005) single-LED model, S = (g + 2g⁵)/3 with g = exp(−((λ−λ₀)/Δ)²), peak 1.

    Δ is chosen so that the full width at half maximum equals ``fwhm`` (nm):
    S = ½ where g + 2g⁵ = 3/2.
    """
    if fwhm <= 0:
        raise ValueError("FWHM must be positive")
    delta = fwhm / (2.0 * np.sqrt(-np.log(_G_HALF)))
    g = np.exp(-(((np.asarray(wavelength, float) - peak) / delta) ** 2))
    return (g + 2.0 * g**5) / 3.0


def led(
    peak: float,
    fwhm: float,
    *,
    grid: np.ndarray = DEFAULT_GRID,
    irradiance: float | None = None,
    name: str | None = None,
) -> Light:
    """A single-colour LED from its peak wavelength and FWHM, nm (Ohno 2005 model)."""
    name = name or f"LED {peak:g} nm (model)"
    spd = Spectrum(
        grid,
        ohno_led_spd(grid, peak, fwhm),
        SpectrumKind.SPD,
        name,
        f"model: Ohno 2005, peak {peak:g} nm, FWHM {fwhm:g} nm",
    )
    return Light(name, spd, irradiance)


def phosphor_white_led(
    *,
    blue_peak: float = 450.0,
    blue_fwhm: float = 20.0,
    phosphor_peak: float = 560.0,
    phosphor_fwhm: float = 120.0,
    phosphor_ratio: float = 2.2,
    grid: np.ndarray = DEFAULT_GRID,
    irradiance: float | None = None,
) -> Light:
    """Phosphor-converted white LED (chapter Fig. 8): blue die plus a broad phosphor peak.

    A model: two Ohno (2005) peaks, the phosphor's integral ``phosphor_ratio``
    times the die's. For tabulated white LEDs use the CIE LED-B1…B5
    illuminants (:func:`cie_illuminant`).
    """
    blue = ohno_led_spd(grid, blue_peak, blue_fwhm)
    yellow = ohno_led_spd(grid, phosphor_peak, phosphor_fwhm)
    values = blue + yellow * phosphor_ratio * np.trapezoid(blue, grid) / np.trapezoid(yellow, grid)
    name = "white LED (model)"
    spd = Spectrum(
        grid,
        values,
        SpectrumKind.SPD,
        name,
        f"model: Ohno 2005 die {blue_peak:g} nm + phosphor {phosphor_peak:g} nm",
    )
    return Light(name, spd, irradiance)


def cie_illuminant(name: str, *, irradiance: float | None = None) -> Light:
    """A tabulated CIE illuminant from colour-science: D50, D65, FL1–FL12, HP1–HP5, LED-B1… .

    HP1 is a standard high-pressure sodium lamp; FL* are fluorescent lamps;
    LED-B* phosphor-converted white LEDs.
    """
    import colour

    try:
        sd = colour.SDS_ILLUMINANTS[name]
    except KeyError:
        known = ", ".join(k for k in colour.SDS_ILLUMINANTS if not k.startswith("ISO"))
        raise InputError(f"unknown CIE illuminant {name!r}; known: {known}") from None
    spd = Spectrum(
        sd.wavelengths, sd.values, SpectrumKind.SPD, f"CIE {name}", f"CIE {name} (colour-science)"
    )
    return Light(spd.name, spd, irradiance)


def cie_daylight(cct: float, *, irradiance: float | None = None) -> Light:
    """CIE D-series daylight at correlated colour temperature ``cct`` K (4000–25000 K)."""
    import colour

    if not 4000 <= cct <= 25000:
        raise InputError(f"CIE daylight is defined for 4000–25000 K, not {cct:g} K")
    xy = colour.temperature.CCT_to_xy_CIE_D(cct * 1.4388 / 1.4380)
    sd = colour.sd_CIE_illuminant_D_series(xy)
    spd = Spectrum(
        sd.wavelengths,
        sd.values,
        SpectrumKind.SPD,
        f"CIE daylight {cct:g} K",
        "CIE D-series (colour-science)",
    )
    return Light(spd.name, spd, irradiance)
