"""Spectrum input: CSV parsing, the errors that name file and line, resampling, (33)-(34)."""

import numpy as np
import pytest

from inspect_validate.errors import InputError
from inspect_validate.spectra import (
    Spectrum,
    normalise_reflectance,
    read_spectrometer,
    read_spectrum_csv,
)


def write(tmp_path, text, name="s.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_csv_with_header_comments_and_samples(tmp_path):
    p = write(tmp_path, "# measured 2026\nnm;r1;r2\n400;0.1;0.2\n410;0.3;0.4\n420;0.5;0.6\n")
    s = read_spectrum_csv(p, kind="reflectance")
    assert s.n_samples == 2 and s.range == (400, 420)
    assert np.allclose(s.values[1], [0.2, 0.4, 0.6])
    assert "columns: r1, r2" in s.notes[0]
    s = read_spectrum_csv(write(tmp_path, "400 0.1\n500 0.2\n", "ws.txt"), kind="qe")
    assert s.values.shape == (1, 2)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("400,0.1\n410,nan\n", "line 2: NaN"),
        ("400,0.1\n400,0.2\n", "line 2: duplicate wavelength 400"),
        ("400,0.1\n410,0.2\n405,0.3\n", "line 3: decreasing wavelength 405"),
        ("400,0.1\n410,abc\n", "line 2: not a number"),
        ("400,0.1\n410,-0.2\n", "line 2: value -0.2 at 410 nm is below zero beyond noise"),
        ("400,0.1,0.2\n410,0.2\n", "line 2: 2 columns, expected 3"),
        ("400,0.1\n", "at least two wavelengths"),
    ],
)
def test_bad_files_name_file_and_line(tmp_path, text, message):
    p = write(tmp_path, text)
    with pytest.raises(InputError, match=message) as info:
        read_spectrum_csv(p, kind="reflectance")
    assert str(p) in str(info.value)


def test_noise_below_zero_is_clipped_and_noted(tmp_path):
    s = read_spectrum_csv(write(tmp_path, "400,-0.01\n410,0.2\n"), kind="reflectance")
    assert s.values[0, 0] == 0.0 and "clipped" in s.notes[0]


def test_resample_interpolates_and_never_extrapolates():
    s = Spectrum([400, 500, 600], [0.0, 1.0, 0.0], "transmission", "t", "test")
    out = s.resample(np.array([350, 400, 450, 550, 600, 650]))
    assert np.isnan(out[0, 0]) and np.isnan(out[0, -1])
    assert np.allclose(out[0, 1:-1], [0.0, 0.5, 0.5, 0.0])
    masked = Spectrum([400, 500, 600], [0.2, np.nan, 0.4], "reflectance", "r", "test")
    assert np.isnan(masked.resample(np.array([450.0]))[0, 0])


def test_spectrum_validation():
    with pytest.raises(InputError, match="strictly increasing"):
        Spectrum([400, 400], [1, 2], "spd", "x", "src")
    with pytest.raises(InputError, match="3 values for 2 wavelengths"):
        Spectrum([400, 410], [1, 2, 3], "spd", "x", "src")


def test_normalisation_33_34_divides_and_masks(tmp_path):
    wl = "400,410,420,430"
    readings = write(
        tmp_path,
        "\n".join(
            f"{w},{r1},{r2}"
            for w, r1, r2 in zip(wl.split(","), [60, 110, 30, 5], [70, 120, 40, 6], strict=True)
        ),
        "r.csv",
    )
    black = write(
        tmp_path,
        "\n".join(f"{w},{b}" for w, b in zip(wl.split(","), [10, 10, -1, 5], strict=True)),
        "b.csv",
    )
    white = write(
        tmp_path,
        "\n".join(f"{w},{v}" for w, v in zip(wl.split(","), [210, 110, 99, 5], strict=True)),
        "w.csv",
    )
    s = read_spectrometer(readings, black=black, white=white)
    expected = (np.array([[60, 110, 30, 5], [70, 120, 40, 6]]) - [10, 10, -1, 5]) / np.array(
        [200, 100, 100, 0.0]
    ).clip(1e-300)
    assert np.allclose(s.values[:, :3], expected[:, :3])
    assert np.all(np.isnan(s.values[:, 3]))  # white − black = 0: invalid, never a number
    assert "1 wavelengths invalid" in s.notes[0] and "430" in s.notes[0]


def test_normalisation_needs_matching_wavelengths():
    a = Spectrum([400, 410], [1, 2], "spd", "a", "a.csv")
    b = Spectrum([400, 420], [1, 2], "spd", "b", "b.csv")
    with pytest.raises(InputError, match=r"b\.csv: reference wavelengths differ"):
        normalise_reflectance(a, b, a)
