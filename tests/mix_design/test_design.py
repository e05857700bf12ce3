"""Illumination design: the mix model against ``predict``, its gradient against finite
differences, the optimiser against a brute-force search, and the shipped example."""

import math

import numpy as np
import pytest
from conftest import ROOT, write_mix_scene

from inspect_validate.mix_design import (
    channel_response,
    comparison_cnr,
    comparison_errors,
    comparison_losses,
    mix_moments,
    optimise_mix,
)
from inspect_validate.model import Exposure, predict
from inspect_validate.scene import read_scene
from inspect_validate.station.model import illumination_light

MIX = ROOT / "sample_images" / "scenes" / "mix" / "scene.yaml"


@pytest.fixture(scope="module")
def inks():
    scene = read_scene(MIX)
    channels = {i + 1: light for i, light in enumerate(scene.lights)}
    response = channel_response(
        channels,
        scene.optics[0],
        scene.cameras[0],
        list(scene.classes),
        grid=scene.grid,
        exposure_time=0.04,
    )
    return scene, channels, response


def test_mix_moments_and_errors_are_predicts_for_the_mixed_light(inks):
    scene, channels, response = inks
    rng = np.random.default_rng(5)
    for levels in rng.uniform(0, 1, (4, 3)):
        light = illumination_light(
            "mix",
            {c: 100 * w for c, w in zip(channels, levels, strict=True)},
            channels,
            grid=scene.grid,
        )
        p = predict(
            [light],
            [scene.optics[0]],
            [scene.cameras[0]],
            list(scene.classes),
            exposure=Exposure("fixed", time=0.04),
            grid=scene.grid,
        )
        mean, variance = mix_moments(response, levels)
        np.testing.assert_allclose(mean, p.mean[0, 0, 0], rtol=1e-12)
        np.testing.assert_allclose(variance, p.variance[0, 0, 0], rtol=1e-12)
        np.testing.assert_allclose(
            comparison_errors(response, levels, scene.comparisons),
            p.error_gaussian[0, 0, 0],
            rtol=1e-9,
        )
        # CNR of groups from their mixture moments, as predict's cnr_db
        np.testing.assert_allclose(
            20 * np.log10(comparison_cnr(response, levels, scene.comparisons)),
            p.cnr_db[0, 0, 0],
            rtol=1e-9,
        )


@pytest.mark.parametrize("quantity", [comparison_errors, comparison_cnr])
def test_gradient_matches_central_differences(inks, quantity):
    scene, _, response = inks  # pairs and one-against-the-rest groups
    levels = np.array([0.7, 0.2, 0.45])
    _, grad = quantity(response, levels, scene.comparisons, gradient=True)
    step = 1e-6
    for c in range(3):
        dw = np.zeros(3)
        dw[c] = step
        numeric = (
            quantity(response, levels + dw, scene.comparisons)
            - quantity(response, levels - dw, scene.comparisons)
        ) / (2 * step)
        np.testing.assert_allclose(grad[:, c], numeric, rtol=1e-5, atol=1e-12)


def brute_force(response, comparisons, channels, points, *, objective="error", refine=7, rounds=11):
    """min of the worst loss (log ε, −log CNR) by grid search, without gradients.

    Every face of the problem is searched on its own: every non-empty subset of
    ``channels`` lit, the rest at 0 — an optimum on a face (a channel off) sits on a
    sharp ridge there that a grid of the whole box misses (CNR of the inks: green
    off, a tent in red 6 CNR units steep). A face is parametrised as the direction
    of the levels on the simplex and the fraction of the largest feasible scale
    along it (so the ridges, rays of fixed proportions, lie along a grid axis):
    a grid of ``points`` per axis, then zooming: a ``refine``-point grid on a box
    around the best point, shrunk ×2/(refine − 1) a round."""
    import itertools

    ceiling = response.ceiling(1e-3)
    best = np.inf
    for n in range(1, len(channels) + 1):
        for face in itertools.combinations(channels, n):
            a = response.sensor.gain * response.electrons[list(face)].T

            def worst(x, face=face, a=a):
                direction = np.r_[x[:-1], 1.0 - x[:-1].sum()]
                if direction[-1] < -1e-12:
                    return np.inf  # off the simplex
                direction = np.clip(direction, 0, None)
                top = min(1.0 / direction.max(), ceiling / (a @ direction).max())
                full = np.zeros(response.electrons.shape[0])
                full[list(face)] = x[-1] * top * direction
                return comparison_losses(response, full, comparisons, objective=objective).max()

            def search(lo, hi, k, worst=worst, d=n):
                axes = [np.linspace(a_, b_, k) for a_, b_ in zip(lo, hi, strict=True)]
                grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d)
                values = np.array([worst(x) for x in grid])
                return grid[int(np.argmin(values))], values.min()

            x, value = search(np.zeros(n), np.ones(n), points)
            half = 1.0 / (points - 1)
            for _ in range(rounds):
                x, value = search(np.clip(x - half, 0, 1), np.clip(x + half, 0, 1), refine)
                half *= 2.0 / (refine - 1)
            best = min(best, value)
    return best


@pytest.mark.parametrize("objective", ["error", "cnr"])
@pytest.mark.parametrize(
    ("channels", "points"),
    # blue+red: a 41² grid, then 11 rounds of 7² zooming by 1/3 (to ~3e-7 of the axes);
    # all three: 11³, then 11 rounds of 7³ (to ~1.7e-6); each face likewise.
    [([0, 2], 41), ([0, 1, 2], 11)],
)
@pytest.mark.slow
def test_optimiser_matches_brute_force(inks, channels, points, objective):
    scene, _, response = inks
    from dataclasses import replace

    sub = replace(response, electrons=response.electrons[channels])
    mix = optimise_mix(sub, scene.comparisons, objective=objective)
    loss = brute_force(response, scene.comparisons, channels, points, objective=objective)
    reference = math.exp(loss) if objective == "error" else math.exp(-loss)
    assert mix.objective == pytest.approx(reference, rel=1e-6)


def test_cnr_and_error_objectives_differ_where_a_group_straddles(tmp_path):
    """CNR sees a side's mixture by its first two moments only: C between A and B gives
    "C vs A,B" a CNR near 0 however little the classes overlap. The two objectives then
    choose different mixes, each the better by its own measure."""
    from inspect_validate.mix_design.problem import design_problem
    from inspect_validate.mix_design.solve import solve

    p = design_problem(write_mix_scene(tmp_path / "s.yaml"), auto_exposure=True)
    by_error, by_cnr = solve(p), solve(p, objective="cnr")
    assert abs(by_error.levels[3] - by_cnr.levels[3]) > 0.1
    e = {d: d.mix.error_gaussian[0, 0, 0].max() for d in (by_error, by_cnr)}
    c = {d: d.mix.cnr_db[0, 0, 0].min() for d in (by_error, by_cnr)}
    assert e[by_error] < e[by_cnr] / 100  # 4e-4 against 0.27
    assert c[by_cnr] > c[by_error] + 20  # −1.2 dB against −30 dB


def test_auto_exposure_designs_the_exposure(tmp_path):
    from inspect_validate.mix_design.mix import channel_response
    from inspect_validate.mix_design.problem import design_problem
    from inspect_validate.mix_design.solve import solve

    def scene(time):
        return write_mix_scene(
            tmp_path / f"{time}.yaml",
            lambda t: t.replace("{mode: fixed, time: 0.04}", f"{{mode: fixed, time: {time}}}"),
        )

    fixed = solve(design_problem(scene(0.04)))
    auto = [solve(design_problem(scene(t), auto_exposure=True)) for t in (0.04, 0.005)]
    # The reference exposure the levels are computed at does not matter.
    assert auto[0].exposure_time == pytest.approx(auto[1].exposure_time, rel=1e-6)
    for c in auto[0].levels:
        assert auto[0].levels[c] == pytest.approx(auto[1].levels[c], abs=1e-6)
    # A freer problem: no worse than at the fixed exposure, and a level at 100 %.
    worst = {d: d.mix.error_gaussian[0, 0, 0].max() for d in (fixed, auto[0])}
    assert worst[auto[0]] <= worst[fixed] * (1 + 1e-9)
    assert max(*auto[0].levels.values(), auto[0].single[1]) == pytest.approx(1.0)
    # The light is not the limit any more: the brightest sample sits at the saturation
    # ceiling, with the mix or the single channel (whichever needs the longer exposure).
    p = auto[0].problem
    at = channel_response(
        p.channels, p.optics, p.sensor, p.classes, grid=p.grid, exposure_time=auto[0].exposure_time
    )
    mix = np.array([auto[0].levels.get(c, 0.0) for c in p.channels])
    single = np.array([auto[0].single[1] if c == auto[0].single[0] else 0.0 for c in p.channels])
    ceiling = at.ceiling(p.max_saturated)
    assert at.signal(mix).max() == pytest.approx(ceiling, rel=1e-6)
    assert at.signal(single).max() <= ceiling * (1 + 1e-9)


def test_shipped_example_mix_beats_every_single_channel_tenfold(inks):
    scene, _, response = inks
    mix = optimise_mix(response, scene.comparisons)
    singles = [comparison_errors(response, np.eye(3)[c], scene.comparisons).max() for c in range(3)]
    assert min(singles) > 0.4  # each LED alone leaves one pair unseparated
    assert mix.objective < min(singles) / 10
    assert mix.levels[0] > 0.5 and mix.levels[2] > 0.2  # blue and red, unequal
    assert abs(mix.levels[0] - mix.levels[2]) > 0.1


def test_design_cli_on_the_example_scene(cli, tmp_path):
    import json

    code, out, err = cli(["design", MIX, "--json", tmp_path / "d.json"])
    assert code == 0, err
    assert "designed mix: channel 1 (blue LED) 100 %, channel 3 (red LED)" in out
    assert "  - {name: design, channels: {1: 100, 3: " in out  # pastes into a station file
    doc = json.loads((tmp_path / "d.json").read_text())
    assert doc["schema"] == "inspect-validate/design" and doc["schema_version"] == 1
    worst_mix = max(c["error_gaussian"] for c in doc["mix"]["comparisons"])
    worst_single = max(c["error_gaussian"] for c in doc["best_single"]["comparisons"])
    assert worst_mix < worst_single / 10
    assert len(doc["drive_tolerance"]) == 6
    assert all(c["saturated_fraction"] < 1e-3 for c in doc["mix"]["classes"])
    assert doc["skipped_work"] == [] and "not computed" not in err


def test_design_cli_lists_a_narrowed_wavelength_range(cli, tmp_path):
    import json

    path = write_mix_scene(
        tmp_path / "s.yaml", lambda t: t.replace("{start: 380, stop: 780, step: 1}", "{step: 1}")
    )
    code, _, err = cli(["design", path, "--json", tmp_path / "d.json"])
    assert code == 0, err
    (work,) = json.loads((tmp_path / "d.json").read_text())["skipped_work"]
    assert work.startswith("wavelengths ") and "narrowed to" in work
    assert f"not computed: {work}" in err


def test_design_cli_cnr_auto_exposure_and_plots(cli, tmp_path):
    import json

    from matplotlib.image import imread

    out = tmp_path / "d"
    code, stdout, err = cli(["design", MIX, "--objective", "cnr", "--auto-exposure", "--out", out])
    assert code == 0, err
    assert "ms (designed), maximising the worst CNR of" in stdout
    assert "CNR_dB mix" in stdout and "the worst CNR is at least" in stdout
    assert "  with camera.exposure_us: " in stdout
    doc = json.loads((out / "design.json").read_text())
    assert doc["exposure"] == "auto" and doc["objective"]["maximise"] == "worst cnr_db"
    path = doc["path"]
    assert path["fraction"][0] == 0 and path["fraction"][-1] == 1
    assert len(path["cnr"]) == len(path["fraction"]) and len(path["cnr"][0]) == 6
    # the path ends at the mix: its worst CNR is the design's
    worst_cnr = min(c["cnr_db"] for c in doc["mix"]["comparisons"])
    assert 20 * math.log10(min(path["cnr"][-1])) == pytest.approx(worst_cnr, abs=1e-6)
    for name in ("design-spectrum.png", "design-path.png"):
        image = imread(out / name)
        assert image.shape[0] > 300 and image.shape[1] > 600 and image.std() > 0.05


def test_design_cli_takes_exposure_and_objective_from_the_scene(cli, tmp_path):
    path = write_mix_scene(
        tmp_path / "s.yaml",
        lambda t: t.replace("{mode: fixed, time: 0.04}", "{mode: auto, max_time: 0.5}").replace(
            "rank: {by: error}", "rank: {by: cnr_db}"
        ),
    )
    code, out, err = cli(["design", path])
    assert code == 0, err
    assert "(designed), maximising the worst CNR" in out
    code, out, err = cli(["design", path, "--objective", "error"])
    assert code == 0 and "minimising the worst ε Gauss" in out


def test_design_cli_on_a_station_names_its_acceptance_comparison(cli):
    code, out, err = cli(["design", ROOT / "sample_images" / "station" / "station.yaml"])
    assert code == 0, err
    assert "minimising the worst ε Gauss of A vs B,C" in out


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda s: s.replace(", irradiance: 2.0}", "}", 1), "has no irradiance"),
        (
            lambda s: s.replace(
                "  - {lens: visible}", "  - {lens: visible}\n  - {lens: visible, name: b}"
            ),
            "optics",
        ),
    ],
)
def test_design_refuses_scenes_it_cannot_mix(cli, tmp_path, edit, message):
    code, out, err = cli(["design", write_mix_scene(tmp_path / "s.yaml", edit)])
    assert code == 2, out + err
    assert message in err and "Traceback" not in err


INKS_STATION = ROOT / "sample_images" / "station" / "inks.yaml"


def _inks_station(tmp_path, **world):
    """The shipped inks station in ``tmp_path`` with more deviations in its simulated world."""
    import shutil

    import yaml

    doc = yaml.safe_load(INKS_STATION.read_text())
    doc["scene"] = str(MIX)
    doc["camera"]["world"].update(world)
    shutil.copy(INKS_STATION.parent / "rois.yaml", tmp_path / "rois.yaml")
    path = tmp_path / "inks.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_design_verify_measures_the_mix_on_the_simulated_station(cli, tmp_path):
    import json

    from inspect_validate.station.file import read_station

    out = tmp_path / "d"
    code, stdout, err = cli(["design", _inks_station(tmp_path), "--verify", "--out", out])
    assert code == 0, stdout + err
    assert "PASS: all" in stdout
    # The station it verified is a station file of its own: re-readable, lit by the mix.
    st = read_station(out / "station.yaml")
    assert [i.name for i in st.illuminations] == ["design", "single-3"]
    assert st.illuminations[0].channels[1] == 100.0 and 55 < st.illuminations[0].channels[3] < 75
    doc = json.loads((out / "verification.json").read_text())
    rows = {(r["illumination"], r["comparison"]): r for r in doc["comparisons"]}
    pairs = ("A vs B", "A vs C", "B vs C")
    worst = {
        (ill, what): max(rows[ill, c][what]["error_gaussian"] for c in pairs)
        for ill in ("design", "single-3")
        for what in ("predicted", "measured")
    }
    # Measured like predicted: the mix ≥ 10× better than the single channel, both ways.
    assert worst["single-3", "measured"] > 10 * worst["design", "measured"]
    assert worst["single-3", "predicted"] > 10 * worst["design", "predicted"]
    # Measured ε of the mix within a factor 2 of the prediction (other ink prints, 4 frames).
    assert 0.5 < worst["design", "measured"] / worst["design", "predicted"] < 2
    assert "measured worst ε: mix" in stdout and "FAIL" not in stdout
    assert sorted(p.name for p in (out / "frames").iterdir()) == [
        "dark",
        "design",
        "manifest.json",
        "single-3",
    ]


def test_design_verify_with_auto_exposure_and_cnr(cli, tmp_path):
    import json

    from inspect_validate.station.file import read_station

    out = tmp_path / "d"
    args = ["design", _inks_station(tmp_path), "--verify", "--out", out]
    code, stdout, err = cli([*args, "--auto-exposure", "--objective", "cnr"])
    assert code == 0, stdout + err
    design = json.loads((out / "design.json").read_text())
    st = read_station(out / "station.yaml")
    # the station it verified runs at the designed exposure, not the station's 40 ms
    assert st.camera.exposure_us == pytest.approx(1e6 * design["exposure_time_s"])
    assert st.camera.exposure_us > 60_000
    assert "measured worst CNR_dB: mix" in stdout and "FAIL" not in stdout


def test_design_verify_notices_a_weaker_led_than_designed_for(cli, tmp_path):
    # The red LED gives 60 % of its stated irradiance: the mix is off its optimum.
    path = _inks_station(tmp_path, irradiance={3: 0.6})
    code, stdout, err = cli(["design", path, "--verify", "--out", tmp_path / "d"])
    assert code == 1, stdout + err
    failed = [line for line in stdout.splitlines() if line.startswith("FAIL ")]
    assert any("design: B vs C ε Gauss" in line for line in failed)
    assert any("design: A vs C SNR_dB deviation" in line for line in failed)
    assert (tmp_path / "d" / "report.html").is_file()  # the reports are written on a failure


def test_design_verify_needs_a_station(cli, tmp_path):
    code, _out, err = cli(["design", MIX, "--verify", "--out", tmp_path / "d"])
    assert code == 2 and "--verify captures on a station" in err
    assert not (tmp_path / "d" / "frames").exists()


def test_write_station_round_trips(tmp_path):
    from inspect_validate.station.file import read_station, write_station

    st = read_station(INKS_STATION)
    again = write_station(st, tmp_path / "elsewhere.yaml", comment="a copy\nof the inks")
    assert again.model_dump(exclude={"path"}) == st.model_dump(exclude={"path"}) | {
        "scene": str(MIX.resolve()),
        "rois": str((INKS_STATION.parent / "rois.yaml").resolve()),
    }
    assert (tmp_path / "elsewhere.yaml").read_text().startswith("# a copy\n# of the inks\n")


def _catalogue_scene(tmp_path, peaks, *, fwhm=25):
    """The inks scene lit by a catalogue of LEDs at ``peaks`` nm (2 W/m² each)."""
    leds = "".join(
        f"  - {{led: {{peak: {p:g}, fwhm: {fwhm}}}, name: LED {p:g}, irradiance: 2.0}}\n"
        for p in peaks
    )

    def relit(text):
        head, rest = text.split("lights:\n")
        return head + "lights:\n" + leds + rest[rest.index("optics:") :]

    return write_mix_scene(tmp_path / "catalogue.yaml", relit)


@pytest.fixture(scope="module")
def catalogue(tmp_path_factory):
    from inspect_validate.mix_design.problem import design_problem

    p = design_problem(_catalogue_scene(tmp_path_factory.mktemp("cat"), range(420, 700, 25)))
    response = channel_response(
        p.channels, p.optics, p.sensor, p.classes, grid=p.grid, exposure_time=p.exposure_time
    )
    return p, response


@pytest.mark.slow
@pytest.mark.parametrize("k", [2, 3])
def test_catalogue_local_search_finds_the_exhaustive_choice(catalogue, k):
    from inspect_validate.mix_design.catalogue import choose_channels

    p, response = catalogue  # 12 LEDs, 420–695 nm
    exhaustive = choose_channels(response, p.objective, k)
    local = choose_channels(response, p.objective, k, exhaustive_max=0)
    assert exhaustive.exhaustive and not local.exhaustive
    assert exhaustive.evaluated == math.comb(12, k)
    if k == 3:
        assert local.evaluated < exhaustive.evaluated / 2  # 220 subsets; k = 2 gains nothing
    assert local.channels == exhaustive.channels
    assert local.mix.objective == pytest.approx(exhaustive.mix.objective, rel=1e-6)
    # The mix of all 12 bounds every choice from below (up to the optimiser's tolerance).
    assert exhaustive.bound <= exhaustive.mix.objective * (1 + 1e-6)
    # The chosen subset's mix is that subset's optimum: the full multi-start agrees.
    again = optimise_mix(response.subset(exhaustive.channels), p.objective, random_starts=16)
    assert exhaustive.mix.objective <= again.objective * (1 + 1e-6)


@pytest.mark.slow
def test_design_cli_chooses_from_a_catalogue(cli, tmp_path):
    import json

    path = _catalogue_scene(tmp_path, range(420, 700, 25))
    code, out, err = cli(["design", path, "--choose", "2", "--json", tmp_path / "d.json"])
    assert code == 0, err
    assert "chose 2 of 12 channels (66 subsets, every subset optimised)" in out
    assert "choosing 2 of 12" in err  # the progress bar
    doc = json.loads((tmp_path / "d.json").read_text())
    assert doc["choice"]["exhaustive"] and len(doc["choice"]["channels"]) == 2
    assert set(doc["illumination"]["channels"]) <= set(doc["choice"]["channels"])
    worst_mix = max(c["error_gaussian"] for c in doc["mix"]["comparisons"])
    assert worst_mix >= doc["choice"]["lower_bound_error"] * (1 - 1e-6)
    code, out, err = cli(["design", path, "--choose", "13"])
    assert code == 2 and "cannot choose 13 of 12" in err


@pytest.fixture(scope="module")
def wide_catalogue(tmp_path_factory):
    """60 LEDs of seeded random peaks 400–700 nm: above JOINT_MAX and POOL_MAX."""
    from inspect_validate.mix_design.problem import design_problem

    peaks = np.sort(np.random.default_rng(60).choice(np.arange(400, 700, 0.5), 60, replace=False))
    path = _catalogue_scene(tmp_path_factory.mktemp("wide"), peaks)
    p = design_problem(path)
    response = channel_response(
        p.channels, p.optics, p.sensor, p.classes, grid=p.grid, exposure_time=p.exposure_time
    )
    return path, p, response


@pytest.mark.slow
def test_a_large_catalogue_is_screened_to_the_joint_optimum(wide_catalogue, monkeypatch):
    """Column generation on 60 lights (above JOINT_MAX): within 1 % of every light
    optimised jointly (the same starts, SLSQP on all 60), the lights left out at 0."""
    from inspect_validate.mix_design import mix

    _, p, response = wide_catalogue
    screened = optimise_mix(response, p.objective)
    monkeypatch.setattr(mix, "JOINT_MAX", 10**6)
    joint = optimise_mix(response, p.objective)
    assert screened.objective <= joint.objective * 1.01, (screened.objective, joint.objective)
    assert (screened.levels == 0).sum() >= 60 - mix.JOINT_MAX


@pytest.mark.slow
def test_choosing_from_a_pool_finds_the_best_single_light(wide_catalogue):
    """--choose 1 of 60 through the pool of POOL_MAX lights finds the best single light
    of all 60 (every one optimised alone), with the all-60 mix as its bound."""
    from inspect_validate.mix_design import catalogue as cat

    _, p, response = wide_catalogue
    pooled = cat.choose_channels(response, p.objective, 1)
    singles = [optimise_mix(response.subset([c]), p.objective) for c in range(60)]
    best = min(range(60), key=lambda c: singles[c].loss)
    assert pooled.channels == (best,) and not pooled.exhaustive
    assert pooled.mix.objective == pytest.approx(singles[best].objective, rel=1e-6)
    assert pooled.bound <= pooled.mix.objective


@pytest.mark.slow
def test_design_cli_on_a_catalogue_reports_its_screening(cli, wide_catalogue):
    path, _, _ = wide_catalogue
    code, out, err = cli(["design", path])
    assert code == 0, err
    assert "design: screened 60 lights alone" in err and "working set of" in err
    listed = out.split("designed mix: ")[1].split("\n")[0]
    assert 1 <= listed.count("channel ") < 60  # the lights in use, not all 60


def test_a_designed_mix_whose_light_never_reaches_the_camera_fails(cli, tmp_path):
    """design --verify on a station whose amber channel is dead: the mix (all amber) fails
    its light check, its separation checks do not run, and the design's verdict says the
    mix was not measured (exit 1, no traceback)."""
    from conftest import copy_station

    path = copy_station(tmp_path, world={"irradiance": {1: 0}})
    code, out, err = cli(["design", path, "--verify", "--out", tmp_path / "d"])
    assert code == 1 and "Traceback" not in err, out + err
    assert "design: light above dark" in out and "no light reaches the camera" in out
    assert "FAIL: the mix was not measured" in out
