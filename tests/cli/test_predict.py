"""`inspect-validate predict` end to end on the shipped scenes, JSON, and scene errors."""

import json

import pytest
from conftest import run_cli


def test_predict_paperboard_json(tmp_path, capsys):
    from conftest import ROOT

    out = tmp_path / "p.json"
    assert (
        run_cli(["predict", ROOT / "sample_images/scenes/paperboard/scene.yaml", "--json", out])
        == 0
    )
    doc = json.loads(out.read_text())
    assert doc["schema"] == "inspect-validate/prediction" and doc["schema_version"] == 2
    best = doc["ranking"][0]
    assert best["light"] == "amber LED" and doc["rank_comparison"] == "A vs B,C"
    comp = best["comparisons"][best["key_comparison"]]
    assert comp["first"] == ["A"] and comp["second"] == ["B", "C"]
    # Every comparison is listed; ε KDE only for the ranking comparison.
    assert len(best["comparisons"]) == 6
    assert [c["error_kde"] is None for c in best["comparisons"]].count(False) == 1
    # The paperboard lights are relative SPDs: no exposure time in seconds.
    assert best["exposure"] == "relative" and best["exposure_time_s"] is None
    assert 0 < comp["error_gaussian"] < 0.5 and 0 < comp["error_kde"] < 0.5
    assert {"mean", "variance", "spectral_variance", "electrons", "saturated_fraction"} <= set(
        best["classes"][0]
    )
    assert "amber LED" in capsys.readouterr().out


def test_predict_table2_top_and_rank_by(capsys):
    from conftest import ROOT

    assert (
        run_cli(
            [
                "predict",
                ROOT / "sample_images/scenes/chapter_table2/scene.yaml",
                "--top",
                "3",
                "--rank-by",
                "snr_db",
                "--kde",
                "never",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "8 combinations" in out and out.count("LED") >= 3


@pytest.mark.parametrize(
    ("scene", "message"),
    [
        (
            "classes: {A: {file: a.csv}}\nlights: [{led: {peak: 500, fwhm: 20}}]\noptics: [ideal]\ncameras: [cmos-visible]\n",
            "classes: .*at least 2",
        ),
        (
            "classes: {A: {file: a.csv}, B: {file: a.csv}}\nlights: [{led: {peak: 500}}]\noptics: [ideal]\ncameras: [cmos-visible]\n",
            r"lights\[0\]\.led\.fwhm: Field required",
        ),
        (
            "classes: {A: {file: a.csv}, B: {file: a.csv}}\nlights: [{laser: 1}]\noptics: [ideal]\ncameras: [cmos-visible]\n",
            r"lights\[0\]: a light: give exactly one of",
        ),
        (
            "classes: {A: {file: missing.csv}, B: {file: a.csv}}\nlights: [{cie: D65}]\noptics: [ideal]\ncameras: [cmos-visible]\n",
            "missing.csv: spectrum file not found",
        ),
        (
            "classes: {A: {file: a.csv}, B: {file: a.csv}}\nlights: [{cie: D65}]\noptics: [ideal]\ncameras: [{file: a.csv}]\n",
            r"cameras\[0\]: a camera from a QE file needs its EMVA 1288 parameters: gain, dark_noise, saturation",
        ),
        (
            "classes: {A: {file: a.csv}, B: {file: a.csv}}\nlights: [{cie: D65}]\noptics: [ideal]\ncameras: [cmos-visible]\nexposure: {mode: fixed, time: 0.01}\n",
            "relative SPD",
        ),
        (
            "classes: {A: {file: a.csv}, B: {file: a.csv}}\nlights: [{led: {peak: 500, fwhm: 20}}]\noptics: [ideal]\ncameras: [cmos-visible]\nwavelength: {start: 500, stop: 500.5, step: 1}\n",
            "wavelength: 500–500.5 nm is narrower than one 1 nm step",
        ),
    ],
)
def test_bad_scenes_exit_2(tmp_path, capsys, scene, message):
    import re

    (tmp_path / "a.csv").write_text("400,0.5,0.52\n700,0.5,0.52\n")
    (tmp_path / "scene.yaml").write_text(scene)
    assert run_cli(["predict", tmp_path / "scene.yaml"]) == 2
    assert re.search(message, capsys.readouterr().err)


def test_masked_wavelengths_are_reported(tmp_path, capsys):
    d = tmp_path
    (d / "r.csv").write_text("400,50,60\n500,60,70\n600,40,45\n700,30,35\n")
    (d / "black.csv").write_text("400,5\n500,5\n600,5\n700,5\n")
    (d / "white.csv").write_text("400,100\n500,100\n600,100\n700,4\n")
    (d / "b.csv").write_text("400,0.3,0.31\n700,0.3,0.31\n")
    (d / "s.yaml").write_text(
        "wavelength: {start: 400, stop: 600}\n"
        "classes:\n  A: {spectrometer: {readings: r.csv, black: black.csv, white: white.csv}}\n  B: {file: b.csv}\n"
        "lights: [{led: {peak: 500, fwhm: 20}}]\noptics: [ideal]\ncameras: [cmos-visible]\n"
    )
    assert run_cli(["predict", d / "s.yaml", "--kde", "never"]) == 0
    err = capsys.readouterr().err
    assert (
        "note: A (" in err
        and "1 wavelengths invalid (white reference ≤ black) between 700 and 700 nm" in err
    )


def test_dask_before_the_scene_is_named_not_taken_as_its_address(capsys):
    from conftest import ROOT

    from inspect_validate.cli.predict import scheduler_address as _scheduler_address

    scene = ROOT / "sample_images/scenes/mix/scene.yaml"
    # `predict --dask SCENE`: click gives SCENE to --dask; the message says what happened.
    assert run_cli(["predict", "--dask", scene]) == 2
    err = capsys.readouterr().err
    assert f"'{scene}' is not a scheduler address" in err and "put --dask after SCENE" in err
    assert "Missing argument" not in err
    for address in ("tcp://10.0.0.5:8786", "scheduler:8786", "[::1]:8786", "local"):
        assert _scheduler_address(None, None, address) == address  # what Dask's Client takes


@pytest.mark.parametrize(
    ("raised", "code", "said"),
    [
        (
            MemoryError,
            70,
            "error: out of memory in predict; predict fewer combinations at a time, or on a "
            "coarser wavelength grid\n",
        ),
        (KeyboardInterrupt, 130, "interrupted\n"),  # predict saves no frames: none are named
    ],
)
def test_what_ends_a_run_is_said_for_the_command_that_ran(monkeypatch, capsys, raised, code, said):
    """Running out of memory, or Ctrl-C, in the middle of a prediction (raised where the
    scene is read). 'measure fewer or smaller frames' and 'frames saved so far are kept'
    were said for every command."""
    import inspect_validate.scene

    def fail(*args, **kwargs):
        raise raised

    monkeypatch.setattr(inspect_validate.scene, "read_scene", fail)
    assert run_cli(["predict", "scene.yaml"]) == code
    assert capsys.readouterr().err.lstrip("\n") == said  # click ends a ^C line first
