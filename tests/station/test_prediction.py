"""A station's prediction, one row per illumination: calibrated by scaling the chain it
was predicted from, against a prediction made afresh from lights whose irradiance was
scaled (the way verify predicted a calibrated station before)."""

import dataclasses

import numpy as np
import pytest
from conftest import ROOT

from inspect_validate.model import Exposure, predict
from inspect_validate.station.file import read_station
from inspect_validate.station.model import illumination_light, station_model

FIELDS = ("exposure_time", "electrons", "mean", "variance", "spectral_variance",
          "saturated_fraction", "snr_db", "cnr_db", "fisher_db", "error_gaussian",
          "sample_mean", "sample_variance")  # fmt: skip


def afresh(model, station, scale):
    """The station predicted from lights whose summed SPD is scaled before integration."""
    lights = [
        illumination_light(i.name, i.channels, model.channels, grid=model.scene.grid,
                           scale=scale.get(i.name, 1.0))
        for i in station.illuminations
    ]  # fmt: skip
    exposure = (
        Exposure("fixed", time=model.exposure_time)
        if model.exposure_time is not None
        else model.scene.exposure
    )
    return predict(lights, [model.optics], [model.sensor], list(model.scene.classes),
                   exposure=exposure, grid=model.scene.grid,
                   comparisons=model.scene.comparisons)  # fmt: skip


@pytest.mark.parametrize("scale", [{"amber": 0.8, "red": 1.25}, {"amber": 1.55}, {"red": 3.0}])
def test_calibrated_is_a_prediction_at_the_scaled_irradiances(scale):
    """To 1e-12 relative: the grey values, noise, exposure and ε at the scaled irradiances,
    including the clipping of a light scaled into saturation (amber × 1.55: 56 % of a
    class's pixels at 255; red × 3: all)."""
    station = read_station(ROOT / "sample_images/station/station.yaml")
    model = station_model(station)
    got = model.predict(station).calibrated(scale)
    want = afresh(model, station, scale)
    if "amber" in scale and scale["amber"] > 1.5:
        assert 0.5 < got.saturated_fraction.max() < 0.6
    for name in FIELDS:
        np.testing.assert_allclose(
            getattr(got, name), getattr(want, name)[:, 0, 0], rtol=1e-12, atol=1e-300, err_msg=name
        )
    assert got.illuminations == tuple(want.lights)


def test_calibrated_keeps_the_rows_and_weights_it_was_given():
    """A prediction narrowed to some illuminations and compared under other weights (priors) is
    calibrated with the same rows and the same comparisons."""
    station = read_station(ROOT / "sample_images/station/station.yaml")
    model = station_model(station)
    whole = model.predict(station)
    priors = dataclasses.replace(whole.comparison_set, weights=(0.7, 0.2, 0.1))
    weighted = priors
    narrow = whole.compared(weighted).select(["red"])
    got = narrow.calibrated({"red": 0.5, "amber": 9.0})
    assert got.illuminations == ("red",) and got.comparison_set == weighted
    want = whole.calibrated({"red": 0.5}).compared(weighted).select(["red"])
    np.testing.assert_allclose(got.snr_db, want.snr_db, rtol=1e-12)
    np.testing.assert_allclose(got.mean, want.mean, rtol=1e-12)
    assert not np.allclose(got.mean, narrow.mean)  # it did move


def test_a_prediction_without_its_chain_cannot_be_calibrated():
    station = read_station(ROOT / "sample_images/station/station.yaml")
    bare = dataclasses.replace(station_model(station).predict(station), chain=None)
    with pytest.raises(ValueError, match="no chain"):
        bare.calibrated({"red": 2.0})
