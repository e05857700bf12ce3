"""Reflection geometry (chapter §2.2): Lambert, Blinn–Phong and Cook–Torrance factors.

The acquisition model works with a *reflectance factor*: the object's radiance
towards the camera is E·R_eff(λ)/π for irradiance E measured perpendicular to the
light. For a diffuse object seen under constant geometry R_eff = R — the
chapter's simplification (§2.5), and the default, which skips this module.
A scene that declares the light and view directions, or a glossy class, gets

    R_eff(λ) = R(λ)·(N·L) + S

with the diffuse part from Lambert's law (4)–(6) and a spectrally flat specular
part S (the light's own colour, as for dielectrics):

* Blinn–Phong (17): S = k_s·(N·H)^n, with the half vector
  H = (L + V)/‖L + V‖ — the printed (13) has a dot product, which is wrong;
* Cook–Torrance (1982): S = π·D·F·G / (4·(N·V)), the microfacet BRDF times π·(N·L),
  with Beckmann's distribution D (roughness m), Schlick's Fresnel F (normal
  reflectance f0) and the Cook–Torrance masking/shadowing G.

All vectors point away from the surface and are normalised here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.errors import InputError

__all__ = [
    "BlinnPhong",
    "CookTorrance",
    "Geometry",
    "beckmann",
    "blinn_phong_specular",
    "cook_torrance_specular",
    "half_vector",
    "lambert",
    "reflectance_factor",
]


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(norm == 0):
        raise InputError(f"direction {v.tolist()} has zero length")
    return v / norm


@dataclass(frozen=True)
class Geometry:
    """Directions of the surface normal N, towards the light L and towards the camera V."""

    light: tuple[float, float, float]
    view: tuple[float, float, float] = (0.0, 0.0, 1.0)
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)


@dataclass(frozen=True)
class BlinnPhong:
    """Blinn–Phong gloss: specular coefficient k_s and exponent n (17)."""

    ks: float
    n: float


@dataclass(frozen=True)
class CookTorrance:
    """Cook–Torrance gloss: RMS facet slope (Beckmann roughness) m and normal Fresnel reflectance f0."""

    roughness: float
    f0: float = 0.04


def lambert(normal: ArrayLike, light: ArrayLike) -> np.ndarray:
    """cos α = N·L (5), zero for light from behind the surface."""
    return np.maximum(np.sum(_unit(normal) * _unit(light), axis=-1), 0.0)


def half_vector(light: ArrayLike, view: ArrayLike) -> np.ndarray:
    """H = (L + V)/‖L + V‖, the corrected (13)."""
    return _unit(_unit(light) + _unit(view))


def blinn_phong_specular(
    normal: ArrayLike, light: ArrayLike, view: ArrayLike, *, ks: float, n: float
) -> np.ndarray:
    """k_s·(N·H)^n, the specular term of (16)–(17)."""
    cos = np.maximum(np.sum(_unit(normal) * half_vector(light, view), axis=-1), 0.0)
    return ks * cos**n


def beckmann(cos_h: ArrayLike, roughness: float) -> np.ndarray:
    """Beckmann facet distribution D(θ_h), normalised so ∫ D·cos θ_h dω = 1."""
    c2 = np.asarray(cos_h, float) ** 2
    m2 = roughness**2
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.exp((c2 - 1.0) / (c2 * m2)) / (np.pi * m2 * c2**2)
    return np.where(c2 > 0, d, 0.0)


def cook_torrance_specular(
    normal: ArrayLike, light: ArrayLike, view: ArrayLike, *, roughness: float, f0: float
) -> np.ndarray:
    """π·(N·L)·f_s with f_s = D·F·G / (4(N·L)(N·V)): the specular reflectance factor."""
    n, to_light, v = _unit(normal), _unit(light), _unit(view)
    nl = np.sum(n * to_light, axis=-1)
    nv = np.sum(n * v, axis=-1)
    if np.any(nl <= 0) or np.any(nv <= 0):
        return np.zeros(np.broadcast(nl, nv).shape)  # lit or seen from behind
    h = half_vector(to_light, v)
    nh = np.sum(n * h, axis=-1)
    vh = np.sum(v * h, axis=-1)
    fresnel = f0 + (1.0 - f0) * (1.0 - vh) ** 5
    masking = np.minimum(1.0, np.minimum(2 * nh * nv / vh, 2 * nh * nl / vh))
    return np.pi * beckmann(nh, roughness) * fresnel * masking / (4.0 * nv)


def reflectance_factor(
    geometry: Geometry | None, gloss: BlinnPhong | CookTorrance | None
) -> tuple[float, float]:
    """(diffuse factor, specular addend) of R_eff = R·diffuse + specular.

    No geometry and no gloss: (1, 0), the chapter's diffuse model.
    """
    if geometry is None:
        if gloss is not None:
            raise InputError(
                "a glossy class needs the scene's geometry (light and view directions)"
            )
        return 1.0, 0.0
    diffuse = float(lambert(geometry.normal, geometry.light))
    if gloss is None:
        return diffuse, 0.0
    if isinstance(gloss, BlinnPhong):
        spec = blinn_phong_specular(
            geometry.normal, geometry.light, geometry.view, ks=gloss.ks, n=gloss.n
        )
    else:
        spec = cook_torrance_specular(
            geometry.normal, geometry.light, geometry.view, roughness=gloss.roughness, f0=gloss.f0
        )
    return diffuse, float(spec)
