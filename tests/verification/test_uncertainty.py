"""Standard errors of measured and predicted class statistics and separations, against
Monte Carlo: the spread of the same estimate over many independent draws.

Each test draws ``N`` independent repeats of what the estimate is made from and compares
the sample standard deviation of the estimates with the standard error the module
computes from one draw (averaged over draws). With N = 400 the sample standard deviation
itself is known to ±3.5 % (1/√(2N)); the delta method's own approximation error is
below 5 % here. Tolerance: 15 %.
"""

import numpy as np
import pytest

from inspect_validate.comparisons import Comparisons
from inspect_validate.measurement import compare, measure_classes
from inspect_validate.station.prediction import StationPrediction
from inspect_validate.verification.uncertainty import (
    class_standard_errors,
    measured_standard_errors,
    predicted_standard_errors,
    separation_standard_errors,
)

N = 400
TOL = 0.15


def _stack(rng, fixed, sigma_t, frames):
    """Frames of fixed pixel values ``fixed`` (H, W) with Gaussian temporal noise."""
    return fixed[None] + rng.normal(0.0, sigma_t, (frames, *fixed.shape))


@pytest.mark.parametrize("frames", [1, 4])
def test_class_standard_errors_match_the_spread_over_captures_of_the_same_parts(frames):
    """The same parts (a fixed spatial pattern, σ_s = 2 DN) captured again and again with
    σ_t = 3 DN of temporal noise: μ and σ² vary over the captures by what
    class_standard_errors says from one capture. One frame cannot tell temporal from
    spatial noise: all of σ² counts as noise, an upper bound of the spread."""
    rng = np.random.default_rng(1)
    fixed = 100.0 + rng.normal(0.0, 2.0, (40, 50))
    mask = {"A": np.ones(fixed.shape, bool)}
    means, variances, se = [], [], []
    for _ in range(N):
        (c,) = measure_classes(_stack(rng, fixed, 3.0, frames), mask)
        means.append(c.mean)
        variances.append(c.variance)
        se.append(class_standard_errors(c))
    se = np.mean(se, axis=0)
    if frames == 1:
        assert se[0] == pytest.approx(np.sqrt(13.0 / 2000), rel=0.1)  # σ²_total / n
        assert np.std(means, ddof=1) < se[0] and np.std(variances, ddof=1) < se[1]
        return
    assert np.std(means, ddof=1) == pytest.approx(se[0], rel=TOL)
    assert np.std(variances, ddof=1) == pytest.approx(se[1], rel=TOL)


def test_separation_standard_errors_match_the_spread_of_snr_cnr_and_log_error():
    """Three classes; SNR_dB (36), CNR_dB and log₁₀ ε of their pairs and of one against
    the others (mixtures: their ε is a root search), each over 400 captures of the same
    parts. (Where |Δμ| is within a few standard errors of 0, SNR_dB is the log of a
    near-zero difference and no normal approximation holds: the checks leave such
    comparisons out below their SNR_dB floor; C vs A,B here is 1 DN apart, 20 of its SE.)"""
    rng = np.random.default_rng(2)
    shape = (30, 40)
    fixed = [m + rng.normal(0.0, s, shape) for m, s in ((100, 2.0), (108, 1.5), (103, 2.5))]
    comparisons = Comparisons.of(["A", "B", "C"])
    frame = np.concatenate(fixed, axis=0)
    masks = {
        name: np.arange(frame.shape[0])[:, None] // shape[0] == k for k, name in enumerate("ABC")
    }
    masks = {k: np.broadcast_to(v, frame.shape) for k, v in masks.items()}
    values, errors = [], []
    for _ in range(N):
        classes = measure_classes(_stack(rng, frame, 3.0, 3), masks)
        m = compare(classes, comparisons, kde="never")
        values.append(
            [
                [c.snr_db for c in m.comparisons],
                [c.cnr_db for c in m.comparisons],
                [c.log_error_gaussian for c in m.comparisons],
            ]
        )
        if len(errors) < 40:  # the estimate barely changes between draws
            e = measured_standard_errors(m, comparisons)
            errors.append([e.snr_db, e.cnr_db, e.log_error])
    spread = np.std(np.array(values), axis=0, ddof=1)
    expected = np.mean(np.array(errors), axis=0)
    np.testing.assert_allclose(spread, expected, rtol=TOL)


def test_a_variance_step_never_crosses_zero():
    """A class whose σ² is below its standard error: the step is shortened and scaled back
    (no NaN, and the result is the derivative's, as a finite difference inside 0 < σ²)."""
    comparisons = Comparisons.of(["A", "B"])
    snr, _, log_error = separation_standard_errors(
        [100.0, 101.0], [0.01, 1.0], [0.001, 0.01], [0.05, 0.01], comparisons
    )
    assert np.all(np.isfinite(snr)) and np.all(np.isfinite(log_error))
    # SNR = Δμ/(σ₁² + σ₂²): d SNR_dB / d σ₁² = −20/ln10 / (σ₁² + σ₂²), times SE 0.05.
    d_var = 20 / np.log(10) / 1.01 * 0.05
    d_mean = 20 / np.log(10) / 1.0 * np.hypot(0.001, 0.01)
    assert snr[0] == pytest.approx(np.hypot(d_var, d_mean), rel=0.02)


def test_predicted_standard_errors_match_the_spread_over_draws_of_the_samples(tmp_path):
    """The scene's classes are S = 12 spectra drawn from a population; the prediction's
    class μ and SNR_dB vary over 300 draws by what predicted_standard_errors says of one
    draw (normal theory for σ²: the population is Gaussian here)."""
    from inspect_validate.components.lights import Light
    from inspect_validate.components.optics import Optics
    from inspect_validate.components.sensors import SensorModel
    from inspect_validate.model import Exposure, ObjectClass, predict
    from inspect_validate.spectra import Spectrum, SpectrumKind

    grid = np.arange(400.0, 701.0, 10.0)
    rng = np.random.default_rng(3)
    flat = np.ones((1, grid.size))
    light = Light("flat", Spectrum(grid, flat, SpectrumKind.SPD, "flat", "test"), irradiance=5.0)
    optics = Optics("ideal", Spectrum(grid, flat, SpectrumKind.TRANSMISSION, "ideal", "test"))
    camera = SensorModel(
        "cam",
        Spectrum(grid, 0.5 * flat, SpectrumKind.QE, "qe", "test"),
        gain=0.05,
        dark_noise=5.0,
        saturation=1e9,
        bit_depth=16,
    )
    comparisons = Comparisons.of(["A", "B"])
    snr, mean, se_snr, se_mean = [], [], [], []
    for _ in range(300):
        classes = [
            ObjectClass(
                name,
                Spectrum(
                    grid,
                    level + rng.normal(0.0, 0.02, (12, 1)) * flat,
                    SpectrumKind.REFLECTANCE,
                    name,
                    "draw",
                ),
            )
            for name, level in (("A", 0.50), ("B", 0.52))
        ]
        p = predict(
            [light],
            [optics],
            [camera],
            classes,
            exposure=Exposure("fixed", time=0.01),
            grid=grid,
        )
        snr.append(p.snr_db[0, 0, 0, 0])
        mean.append(p.mean[0, 0, 0, 0])
        e = predicted_standard_errors(StationPrediction.of(p), 0, comparisons)
        se_snr.append(e.snr_db[0])
        se_mean.append(e.mean[0])
    assert np.std(mean, ddof=1) == pytest.approx(np.mean(se_mean), rel=TOL)
    assert np.std(snr, ddof=1) == pytest.approx(np.mean(se_snr), rel=TOL)
