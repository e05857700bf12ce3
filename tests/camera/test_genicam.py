"""GenICam backend against the simulated GenTL producer shipped in the genicam wheel (viky.cti)."""

from pathlib import Path

import numpy as np
import pytest

from inspect_validate.camera.grabbers.genicam import GenICamGrabber, find_producers
from inspect_validate.errors import DeviceError

genicam = pytest.importorskip("genicam")
CTI = next(iter(Path(genicam.__file__).parent.glob("*.cti")), None)
pytestmark = pytest.mark.skipif(
    CTI is None, reason="this genicam wheel ships no simulated producer"
)


def test_enumerate_configure_grab():
    with GenICamGrabber(str(CTI), serial="1") as cam:
        assert "Viky" in cam.name and "serial 1" in cam.name
        # viky has no ExposureTime or Gain node: reported, not fatal.
        assert {"exposure", "gain"} <= cam.missing
        cam.configure(pixel_format="Mono8", region=(0, 0, 160, 120), exposure_us=1000, gain_db=3)
        frames = cam.grab(3, timeout_s=3)
        assert [f.data.shape for f in frames] == [(120, 160)] * 3
        assert all(
            f.data.dtype == np.uint8 and f.pixel_format == "Mono8" and f.bit_depth == 8
            for f in frames
        )
        ids = [f.frame_id for f in frames]
        assert ids == sorted(ids) and len(set(ids)) == 3
        assert frames[0].exposure_us is None and frames[0].clock in ("arrival", "device")
        assert (
            frames[0].data.flags.owndata
            or frames[0].data.base is None
            or frames[0].data.base.flags.owndata
        )
        # Locked nodes: configuring again stops the acquisition first.
        cam.configure(region=(0, 0, 200, 100))
        assert cam.grab(1)[0].data.shape == (100, 200)


def test_fetch_timeout_is_a_clear_error():
    with GenICamGrabber(str(CTI), index=0) as cam:
        cam.configure(pixel_format="Mono8")
        cam._nodes.AcquisitionFrameRate.value = 1.0
        cam.grab(1, timeout_s=3)
        with pytest.raises(
            DeviceError, match=r"no frame within 0.01 s \(frame 1 of 2\); check trigger mode"
        ):
            cam.grab(2, timeout_s=0.01)


def test_colour_format_is_refused():
    with GenICamGrabber(str(CTI), index=2) as cam:
        cam.configure()
        cam._nodes.PixelFormat.value = "RGBa8"
        with pytest.raises(DeviceError, match=r"RGBa8.*not a supported monochrome format"):
            cam.grab(1, timeout_s=3)
        with pytest.raises(DeviceError, match="Mono16 not offered"):
            cam.configure(pixel_format="Mono16")


def test_selection_and_producer_errors(tmp_path, monkeypatch):
    with pytest.raises(
        DeviceError,
        match=r"no GenICam camera with serial 42; found: .*Viky \(serial 0\), .*\(serial 2\)",
    ):
        GenICamGrabber(str(CTI), serial="42")
    with pytest.raises(DeviceError, match="camera index 7 does not exist"):
        GenICamGrabber(str(CTI), index=7)
    with pytest.raises(DeviceError, match=r"producer .* not found"):
        find_producers(str(tmp_path / "none.cti"))
    monkeypatch.setenv("GENICAM_GENTL64_PATH", str(CTI.parent))
    assert CTI in find_producers()
    monkeypatch.setenv("GENICAM_GENTL64_PATH", str(tmp_path))
    with pytest.raises(DeviceError, match="set GENICAM_GENTL64_PATH"):
        find_producers()


def test_full_capture_through_harvesters(tmp_path, capsys):
    """A station on viky through ``inspect-validate capture``: switch, flush, verify, save, darks."""
    import json

    from inspect_validate.cli import main

    station = tmp_path / "viky.yaml"
    station.write_text(
        f"camera: {{backend: genicam, cti: '{CTI}', serial: '0', pixel_format: Mono8,"
        " exposure_us: 5000, gain_db: 0}\n"
        "controller: {backend: simulated, channels: 2}\n"
        "illuminations:\n  - {name: one, channels: {1: 100}}\n  - {name: two, channels: {2: 50}}\n"
        "frames: 3\ndark_frames: 2\nbrightness_tolerance: 0.05\n"
    )
    out = tmp_path / "cap"
    with pytest.raises(SystemExit) as info:
        main(["capture", str(station), "--out", str(out)])
    err = capsys.readouterr().err
    assert info.value.code == 0, err
    # viky has no ExposureTime/Gain: the capture says so and records it.
    assert "warning: the camera has no exposure, gain setting" in err
    # viky's picture ignores the lights: every lit step is reported as no brighter than dark.
    assert "warning: step 'one'" in err and "warning: step 'two'" in err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["camera"]["not_applied"] == ["exposure", "gain"]
    assert "Viky" in manifest["camera"]["name"]
    for step, n in (("one", 3), ("two", 3), ("dark", 2)):
        assert manifest["steps"][step]["complete"]
        metas = [json.loads(p.read_text()) for p in sorted((out / step).glob("frame_*.json"))]
        assert len(metas) == n
        assert all(m["pixel_format"] == "Mono8" and m["exposure_us"] is None for m in metas)
        ids = [m["frame_id"] for m in metas]
        assert ids == sorted(ids) and len(set(ids)) == n
        # The stream is restarted after every switch: nothing queued before it survives.
        assert all(m["stream_restarted"] for m in metas)


def test_no_frame_from_before_the_switch_survives_a_deep_queue(tmp_path, capsys):
    """viky free-runs at 20 fps into 16 announced buffers; the slow controller takes
    0.6 s per switch, so 12 frames from before the switch wait in the queue — three
    times the flush count, under lights of equal brightness (viky ignores them), so
    no brightness check can tell. A frame exposed after the switch cannot arrive
    earlier than one frame period (50 ms) after it; a queued one arrives at once."""
    import json

    from inspect_validate.cli import main

    station = tmp_path / "viky.yaml"
    station.write_text(
        f"camera: {{backend: genicam, cti: '{CTI}', serial: '1', pixel_format: Mono8,"
        " num_buffers: 16, flush_frames: 4}\n"
        "controller: {backend: simulated, channels: 2, simulator_args: [--slow, '0.3'], timeout_s: 2}\n"
        "illuminations:\n  - {name: one, channels: {1: 100}}\n  - {name: two, channels: {2: 100}}\n"
        "frames: 3\ndark_frames: 0\nbrightness_tolerance: 0.05\n"
    )
    out = tmp_path / "cap"
    with pytest.raises(SystemExit) as info:
        main(["capture", str(station), "--out", str(out)])
    assert info.value.code == 0, capsys.readouterr().err
    for step in ("one", "two"):
        for meta in (json.loads(p.read_text()) for p in sorted((out / step).glob("frame_*.json"))):
            assert meta["clock"] == "arrival"
            after_switch_ms = (meta["timestamp_ns"] - meta["light_switched_ns"]) / 1e6
            assert after_switch_ms >= 25, (
                f"{step}: a frame arrived {after_switch_ms:.2f} ms after the switch"
            )


def _capture(tmp_path, station_text):
    from inspect_validate.cli import main

    station = tmp_path / "station.yaml"
    station.write_text(station_text)
    out = tmp_path / "cap"
    with pytest.raises(SystemExit) as info:
        main(["capture", str(station), "--out", str(out)])
    return info.value.code, out


def test_software_trigger_on_tlsimu(tmp_path, capsys, tlsimu_cti):
    """TLSimu (genicam 1.5.0) has TriggerSoftware: the default acquisition triggers one
    frame per verified frame after each switch; nothing untriggered arrives."""
    import json

    with GenICamGrabber(str(tlsimu_cti), serial="SN_InterfaceA_0") as cam:
        has = cam.features()
        assert has.software_trigger and not has.trigger_lines and not has.chunks
        cam.configure(pixel_format="Mono8")
        cam.arm("software-trigger")
        with pytest.raises(DeviceError, match=r"no frame within 0\.2 s"):
            cam.grab(1, timeout_s=0.2)  # armed, not triggered: no frame
        cam.trigger()
        assert cam.grab(1, timeout_s=2)[0].data.shape == (512, 512)
    code, out = _capture(
        tmp_path,
        f"camera: {{backend: genicam, cti: '{tlsimu_cti}', serial: SN_InterfaceA_0,"
        " pixel_format: Mono8}\n"
        "controller: {backend: simulated, channels: 2}\n"
        "illuminations:\n  - {name: one, channels: {1: 100}}\n  - {name: two, channels: {2: 50}}\n"
        "frames: 3\ndark_frames: 2\n",
    )
    assert code == 0, capsys.readouterr().err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["camera"]["acquisition"] == "software-trigger"
    for step, n in (("one", 3), ("two", 3), ("dark", 2)):
        metas = [json.loads(p.read_text()) for p in sorted((out / step).glob("frame_*.json"))]
        assert len(metas) == n and manifest["steps"][step]["discarded"] == {}
        assert all(m["acquisition"] == "software-trigger" for m in metas)
        assert not any(m["stale_frames_possible"] or m["stream_restarted"] for m in metas)
        ids = [m["frame_id"] for m in metas]
        assert ids == list(range(ids[0], ids[0] + n))  # one frame per trigger, none lost
    # TLSimu has ChunkModeActive but no exposure or gain chunk to select: asking for
    # chunks is refused before any light, naming what it lacks.
    (tmp_path / "chunks").mkdir()
    code, out = _capture(
        tmp_path / "chunks",
        f"camera: {{backend: genicam, cti: '{tlsimu_cti}', serial: SN_InterfaceA_0,"
        " pixel_format: Mono8, chunks: true}\n"
        "controller: {backend: simulated, channels: 2}\n"
        "illuminations:\n  - {name: one, channels: {1: 100}}\nframes: 2\ndark_frames: 0\n",
    )
    err = capsys.readouterr().err
    assert code == 2 and "TLSimuMono (serial SN_InterfaceA_0) lacks exposure or gain chunks" in err


def test_a_mode_the_camera_lacks_is_refused_before_any_light(tmp_path, capsys):
    """viky free-runs only: asking it for a software trigger, a trigger line or a strobe
    line is refused naming the feature and the camera, with no light switched and no
    capture folder left behind to block a rerun."""
    for camera, feature in (
        ("acquisition: software-trigger", "TriggerSoftware"),
        ("acquisition: hardware-trigger, trigger_line: Line1", "TriggerSource Line1"),
        ("acquisition: software-trigger, strobe_line: Line2", "ExposureActive on Line2"),
        ("chunks: true", "exposure or gain chunks"),
    ):
        pulse = ", pulse: {width_us: 6000}" if "Line" in camera else ""
        code, out = _capture(
            tmp_path,
            f"camera: {{backend: genicam, cti: '{CTI}', serial: '0', pixel_format: Mono8,"
            f" exposure_us: 5000, {camera}}}\n"
            f"controller: {{backend: simulated, channels: 2{pulse}}}\n"
            "illuminations:\n  - {name: one, channels: {1: 100}}\nframes: 2\ndark_frames: 0\n",
        )
        err = capsys.readouterr().err
        assert code == 2, err
        assert "Viky (serial 0) lacks " in err and feature in err, err
        assert "Nothing was switched" in err
        # A strobed light needs triggered frames: free-running is no way out for it.
        strobed = "strobe_line" in camera
        assert ("leave out camera.strobe_line" in err) == strobed, err
        assert not (out / "manifest.json").exists()  # no step began


@pytest.mark.parametrize("kind", ["folder", "fifo", "devnull", "text"])
def test_a_cti_that_is_no_producer_says_so(cli, tmp_path, kind):
    """--cti a folder, a FIFO or /dev/null read 'GenTL producer … not found'; a text file
    'cameras: none found'."""
    import os

    path = {"folder": tmp_path, "devnull": "/dev/null"}.get(kind, tmp_path / "x.cti")
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "text":
        path.write_text("not a library")
    code, out, err = cli(["devices", "--cti", path, "--backend", "genicam"])
    said = out + err
    assert code in (0, 2, 3) and "not found" not in said and "Traceback" not in said, said
    assert "is a folder" in said or "not a regular file" in said or "no GenTL producer" in said
