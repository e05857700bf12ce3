"""`devices`: the cameras each backend sees and what they offer, the serial ports and
what answers on them — on TLSimu and viky (two GenTL producers), pylon's emulator, the
simulated controller on a pseudo-terminal and on TCP, and a sysfs tree as the kernel
lays it out for a USB camera. Aravis' fake camera: tests/camera/test_aravis.py."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from inspect_validate.camera.grabbers.v4l2 import discover_v4l2
from inspect_validate.camera.registry import Search

VIKY = Path(__import__("genicam").__file__).parent / "viky.cti"


def devices_json(cli, *args):
    code, out, err = cli(["devices", *args, "--json", "-"])
    assert code == 0, err
    return json.loads(out)


def test_two_gentl_producers_each_camera_named_with_its_producer(cli, tlsimu_cti, monkeypatch):
    monkeypatch.setenv(
        "GENICAM_GENTL64_PATH", os.pathsep.join([str(tlsimu_cti.parent), str(VIKY.parent)])
    )
    doc = devices_json(cli, "--backend", "genicam")
    cams = doc["cameras"]
    by_source = {Path(c["source"]).name for c in cams}
    assert {"TLSimu.cti", "viky.cti"} <= by_source
    mono = next(c for c in cams if c["serial"] == "SN_InterfaceA_0")
    assert mono["model"] == "TLSimuMono" and mono["access"] == "free"
    assert mono["station"] == {
        "backend": "genicam",
        "cti": str(tlsimu_cti),
        "serial": "SN_InterfaceA_0",
    }
    assert doc["unavailable"] == {}


def test_features_of_a_gentl_camera_open_it_by_the_keys_listed(cli, tlsimu_cti):
    doc = devices_json(
        cli, "--backend", "genicam", "--cti", tlsimu_cti, "--features", "SN_InterfaceA_0"
    )
    f = doc["features"]
    assert f["camera"] == "EMVA_D TLSimuMono (serial SN_InterfaceA_0)"
    assert {"Mono8", "Mono12Packed", "Mono16"} <= set(f["monochrome"]) and f["bit_depth"] == 16
    assert "RGB8" in f["pixel_formats"] and "RGB8" not in f["monochrome"]
    assert f["max_size"] == [4096, 4096] and f["software_trigger"] is True
    assert f["exposure_us"] is None  # TLSimu has no exposure node: said, not invented
    # GenTL's stream info, and each buffer's own incomplete flag; no packets, no temperature
    assert f["health"] == ["frames_incomplete", "frames_delivered", "frames_lost"]


def test_text_listing_and_a_missing_producer_say_what_to_do(cli, monkeypatch):
    monkeypatch.setenv("GENICAM_GENTL64_PATH", "")
    code, out, err = cli(["devices", "--backend", "genicam", "--backend", "replay"])
    assert code == 0
    assert "cameras: none found" in out
    assert "genicam: cannot look: no GenTL producer" in out and "--cti" in out
    assert "nothing to discover: replay" in out
    code, out, err = cli(["devices", "--backend", "acme"])
    assert code == 2 and "no camera backend 'acme' is installed" in err and "genicam" in err


def test_a_camera_not_found_is_named_with_those_found(cli, tlsimu_cti):
    code, _out, err = cli(
        ["devices", "--cti", tlsimu_cti, "--backend", "genicam", "--features", "NOPE"]
    )
    assert code == 3
    assert "no camera with serial or id 'NOPE' found" in err and "SN_InterfaceA_0" in err


def test_pylon_emulator_cameras_and_features(tmp_path):
    env = {**os.environ, "PYLON_CAMEMU": "2"}
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "inspect_validate",
            "devices",
            "--backend",
            "pylon",
            "--features",
            "0815-0001",
            "--json",
            "-",
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    if "pypylon is not installed" in run.stdout + run.stderr:
        pytest.skip("pypylon is not installed")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert [c["serial"] for c in doc["cameras"]] == ["0815-0000", "0815-0001"]
    assert all(c["access"] == "free" and c["backend"] == "pylon" for c in doc["cameras"])
    assert doc["cameras"][1]["station"] == {"backend": "pylon", "serial": "0815-0001"}
    f = doc["features"]
    assert f["exposure_us"][0] > 0 and f["exposure_us"][1] >= 1e6
    assert f["gain_db"] is not None and f["gain_db"][0] <= 0 < f["gain_db"][1]
    assert f["monochrome"] == ["Mono8", "Mono10", "Mono12", "Mono16"]
    assert "Line1" in f["trigger_lines"] and "FrameStart" in f["trigger_selectors"]
    # the stream grabber's statistics; the emulator is no GigE link (no packets) and has a
    # DeviceTemperatureSelector but no DeviceTemperature (no temperature)
    assert f["health"] == ["frames_delivered", "frames_incomplete", "frames_lost"]


def test_ports_probed_find_the_controllers_on_a_pty_and_on_tcp(cli, simulator, tmp_path):
    pty, _, _ = simulator()
    tcp, _, _ = simulator("--tcp", "--dialect", "line")
    silent, _, _ = simulator("--mute-after", "0")
    protocol = tmp_path / "protocol.yaml"
    protocol.write_text(
        'commands: {set: "SET {channel} {value:.0f}", status: "STATUS?"}\n'
        'terminator: "\\n"\nmax_value: 255\n'
    )
    doc = devices_json(
        cli,
        "--backend",
        "replay",
        "--port",
        pty,
        "--port",
        tcp,
        "--port",
        silent,
        "--protocol",
        protocol,
    )
    answers = {p["device"]: p["answer"] for p in doc["ports"]}
    assert answers[pty].startswith("Gardasoft RT: RT-simulated")
    assert answers[tcp] == "ASCII protocol: OK 1=0 2=0 3=0 4=0"
    assert answers[silent] == ""
    # A controller that answers its probe with an error is there: said, not "no answer".
    erring, _, _ = simulator("--error", "VR:999")
    doc = devices_json(cli, "--backend", "replay", "--port", erring, "--probe")
    answer = {p["device"]: p["answer"] for p in doc["ports"]}[erring]
    assert answer.startswith("answers, with an error: controller answered 'Err 999' to 'VR'"), (
        answer
    )
    code, out, _ = cli(["devices", "--backend", "replay", "--port", pty])
    assert code == 0 and "not probed (--probe)" in out  # nothing is sent unless asked


@pytest.mark.parametrize(
    "text, message",
    [
        ("commands: {set: 'S {channel}'}\n", "neither a 'status' nor an 'init' command"),
        ("commands: {status: 'ST'}\n", "a 'set' template is required"),
        ("commands: [\n", "not valid YAML"),
    ],
)
def test_a_protocol_that_cannot_probe_is_refused(cli, simulator, tmp_path, text, message):
    pty, _, _ = simulator()
    protocol = tmp_path / "protocol.yaml"
    protocol.write_text(text)
    code, _out, err = cli(["devices", "--backend", "replay", "--port", pty, "--protocol", protocol])
    assert code == 2 and message in err


def test_v4l2_devices_read_from_the_kernels_sysfs_layout(tmp_path):
    usb = tmp_path / "devices" / "usb1" / "1-1"
    (usb / "1-1:1.0").mkdir(parents=True)
    for name, value in (
        ("serial", "A1B2C3"),
        ("manufacturer", "The Imaging Source"),
        ("idVendor", "199e"),
    ):
        (usb / name).write_text(value + "\n")
    sysfs = tmp_path / "class" / "video4linux"
    for node, index in (("video0", 0), ("video1", 1), ("video10", 0)):
        (sysfs / node).mkdir(parents=True)
        (sysfs / node / "name").write_text("DMK 33UX264\n")
        (sysfs / node / "index").write_text(f"{index}\n")
        (sysfs / node / "device").symlink_to(usb / "1-1:1.0")
    (sysfs / "v4l-subdev0").mkdir()
    found = discover_v4l2(Search(), sysfs=sysfs)
    assert [d.device_id for d in found] == ["/dev/video0", "/dev/video1", "/dev/video10"]
    first = found[0]
    assert (first.serial, first.vendor, first.model) == (
        "A1B2C3",
        "The Imaging Source",
        "DMK 33UX264",
    )
    assert first.interface == "USB" and first.source == "index 0" and first.backend == "v4l2"
    if not Path("/dev/video0").exists():
        assert first.access == "no device node"


def test_a_backend_whose_library_is_missing_says_what_to_install(tmp_path):
    """PyGObject made unimportable (as on a machine without it): `devices` lists aravis
    as unable to look, with every package it needs."""
    code = (
        "import sys; sys.modules['gi'] = None\n"
        "from inspect_validate.cli import main\n"
        "main(['devices', '--backend', 'aravis'])\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    line = next(x for x in run.stdout.splitlines() if x.startswith("aravis: cannot look"))
    for package in ("gir1.2-aravis-0.8", "libgirepository1.0-dev", "libcairo2-dev", "pkg-config"):
        assert package in line
    assert "inspect-validate[aravis]" in line


def test_a_port_that_cannot_be_a_controller_says_why(cli, tmp_path):
    """A missing path, a folder and a regular file each read 'no answer' before."""
    (tmp_path / "file").write_text("")
    for port, says in (
        (tmp_path / "nope", "no such device"),
        (tmp_path, "a folder, not a serial port"),
        (tmp_path / "file", "not a device (a serial port is a character device)"),
    ):
        code, out, err = cli(["devices", "--port", port, "--probe", "--backend", "replay"])
        assert code in (0, 3) and "Traceback" not in err, err
        line = next(line for line in out.splitlines() if line.startswith(str(port)))
        assert says in line and "no answer" not in line, out
