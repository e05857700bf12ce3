"""Replay camera and manual controller, end to end through ``inspect-validate capture``."""

import io
import json

import cv2
import numpy as np
import pytest
import tifffile
from conftest import ROOT, run_cli

SCENES = ROOT / "sample_images" / "scenes"


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A capture of the built-in simulated station: what a replay re-runs."""
    out = tmp_path_factory.mktemp("rec") / "cap"
    assert (
        run_cli(["capture", ROOT / "sample_images" / "station" / "station.yaml", "--out", out]) == 0
    )
    return out


def replay_station(tmp_path, folder, *, exposure=8000, frames=4, illuminations=None):
    illuminations = (
        illuminations
        or "  - {name: amber, channels: {1: 100}}\n  - {name: red, channels: {2: 100}}\n"
    )
    path = tmp_path / "replay.yaml"
    path.write_text(
        f"camera: {{backend: replay, folder: '{folder}', exposure_us: {exposure}, gain_db: 0}}\n"
        "controller: {backend: simulated, channels: 2}\n"
        f"illuminations:\n{illuminations}frames: {frames}\ndark_frames: 4\n"
    )
    return path


def test_replayed_capture_serves_the_recorded_frames_per_light(tmp_path, recording, capsys):
    out = tmp_path / "again"
    assert run_cli(["capture", replay_station(tmp_path, recording), "--out", out]) == 0
    for step in ("amber", "red", "dark"):
        for i in range(1, 5):
            name = f"frame_{i:04d}"
            original = tifffile.imread(recording / step / f"{name}.tif")
            replayed = tifffile.imread(out / step / f"{name}.tif")
            assert np.array_equal(original, replayed)
            meta = json.loads((out / step / f"{name}.json").read_text())
            assert meta["extra"]["replayed_from"] == str(recording / step / f"{name}.tif")
            assert meta["discarded_before"] == 0 and meta["exposure_us"] == 8000


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            {"exposure": 5000},
            "the station asks exposure_us = 5000.0, the recording was taken at 8000.0",
        ),
        ({"frames": 5}, "no more frames under channel 1 at 100 % (4 in all)"),
        (
            {
                "illuminations": "  - {name: amber, channels: {1: 100}}\n"
                "  - {name: both, channels: {1: 50, 2: 50}}\n"
            },
            "nothing was recorded under channel 1 at 50 %, channel 2 at 50 % (recorded: channel 1 at 100 %;",
        ),
    ],
)
def test_replay_refuses_what_was_not_recorded(tmp_path, recording, capsys, kwargs, message):
    out = tmp_path / "again"
    assert run_cli(["capture", replay_station(tmp_path, recording, **kwargs), "--out", out]) == 3
    assert message in capsys.readouterr().err
    if "exposure" in kwargs:  # refused while configuring: no manifest blocks a plain rerun
        assert not (out / "manifest.json").exists()
        return
    manifest = json.loads((out / "manifest.json").read_text())
    if "illuminations" in kwargs:  # the camera failed mid-run: the finished step is kept
        assert manifest["steps"]["amber"]["complete"] and "error" in manifest["steps"]["both"]
        assert len(list((out / "amber").glob("frame_*.tif"))) == 4


def test_replay_refuses_a_recording_whose_sidecar_is_a_pipe(tmp_path, recording, capsys):
    """A FIFO would block the index's read until a writer came: it is named instead."""
    import os
    import shutil

    folder = tmp_path / "rec"
    shutil.copytree(recording, folder)
    (folder / "red" / "frame_0002.json").unlink()
    os.mkfifo(folder / "red" / "frame_0002.json")
    assert run_cli(["capture", replay_station(tmp_path, folder), "--out", tmp_path / "o"]) == 2
    err = capsys.readouterr().err
    assert "frame_0002.json: not a capture sidecar" in err and "not a regular file" in err


def manual_station(tmp_path, n_images=6):
    folder = tmp_path / "images"
    folder.mkdir()
    for i in range(n_images):  # two levels, as two lights would give
        cv2.imwrite(
            str(folder / f"img_{i:02d}.png"), np.full((32, 48), 40 if i < 3 else 90, np.uint8)
        )
    path = tmp_path / "manual.yaml"
    path.write_text(
        "camera: {backend: replay, folder: images, flush_frames: 1}\n"
        "controller: {backend: manual, channels: 2}\n"
        "illuminations:\n  - {name: one, channels: {1: 100}}\n  - {name: two, channels: {2: 60}}\n"
        "frames: 2\ndark_frames: 0\n"
    )
    return path


def test_manual_controller_prompts_for_each_setting(tmp_path, capsys, monkeypatch):
    station = manual_station(tmp_path)
    monkeypatch.setattr("sys.stdin", io.StringIO("\n\n\n"))
    out = tmp_path / "cap"
    assert run_cli(["capture", station, "--out", out]) == 0
    err = capsys.readouterr().err
    prompts = [line for line in err.splitlines() if line.startswith("Set the lights:")]
    assert prompts == [
        "Set the lights: channel 1 at 100 %",
        "Set the lights: channel 2 at 60 %",
        "Set the lights: all lights OFF",
    ]
    assert "warning: the camera has no exposure, gain setting" not in err  # none was asked
    # The plain image folder is served in order; one frame is flushed after each switch.
    one = [tifffile.imread(p)[0, 0] for p in sorted((out / "one").glob("*.tif"))]
    two = [tifffile.imread(p)[0, 0] for p in sorted((out / "two").glob("*.tif"))]
    assert one == [40, 40] and two == [90, 90]


def test_manual_controller_without_an_operator(tmp_path, capsys, monkeypatch):
    station = manual_station(tmp_path)
    monkeypatch.setattr("sys.stdin", io.StringIO(""))
    assert run_cli(["capture", station, "--out", tmp_path / "cap"]) == 3
    assert "manual switching: no operator to switch the lights (standard input is closed)" in (
        capsys.readouterr().err
    )


def test_camera_backends_without_hardware_give_clear_errors(tmp_path, capsys):
    station = tmp_path / "s.yaml"
    base = "controller: {backend: simulated, channels: 1}\nilluminations: [{name: a, channels: {1: 100}}]\n"
    station.write_text("camera: {backend: v4l2, device: /dev/video99}\n" + base)
    assert run_cli(["capture", station, "--out", tmp_path / "o1"]) == 3
    assert "V4L2 camera /dev/video99: cannot open it" in capsys.readouterr().err
    station.write_text("camera: {backend: replay, folder: nowhere}\n" + base)
    assert run_cli(["capture", station, "--out", tmp_path / "o2"]) == 2
    assert "replay folder not found (camera.folder in the station file)" in capsys.readouterr().err
