"""Reading spectra: CSV files and spectrometer readings with black/white references.

CSV: the first column is the wavelength in nm, every further column one sample.
A first line that is not numeric is a header (its column names are kept in the
notes); lines starting with ``#`` are comments; the delimiter is a comma,
semicolon, tab or spaces. Errors name the file and line.
"""

from __future__ import annotations

import csv
import io as _io
from pathlib import Path

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.files import input_file
from inspect_validate.spectra.spectrum import Spectrum, SpectrumKind

__all__ = ["normalise_reflectance", "read_spectrometer", "read_spectrum_csv"]

NEGATIVE_NOISE = 0.02
"""Reflectance, transmission or QE down to −0.02 is measurement noise (clipped to 0, noted);
below that the file is refused."""
UPPER = {
    SpectrumKind.REFLECTANCE: 2.0,  # fluorescent or glossy samples exceed a white standard
    SpectrumKind.TRANSMISSION: 1.0 + NEGATIVE_NOISE,
    SpectrumKind.QE: 1.0 + NEGATIVE_NOISE,
    SpectrumKind.SPD: 1e12,  # W·m⁻²·nm⁻¹ or relative units: beyond this it is not a light
}
"""Largest accepted value per kind; above it the file is refused (values in percent, wrong column)."""
WAVELENGTH_RANGE = (1.0, 100_000.0)
"""nm: the first column must lie within (1 nm, 100 µm]."""
SPECTRUM_MAX_BYTES = 64 * 2**20
"""The largest spectrum CSV read: a spectrometer's 10⁶ rows are about 20 MB."""


def read_spectrum_csv(
    path: str | Path, *, kind: SpectrumKind | str, name: str | None = None, raw: bool = False
) -> Spectrum:
    """Read a spectrum CSV (wavelength in nm, then one column per sample).

    ``raw=True`` reads spectrometer counts, which may be negative (noise on the
    black reference) and are checked only for being numbers.

    Raises
    ------
    InputError
        Unreadable file, non-numeric or NaN value, non-increasing or duplicate
        wavelength, too few rows, or values far below zero; the message names
        the file and line.
    """
    path = input_file(
        path,
        "spectrum file",
        todo="give a CSV of wavelength (nm) and value",
        largest=SPECTRUM_MAX_BYTES,
    )
    kind = SpectrumKind(kind)
    try:
        text = path.read_text()
    except OSError as exc:
        raise InputError(f"cannot read spectrum file: {exc.strerror}", source=str(path)) from None
    except UnicodeDecodeError:
        raise InputError("not a text (CSV) file", source=str(path)) from None
    lines = [
        (i + 1, ln)
        for i, ln in enumerate(text.splitlines())
        if ln.strip() and not ln.lstrip().startswith("#")
    ]
    if not lines:
        raise InputError("no data", source=str(path))
    dialect = _dialect(lines[0][1])
    rows: list[tuple[int, list[float]]] = []
    header = None
    for k, (lineno, line) in enumerate(lines):
        cells = [
            c.strip() for c in next(csv.reader(_io.StringIO(line), dialect)) if c.strip() != ""
        ]
        try:
            numbers = [float(c) for c in cells]
        except ValueError:
            if k == 0:
                header = cells
                continue
            raise InputError(
                f"line {lineno}: not a number in {line.strip()!r}", source=str(path)
            ) from None
        if rows and len(numbers) != len(rows[0][1]):
            raise InputError(
                f"line {lineno}: {len(numbers)} columns, expected {len(rows[0][1])}",
                source=str(path),
            )
        if len(numbers) < 2:
            raise InputError(
                f"line {lineno}: need a wavelength and at least one value", source=str(path)
            )
        bad = [j for j, v in enumerate(numbers) if not np.isfinite(v)]
        if bad:
            raise InputError(
                f"line {lineno}: NaN or infinite value in column {bad[0] + 1}", source=str(path)
            )
        rows.append((lineno, numbers))
    if len(rows) < 2:
        raise InputError("needs at least two wavelengths", source=str(path))
    data = np.array([r[1] for r in rows])
    wl = data[:, 0]
    for (ln, _), step in zip(rows[1:], np.diff(wl), strict=True):
        if step <= 0:
            what = "duplicate" if step == 0 else "decreasing"
            raise InputError(
                f"line {ln}: {what} wavelength {wl[rows.index((ln, _))]:g} nm", source=str(path)
            )
    _check_wavelengths(wl, path)
    values = data[:, 1:].T
    _check_upper(values, wl, rows, kind, path, raw)
    notes = []
    if header:
        notes.append(f"columns: {', '.join(header[1:])}")
    if raw:
        pass  # counts: any finite number
    elif kind is not SpectrumKind.SPD:
        values, clip_note = _check_negative(values, wl, rows, path)
        notes += clip_note
    elif np.any(values < 0):
        j = int(np.argwhere(values < 0)[0][1])
        raise InputError(f"line {rows[j][0]}: negative power", source=str(path))
    return Spectrum(wl, values, kind, name or path.stem, str(path), tuple(notes))


def _check_wavelengths(wl, path):
    lo, hi = WAVELENGTH_RANGE
    if wl[-1] < 50.0 and wl[0] > 0:
        raise InputError(
            f"wavelengths {wl[0]:g}–{wl[-1]:g} look like µm; the first column must be in nm "
            "(multiply by 1000)",
            source=str(path),
        )
    if wl[0] <= lo or wl[-1] > hi:
        raise InputError(
            f"wavelengths {wl[0]:g}–{wl[-1]:g} nm are outside {lo:g} nm – {hi / 1000:g} µm; "
            "the first column must be the wavelength in nm",
            source=str(path),
        )


def _check_upper(values, wl, rows, kind, path, raw):
    limit = UPPER[kind] if not raw else UPPER[SpectrumKind.SPD]
    over = values > limit
    if not over.any():
        return
    s, j = np.argwhere(over)[0]
    hint = (
        "values in percent? divide by 100"
        if kind is not SpectrumKind.SPD and values.max() <= 100 * limit
        else "check the column order and units"
    )
    raise InputError(
        f"line {rows[j][0]}: {kind.value} {values[s, j]:g} at {wl[j]:g} nm is above {limit:g}; {hint}",
        source=str(path),
    )


def _dialect(line: str):
    for delim in (",", ";", "\t"):
        if delim in line:

            class D(csv.excel):
                delimiter = delim

            return D

    class Space(csv.excel):
        delimiter = " "
        skipinitialspace = True

    return Space


def _check_negative(values, wl, rows, path):
    far = values < -NEGATIVE_NOISE
    if far.any():
        s, j = np.argwhere(far)[0]
        raise InputError(
            f"line {rows[j][0]}: value {values[s, j]:g} at {wl[j]:g} nm is below zero beyond noise "
            f"(−{NEGATIVE_NOISE}); check the black reference or the column order",
            source=str(path),
        )
    small = values < 0
    if small.any():
        return np.maximum(values, 0.0), [
            f"{int(small.sum())} slightly negative values clipped to 0"
        ]
    return values, []


def normalise_reflectance(
    readings: Spectrum, black: Spectrum, white: Spectrum, *, name: str | None = None
) -> Spectrum:
    """Compensate (33) and normalise (34) raw spectrometer readings.

    ``R_norm = (R − R_black) / (R_white − R_black)`` where the compensated white
    is > 0; elsewhere the value is invalid (NaN) and the range is noted. The
    chapter's printed (34) subtracts (a misprint); its text divides.

    Parameters
    ----------
    readings : Spectrum
        Raw readings of the object, one sample per reading.
    black, white : Spectrum
        Black and white reference readings (averaged if several), on the same
        wavelengths as ``readings``.
    """
    for ref in (black, white):
        if ref.wavelengths.shape != readings.wavelengths.shape or not np.allclose(
            ref.wavelengths, readings.wavelengths
        ):
            raise InputError(
                "reference wavelengths differ from the readings'; export all with one spectrometer setting",
                source=ref.source,
            )
    b = black.values.mean(axis=0)
    w_comp = white.values.mean(axis=0) - b
    valid = w_comp > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        norm = np.where(valid, (readings.values - b) / w_comp, np.nan)
    notes = []
    if not valid.all():
        bad = readings.wavelengths[~valid]
        notes.append(
            f"{bad.size} wavelengths invalid (white reference ≤ black) between {bad.min():g} and {bad.max():g} nm"
        )
    return Spectrum(
        readings.wavelengths,
        norm,
        SpectrumKind.REFLECTANCE,
        name or readings.name,
        readings.source,
        tuple(notes),
    )


def read_spectrometer(
    readings: str | Path, *, black: str | Path, white: str | Path, name: str | None = None
) -> Spectrum:
    """Reflectance from spectrometer CSV exports: readings plus black and white references."""
    counts = [
        read_spectrum_csv(p, kind=SpectrumKind.SPD, raw=True) for p in (readings, black, white)
    ]
    return normalise_reflectance(*counts, name=name or Path(readings).stem)
