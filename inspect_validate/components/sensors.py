"""Cameras (chapter §2.4): quantum efficiency and the EMVA 1288 linear camera model.

QE(λ) = n_e / n_ph (23); the energy efficiency EE(λ) = QE(λ)·λ/(hc) (24)–(25) is
what multiplies the irradiance in (32). With the EMVA 1288 parameters a camera
turns a mean number of photo-electrons μ_e into grey values:

    μ_y = μ_y.dark + K·μ_e,   σ_y² = K²(σ_d² + μ_e) + σ_q²,  σ_q² = 1/12 DN².

Beyond the temporal model a real sensor has a dark current I_d (e⁻/s: its electrons
add to the signal and to its shot noise over the exposure t) and spatial
non-uniformities that are the same in every frame: the dark signal's (DSNU, e⁻ rms
over the pixels) and the photo-response's (PRNU, relative rms of the gain), which
add K²(DSNU² + PRNU²·μ_e²) to a region's spatial variance (EMVA 1288 release 4.0,
§8).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.constants import C, H
from inspect_validate.errors import InputError
from inspect_validate.spectra import Spectrum, SpectrumKind

__all__ = [
    "BUILT_IN_CAMERAS",
    "QUANTISATION_VARIANCE",
    "SensorModel",
    "builtin_sensor",
    "energy_efficiency",
    "gain_factor",
    "grey_value",
    "qe_model",
]

QUANTISATION_VARIANCE = 1.0 / 12.0
"""σ_q², DN²: the variance rounding to whole grey values adds (EMVA 1288)."""


def grey_value(
    mu_e: np.ndarray | float,
    gain: np.ndarray | float,
    dark_noise: np.ndarray | float,
    dark_offset: np.ndarray | float,
) -> tuple[Any, Any]:
    """Mean (DN) and temporal variance (DN²) of the grey value of ``mu_e`` mean
    photo-electrons (EMVA 1288, before clipping): offset + K μ_e and
    K² (σ_d² + μ_e) + 1/12 DN², K in DN/e⁻ and σ_d in e⁻."""
    return (
        dark_offset + gain * mu_e,
        gain**2 * (dark_noise**2 + mu_e) + QUANTISATION_VARIANCE,
    )


@dataclass(frozen=True)
class SensorModel:
    """A monochrome camera.

    Attributes
    ----------
    name : str
    qe : Spectrum
        Quantum efficiency, 0..1.
    gain : float
        System gain K, DN/e⁻.
    dark_noise : float
        Temporal dark noise σ_d, e⁻.
    saturation : float
        Saturation capacity μ_e.sat, e⁻.
    bit_depth : int
    dark_offset : float
        Mean dark value μ_y.dark, DN.
    pixel_pitch : float
        Pixel pitch, µm (the pixel area A = pitch²).
    dark_current : float
        I_d, e⁻/s.
    dsnu : float
        Dark signal non-uniformity, e⁻ rms over the pixels.
    prnu : float
        Photo-response non-uniformity, relative rms of the gain (0.01 = 1 %).
    """

    name: str
    qe: Spectrum
    gain: float
    dark_noise: float
    saturation: float
    bit_depth: int = 12
    dark_offset: float = 0.0
    pixel_pitch: float = 3.45
    dark_current: float = 0.0
    dsnu: float = 0.0
    prnu: float = 0.0

    def __post_init__(self):
        for field in (
            "gain",
            "saturation",
            "pixel_pitch",
            "dark_noise",
            "dark_offset",
            "dark_current",
            "dsnu",
            "prnu",
        ):
            if not np.isfinite(getattr(self, field)):
                raise InputError(f"camera {self.name!r}: {field} must be a finite number")
        for field in ("gain", "saturation", "pixel_pitch"):
            if not getattr(self, field) > 0:
                raise InputError(f"camera {self.name!r}: {field} must be positive")
        negative = min(self.dark_noise, self.dark_offset, self.dark_current, self.dsnu, self.prnu)
        if negative < 0 or not BIT_DEPTHS[0] <= self.bit_depth <= BIT_DEPTHS[1]:
            raise InputError(
                f"camera {self.name!r}: dark_noise, dark_offset, dark_current, dsnu, prnu ≥ 0 "
                f"and bit_depth {BIT_DEPTHS[0]}..{BIT_DEPTHS[1]}"
            )
        # Values each possible alone but not together: a camera that cannot record a signal.
        full_scale = 2.0**self.bit_depth - 1.0
        if self.dark_offset >= full_scale:
            raise InputError(
                f"camera {self.name!r}: dark_offset {self.dark_offset:.6g} DN fills the "
                f"{self.bit_depth}-bit range (at most {full_scale:.0f} DN), leaving no room for "
                "a signal: check dark_offset and bit_depth"
            )
        if self.gain * self.saturation < 1.0:
            raise InputError(
                f"camera {self.name!r}: gain × saturation is {self.gain * self.saturation:.3g} "
                "DN, so the full well spans less than one grey value: check gain (DN/e⁻) and "
                "saturation (e⁻)"
            )

    @property
    def max_dn(self) -> float:
        """Largest grey value: full scale or the saturation capacity, whichever is lower, DN."""
        return min(2.0**self.bit_depth - 1.0, self.dark_offset + self.gain * self.saturation)


BIT_DEPTHS = (8, 32)
"""The bit depths a camera may have: no monochrome machine-vision format (Mono8 and
deeper) records fewer than 8 bits, and a 32-bit value is the widest read."""


def gain_factor(gain_db: float) -> float:
    """The factor an analogue gain of ``gain_db`` dB multiplies the system gain K by:
    10^(gain_db/20) (GenICam's ``Gain`` in dB is an amplitude ratio)."""
    return 10.0 ** (gain_db / 20.0)


def energy_efficiency(qe: ArrayLike, wavelength: ArrayLike) -> np.ndarray:
    """EE(λ) = QE(λ)·λ/(hc) (24)–(25), electrons per joule; ``wavelength`` in nm."""
    return np.asarray(qe, float) * np.asarray(wavelength, float) * 1e-9 / (H * C)


def qe_model(
    grid: ArrayLike, *, peak: float, peak_qe: float, left: float, right: float, lo: float, hi: float
) -> np.ndarray:
    """A smooth single-peaked QE curve: a Gaussian with separate widths left and right of
    the peak, cut off smoothly at the sensor material's limits ``lo``/``hi`` (nm)."""
    g = np.asarray(grid, float)
    width = np.where(g < peak, left, right)
    edges = 1.0 / (1.0 + np.exp(-(g - lo) / 8.0)) / (1.0 + np.exp((g - hi) / 8.0))
    return peak_qe * np.exp(-0.5 * ((g - peak) / width) ** 2) * edges


_GRID = np.arange(300.0, 1801.0, 1.0)
BUILT_IN_CAMERAS: dict[str, tuple[dict[str, float], dict[str, Any]]] = {
    # name: QE model parameters, EMVA parameters
    "cmos-visible": (
        dict(peak=530, peak_qe=0.68, left=85, right=170, lo=350, hi=1050),
        dict(
            gain=0.39,
            dark_noise=2.3,
            saturation=10500,
            bit_depth=12,
            dark_offset=0.0,
            pixel_pitch=3.45,
        ),
    ),
    "cmos-nir-enhanced": (
        dict(peak=650, peak_qe=0.62, left=130, right=260, lo=350, hi=1100),
        dict(
            gain=0.38,
            dark_noise=6.0,
            saturation=10800,
            bit_depth=12,
            dark_offset=0.0,
            pixel_pitch=5.5,
        ),
    ),
    "ingaas-swir": (
        dict(peak=1350, peak_qe=0.8, left=600, right=900, lo=920, hi=1690),
        dict(
            gain=0.065,
            dark_noise=180.0,
            saturation=250000,
            bit_depth=14,
            dark_offset=0.0,
            pixel_pitch=15.0,
        ),
    ),
}


def builtin_sensor(name: str) -> SensorModel:
    """One of :data:`BUILT_IN_CAMERAS`: typical sensors with modelled QE curves."""
    try:
        qe_args, emva = BUILT_IN_CAMERAS[name]
    except KeyError:
        raise InputError(
            f"unknown camera {name!r}; built-in cameras: {', '.join(BUILT_IN_CAMERAS)}"
        ) from None
    label = f"{name} (model)"
    qe = Spectrum(
        _GRID,
        qe_model(_GRID, **qe_args),
        SpectrumKind.QE,
        label,
        f"model: QE peak {qe_args['peak']} nm",
    )
    return SensorModel(label, qe, **emva)
