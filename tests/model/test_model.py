"""The acquisition model against independent computations.

* The integral (32): a brute-force 0.01 nm integration with independent
  interpolation (tolerance 1e-4: the model's 1 nm trapezoid rule).
* μ and σ² in DN: a direct photon-count simulation of the EMVA 1288 model
  (Poisson electrons, Gaussian dark noise, gain, rounding; tolerance 5 standard
  errors of the simulation).
"""

import numpy as np
import pytest

from inspect_validate.components import (
    Light,
    Optics,
    SensorModel,
    builtin_sensor,
    ideal_lens,
    led,
    lens,
)
from inspect_validate.components.lights import C, H
from inspect_validate.errors import InputError
from inspect_validate.model import Exposure, ObjectClass, predict, rank
from inspect_validate.spectra import Spectrum

GRID = np.arange(400.0, 701.0, 1.0)


def flat_class(name, level, spread=0.0, n=5, lo=400, hi=700):
    g = np.arange(lo, hi + 1.0, 5.0)
    samples = [np.full(g.size, level * (1 + spread * (i - (n - 1) / 2))) for i in range(n)]
    return ObjectClass(name, Spectrum(g, samples, "reflectance", name, f"{name}.csv"))


def test_integral_matches_brute_force():
    light = led(550, 40, irradiance=10.0)
    optics = lens("visible", f_number=2.0)
    camera = builtin_sensor("cmos-visible")
    g = np.arange(400, 701, 10.0)
    refl = Spectrum(g, 0.3 + 0.4 * (g - 400) / 300, "reflectance", "ramp", "t")
    other = flat_class("flat", 0.5)
    p = predict(
        [light],
        [optics],
        [camera],
        [ObjectClass("ramp", refl), other],
        exposure=Exposure("fixed", time=1e-3),
        grid=GRID,
    )
    fine = np.arange(400.0, 700.0 + 1e-9, 0.01)
    e = np.interp(fine, light.spd.wavelengths, light.spd.values[0])
    e *= 10.0 / np.trapezoid(light.spd.values[0], light.spd.wavelengths)
    t = np.interp(fine, optics.transmission.wavelengths, optics.transmission.values[0])
    qe = np.interp(fine, camera.qe.wavelengths, camera.qe.values[0])
    r = np.interp(fine, g, refl.values[0])
    area = (camera.pixel_pitch * 1e-6) ** 2
    mu_e = area * 1e-3 / (H * C) / (4 * 2.0**2) * np.trapezoid(e * r * t * qe * fine * 1e-9, fine)
    assert p.electrons[0, 0, 0, 0] == pytest.approx(mu_e, rel=1e-4)


def test_mean_and_variance_match_a_photon_count_simulation():
    rng = np.random.default_rng(30)
    camera = SensorModel(
        "sim",
        Spectrum([300, 1100], [0.5, 0.5], "qe", "qe", "t"),
        gain=0.4,
        dark_noise=7.0,
        saturation=20000,
        bit_depth=14,
        dark_offset=50.0,
    )
    light = Light("flat", Spectrum([300, 1100], [1.0, 1.0], "spd", "flat", "t"), irradiance=1.0)
    classes = [flat_class("A", 0.4, spread=0.05), flat_class("B", 0.7, spread=0.0)]
    p = predict(
        [light], [ideal_lens()], [camera], classes, exposure=Exposure("fixed", time=2e-3), grid=GRID
    )
    n = 200_000
    for k in range(2):
        per_sample = (
            p.electrons[0, 0, 0, k] * (1 + 0.05 * (np.arange(5) - 2))
            if k == 0
            else np.full(5, p.electrons[0, 0, 0, k])
        )
        electrons = rng.poisson(np.repeat(per_sample, n // 5))
        dn = np.floor(50.0 + 0.4 * (electrons + rng.normal(0, 7.0, electrons.size)) + 0.5)
        mean, var = dn.mean(), dn.var(ddof=1)
        # The model's class variance counts the sample spread with ddof=1 over
        # 5 samples; the simulation pools the samples (ddof=0 weights).
        spectral = p.spectral_variance[0, 0, 0, k] * 4 / 5
        predicted_var = p.variance[0, 0, 0, k] - p.spectral_variance[0, 0, 0, k] + spectral
        assert p.mean[0, 0, 0, k] == pytest.approx(mean, abs=5 * np.sqrt(var / dn.size))
        assert predicted_var == pytest.approx(var, rel=5 * np.sqrt(2 / dn.size) + 1e-3)


def test_dark_current_and_fixed_pattern_match_a_pixel_simulation():
    """A sensor with dark current (5000 e⁻/s over 2 ms: 10 e⁻), DSNU 6 e⁻ and PRNU 3 %:
    the predicted class mean and (temporal + spatial) variance against 200,000 pixels
    simulated directly — each its own gain factor and dark signal, Poisson electrons,
    dark noise, rounding — within 5 standard errors."""
    rng = np.random.default_rng(32)
    camera = SensorModel(
        "sim",
        Spectrum([300, 1100], [0.5, 0.5], "qe", "qe", "t"),
        gain=0.4,
        dark_noise=7.0,
        saturation=20000,
        bit_depth=14,
        dark_offset=50.0,
        dark_current=5000.0,
        dsnu=6.0,
        prnu=0.03,
    )
    light = Light("flat", Spectrum([300, 1100], [1.0, 1.0], "spd", "flat", "t"), irradiance=1.0)
    classes = [flat_class("A", 0.4), flat_class("B", 0.7)]
    p = predict(
        [light], [ideal_lens()], [camera], classes, exposure=Exposure("fixed", time=2e-3), grid=GRID
    )
    n = 200_000
    for k in range(2):
        mu_e = p.electrons[0, 0, 0, k]
        gain_factor = 1 + 0.03 * rng.standard_normal(n)
        dark_signal = 6.0 * rng.standard_normal(n)
        electrons = rng.poisson(mu_e * gain_factor + 5000.0 * 2e-3) + dark_signal
        dn = np.floor(50.0 + 0.4 * (electrons + rng.normal(0, 7.0, n)) + 0.5)
        mean, var = dn.mean(), dn.var(ddof=1)
        assert p.mean[0, 0, 0, k] == pytest.approx(mean, abs=5 * np.sqrt(var / n))
        assert p.variance[0, 0, 0, k] == pytest.approx(var, rel=5 * np.sqrt(2 / n) + 1e-3)
        # The terms are there: without the fixed pattern the variance is far too small.
        assert p.variance[0, 0, 0, k] - 0.4**2 * (36 + (0.03 * mu_e) ** 2) < 0.9 * var


@pytest.mark.parametrize(
    "gain, dark_noise, dimmest, brightest", [(0.4, 7.0, 10, 5000), (0.5, 2.0, 1, 20)]
)
def test_expected_grey_is_the_truth_behind_expose(gain, dark_noise, dimmest, brightest):
    """expected_grey's per-pixel mean and temporal variance against 400 frames that
    expose renders from the same electrons, pooled over 2500 pixels: within 5
    standard errors. In the second, dim case (σ 1.1–2.4 DN) the rounding's 1/12 DN²
    is some 20 standard errors of the pooled variance: leaving it out fails."""
    from inspect_validate.model.render import expected_grey, expose

    camera = SensorModel(
        "sim",
        Spectrum([300, 1100], [0.5, 0.5], "qe", "qe", "t"),
        gain=gain,
        dark_noise=dark_noise,
        saturation=20000,
        bit_depth=14,
        dark_offset=50.0,
    )
    rng = np.random.default_rng(31)
    electrons = np.geomspace(dimmest, brightest, 2500).reshape(50, 50)
    frames = np.stack([expose(electrons, camera, rng=rng) for _ in range(400)]).astype(float)
    mean, variance = expected_grey(electrons, camera)
    n = frames.shape[0]
    z_mean = (frames.mean(axis=0) - mean) / np.sqrt(variance / n)
    assert abs(z_mean.mean()) < 5 / np.sqrt(z_mean.size)
    se = np.sqrt(np.sum(2 * variance**2 / (n - 1))) / variance.size
    assert np.mean(frames.var(axis=0, ddof=1)) == pytest.approx(np.mean(variance), abs=5 * se)


def test_auto_exposure_puts_the_brightest_class_at_target():
    cam = builtin_sensor("cmos-visible")
    p = predict(
        [led(520, 30)],
        [ideal_lens()],
        [cam],
        [flat_class("A", 0.2), flat_class("B", 0.8)],
        exposure=Exposure("auto", target=0.6),
        grid=GRID,
    )
    assert p.electrons[0, 0, 0].max() == pytest.approx(0.6 * cam.saturation, rel=1e-12)
    assert p.mean[0, 0, 0, 1] == pytest.approx(cam.gain * 0.6 * cam.saturation, rel=1e-9)


def test_saturation_is_clipped_and_reported():
    cam = builtin_sensor("cmos-visible")
    p = predict(
        [led(520, 30, irradiance=100.0)],
        [ideal_lens()],
        [cam],
        [flat_class("A", 0.2), flat_class("B", 0.8)],
        exposure=Exposure("fixed", time=1.0),
        grid=GRID,
    )
    assert p.saturated_fraction[0, 0, 0, 1] == pytest.approx(1.0)
    assert p.mean[0, 0, 0, 1] == pytest.approx(cam.max_dn, rel=1e-9)
    assert p.variance[0, 0, 0, 1] < 1e-6


def test_ranking_and_table2_pattern():
    from conftest import ROOT

    from inspect_validate.scene import read_scene

    sc = read_scene(ROOT / "sample_images/scenes/chapter_table2/scene.yaml")
    p = sc.predict()
    err = p.error_gaussian[..., 0]
    led_errors, daylight = err[1].ravel(), err[0].ravel()
    # Table 2: LED errors small and nearly constant, daylight errors spread widely.
    assert led_errors.max() < 1e-3 and led_errors.max() / led_errors.min() < 2
    assert daylight.max() > 0.2 and daylight.min() < 0.05 and daylight.min() > led_errors.max()
    order = rank(p)[0]
    assert all(p.lights[i] == "LED" for i in order[:4, 0])


def test_paperboard_amber_beats_red():
    from conftest import ROOT

    from inspect_validate.scene import read_scene

    sc = read_scene(ROOT / "sample_images/scenes/paperboard/scene.yaml")
    p = sc.predict()
    order, key = rank(p, comparison="A vs B,C")[:2]
    assert p.lights[order[0][0]] == "amber LED" and key[0] * 5 < key[1]


def test_errors_name_the_component():
    cam = builtin_sensor("cmos-visible")
    classes = [flat_class("A", 0.2), flat_class("B", 0.8)]
    with pytest.raises(InputError, match=r"relative SPD.*irradiance"):
        predict(
            [led(520, 30)],
            [ideal_lens()],
            [cam],
            classes,
            exposure=Exposure("fixed", time=1e-3),
            grid=GRID,
        )
    swir = builtin_sensor("ingaas-swir")
    with pytest.raises(
        InputError, match="no wavelength where light, optics and camera all respond"
    ):
        predict([led(520, 20)], [ideal_lens()], [swir], classes, grid=np.arange(400.0, 1800.0))
    masked = Spectrum([400, 550, 700], [[0.3, np.nan, 0.3]] * 2, "reflectance", "M", "m.csv")
    with pytest.raises(InputError, match=r"m\.csv: class 'M': reflectance invalid \(masked\)"):
        predict(
            [led(550, 30)], [ideal_lens()], [cam], [ObjectClass("M", masked), classes[0]], grid=GRID
        )
    with pytest.raises(InputError, match="at least two object classes"):
        predict([led(550, 30)], [ideal_lens()], [cam], classes[:1], grid=GRID)


def test_vectorised_shapes():
    p = predict(
        [led(450, 20), led(590, 15), led(630, 18)],
        [ideal_lens(), lens("visible")],
        [builtin_sensor("cmos-visible"), builtin_sensor("cmos-nir-enhanced")],
        [flat_class("A", 0.3), flat_class("B", 0.5), flat_class("C", 0.7)],
        grid=GRID,
    )
    assert p.mean.shape == (3, 2, 2, 3) and p.snr_db.shape == (3, 2, 2, 6)
    assert p.comparisons[-1] == (("C",), ("A", "B"))
    # The UV lens passes 300 nm, the visible lens hardly does.
    uv, vis = (
        Optics(k, lens(k).transmission).transmission.resample(np.array([300.0]))[0, 0]
        for k in ("uv", "visible")
    )
    assert uv > 2 * vis
