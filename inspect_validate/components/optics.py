"""Optics (chapter §2.3): lens materials, coated lenses, measured transmission.

t_opt(λ) = t_mat(λ) · t_coat(λ)  (22).

Material transmission of a plate is computed from real dispersion data — the
published Sellmeier coefficients of each Table 1 material give n(λ) and with it
the Fresnel surface losses (with incoherent multiple reflections) — times an
internal-absorption model whose UV and IR edges sit at the ends of the
material's Table 1 transmission range (internal transmission ½ for 10 mm there,
exponential Urbach-type tails beyond). The absorption edges are a model, so the
names of these curves say so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.errors import InputError
from inspect_validate.spectra import Spectrum, SpectrumKind

__all__ = ["MATERIALS", "Optics", "ideal_lens", "lens", "material_transmission", "refractive_index"]

HC_EV_NM = 1239.841984  # photon energy E [eV] = HC_EV_NM / λ [nm]


@dataclass(frozen=True)
class Material:
    name: str
    sellmeier_b: tuple[float, float, float]
    sellmeier_c: tuple[float, float, float]  # µm²
    range_nm: tuple[float, float]  # chapter Table 1
    reference: str


MATERIALS = {
    "BK7": Material(
        "BK7",
        (1.03961212, 0.231792344, 1.01046945),
        (0.00600069867, 0.0200179144, 103.560653),
        (330, 2100),
        "SCHOTT N-BK7 datasheet",
    ),
    "fused_silica": Material(
        "UV fused silica",
        (0.6961663, 0.4079426, 0.8974794),
        (0.0684043**2, 0.1162414**2, 9.896161**2),
        (185, 2500),
        "Malitson 1965",
    ),
    "CaF2": Material(
        "CaF2",
        (0.5675888, 0.4710914, 3.8484723),
        (0.050263605**2, 0.1003909**2, 34.649040**2),
        (170, 8000),
        "Malitson 1963",
    ),
    "MgF2": Material(
        "MgF2 (ordinary ray)",
        (0.48755108, 0.39875031, 2.3120353),
        (0.04338408**2, 0.09461442**2, 23.793604**2),
        (150, 6500),
        "Dodge 1984",
    ),
    "ZnSe": Material(
        "ZnSe",
        (4.45813734, 0.467216334, 2.89566290),
        (0.200859853**2, 0.391371166**2, 47.1362108**2),
        (600, 16000),
        "Connolly 1979",
    ),
}


@dataclass(frozen=True)
class Optics:
    """A lens: transmission t_opt(λ) (22) and f-number (sets the image irradiance)."""

    name: str
    transmission: Spectrum
    f_number: float = 4.0

    def __post_init__(self):
        if not (np.isfinite(self.f_number) and self.f_number >= 0.5):
            raise InputError(
                f"optics {self.name!r}: f-number must be at least 0.5, not {self.f_number!r}"
            )


def refractive_index(material: str, wavelength: ArrayLike) -> np.ndarray:
    """n(λ) from the Sellmeier equation; ``wavelength`` in nm."""
    m = _material(material)
    l2 = (np.asarray(wavelength, float) * 1e-3) ** 2
    n2 = 1.0 + sum(b * l2 / (l2 - c) for b, c in zip(m.sellmeier_b, m.sellmeier_c, strict=True))
    return np.sqrt(n2)


def _material(name: str) -> Material:
    try:
        return MATERIALS[name]
    except KeyError:
        raise InputError(f"unknown lens material {name!r}; known: {', '.join(MATERIALS)}") from None


def material_transmission(
    material: str, *, thickness_mm: float = 10.0, grid: np.ndarray | None = None
) -> Spectrum:
    """Transmission of an uncoated plate: Fresnel losses from n(λ) and modelled absorption edges."""
    m = _material(material)
    lo, hi = m.range_nm
    grid = (
        np.arange(max(lo * 0.8, 100.0), min(hi * 1.2, 20000.0) + 1, 1.0)
        if grid is None
        else np.asarray(grid, float)
    )
    energy = HC_EV_NM / grid
    # α·10 mm = ln 2 at the range ends; Urbach-type slopes of 0.08 eV (UV) and,
    # for the multiphonon IR edge, 4 % of the edge energy.
    e_uv, e_ir = HC_EV_NM / lo, HC_EV_NM / hi
    alpha = (
        np.log(2.0)
        / 10.0
        * (
            np.exp(np.clip((energy - e_uv) / 0.08, -700, 700))
            + np.exp(np.clip((e_ir - energy) / (0.04 * e_ir), -700, 700))
        )
    )
    tau = np.exp(-alpha * thickness_mm)
    # Sellmeier fits diverge near their poles, far outside the transmission range.
    n = np.clip(np.nan_to_num(refractive_index(material, grid), nan=1.0), 1.0, 5.0)
    r = ((n - 1.0) / (n + 1.0)) ** 2
    t = (1.0 - r) ** 2 * tau / (1.0 - r**2 * tau**2)
    name = f"{m.name} {thickness_mm:g} mm (Sellmeier + edge model)"
    return Spectrum(
        grid,
        t,
        SpectrumKind.TRANSMISSION,
        name,
        f"model: {m.reference} dispersion, absorption edges at Table 1 range",
    )


def _coating(grid, centre, half_width, surfaces, r_in: float = 0.005, r_out: float = 0.04):
    """t_coat of ``surfaces`` AR-coated surfaces: residual reflection r_in inside the band."""
    band = np.exp(-(np.abs((grid - centre) / half_width) ** 8))
    return (1.0 - (r_in + (r_out - r_in) * (1.0 - band))) ** surfaces


_LENSES = {
    # name: (material, glass path mm, coating centre nm, half width nm, surfaces, f-number)
    "visible": ("BK7", 30.0, 550.0, 170.0, 12, 4.0),
    "uv": ("fused_silica", 20.0, 450.0, 200.0, 8, 4.5),
    "swir": ("fused_silica", 25.0, 1025.0, 625.0, 10, 2.0),
}


def lens(kind: str, *, f_number: float | None = None) -> Optics:
    """A photographic lens model: ``visible`` (AR-coated, 400–700 nm), ``uv`` (250–650 nm), ``swir`` (400–1650 nm).

    t_opt = t_mat · t_coat (22); the glass from :func:`material_transmission`, the
    coating a band of low residual reflection on every surface.
    """
    try:
        material, path, centre, half, surfaces, f_default = _LENSES[kind]
    except KeyError:
        raise InputError(
            f"unknown lens {kind!r}; built-in lenses: {', '.join(_LENSES)}, ideal"
        ) from None
    glass = material_transmission(material, thickness_mm=path)
    grid = glass.wavelengths[(glass.wavelengths >= 200) & (glass.wavelengths <= 2500)]
    t = glass.resample(grid)[0] * _coating(grid, centre, half, surfaces)
    name = f"{kind} lens (model)"
    spectrum = Spectrum(
        grid,
        t,
        SpectrumKind.TRANSMISSION,
        name,
        f"model: {glass.name} × AR coating {centre - half:g}–{centre + half:g} nm",
    )
    return Optics(name, spectrum, f_number or f_default)


def ideal_lens(*, f_number: float = 4.0, grid: np.ndarray | None = None) -> Optics:
    """t_opt = 1 over 200–2500 nm."""
    grid = np.arange(200.0, 2501.0, 1.0) if grid is None else np.asarray(grid, float)
    return Optics(
        "ideal lens",
        Spectrum(grid, np.ones_like(grid), SpectrumKind.TRANSMISSION, "ideal lens", "model: t = 1"),
        f_number,
    )
