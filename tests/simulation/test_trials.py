"""Verdicts on simulated stations, many at a time: a known-good station passes, a changed
one fails, and the in-process trials decide as the CLI does.

The seeds are fixed, so each test is deterministic; the rates themselves, over hundreds
of runs, are measured by ``benchmarks/bench_verdicts.py`` (docs/guide/verify.md).
"""

import json

import pytest
import yaml
from conftest import ROOT, copy_station, run_cli

from inspect_validate.simulation import run_trials
from inspect_validate.station.file import read_station

STATION = ROOT / "sample_images" / "station" / "station.yaml"


@pytest.mark.slow
def test_the_shipped_station_passes_unchanged_and_fails_a_five_percent_light_loss():
    """Ten worlds of the shipped station with the manual's drift block, each trained on 5
    repeats: every unchanged one passes (at 0.27 % the chance of a false alarm among ten
    is 2.7 %, and with these seeds there is none) and every one whose amber LED lost 5 %
    fails, on the amber μ drift checks (the fit absorbs the loss for agreement)."""
    station = read_station(STATION)  # no drift block: run_trials adds the manual's
    assert station.acceptance.drift is None
    trials = list(
        run_trials(
            station, runs=range(10), repeats=5, changes={"amber 95 %": {"irradiance": {1: 0.95}}}
        )
    )
    good = [t for t in trials if t.case == "unchanged"]
    changed = [t for t in trials if t.case == "amber 95 %"]
    assert len(good) == len(changed) == 10
    assert all(t.passed for t in good), [t.failed for t in good if not t.passed]
    assert not any(t.passed for t in changed)
    for t in changed:
        assert {"amber: A μ drift", "amber: B μ drift", "amber: C μ drift"} <= set(t.failed)
        assert set(t.kinds) == {"drift"}


def test_lights_that_vary_between_captures_widen_the_golden_spread(tmp_path):
    """A world whose lights vary 0.5 % from capture to capture: its repeats vary by that
    (about 0.8 DN on amber's ~160 DN), not by the noise of the mean (0.007 DN), and the
    drift limit follows, so the unchanged station still passes."""
    doc = yaml.safe_load(STATION.read_text())
    doc["scene"] = str(STATION.parent / doc["scene"])
    doc["rois"] = str(STATION.parent / doc["rois"])
    doc["camera"]["world"] = {"irradiance_jitter": 0.005}
    path = tmp_path / "jitter.yaml"
    path.write_text(yaml.safe_dump(doc))
    (trial,) = run_trials(read_station(path), runs=[0], repeats=6)
    assert trial.passed, trial.failed
    code = run_cli(["train", path, "--out", tmp_path / "g.json", "--repeats", 4])
    assert code == 0
    golden = json.loads((tmp_path / "g.json").read_text())
    a = golden["illuminations"]["amber"]["classes"]["A"]["mean"]
    assert 0.1 < a["std"] < 4.0 and max(a["standard_errors"]) < 0.02


def test_a_trial_decides_as_the_cli_does(tmp_path):
    """The in-process trial and `verify` on the same station: the same checks, limits set
    the same way (the CLI's capture has its own noise, so values differ slightly)."""
    path = copy_station(tmp_path)
    station = read_station(path)
    (trial,) = run_trials(station, runs=[3], repeats=5)
    code = run_cli(["train", path, "--out", tmp_path / "g.json", "--repeats", 5])
    assert code == 0
    doc = yaml.safe_load(path.read_text())
    doc["acceptance"]["drift"] = {"golden": "g.json"}
    path.write_text(yaml.safe_dump(doc))
    assert (
        run_cli(["verify", path, "--frames-out", tmp_path / "f", "--report", tmp_path / "r"]) == 0
    )
    report = json.loads((tmp_path / "r" / "verification.json").read_text())
    assert trial.passed and report["verdict"] == "pass"
    assert report["false_alarm"]["rate"] == 0.0027
    kinds = {c["kind"] for c in report["checks"]}
    # the CLI's captures also hold the camera's settings snapshot and what it reported of
    # the acquisition (fixed checks, outside the rate); the trials' in-process frames
    # have neither, and nothing else differs
    assert kinds == {
        "light",
        "separation",
        "saturation",
        "agreement",
        "ranking",
        "drift",
        "settings",
        "health",
    }


def test_too_few_repeats_for_the_rate_are_refused_in_trials_too():
    from inspect_validate.errors import InputError

    station = read_station(STATION)
    with pytest.raises(InputError, match="3 repeats are too few"):
        list(run_trials(station, runs=[0], repeats=3))


def test_parts_redrawn_differ_between_openings_on_one_fixed_sensor(tmp_path):
    """world.parts: redrawn: two openings of the camera show other parts (another draw of
    each class's samples: class means apart by far more than the noise), the camera's own
    fixed pattern is the same, and the same noise seed draws the same parts (the trials
    stay reproducible). With reflectance_seed, which fixes one draw, it is refused."""
    import numpy as np

    from inspect_validate.errors import InputError
    from inspect_validate.simulation.camera import SimulatedGrabber
    from inspect_validate.station.model import station_model
    from inspect_validate.station.world import World

    model = station_model(read_station(STATION))
    state = tmp_path / "state.json"
    state.write_text(json.dumps({"channels": {"1": 100}}))

    def opened(noise_seed):
        g = SimulatedGrabber(model, state, world=World(parts="redrawn"), noise_seed=noise_seed)
        means = [float(g.rates[0, g.sample_class == k].mean()) for k in range(3)]
        return np.array(means), g._pattern

    a, pattern_a = opened(1)
    b, pattern_b = opened(2)
    again, _ = opened(1)
    assert np.max(np.abs(a - b) / a) > 1e-3  # other parts: the classes' mean signal moved
    assert np.array_equal(a, again)
    assert (pattern_a is None and pattern_b is None) or all(
        np.array_equal(x, y) for x, y in zip(pattern_a, pattern_b, strict=True)
    )
    path = copy_station(tmp_path, world={"parts": "redrawn", "reflectance_seed": 3})
    with pytest.raises(InputError, match="give one of the two"):
        read_station(path)
