"""Component models against colour-science and published data."""

import colour
import numpy as np
import pytest

from inspect_validate.components import (
    MATERIALS,
    blackbody,
    builtin_sensor,
    cie_daylight,
    cie_illuminant,
    energy_efficiency,
    lens,
    material_transmission,
    planck,
)
from inspect_validate.components import lights as lights_module
from inspect_validate.components.lights import K_B, C, H, ohno_led_spd
from inspect_validate.components.optics import refractive_index
from inspect_validate.errors import InputError


def test_planck_matches_colour_science_with_the_same_constants():
    wl = np.geomspace(100, 20000, 200)
    for t in (300.0, 1000.0, 3200.0, 5500.0, 20000.0):
        # colour-science takes the first radiation constant c1 = 2πhc² and divides by π.
        ref = (
            colour.colorimetry.planck_law(wl * 1e-9, t, c1=2 * np.pi * H * C**2, c2=H * C / K_B)
            * 1e-9
        )
        assert np.allclose(planck(wl, t), ref, rtol=1e-12, atol=0)


def test_planck_is_stable_at_extremes():
    u = planck(np.array([1.0, 10.0, 1e6]), np.array([50.0]))
    assert np.all(np.isfinite(u)) and u[0] == 0.0 and u[2] > 0
    assert np.all(np.isfinite(planck(1e-3, 1e-3)))


def test_ohno_led_matches_colour_science_and_has_the_stated_fwhm():
    grid = np.arange(500.0, 600.0, 0.01)
    ours = ohno_led_spd(grid, 555, 30)
    delta = 30 / (2 * np.sqrt(-np.log(lights_module._G_HALF)))
    ref = colour.colorimetry.sd_single_led_Ohno2005(
        555, delta, shape=colour.SpectralShape(500, 600, 1)
    )
    assert np.allclose(
        ohno_led_spd(ref.wavelengths, 555, 30), ref.values / ref.values.max(), rtol=1e-12
    )
    half = grid[ours >= 0.5]
    assert half[-1] - half[0] == pytest.approx(30, abs=0.02)


def test_ohno_half_maximum_constant_is_the_quintics_root():
    # Independent references: scipy's brentq and a 40-digit mpmath root.
    import mpmath
    from scipy.optimize import brentq

    g = lights_module._G_HALF
    assert g == brentq(lambda g: g + 2 * g**5 - 1.5, 0.5, 1.0, xtol=1e-15)
    with mpmath.workdps(40):
        exact = mpmath.findroot(lambda g: g + 2 * g**5 - mpmath.mpf(3) / 2, 0.8)
        assert abs(mpmath.mpf(g) - exact) <= mpmath.mpf(2) ** -53 * exact


# CIE 15:2004 Table T.1, the relative SPD of D65 (1 at 560 nm = 100), read from the
# publication: an independent reference for the data taken from colour-science.
D65_PUBLISHED = {300: 0.0341, 400: 82.7549, 460: 117.812, 500: 109.354, 560: 100.0,
                 600: 90.0062, 700: 71.6091}  # fmt: skip


def test_cie_illuminants_are_the_published_tables():
    """D65 as read is CIE 15's table (it was compared with colour-science, where it is
    read from: a test that could not fail)."""
    d65 = cie_illuminant("D65")
    wavelengths = np.array(list(D65_PUBLISHED))
    ours = d65.spd.resample(wavelengths)[0]
    scale = 100.0 / d65.spd.resample(np.array([560.0]))[0][0]
    np.testing.assert_allclose(ours * scale, list(D65_PUBLISHED.values()), rtol=1e-6)
    daylight = cie_daylight(6500)
    ref = colour.SDS_ILLUMINANTS["D65"]
    common = np.intersect1d(daylight.spd.wavelengths, ref.wavelengths)
    ours = daylight.spd.resample(common)[0]
    theirs = ref.values[np.isin(ref.wavelengths, common)]
    # Computed D-series at 6500·1.4388/1.4380 K against the tabulated D65.
    assert np.allclose(ours / ours.sum(), theirs / theirs.sum(), rtol=0.02)
    assert "HP1" in cie_illuminant("HP1").name
    with pytest.raises(InputError, match="unknown CIE illuminant"):
        cie_illuminant("D99")


def test_refractive_indices_are_the_published_values():
    assert refractive_index("BK7", 587.56) == pytest.approx(1.5168, abs=1e-4)  # n_d
    assert refractive_index("fused_silica", 587.56) == pytest.approx(1.4585, abs=1e-4)
    assert refractive_index("CaF2", 587.56) == pytest.approx(1.4338, abs=1e-4)


@pytest.mark.parametrize("material", list(MATERIALS))
def test_material_transmission_follows_table1_range(material):
    t = material_transmission(material)
    lo, hi = MATERIALS[material].range_nm
    inside = t.resample(np.geomspace(lo * 1.15, hi * 0.85, 20))[0]
    n = refractive_index(material, np.geomspace(lo * 1.15, hi * 0.85, 20))
    fresnel = 2 * n / (n**2 + 1)  # two surfaces, incoherent multiple reflections, no absorption
    assert np.all(inside <= fresnel * (1 + 1e-4)) and np.all(inside > 0.8 * fresnel)
    assert t.resample(np.array([lo * 0.85]))[0, 0] < 0.05  # beyond the UV edge


def test_lens_is_material_times_coating():
    visible = lens("visible")
    t = visible.transmission.resample(np.array([550.0, 350.0, 900.0]))[0]
    assert t[0] > 0.85 and t[1] < t[0] and t[2] < t[0]
    with pytest.raises(InputError, match="unknown lens"):
        lens("fisheye")


def test_cameras_and_energy_efficiency():
    cam = builtin_sensor("cmos-visible")
    assert "(model)" in cam.name and cam.max_dn == pytest.approx(min(4095, 0.39 * 10500))
    assert energy_efficiency(0.5, 600) == pytest.approx(0.5 * 600e-9 / (H * C))
    with pytest.raises(InputError, match="built-in cameras"):
        builtin_sensor("ccd-9000")
    assert blackbody(3000).spd.values.max() > 0


def test_gain_factor_is_an_amplitude_ratio():
    from inspect_validate.components.sensors import gain_factor

    assert gain_factor(0.0) == 1.0
    assert gain_factor(20.0) == pytest.approx(10.0, rel=1e-15)
    assert gain_factor(-20.0 * np.log10(2.0)) == pytest.approx(0.5, rel=1e-15)
