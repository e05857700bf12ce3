"""Basler backend against pypylon's camera emulator (PYLON_CAMEMU), in a subprocess.

pylon reads PYLON_CAMEMU when its transport layers start, so each check runs
in a fresh interpreter with the variable set.
"""

import json
import os
import subprocess
import sys

import pytest
from conftest import run_with_emulator

pytest.importorskip("pypylon")


def test_emulator_serves_files_pixel_exactly(tmp_path):
    out = run_with_emulator(
        f"""
        import numpy as np, cv2
        from inspect_validate.camera.grabbers.pylon import PylonGrabber
        img = (np.arange(48 * 64).reshape(48, 64) * 7 % 256).astype(np.uint8)
        cv2.imwrite("{tmp_path}/a.png", img)
        with PylonGrabber(index=0) as cam:
            cam.configure(pixel_format="Mono8", region=(0, 0, 64, 48), exposure_us=5000, gain_db=0)
            cam.nodes.TestImageSelector.Value = "Off"
            cam.nodes.ImageFileMode.Value = "On"
            cam.nodes.ImageFilename.Value = "{tmp_path}/a.png"
            frames = cam.grab(3)
            assert all(np.array_equal(f.data, img) for f in frames), "not pixel-exact"
            assert frames[0].exposure_us == 5000 and frames[0].pixel_format == "Mono8"
            assert len({{f.frame_id for f in frames}}) == 3
            print("ok", cam.name)
        """,
        tmp_path,
    )
    assert out.startswith("ok Basler Emulation")


def test_emulator_errors(tmp_path):
    out = run_with_emulator(
        """
        from inspect_validate.camera.grabbers.pylon import PylonGrabber
        from inspect_validate.errors import DeviceError
        try:
            PylonGrabber(serial="nope")
        except DeviceError as e:
            print("serial:", e)
        with PylonGrabber() as cam:
            try:
                cam.configure(pixel_format="RGB8Packed")
            except DeviceError as e:
                print("format:", e)
            cam.nodes.TriggerMode.Value = "On"  # no trigger will come
            try:
                cam.grab(1, timeout_s=0.2)
            except DeviceError as e:
                print("timeout:", e)
        """,
        tmp_path,
    )
    assert (
        "serial: no pylon camera with serial nope; found: Basler Emulation (serial 0815-0000)"
        in out
    )
    assert "format: " in out and "RGB8Packed not offered as monochrome" in out
    assert "timeout: " in out and "no frame within 0.2 s" in out


def test_restart_drops_the_frames_pylon_queued_before_the_switch(tmp_path):
    # While the capture saves, a free-running camera fills pylon's MaxNumBuffer buffers
    # with frames exposed under the old light; a fixed flush of 4 would keep six of them.
    out = run_with_emulator(
        """
        import time
        from inspect_validate.camera.grabbers.pylon import PylonGrabber
        with PylonGrabber() as cam:
            cam.configure(region=(0, 0, 64, 64))
            cam.nodes.AcquisitionFrameRateEnable.Value = True
            cam.nodes.AcquisitionFrameRate.Value = 50
            last = cam.grab(1)[0].frame_id
            time.sleep(0.5)
            print("queued", cam.nodes.NumReadyBuffers.Value, cam.nodes.MaxNumBuffer.Value)
            print("restarted", cam.restart_stream(), cam.nodes.NumReadyBuffers.Value)
            print("skipped", cam.grab(1)[0].frame_id - last - 1)
        """,
        tmp_path,
    )
    queued, restarted, skipped = (line.split() for line in out.splitlines())
    assert queued[1] == queued[2] == "10"
    assert restarted[1:] == ["True", "0"]
    assert int(skipped[1]) >= 10  # pylon counts the dropped buffers in the frame IDs


@pytest.mark.parametrize("acquisition", ["software-trigger", "free-run"])
def test_full_capture_through_the_emulator_matches_the_simulated_station(tmp_path, acquisition):
    """The simulated station's capture, every frame through pylon's grab engine:
    software-triggered (the default on a camera with TriggerSoftware), or free-running
    with the stream restarted after each switch."""
    from conftest import ROOT

    from inspect_validate.cli import main

    station = ROOT / "sample_images" / "station"
    text = (station / "station.yaml").read_text()
    text = text.replace(
        "backend: simulated\n",
        f"backend: pylon\n  simulate: true\n  pixel_format: Mono16\n  acquisition: {acquisition}\n",
        1,
    )
    text = text.replace("../scenes/", f"{ROOT / 'sample_images' / 'scenes'}/")
    pylon_station = tmp_path / "pylon.yaml"
    pylon_station.write_text(text)
    out = tmp_path / "emu"
    env = {**os.environ, "PYLON_CAMEMU": "1"}
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "inspect_validate",
            "capture",
            str(pylon_station),
            "--out",
            str(out),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    meta = json.loads((out / "red" / "frame_0001.json").read_text())
    # The emulator stamps no time (TimeStamp 0), but neither a triggered frame nor the
    # restarted stream needs a flush.
    assert meta["device"].startswith("Basler Emulation") and meta["clock"] == "arrival"
    assert meta["pixel_format"] == "Mono16" and meta["exposure_us"] == 8000
    assert meta["acquisition"] == acquisition and meta["discarded_before"] == 0
    assert meta["stream_restarted"] is (acquisition == "free-run")
    assert meta["stale_frames_possible"] is False

    # The same station on the simulated camera: class means agree within noise.
    sim = tmp_path / "sim"
    means = {}
    for name, folder, station_file in (
        ("emu", out, None),
        ("sim", sim, station / "station.yaml"),
    ):
        if station_file is not None:
            with pytest.raises(SystemExit) as info:
                main(["capture", str(station_file), "--out", str(folder)])
            assert info.value.code == 0
        doc = tmp_path / f"{name}.json"
        with pytest.raises(SystemExit) as info:
            main(
                [
                    "measure",
                    str(folder / "amber"),
                    "--dark",
                    str(folder / "dark"),
                    "--rois",
                    str(station / "rois.yaml"),
                    "--json",
                    str(doc),
                ]
            )
        assert info.value.code == 0
        means[name] = {c["name"]: c for c in json.loads(doc.read_text())["classes"]}
    for cls, m in means["sim"].items():
        e = means["emu"][cls]
        # Different noise realisations of the same model: the spatial spread dominates.
        assert abs(e["mean"] - m["mean"]) < 4 * (m["variance"] / m["n_pixels"]) ** 0.5 + 0.5, cls
        assert abs(e["variance"] / m["variance"] - 1) < 0.1, cls


def test_verify_through_the_emulator_recovers_a_dimmer_light(tmp_path):
    """`verify` end to end on pylon's grab engine and the simulated controller process on a
    pseudo-terminal, against a world whose amber light gives 40 % of its stated irradiance."""
    from conftest import copy_station, through_sdk

    path = through_sdk(copy_station(tmp_path, world={"irradiance": {1: 0.4}}))
    report = tmp_path / "report"
    done = subprocess.run(
        [sys.executable, "-m", "inspect_validate", "verify", str(path), "--report", str(report)],
        env={**os.environ, "PYLON_CAMEMU": "1"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    result = json.loads((report / "verification.json").read_text())
    assert result["verdict"] == "pass"
    scales = result["calibration"]["illuminations"]
    assert scales["amber"]["scale"] == pytest.approx(0.4, rel=0.01)
    assert scales["red"]["scale"] == pytest.approx(1.0, rel=0.01)
    meta = json.loads((report / "frames" / "amber" / "frame_0001.json").read_text())
    assert meta["device"].startswith("Basler Emulation")
    assert (report / "report.html").stat().st_size > 0


def test_legacy_node_names_and_software_trigger(tmp_path):
    """A GigE camera of the GenICam 1.x era has ExposureTimeAbs, not ExposureTime: with
    the SFNC name made unknown, the emulator's legacy node is used and read back. The
    software trigger gives one frame per TriggerSoftware, none without."""
    out = run_with_emulator(
        """
        from inspect_validate.camera.grabbers import pylon as backend
        from inspect_validate.errors import DeviceError
        backend.PylonGrabber._EXPOSURE_NODES = ("NoSuchExposureNode", "ExposureTimeAbs")
        with backend.PylonGrabber(index=0) as cam:
            cam.configure(pixel_format="Mono8", exposure_us=5000)
            has = cam.features()
            cam.arm("software-trigger")
            try:
                cam.grab(1, timeout_s=0.3)
                print("untriggered frame")
            except DeviceError:
                pass
            cam.trigger()
            frame = cam.grab(1, timeout_s=2)[0]
            print(cam._first(cam._EXPOSURE_NODES), frame.exposure_us, has.software_trigger, has.trigger_lines,
                  has.strobe_lines, has.chunks, cam.increments().get("exposure_us"))
        """,
        tmp_path,
    )
    assert out.split() == [
        "ExposureTimeAbs",
        "5000.0",
        "True",
        "('Line1',",
        "'Line2',",
        "'Line3')",
        "('Line1',",
        "'Line2',",
        "'Line3')",
        "()",
        "None",  # ExposureTimeAbs has no increment on the emulator
    ]
