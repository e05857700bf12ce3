"""Triggered, strobed and chunk-verified acquisition on the simulated station.

The simulated camera triggers as a GenICam camera does (TriggerSoftware, a pulse on
Line1 counted by the simulated controller's ``TR`` commands) and lights a pulsed
channel only when it fires, for the part of the exposure the pulse covers; its chunks
carry the exposure each frame really had. The hardware SDK paths are in
test_genicam.py (TLSimu, viky) and test_pylon.py (pylon's emulator).
"""

import json
import re

import numpy as np
import pytest
import yaml
from conftest import copy_station, run_cli, station_copy, watch_cycles


def _capture(station, out, capsys):
    code = run_cli(["capture", station, "--out", out])
    return code, capsys.readouterr().err


def _metas(out, step):
    return [json.loads(p.read_text()) for p in sorted((out / step).glob("frame_*.json"))]


def _amber_mean(out):
    return float(np.mean([m["mean"] for m in _stats(out / "amber")]))


def _stats(folder):
    import tifffile

    return [{"mean": float(tifffile.imread(p).mean())} for p in sorted(folder.glob("*.tif"))]


def test_hardware_trigger_pulses_the_light_and_fires_the_camera(tmp_path, capsys):
    """Each frame is one TR command: the controller flashes the illumination's channels
    (pulse mode, RT…us) and its trigger output fires the camera on Line1. A pulse that
    covers the exposure gives the frames of continuous light."""
    free = tmp_path / "continuous"
    assert (
        _capture(station_copy(tmp_path, camera={"acquisition": "free-run"}), free, capsys)[0] == 0
    )
    station = station_copy(
        tmp_path,
        camera={"acquisition": "hardware-trigger", "trigger_line": "Line1", "trigger_delay_us": 50},
        pulse={"width_us": 8100, "delay_us": 20},
    )
    out = tmp_path / "hw"
    code, err = _capture(station, out, capsys)
    assert code == 0, err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["camera"]["acquisition"] == "hardware-trigger"
    assert manifest["camera"]["trigger_line"] == "Line1"
    # The controller was put in pulse mode, times sent with their unit (a bare RT time is ms).
    assert "CH1 pulse 100% 8100us 20us" in manifest["steps"]["amber"]["controller_status"]
    for step in ("amber", "red", "dark"):
        metas = _metas(out, step)
        assert len(metas) == 4 and all(m["light_pulsed"] for m in metas)
        assert not any(m["stale_frames_possible"] for m in metas)
    assert _metas(out, "amber")[0]["extra"]["lights"]["1"] == 100.0
    # Covered exposure: as bright as continuous light, within the frames' noise.
    assert _amber_mean(out) == pytest.approx(_amber_mean(free), rel=0.01)


def test_strobe_from_the_camera_lights_each_exposure(tmp_path, capsys):
    """Software-triggered frames whose ExposureActive output (Line2) triggers the
    controller; triggers are spaced for the light's duty limit."""
    station = station_copy(
        tmp_path,
        camera={"acquisition": "software-trigger", "strobe_line": "Line2"},
        pulse={"width_us": 8000, "max_duty": 0.1},
    )
    out = tmp_path / "strobe"
    code, err = _capture(station, out, capsys)
    assert code == 0, err
    assert json.loads((out / "manifest.json").read_text())["camera"]["strobe_line"] == "Line2"
    metas = _metas(out, "amber")
    assert metas[0]["extra"]["lights"] == {"1": 100.0, "2": 0.0}
    # 8 ms at most 10 % of the time: triggers at least 80 ms apart (the exposures'
    # timestamps follow them by a varying delay, so it is the triggers that are paced).
    gaps = np.diff([m["extra"]["trigger_ns"] for m in metas]) / 1e6
    assert gaps.min() >= 80, gaps


@pytest.mark.parametrize(
    "camera, pulse, message",
    [
        (
            {"acquisition": "hardware-trigger", "trigger_line": "Line1"},
            {"width_us": 6000},
            r"controller.pulse lights 0–6000 µs after the trigger, the exposure runs 0–8000 µs",
        ),
        (
            {"acquisition": "hardware-trigger", "trigger_line": "Line1", "trigger_delay_us": 10},
            {"width_us": 9000, "delay_us": 30},
            r"delay_us ≤ camera.trigger_delay_us",
        ),
        (
            {"acquisition": "software-trigger", "strobe_line": "Line2"},
            {"width_us": 9000, "delay_us": 5},
            r"delay_us ≤ 0 \(the exposure's start\)",
        ),
        ({"acquisition": "hardware-trigger"}, {"width_us": 9000}, r"needs camera.trigger_line"),
        (
            {"acquisition": "hardware-trigger", "trigger_line": "Line1"},
            None,
            r"needs controller.pulse",
        ),
        ({"acquisition": "free-run", "strobe_line": "Line2"}, {"width_us": 9000}, r"not free-run"),
        ({}, {"width_us": 9000}, r"controller.pulse is used with"),
        (
            {"acquisition": "hardware-trigger", "trigger_line": "Line1"},
            {"width_us": 9000, "max_duty": 1e-6},
            r"spaces frames 9e\+03 s apart",
        ),
        (
            {"acquisition": "hardware-trigger", "trigger_line": "Line 1"},
            {"width_us": 9000},
            r"trigger_line",
        ),
    ],
)
def test_inconsistent_timing_is_refused_when_read(tmp_path, capsys, camera, pulse, message):
    extra = {"pulse": pulse} if pulse else {}
    station = station_copy(tmp_path, camera=camera, **extra)
    code, err = _capture(station, tmp_path / "cap", capsys)
    assert code == 2 and "station.yaml" in err, err
    assert re.search(message, err), err
    assert not (tmp_path / "cap" / "manifest.json").exists()


def test_a_line_the_camera_lacks_is_refused_naming_it(tmp_path, capsys):
    station = station_copy(
        tmp_path,
        camera={"acquisition": "hardware-trigger", "trigger_line": "Line3"},
        pulse={"width_us": 9000},
    )
    code, err = _capture(station, tmp_path / "cap", capsys)
    assert code == 2
    assert "simulated camera" in err and "lacks TriggerSource Line3" in err
    assert "it offers Line1" in err


def test_chunks_discard_frames_exposed_otherwise(tmp_path, capsys):
    """Every third frame exposed at half the setting (a late-applied setting), its chunk
    saying so: each is discarded and counted with its reason; without chunks the same
    camera fails the step on the brightness jump instead of recording it."""
    world = {"exposure_glitch_every": 3}
    out = tmp_path / "chunks"
    code, err = _capture(station_copy(tmp_path, camera={"world": world}), out, capsys)
    assert code == 0, err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["camera"]["chunks"] == ["ExposureTime", "Gain"]
    reasons = {}
    for step in ("amber", "red", "dark"):
        for reason, n in manifest["steps"][step]["discarded"].items():
            reasons[reason] = reasons.get(reason, 0) + n
        assert all(m["extra"]["chunk"]["ExposureTime"] == 8000 for m in _metas(out, step))
    assert reasons == {"chunk ExposureTime 4000, not the 8000 requested": 5}  # frames 3, 6, … 15

    code, err = _capture(
        station_copy(tmp_path, camera={"world": world, "chunks": False}), tmp_path / "no", capsys
    )
    assert code == 3 and "brightness jumps within a step" in err


def test_a_lagging_chunk_does_not_pass_a_wrong_frame(tmp_path, capsys):
    """Chunks one frame late (a firmware fault): the dim frame carries the previous,
    correct values and the next frame the dim one's. The dim frame is caught by its
    brightness; the good frame after it, by its chunk, with the lag named."""
    world = {"exposure_glitch_every": 4, "chunk_lag": True}
    out = tmp_path / "lag"
    code, err = _capture(station_copy(tmp_path, camera={"world": world}), out, capsys)
    assert code == 0, err
    manifest = json.loads((out / "manifest.json").read_text())
    reasons = set()
    for step in ("amber", "red"):
        reasons |= set(manifest["steps"][step]["discarded"])
        means = [s["mean"] for s in _stats(out / step)]
        assert max(means) / min(means) < 1.02  # no half-exposed frame was kept
    assert "brightness off the step's level, chunk as requested" in reasons
    assert any("the camera's chunks lag a frame" in r for r in reasons), reasons


_MODES = {
    "free-run": ({"acquisition": "free-run"}, None),
    "software-trigger": ({"acquisition": "software-trigger"}, None),
    "hardware-trigger": (
        {"acquisition": "hardware-trigger", "trigger_line": "Line1"},
        {"width_us": 8200, "delay_us": 0},
    ),
    "strobe": ({"acquisition": "software-trigger", "strobe_line": "Line2"}, {"width_us": 8100}),
}


def _moded_station(tmp_path, mode, world=None):
    path = copy_station(tmp_path, world=world)
    doc = yaml.safe_load(path.read_text())
    camera, pulse = _MODES[mode]
    doc["camera"].update(camera)
    if pulse:
        doc["controller"]["pulse"] = pulse
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@pytest.mark.parametrize("mode", list(_MODES))
def test_verify_and_watch_in_every_mode(cli, tmp_path, golden, mode):
    """verify passes the shipped station in each mode (the pulsed light covers the
    exposure, so the prediction holds), and watch keeps it in control against a golden
    file trained software-triggered — then flags the amber LED at 80 % from cycle 2."""
    code, out, err = cli(["verify", _moded_station(tmp_path, mode), "--report", tmp_path / "r"])
    assert code == 0, out + err
    assert f"frames: amber: {_MODES[mode][0]['acquisition']}, 4 frames" in out
    world = {"changes": [{"start": 2, "irradiance": {1: 0.8}}]}
    (tmp_path / "w").mkdir()
    station = _moded_station(tmp_path / "w", mode, world=world)
    if mode == "free-run":  # trained triggered: its TriggerMode differs, as it should
        _, out, err, _ = watch_cycles(cli, station, golden, tmp_path / "w" / "s.sqlite", 1)
        assert "cycle 0: FAIL (camera settings unchanged since training)" in out, out + err
        doc = yaml.safe_load(station.read_text())
        doc["acceptance"]["health"] = {"settings": False}
        station.write_text(yaml.safe_dump(doc, sort_keys=False))
    db = tmp_path / "w" / "history.sqlite"
    code, out, err, rows = watch_cycles(cli, station, golden, db, 3)
    assert code == 1, out + err
    assert [r[1] for r in rows[:2]] == ["pass", "pass"], rows
    assert rows[2][1] != "pass" and "amber dimmer" in (rows[2][2] or ""), rows
