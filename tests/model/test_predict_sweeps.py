"""Sweeps that meet candidates which cannot work: saturation, blind cameras, uncovered bands.

A sweep never loses its results to one candidate: saturated rows are kept,
marked and ranked after every unsaturated one; combinations that cannot be
predicted are skipped with their reason; every number printed or written is
finite or a documented infinity.
"""

import json

import numpy as np
import pytest
from conftest import run_cli as run

from inspect_validate.components import builtin_sensor, ideal_lens, led
from inspect_validate.model import Exposure, ObjectClass, predict, predicted_kde_error, rank
from inspect_validate.spectra import Spectrum

GRID = np.arange(380.0, 781.0, 1.0)


def flat(name, level, spread=0.05, n=6, lo=380, hi=780):
    g = np.arange(lo, hi + 1.0, 5.0)
    return ObjectClass(
        name,
        Spectrum(
            g,
            [np.full(g.size, level * (1 + spread * (i - n / 2) / n)) for i in range(n)],
            "reflectance",
            name,
            f"{name}.csv",
        ),
    )


def test_over_exposing_candidate_is_kept_marked_and_ranked_last():
    cam = builtin_sensor("cmos-visible")
    dim = led(550, 30, irradiance=0.5, name="dim")
    blinding = led(550, 30, irradiance=5000.0, name="blinding")  # every class clipped
    classes = [flat("A", 0.3), flat("B", 0.6)]
    p = predict(
        [blinding, dim],
        [ideal_lens()],
        [cam],
        classes,
        exposure=Exposure("fixed", time=5e-3),
        grid=GRID,
    )
    assert p.saturated_fraction[0].min() > 0.99  # clipped to a constant
    order, _, column, saturated = rank(p)
    assert [p.lights[i] for i in order[:, 0]] == ["dim", "blinding"]
    assert saturated.tolist() == [False, True]
    # The KDE path meets zero spread (both classes one grey value): a defined error.
    eps = predicted_kde_error(p, tuple(order[1]), int(column[1]))
    assert eps == pytest.approx(0.5)  # both classes at full scale: indistinguishable


def test_partly_saturated_light_does_not_outrank_a_correctly_exposed_one():
    """Clipping shrinks the variance: unpenalised, the clipped light would win."""
    cam = builtin_sensor("cmos-visible")
    good = led(550, 30, irradiance=5.0, name="exposed right")
    hot = led(550, 30, irradiance=7.0, name="half clipped")
    classes = [flat("A", 0.75, spread=0.3), flat("B", 0.9, spread=0.3)]
    p = predict(
        [hot, good],
        [ideal_lens()],
        [cam],
        classes,
        exposure=Exposure("fixed", time=5e-3),
        grid=GRID,
    )
    assert 0.3 < p.saturated_fraction[0, 0, 0, 1] < 0.7
    assert p.error_gaussian[0, 0, 0, 0] < p.error_gaussian[1, 0, 0, 0]  # flattered by clipping
    order, _, _, saturated = rank(p)
    assert p.lights[order[0, 0]] == "exposed right" and saturated.tolist() == [False, True]


def test_blind_camera_is_skipped_and_the_rest_ranked():
    classes = [flat("A", 0.3), flat("B", 0.6)]
    swir = builtin_sensor("ingaas-swir")  # blind at 380-780 nm
    p = predict(
        [led(550, 30)], [ideal_lens()], [builtin_sensor("cmos-visible"), swir], classes, grid=GRID
    )
    assert p.valid.tolist() == [[[True, False]]]
    assert len(p.skipped) == 1 and "ingaas-swir" in p.skipped[0] and "no wavelength" in p.skipped[0]
    order = rank(p)[0]
    assert order.tolist() == [[0, 0, 0]]
    assert np.isnan(p.mean[0, 0, 1]).all()
    # The skip costs the others nothing: their numbers are those of a sweep without it
    # (to 1e-12 relative: the products are summed in other blocks).
    alone = predict(
        [led(550, 30)], [ideal_lens()], [builtin_sensor("cmos-visible")], classes, grid=GRID
    )
    np.testing.assert_allclose(p.mean[:, :, :1], alone.mean, rtol=1e-12)
    np.testing.assert_allclose(p.error_gaussian[:, :, :1], alone.error_gaussian, rtol=1e-12)


def test_class_that_misses_the_light_band_is_not_a_perfect_separation():
    blue_only = flat("B", 0.6, lo=380, hi=475)
    classes = [flat("A", 0.3), blue_only]
    amber, blue = led(590, 15, name="amber"), led(430, 15, name="blue")
    p = predict([amber, blue], [ideal_lens()], [builtin_sensor("cmos-visible")], classes, grid=GRID)
    assert p.valid[:, 0, 0].tolist() == [False, True]
    assert "class 'B' is measured over 380–475 nm" in p.skipped[0]


def test_worst_pair_is_the_key_and_the_listed_comparison(tmp_path):
    """The row's key comparison is the worst *pair*, never a one-vs-rest group."""
    cam = builtin_sensor("cmos-visible")
    classes = [flat("A", 0.3), flat("B", 0.32), flat("C", 0.8)]
    p = predict([led(550, 30)], [ideal_lens()], [cam], classes, grid=GRID)
    _, key, column, _ = rank(p)
    pairs = [i for i, (a, b) in enumerate(p.comparisons) if len(a) == len(b) == 1]
    worst = max(pairs, key=lambda j: p.error_gaussian[0, 0, 0, j])
    assert column[0] == worst and p.comparisons[worst] == (("A",), ("B",))
    assert key[0] == p.error_gaussian[0, 0, 0, worst]


def _scene(tmp_path, lights, cameras="[cmos-visible]", extra=""):
    g = np.arange(380, 781, 5)
    for name, level in (("a", 0.3), ("b", 0.6)):
        rows = "\n".join(f"{w},{level},{level * 1.02},{level * 0.98}" for w in g)
        (tmp_path / f"{name}.csv").write_text(rows + "\n")
    (tmp_path / "s.yaml").write_text(
        "classes: {A: {file: a.csv}, B: {file: b.csv}}\n"
        f"lights: {lights}\noptics: [ideal]\ncameras: {cameras}\n{extra}"
    )
    return tmp_path / "s.yaml"


def test_cli_sweep_with_saturating_and_blind_candidates(tmp_path, capsys):
    scene = _scene(
        tmp_path,
        "[{led: {peak: 550, fwhm: 30}, irradiance: 0.5, name: dim}, "
        "{led: {peak: 550, fwhm: 30}, irradiance: 5000, name: blinding}]",
        "[cmos-visible, ingaas-swir]",
        "exposure: {mode: fixed, time: 0.005}\n",
    )
    out = tmp_path / "p.json"
    assert run(["predict", scene, "--json", out]) == 0
    captured = capsys.readouterr()
    assert "skipped: dim × ideal lens × ingaas-swir (model)" in captured.err
    assert "(2 skipped)" in captured.out and " !" in captured.out
    doc = json.loads(out.read_text())
    assert [r["light"] for r in doc["ranking"]] == ["dim", "blinding"]
    assert [r["saturated"] for r in doc["ranking"]] == [False, True]
    assert doc["ranking"][0]["exposure"] == "absolute"
    assert doc["ranking"][0]["exposure_time_s"] == pytest.approx(0.005)
    assert len(doc["skipped"]) == 2
    text = out.read_text()
    assert "NaN" not in text and "Infinity" not in text


def test_irradiance_is_stated_over_the_visible_band():
    """A 3000 K blackbody given 10 W/m² puts 10 W/m² in 380–780 nm (the documented band)."""
    from dataclasses import replace

    from inspect_validate.components import blackbody

    bb = replace(blackbody(3000.0), irradiance=10.0)
    assert bb.band == (380.0, 780.0)
    grid = np.arange(300.0, 1801.0, 1.0)
    classes = [flat("A", 0.3, lo=300, hi=1800), flat("B", 0.6, lo=300, hi=1800)]
    p = predict([bb], [ideal_lens()], [builtin_sensor("cmos-visible")], classes, grid=grid)
    assert p.valid.all()
    from inspect_validate.model.acquisition import _irradiance_scale

    e = bb.spd.resample(grid)[0] * _irradiance_scale([bb])[0]
    band = (grid >= 380) & (grid <= 780)
    assert np.trapezoid(e[band], grid[band]) == pytest.approx(10.0, rel=1e-3)
    # Over the model's whole range it is several times more: what the old rule got wrong.
    assert np.trapezoid(e, grid) > 3 * 10.0


def test_predict_of_a_scene_too_large_to_hold_points_to_sweep(monkeypatch):
    """Scene.predict() of 100 × 100 × 100 combinations ran past 240 s (every array of
    every combination, each group's mixture ε for each); above PREDICT_MAX_BYTES it is
    refused at once, saying how large and pointing to sweep, which the scene still takes."""
    from conftest import ROOT

    from inspect_validate.errors import InputError
    from inspect_validate.model import acquisition
    from inspect_validate.scene import read_scene

    scene = read_scene(ROOT / "sample_images" / "scenes" / "mix" / "scene.yaml")
    assert scene.predict().mean.shape[:3] == (3, 1, 1)
    monkeypatch.setattr(acquisition, "PREDICT_MAX_BYTES", 1000)
    with pytest.raises(InputError, match=r"3 × 1 × 1 = 3 combinations: .*rank them with sweep"):
        scene.predict()
    ranking = scene.sweep(by="error", comparison=None, top=2)
    assert ranking.index.shape == (2, 3)
