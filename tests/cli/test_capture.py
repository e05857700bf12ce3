"""`inspect-validate capture` on the simulated station (the simulated Gardasoft process on a pty, the
model-rendered camera): exit codes, station-file errors, controller and camera faults with
every frame kept, resume. The device layer's sequence alone: tests/camera/test_sequence.py."""

import json
import re
import shutil

import numpy as np
import pytest
from conftest import ROOT, run_cli, station_copy

STATION = ROOT / "sample_images" / "station"


@pytest.mark.parametrize("acquisition", [None, "free-run"])
def test_capture_then_measure_on_the_simulated_station(tmp_path, capsys, acquisition):
    """By default the simulated camera, which has TriggerSoftware, is software-triggered:
    nothing from before a switch can arrive. Free-running, its 2-frame pipeline holds
    frames from before every switch, which the capture must discard."""
    out = tmp_path / "cap"
    station = (
        station_copy(tmp_path, camera={"acquisition": acquisition})
        if acquisition
        else STATION / "station.yaml"
    )
    assert run_cli(["capture", station, "--out", out]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert all(manifest["steps"][s]["complete"] for s in ("amber", "red", "dark"))
    mode = acquisition or "software-trigger"
    assert manifest["camera"]["acquisition"] == mode
    for step, lights in (
        ("amber", {"1": 100.0, "2": 0.0}),
        ("red", {"1": 0.0, "2": 100.0}),
        ("dark", {"1": 0.0, "2": 0.0}),
    ):
        sidecars = sorted((out / step).glob("frame_*.json"))
        assert len(sidecars) == 4 and len(list((out / step).glob("frame_*.tif"))) == 4
        for sc in sidecars:
            meta = json.loads(sc.read_text())
            # Every kept frame was exposed under this step's light, after the switch.
            assert (
                meta["extra"]["lights"] == lights
                and meta["station_sha256"] == manifest["station_sha256"]
            )
            assert meta["acquisition"] == mode
            assert meta["stale_frames_possible"] is (mode == "free-run")
        first = json.loads(sidecars[0].read_text())
        if mode == "free-run":
            assert first["discarded_before"] >= (2 if step != "amber" else 0)
            if step != "amber":
                assert first["discarded"]["exposed before the switch"] >= 2
        else:
            assert first["discarded_before"] == 0 and first["discarded"] == {}
            assert manifest["steps"][step]["discarded"] == {}
    # The camera's pipeline holds 2 frames: a capture that did not discard would have recorded them.
    doc = tmp_path / "m.json"
    assert (
        run_cli(
            [
                "measure",
                out / "amber",
                "--dark",
                out / "dark",
                "--rois",
                STATION / "rois.yaml",
                "--json",
                doc,
            ]
        )
        == 0
    )
    classes = {c["name"]: c for c in json.loads(doc.read_text())["classes"]}
    assert classes["A"]["mean"] > classes["C"]["mean"] > classes["B"]["mean"]  # amber separates A
    assert classes["A"]["temporal_variance"] > 0 and classes["A"]["n_frames"] == 4


def test_controller_vanishing_keeps_frames_and_resume_finishes(tmp_path, capsys):
    station = station_copy(tmp_path, simulator_args=["--vanish-after", "3"])
    out = tmp_path / "cap"
    assert run_cli(["capture", station, "--out", out]) == 3
    err = capsys.readouterr().err
    assert re.search(r"error: /dev/pts/\d+: ", err)
    amber = sorted((out / "amber").glob("frame_*.tif"))
    assert len(amber) == 4
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["steps"]["amber"]["complete"] and "error" in manifest["steps"]["red"]
    before = [p.read_bytes() for p in amber]
    # Each run's simulator vanishes after 3 commands again; resuming makes progress every time.
    codes = [run_cli(["capture", station, "--out", out, "--resume"]) for _ in range(2)]
    assert codes[-1] == 0 and [p.read_bytes() for p in amber] == before
    manifest = json.loads((out / "manifest.json").read_text())
    assert all(manifest["steps"][s]["complete"] for s in ("amber", "red", "dark"))


def test_controller_over_tcp_captures_and_a_dropped_connection_keeps_frames(tmp_path, capsys):
    """The simulated controller on 127.0.0.1 (an Ethernet controller's socket:// port):
    a full capture, then one whose connection drops after the amber step."""
    out = tmp_path / "cap"
    assert run_cli(["capture", station_copy(tmp_path, simulator_args=["--tcp"]), "--out", out]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert all(manifest["steps"][s]["complete"] for s in ("amber", "red", "dark"))

    station = station_copy(tmp_path, simulator_args=["--tcp", "--drop-after", "3"])
    out = tmp_path / "dropped"
    assert run_cli(["capture", station, "--out", out]) == 3
    err = capsys.readouterr().err
    assert re.search(r"error: socket://127\.0\.0\.1:\d+: the connection failed", err), err
    assert "network connection was lost" in err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["steps"]["amber"]["complete"] and "error" in manifest["steps"]["red"]
    assert len(list((out / "amber").glob("frame_*.tif"))) == 4


def test_err_reply_names_the_command_and_keeps_frames(tmp_path, capsys):
    station = station_copy(tmp_path, simulator_args=["--error", "RS2,100:3"])
    out = tmp_path / "cap"
    assert run_cli(["capture", station, "--out", out]) == 3
    assert "answered 'Err 3' to 'RS2,100'" in capsys.readouterr().err
    assert len(list((out / "amber").glob("frame_*.tif"))) == 4


@pytest.mark.parametrize(
    "fault, message",
    [
        (["--mute-after", "3"], r"no answer to 'RS\d,\d+' within 0.5 s; check the cable"),
        (["--garbage-after", "3"], r"unexpected reply b'\\xff\\xfe\\x00\\x80garbage' to 'RS"),
        (["--slow", "0.8"], r"no answer to 'RS1,100' within 0.5 s"),
    ],
)
def test_silent_or_garbled_controller_keeps_frames(tmp_path, capsys, fault, message):
    station = station_copy(tmp_path, simulator_args=fault, timeout_s=0.5)
    out = tmp_path / "cap"
    assert run_cli(["capture", station, "--out", out]) == 3
    err = capsys.readouterr().err
    assert re.search(r"error: /dev/pts/\d+: " + message, err), err
    manifest = json.loads((out / "manifest.json").read_text())
    failed = [s for s, v in manifest["steps"].items() if "error" in v]
    assert len(failed) == 1
    if fault[0] != "--slow":  # two commands (amber) answered before the fault: amber is kept
        assert manifest["steps"]["amber"]["complete"]
        assert len(list((out / "amber").glob("frame_*.tif"))) == 4


def test_existing_capture_needs_resume_and_the_same_station(tmp_path, capsys):
    station = station_copy(tmp_path)
    out = tmp_path / "cap"
    assert run_cli(["capture", station, "--out", out]) == 0
    assert run_cli(["capture", station, "--out", out]) == 2
    assert "continue it with 'capture --resume'" in capsys.readouterr().err
    station.write_text(station.read_text().replace("frames: 4", "frames: 5"))
    assert run_cli(["capture", station, "--out", out, "--resume"]) == 2
    assert "different station file" in capsys.readouterr().err


def test_bad_station_file_names_the_field(tmp_path, capsys):
    bad = tmp_path / "s.yaml"
    bad.write_text(
        "camera: {backend: simulated}\ncontroller: {backend: telepathy}\nilluminations: []\n"
    )
    assert run_cli(["capture", bad, "--out", tmp_path / "o"]) == 2
    err = capsys.readouterr().err
    assert (
        "controller: backend must be one of gardasoft, generic, manual, none, simulated" in err
        and "illuminations" in err
    )


def test_a_step_no_brighter_than_dark_is_reported(tmp_path, capsys):
    station = station_copy(tmp_path)
    text = station.read_text().replace("channels: 2\n", "channels: 3\n")
    # Channel 3 drives no light the camera sees (a wrong channel in the station file).
    text = text.replace(
        "  - {name: red, channels: {2: 100}}\n",
        "  - {name: red, channels: {2: 100}}\n  - {name: unplugged, channels: {3: 100}}\n",
    )
    station.write_text(text)
    out = tmp_path / "cap"
    assert run_cli(["capture", station, "--out", out]) == 0
    err = capsys.readouterr().err
    assert "warning: step 'unplugged': mean" in err and "no brighter than the dark frames" in err
    assert "'amber'" not in err and "'red'" not in err
    warnings = json.loads((out / "manifest.json").read_text())["warnings"]
    assert len(warnings) == 1 and warnings[0].startswith("step 'unplugged'")


LINE_PROTOCOL = {
    "terminator": "\n",
    "reply_end": "\r\n",
    "ok": "^OK",
    "error": "ERROR (?P<code>\\d+)",
    "max_value": 255,
    "commands": {"set": "SET {channel} {value:.0f}", "off": "OFF {channel}"},
}


def test_capture_through_the_generic_ascii_controller(tmp_path, capsys):
    station = station_copy(tmp_path, simulator_args=["--dialect", "line"], protocol=LINE_PROTOCOL)
    out = tmp_path / "cap"
    assert run_cli(["capture", station, "--out", out]) == 0
    meta = json.loads((out / "red" / "frame_0001.json").read_text())
    assert meta["controller"].startswith("ASCII controller on /dev/pts/")
    assert meta["extra"]["lights"] == {"1": 0.0, "2": 100.0}


def test_generic_controller_faults_keep_frames(tmp_path, capsys):
    station = station_copy(
        tmp_path,
        simulator_args=["--dialect", "line", "--error", "SET 2:4"],
        protocol=LINE_PROTOCOL,
        error_codes={4: "channel disabled"},
    )
    out = tmp_path / "cap"
    assert run_cli(["capture", station, "--out", out]) == 3
    assert "answered 'ERROR 4' (channel disabled) to 'SET 2 255'" in capsys.readouterr().err
    assert len(list((out / "amber").glob("frame_*.tif"))) == 4


@pytest.mark.parametrize(
    "protocol, field",
    [
        ({"commands": {"set": "SET {chan} {value}"}}, "controller.protocol.commands"),
        ({"commands": {"off": "OFF {channel}"}}, "a 'set' template is required"),
        ({"commands": {"set": "S{channel}"}, "ok": "(unclosed"}, "controller.protocol.ok"),
    ],
)
def test_generic_protocol_is_validated(tmp_path, capsys, protocol, field):
    station = station_copy(tmp_path, protocol=protocol)
    assert run_cli(["capture", station, "--out", tmp_path / "o"]) == 2
    err = capsys.readouterr().err
    assert str(station) in err and field in err


def test_illumination_on_a_missing_channel_is_refused_when_read(tmp_path, capsys):
    path = station_copy(tmp_path)
    path.write_text(
        path.read_text().replace(
            "{name: red, channels: {2: 100}}", "{name: red, channels: {3: 100}}"
        )
    )
    assert run_cli(["capture", path, "--out", tmp_path / "o"]) == 2
    err = capsys.readouterr().err
    assert (
        "illuminations[1] (red): channel 3 is not on the controller (controller.channels: 2)" in err
    )
    assert not (tmp_path / "o" / "manifest.json").exists()


def test_settings_of_another_backend_are_refused(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text(
        "camera: {backend: genicam, latency: 3}\ncontroller: {backend: gardasoft, port: /dev/x}\n"
        "illuminations: [{name: a, channels: {1: 100}}]\n"
    )
    assert run_cli(["capture", path, "--out", tmp_path / "o"]) == 2
    assert "camera.latency: Extra inputs are not permitted" in capsys.readouterr().err


def test_camera_that_fails_to_open_leaves_nothing_blocking_a_rerun(tmp_path, capsys):
    path = station_copy(tmp_path)
    good = path.read_text()
    path.write_text(re.sub(r"(\nscene: ).*", r"\1missing.yaml", good))
    out = tmp_path / "o"
    assert run_cli(["capture", path, "--out", out]) == 2
    assert "missing.yaml" in capsys.readouterr().err
    assert not (out / "manifest.json").exists()
    path.write_text(good)
    assert run_cli(["capture", path, "--out", out]) == 0


def test_resume_with_another_camera_is_refused(tmp_path, capsys):
    path = station_copy(tmp_path, simulator_args=["--vanish-after", "5"])
    out = tmp_path / "o"
    assert run_cli(["capture", path, "--out", out]) == 3
    manifest = json.loads((out / "manifest.json").read_text())
    assert "simulated camera" in manifest["camera"]["name"]
    manifest["camera"]["name"] = "Basler acA1920 (serial 123)"  # as if another camera took them
    (out / "manifest.json").write_text(json.dumps(manifest))
    capsys.readouterr()
    assert run_cli(["capture", path, "--out", out, "--resume"]) == 2
    assert "taken with 'Basler acA1920 (serial 123)'" in capsys.readouterr().err


def test_controller_status_is_recorded_per_step(tmp_path):
    out = tmp_path / "o"
    assert run_cli(["capture", station_copy(tmp_path), "--out", out]) == 0
    steps = json.loads((out / "manifest.json").read_text())["steps"]
    assert "CH1 continuous 100%" in steps["amber"]["controller_status"]
    assert "CH2 continuous 0%" in steps["amber"]["controller_status"]
    assert "CH2 continuous 100%" in steps["red"]["controller_status"]


def test_a_jump_on_the_last_frame_keeps_the_verified_frames(tmp_path, capsys):
    """Frames are saved as they are verified, not after the whole step."""
    import cv2

    folder = tmp_path / "images"
    folder.mkdir()
    for i, level in enumerate([40, 40, 40, 90]):
        cv2.imwrite(str(folder / f"img_{i}.png"), np.full((32, 48), level, np.uint8))
    path = tmp_path / "s.yaml"
    path.write_text(
        "camera: {backend: replay, folder: images, flush_frames: 0}\n"
        "controller: {backend: simulated, channels: 1}\n"
        "illuminations: [{name: one, channels: {1: 100}}]\nframes: 4\ndark_frames: 0\n"
    )
    out = tmp_path / "o"
    assert run_cli(["capture", path, "--out", out]) == 3
    assert "brightness jumps" in capsys.readouterr().err
    assert len(list((out / "one").glob("frame_*.tif"))) == 3
    assert len(list((out / "one").glob("frame_*.json"))) == 3


def test_a_frame_that_cannot_be_written_stops_the_capture_naming_the_file(tmp_path):
    """Saving runs on the writer thread; its failure must still reach the user. A file-size
    limit below one frame (SIGXFSZ ignored, so the write fails with EFBIG, as a full disk
    fails with ENOSPC): exit 2 naming the frame file, the step not complete, no
    half-written file left."""
    import subprocess
    import sys

    station = station_copy(tmp_path)
    out = tmp_path / "cap"
    script = (
        "import resource, signal\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))\n"
        "from inspect_validate.cli import main\n"
        f"main(['capture', {str(station)!r}, '--out', {str(out)!r}])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2, done.stderr
    assert f"{out / 'amber' / 'frame_0001.tif'}: cannot write (File too large)" in done.stderr
    assert "Traceback" not in done.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    # Found while the next light's first frame exposes, the failure is still amber's.
    assert not manifest["steps"]["amber"]["complete"]
    assert "File too large" in manifest["steps"]["amber"]["error"]
    assert [s for s, v in manifest["steps"].items() if "error" in v] == ["amber"]
    assert not list(out.rglob("*.tmp")) and not list(out.rglob("frame_*"))


@pytest.mark.parametrize("inherited", ["default", "ignored"])
def test_an_interrupted_capture_keeps_every_frame_it_grabbed_complete(tmp_path, inherited):
    """SIGINT once the first frame is on disk: exit 130, and every frame file that exists
    is whole, with its sidecar (frames queued for the writer thread are written before
    the process ends); --resume then finishes the capture. The same when the capture
    inherited SIGINT as ignored (a job started with '&' from a script, or a test
    runner run in the background)."""
    import signal
    import subprocess
    import sys
    import time

    import tifffile

    station = station_copy(tmp_path)
    out = tmp_path / "cap"
    text = station.read_text().replace("frames: 4\n", "frames: 40\n")
    station.write_text(text)
    proc = subprocess.Popen(
        [sys.executable, "-m", "inspect_validate", "capture", str(station), "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(
            signal.SIGINT, signal.SIG_IGN if inherited == "ignored" else signal.SIG_DFL
        ),
    )
    deadline = time.monotonic() + 60
    while not list(out.glob("amber/frame_*.json")) and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    tifs = sorted(out.glob("amber/frame_*.tif"))
    assert tifs and len(tifs) == len(list(out.glob("amber/frame_*.json")))
    for tif in tifs:
        assert tifffile.imread(tif).shape == (240, 320)
    assert not list(out.rglob("*.tmp"))
    assert run_cli(["capture", station, "--out", out, "--resume"]) == 0
    assert len(list(out.glob("amber/frame_*.tif"))) == 40


def test_the_simulated_controller_ends_with_a_killed_capture(tmp_path):
    """kill -9 of capture: its simulated controller (in a session of its own, so a
    terminal's Ctrl-C reaches the tool first) exits with it and removes its temporary
    folder, instead of living on as an orphan."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    station = station_copy(tmp_path, simulator_args=["--slow", "0.05"])
    doc = station.read_text().replace("frames: 4\n", "frames: 400\n")
    station.write_text(doc)
    capture = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "inspect_validate",
            "capture",
            str(station),
            "--out",
            str(tmp_path / "o"),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 60
    child = None
    while child is None and time.monotonic() < deadline:
        children = Path(f"/proc/{capture.pid}/task/{capture.pid}/children")
        pids = children.read_text().split() if children.exists() else []
        child = int(pids[0]) if pids else None
        time.sleep(0.05)
    assert child is not None, "the simulated controller did not start"
    argv = Path(f"/proc/{child}/cmdline").read_bytes().split(b"\0")
    folder = Path(argv[argv.index(b"--state") + 1].decode()).parent
    assert os.getsid(child) != os.getsid(capture.pid)  # its own session
    while not (tmp_path / "o" / "amber" / "frame_0002.tif").exists():
        assert time.monotonic() < deadline and capture.poll() is None
        time.sleep(0.05)
    os.kill(capture.pid, signal.SIGKILL)
    capture.wait()
    for _ in range(100):
        if (
            not Path(f"/proc/{child}").exists()
            or b"Z" in Path(f"/proc/{child}/stat").read_bytes().split(b" ")[2]
        ):
            break
        time.sleep(0.05)
    stat = Path(f"/proc/{child}/stat")
    assert not stat.exists() or stat.read_bytes().split(b" ")[2] == b"Z"  # gone (or a zombie)
    assert not folder.exists()


def test_sigterm_ends_a_capture_as_ctrl_c_does(tmp_path):
    """SIGTERM (kill, systemd) mid-capture: exit 130 with the interruption message and
    every frame already grabbed on disk — not the default action's silent 143."""
    import os
    import signal

    from conftest import capture_running

    station = station_copy(tmp_path, simulator_args=["--slow", "0.05"])
    station.write_text(station.read_text().replace("frames: 4\n", "frames: 400\n"))
    out = tmp_path / "o"
    proc = capture_running(station, out, out / "amber" / "frame_0002.json", timeout=60)
    os.kill(proc.pid, signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted; any frames saved so far are kept (capture --resume continues)" in err
    tifs = sorted((out / "amber").glob("frame_*.tif"))
    assert len(tifs) >= 2 and len(tifs) == len(list((out / "amber").glob("frame_*.json")))


@pytest.mark.parametrize(
    "damage",
    ["{not json", "", '{"steps": [1, 2]}', '{"steps": {"amber": 3}}', "step file"],
)
def test_resume_on_a_damaged_capture_is_refused_naming_the_file(tmp_path, capsys, damage):
    """A manifest that is not JSON, empty, or without a mapping of step records, or a
    file where a step's folder was: exit 2 naming the file, frames left as they are."""
    station = station_copy(tmp_path, simulator_args=["--vanish-after", "3"])
    out = tmp_path / "cap"
    assert run_cli(["capture", station, "--out", out]) == 3
    saved = sorted(out.glob("*/frame_*.tif"))
    manifest = out / "manifest.json"
    if damage == "step file":
        shutil.rmtree(out / "red", ignore_errors=True)
        (out / "red").write_text("not a folder")
        where = out / "red"
    else:
        doc = json.loads(manifest.read_text())
        text = damage if "amber" not in damage else json.dumps({**doc, "steps": {"amber": 3}})
        manifest.write_text(text)
        where = manifest
    capsys.readouterr()
    assert run_cli(["capture", station, "--out", out, "--resume"]) == 2
    err = capsys.readouterr().err
    assert f"error: {where}: " in err and "Traceback" not in err
    assert all(p.exists() for p in saved if p.parent.name == "amber")


@pytest.mark.parametrize(
    "camera, suggestion",
    [
        (
            "{backend: simulated, exposure_ms: 8}",
            "camera.exposure_ms: Extra inputs are not permitted; did you mean 'exposure_us'?",
        ),
        ("{backend: simulated, gain: 2}", "did you mean 'gain_db'?"),
        ("{backend: simulated, zzzz: 1}", "camera.zzzz: Extra inputs are not permitted\n"),
        # Another backend's key is said to be one, not 'did you mean' itself.
        (
            "{backend: replay, folder: f, width: 640}",
            "camera.width: Extra inputs are not permitted: 'width' is not a key of this section\n",
        ),
    ],
)
def test_a_misspelt_key_gets_the_key_it_meant(tmp_path, capsys, camera, suggestion):
    path = tmp_path / "s.yaml"
    path.write_text(
        f"camera: {camera}\ncontroller: {{backend: simulated, channels: 1}}\n"
        "illuminations: [{name: a, channels: {1: 100}}]\n"
    )
    assert run_cli(["capture", path, "--out", tmp_path / "o"]) == 2
    assert suggestion in capsys.readouterr().err


def test_a_run_refused_before_any_frame_leaves_no_folders(tmp_path, capsys):
    """A camera that is not there (pylon without its emulator): capture, verify, train and
    characterize refuse it, and the folders they had made for their output are gone
    again (they blocked a rerun, and looked like results); a capture that saved frames
    keeps them (tests above)."""
    import yaml

    doc = yaml.safe_load((ROOT / "sample_images" / "station" / "station.yaml").read_text())
    doc["camera"] = {"backend": "pylon", "serial": "NOT-THERE", "exposure_us": 8000}
    doc["scene"] = str(ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml")
    doc["rois"] = str(ROOT / "sample_images" / "station" / "rois.yaml")
    station = tmp_path / "s.yaml"
    station.write_text(yaml.safe_dump(doc))
    out = tmp_path / "out"
    for args in (
        ["capture", station, "--out", out / "c" / "deep"],
        ["verify", station, "--report", out / "r"],
        ["train", station, "--out", out / "g.json"],
        ["characterize", station, "--out", out / "ch", "--report", out / "chr"],
    ):
        code = run_cli(args)
        assert code in (2, 3), capsys.readouterr().err
    assert not out.exists() or sorted(p.name for p in out.rglob("*")) == []


def test_a_second_capture_into_a_folder_being_written_is_refused(tmp_path, capsys):
    """Two captures into one --out (two terminals, one command repeated) wrote over each
    other's frames and manifest; the second is now refused at once, naming the first's
    process, and the folder is free again, without a lock file among the frames, once
    the first has ended."""
    import os
    import subprocess
    import sys

    from inspect_validate.camera.storage import LOCK_FILE, CaptureStore
    from inspect_validate.errors import InputError

    out = tmp_path / "cap"
    first = CaptureStore(out, station_path=tmp_path / "s.yaml", station_sha256="0", resume=False)
    with pytest.raises(InputError, match=rf"another capture \(pid {os.getpid()}\) is writing"):
        CaptureStore(out, station_path=tmp_path / "s.yaml", station_sha256="0", resume=False)
    # Through the CLI, from another process: exit 2, nothing written into the folder.
    station = ROOT / "sample_images" / "station" / "station.yaml"
    run = subprocess.run(
        [sys.executable, "-m", "inspect_validate", "capture", str(station), "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 2 and "another capture" in run.stderr, run.stderr
    assert sorted(p.name for p in out.iterdir()) == [LOCK_FILE]
    first.release()
    assert sorted(out.iterdir()) == []
    assert run_cli(["capture", station, "--out", out]) == 0
    assert LOCK_FILE not in {p.name for p in out.iterdir()}
