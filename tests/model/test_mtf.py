"""The in-focus MTF against closed forms: the circular pupil's diffraction MTF (Goodman
eq. 6-32) at its known points, its MTF50 0.404/(λN), a spectrum's mean, the pixel's sinc;
and a station's in-focus MTF50 from its scene."""

import numpy as np
import pytest

from inspect_validate.model.mtf import (
    DIFFRACTION_MTF50,
    blur_sigma,
    diffraction_mtf,
    falls_to,
    focus_mtf,
    texture_kernel,
    texture_share,
)


def test_the_diffraction_mtf_at_its_known_points():
    # 1 at 0, 0 at the cut-off, and ½ at s = 0.40397 (solved to 1e-5 by bisection
    # of the closed form, as tables give 0.404)
    assert diffraction_mtf([0.0, 1.0, 1.5]) == pytest.approx([1.0, 0.0, 0.0], abs=1e-12)
    assert diffraction_mtf(DIFFRACTION_MTF50) == pytest.approx(0.5, abs=1e-5)
    # s = ½: (2/π)(π/3 − ½·√¾)
    assert diffraction_mtf(0.5) == pytest.approx(2 / np.pi * (np.pi / 3 - 0.5 * 0.75**0.5))


def test_one_wavelength_without_a_pixel_is_0404_over_lambda_n():
    """Monochromatic 550 nm at f/8 on 5 µm pixels: MTF50 in cycles/px is
    0.40397 · p/(λN); the pixel's sinc divided out."""
    f = np.linspace(0, 1, 20001)
    mtf = focus_mtf(f, wavelengths=[550.0], weights=[1.0], f_number=8.0, pixel_pitch=5.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        bare = np.where(f > 0, mtf / np.abs(np.sinc(f)), 1.0)
    assert falls_to(f, bare) == pytest.approx(DIFFRACTION_MTF50 * 5.0 / (0.55 * 8.0), rel=1e-4)


def test_a_spectrum_passes_the_weighted_mean_and_the_pixel_its_sinc():
    f = np.array([0.1, 0.3])
    lam, w = np.array([450.0, 650.0]), np.array([1.0, 3.0])
    got = focus_mtf(f, wavelengths=lam, weights=w, f_number=4.0, pixel_pitch=3.45)
    s = f[:, None] / 3.45 * lam * 1e-3 * 4.0
    want = (diffraction_mtf(s) @ (w / w.sum())) * np.abs(np.sinc(f))
    assert got == pytest.approx(want, rel=1e-12)
    with pytest.raises(ValueError, match="no wavelength"):
        focus_mtf(f, wavelengths=lam, weights=[0.0, 0.0], f_number=4.0, pixel_pitch=3.45)


def test_falls_to_interpolates_and_is_nan_where_it_never_falls():
    assert falls_to([0, 1, 2], [1.0, 0.6, 0.4]) == pytest.approx(1.5)
    assert np.isnan(falls_to([0, 1], [1.0, 0.9]))


def test_a_stations_in_focus_mtf50_lies_between_its_bounds():
    """The shipped station (f/4, 3.45 µm): below the pixel alone (sinc's MTF50 0.6034
    cycles/px) and above diffraction at 780 nm alone times it; its red illumination
    (longer waves) less sharp than its amber."""
    from conftest import ROOT

    from inspect_validate.station.file import read_station
    from inspect_validate.station.model import station_model

    station = read_station(ROOT / "sample_images" / "station" / "station.yaml")
    got = station_model(station).focus_mtf50(station)
    f = np.linspace(0, 1, 20001)
    worst = falls_to(f, focus_mtf(f, wavelengths=[780.0], weights=[1.0], f_number=4.0,
                                  pixel_pitch=3.45))  # fmt: skip
    for value in got.values():
        assert worst < value < 0.6034
    assert got["red"] < got["amber"]


@pytest.mark.parametrize("sigma", [0.3, 0.5, 1.0, 1.5])
def test_the_texture_kernel_is_the_box_blur_box_summed_on_a_fine_grid(sigma):
    """The closed form against the simulated camera's own kernel (box ∗ G ∗ box summed
    on a grid of 64 points a pixel): within 1.1e-4; it sums to 1; the share of an
    independent texture is Σc² squared (σ 0.5 px: 0.198, not the 0.411 of the Gaussian
    sampled at whole pixels)."""
    from inspect_validate.simulation.camera import _blur_kernel

    c = texture_kernel(sigma)
    assert c.sum() == pytest.approx(1.0, abs=1e-6)
    assert np.abs(c - _blur_kernel(sigma)).max() < 1.1e-4
    assert texture_share(sigma) == pytest.approx(float(np.sum(c * c) ** 2), rel=1e-12)
    assert texture_share(0.0) == 1.0
    if sigma == 0.5:
        assert texture_share(sigma) == pytest.approx(0.1976, abs=5e-4)


@pytest.mark.parametrize("sigma", [0.0, 0.4, 1.0, 2.0])
def test_the_blur_is_found_again_from_its_mtf50(sigma):
    """σ from the MTF50 of |sinc ν|·exp(−2π²σ²ν²), to 1e-6 px (the pixel alone: 0)."""
    f = np.linspace(1e-4, 0.999, 200_001)
    mtf50 = falls_to(f, np.abs(np.sinc(f)) * np.exp(-2 * np.pi**2 * sigma**2 * f**2))
    assert blur_sigma(mtf50) == pytest.approx(sigma, abs=1e-4)
    assert np.isnan(blur_sigma(float("nan")))
