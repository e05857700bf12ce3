"""Spectra: the data type, reading files, normalising spectrometer readings."""

from inspect_validate.spectra.io import normalise_reflectance, read_spectrometer, read_spectrum_csv
from inspect_validate.spectra.spectrum import Spectrum, SpectrumKind

__all__ = [
    "Spectrum",
    "SpectrumKind",
    "normalise_reflectance",
    "read_spectrometer",
    "read_spectrum_csv",
]
