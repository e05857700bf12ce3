"""The spectral data type: wavelengths in nm and one or more sampled curves.

A :class:`Spectrum` holds what a component or object does at each wavelength —
a light's spectral power distribution (SPD), an object's reflectance, a lens's
transmission or a sensor's quantum efficiency — for one or more *samples* (e.g.
20 spectrometer readings of one paperboard, whose spread is the class's spectral
variance). Values that are invalid (e.g. where the white reference was ≤ 0 in
(34)) are NaN and never enter a computation silently.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from inspect_validate.errors import InputError

__all__ = ["Spectrum", "SpectrumKind"]


class SpectrumKind(StrEnum):
    SPD = "spd"
    """Spectral power distribution of a light, relative or W·m⁻²·nm⁻¹."""
    REFLECTANCE = "reflectance"
    """Diffuse reflectance R(λ), 0..1."""
    TRANSMISSION = "transmission"
    """Transmission t(λ) of optics or a filter, 0..1."""
    QE = "qe"
    """Quantum efficiency QE(λ) = n_e / n_ph (23), 0..1."""


@dataclass(frozen=True, eq=False)
class Spectrum:
    """Spectral curves on a common wavelength axis.

    Parameters
    ----------
    wavelengths : array_like, shape (W,)
        Strictly increasing wavelengths, nm.
    values : array_like, shape (W,) or (S, W)
        One curve per sample; NaN marks invalid values.
    kind : SpectrumKind
    name : str
    source : str
        Where it came from: a file path, or ``"model: ..."`` / ``"CIE ..."``.
    notes : tuple of str
        What was noticed while reading (masked wavelengths, clipped noise).
    """

    wavelengths: np.ndarray
    values: np.ndarray
    kind: SpectrumKind
    name: str
    source: str
    notes: tuple[str, ...] = field(default=())

    def __post_init__(self):
        wl = np.asarray(self.wavelengths, dtype=np.float64)
        values = np.atleast_2d(np.asarray(self.values, dtype=np.float64))
        if wl.ndim != 1 or wl.size < 2:
            raise InputError("a spectrum needs at least two wavelengths", source=self.source)
        if values.shape[-1] != wl.size:
            raise InputError(
                f"{values.shape[-1]} values for {wl.size} wavelengths", source=self.source
            )
        if not np.all(np.isfinite(wl)) or np.any(np.diff(wl) <= 0):
            raise InputError(
                "wavelengths must be finite and strictly increasing", source=self.source
            )
        for a in (wl, values):
            a.flags.writeable = False
        object.__setattr__(self, "wavelengths", wl)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "kind", SpectrumKind(self.kind))

    @property
    def n_samples(self) -> int:
        return self.values.shape[0]

    @property
    def range(self) -> tuple[float, float]:
        """First and last wavelength, nm."""
        return float(self.wavelengths[0]), float(self.wavelengths[-1])

    @property
    def support(self) -> tuple[float, float]:
        """The range less its leading and trailing zeros, nm: where the spectrum can be
        non-zero between samples (the bounding zero samples are kept). A NaN counts as
        non-zero (unknown); an all-zero spectrum's support is its range."""
        nonzero = np.flatnonzero(np.any(self.values != 0, axis=0))
        if nonzero.size == 0:
            return self.range
        lo, hi = max(nonzero[0] - 1, 0), min(nonzero[-1] + 1, self.wavelengths.size - 1)
        return float(self.wavelengths[lo]), float(self.wavelengths[hi])

    def resample(self, grid: np.ndarray) -> np.ndarray:
        """Values on ``grid`` (nm) by linear interpolation, shape (S, len(grid)).

        Never extrapolates: outside the measured range the result is NaN, and
        the caller decides (the model integrates only where every component is
        defined).
        """
        grid = np.asarray(grid, dtype=np.float64)
        out = np.full((self.n_samples, grid.size), np.nan)
        inside = (grid >= self.wavelengths[0]) & (grid <= self.wavelengths[-1])
        for i, row in enumerate(self.values):  # S is small (samples of one class)
            out[i, inside] = np.interp(grid[inside], self.wavelengths, row)
        # A NaN neighbour makes the interpolated value invalid too.
        if np.isnan(self.values).any():
            bad = np.isnan(self.values).astype(float)
            for i, row in enumerate(bad):
                out[i, inside] = np.where(
                    np.interp(grid[inside], self.wavelengths, row) > 0, np.nan, out[i, inside]
                )
        return out

    def with_values(
        self, values: np.ndarray, *, name: str | None = None, notes: Iterable[str] = ()
    ) -> Spectrum:
        """A copy with new values on the same wavelengths."""
        return Spectrum(
            self.wavelengths,
            values,
            self.kind,
            name or self.name,
            self.source,
            self.notes + tuple(notes),
        )
