"""The light's field: the surface fitted to flat targets of known falloff (vignetting
quadratic in the radius, a linear gradient, both), each region's share and spread against
closed forms, the field file refused where edited, and the field in the prediction: μ
scaled by the region's share, σ² gaining v·S² exactly."""

import json

import numpy as np
import pytest

from inspect_validate.characterization.field import (
    Field,
    degree_of,
    fit_field,
    region_field,
)
from inspect_validate.errors import InputError

H, W = 240, 320


def _truth(vignetting, gradient):
    yy, xx = np.mgrid[0:H, 0:W]
    r2 = ((yy - (H - 1) / 2) ** 2 + (xx - (W - 1) / 2) ** 2) / (
        ((H - 1) / 2) ** 2 + ((W - 1) / 2) ** 2
    )
    f = (1 - vignetting * r2) * (1 - gradient * xx / (W - 1))
    return f / f.max()


@pytest.mark.parametrize(
    ("vignetting", "gradient"), [(0.05, 0.0), (0.3, 0.0), (0.0, 0.1), (0.1, 0.1), (0.3, -0.1)]
)
def test_the_surface_holds_a_vignetting_times_a_gradient(vignetting, gradient):
    """Frames averaging 150 DN of signal with 0.3 DN of noise a pixel (four frames of a
    Mono8 camera's): the corners' falloff within 0.05 % (absolute) of the truth, every
    pixel within 0.05 %, the residual at the noise's block mean (0.3/150/8 = 2.5e-4). A
    surface of degree 2 (HALCON's) misses a vignetting times a gradient by over 0.2 %."""
    truth = _truth(vignetting, gradient)
    rng = np.random.default_rng(3)
    f = fit_field(150 * truth + rng.normal(0, 0.3, truth.shape))
    t_corners = truth[[0, 0, -1, -1], [0, -1, 0, -1]]
    assert f.corner_falloff == pytest.approx(1 - t_corners.mean(), abs=5e-4)
    assert np.abs(f.map() - truth).max() < 5e-4
    assert f.residual < 4e-4
    assert f.signal == pytest.approx(150, rel=2e-3)
    assert f.uniformity == pytest.approx(truth.min(), abs=5e-4)
    if vignetting and gradient:
        coarse = fit_field(150 * truth, degree=2)
        assert np.abs(coarse.map() - truth).max() > 2e-3


def test_a_regions_share_and_spread_are_the_ramps_closed_form():
    """A linear gradient g across the frame: over columns a..b its mean is the mean of
    the ramp, its variance (g/(W−1))²·((b−a+1)² − 1)/12 (a discrete uniform's)."""
    g = 0.2
    f = fit_field(100 * _truth(0.0, g))
    mask = np.zeros((H, W), bool)
    a, b = 40, 199
    mask[50:150, a : b + 1] = True
    r = region_field(f, mask)
    x = np.arange(a, b + 1)
    ramp = 1 - g * x / (W - 1)
    assert r.mean == pytest.approx(ramp.mean(), rel=1e-5)
    variance = (g / (W - 1)) ** 2 * ((b - a + 1) ** 2 - 1) / 12
    assert r.spread == pytest.approx(variance / ramp.mean() ** 2, rel=1e-3)
    assert (r.low, r.high) == pytest.approx((ramp.min(), ramp.max()), abs=1e-5)


def test_bad_frames_and_masks_are_refused_naming_why():
    with pytest.raises(InputError, match="too few"):
        fit_field(np.ones((16, 16)))
    with pytest.raises(InputError, match="no light above dark"):
        fit_field(-np.ones((H, W)))
    image = np.ones((H, W))
    image[3, 3] = np.nan
    with pytest.raises(InputError, match="not finite"):
        fit_field(image)
    f = fit_field(np.ones((H, W)))
    with pytest.raises(InputError, match="320×240 frames"):
        region_field(f, np.ones((100, 100), bool))
    with pytest.raises(InputError, match="no pixel"):
        region_field(f, np.zeros((H, W), bool))


def test_a_surfaces_degree_follows_from_its_coefficients():
    assert [degree_of(n) for n in (1, 3, 6, 10, 15)] == [0, 1, 2, 3, 4]
    with pytest.raises(ValueError):
        degree_of(7)


def test_the_field_file_is_read_back_and_an_edited_one_refused(tmp_path):
    from inspect_validate.characterization.field_file import (
        field_document,
        read_field,
        write_field,
    )

    f = fit_field(100 * _truth(0.2, 0.05))
    mask = np.zeros((H, W), bool)
    mask[:20, :20] = True
    doc = field_document({"amber": f}, masks={"A": mask})
    path = write_field(tmp_path / "field.json", doc)
    back = read_field(path).fields()["amber"]
    assert np.allclose(back.map(), f.map())
    assert doc["illuminations"]["amber"]["regions"]["A"]["mean"] < 0.85  # a corner
    edited = json.loads(path.read_text())
    edited["illuminations"]["amber"]["coefficients"][0] *= 1.1
    path.write_text(json.dumps(edited))
    with pytest.raises(InputError, match="was edited"):
        read_field(path)
    edited["illuminations"]["amber"]["coefficients"].append(0.0)
    path.write_text(json.dumps(edited))
    with pytest.raises(InputError, match="polynomial"):
        read_field(path)
    path.write_text(json.dumps({"schema": "inspect-validate/golden"}))
    with pytest.raises(InputError, match="this is a golden file"):
        read_field(path)
    with pytest.raises(InputError, match="field"):
        read_field(tmp_path / "missing.json")


def test_the_field_in_the_prediction_scales_mu_and_adds_its_spread():
    """Each class at m of the light and spread v: its signal above dark is m times the
    point's, its σ² the point's at m of the light plus v·(m S)² (the field's own
    variance over the region), to rounding."""
    from conftest import ROOT

    from inspect_validate.station.file import read_station
    from inspect_validate.station.model import station_model

    station = read_station(ROOT / "sample_images" / "station" / "station.yaml")
    model = station_model(station)
    point = model.predict(station)
    n_l, n_k = len(point.illuminations), len(point.classes)
    m, v = 0.8, 0.004
    field = np.zeros((n_l, n_k, 2))
    field[..., 0], field[..., 1] = m, v
    fielded = model.predict(station, field=field)
    dark = model.sensor.dark_offset
    signal = fielded.mean - dark
    assert signal == pytest.approx(m * (point.mean - dark), rel=1e-9)
    # the point at m of the light: the same chain with every light scaled by m
    dimmer = point.calibrated(dict.fromkeys(point.illuminations, m))
    assert fielded.variance == pytest.approx(dimmer.variance + v * signal**2, rel=1e-9)
    # kept through a calibration
    again = fielded.calibrated(dict.fromkeys(point.illuminations, 1.0))
    assert again.variance == pytest.approx(fielded.variance, rel=1e-12)


def test_a_field_is_a_frozen_record():
    f = Field(32, 32, (1.0,), 0.0, 1.0)
    assert f.at(3, 4) == pytest.approx(1.0)
    with pytest.raises(AttributeError):
        f.width = 3


def test_the_parts_show_the_fields_slopes_with_statsmodels_standard_errors():
    """μ of 30 parts on a plane (1 % per 100 px along x, −2 % along y) with noise: the
    slopes relative to μ's mean and their standard errors are statsmodels OLS's (to
    1e-9); parts that never move along an axis, or too few, give NaN."""
    import statsmodels.api as sm

    from inspect_validate.characterization.field import part_slopes

    rng = np.random.default_rng(5)
    x, y = rng.uniform(100, 400, 30), rng.uniform(50, 250, 30)
    mu = 150 * (1 + 0.01 * (x - x.mean()) / 100 - 0.02 * (y - y.mean()) / 100)
    mu = mu + rng.normal(0, 0.2, 30)
    slope, se = part_slopes(mu, x, y)
    design = sm.add_constant(np.column_stack([(x - x.mean()) / 100, (y - y.mean()) / 100]))
    fit = sm.OLS(mu, design).fit()
    assert slope == pytest.approx(fit.params[1:] / fit.params[0], rel=1e-9)
    assert se == pytest.approx(fit.bse[1:] / fit.params[0], rel=1e-9)
    assert slope == pytest.approx([0.01, -0.02], abs=3e-4)
    assert np.isnan(part_slopes(mu[:3], x[:3], y[:3])[0]).all()
    assert np.isnan(part_slopes(mu, np.full(30, 200.0), y)[0]).all()


@pytest.mark.parametrize("degree", [2, 4])
def test_the_map_is_the_surface_at_every_pixel(degree):
    """Field.map (an outer product a power of x) against Field.at of every pixel, to
    1e-12, for random coefficients of a surface of degree 2 and 4 on a 37 × 23 frame."""
    from inspect_validate.characterization.field import Field, _exponents

    coefficients = np.random.default_rng(degree).normal(size=len(_exponents(degree)))
    field = Field(37, 23, tuple(coefficients), 0.0, 1.0)
    y, x = np.mgrid[0:23, 0:37]
    assert np.abs(field.map() - field.at(x, y)).max() < 1e-12
