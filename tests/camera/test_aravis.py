"""Aravis (GigE Vision through PyGObject) against Aravis' own fake camera on the loopback
interface: a real GVCP/GVSP implementation over UDP, started in a process of its own.

Needs Debian's gir1.2-aravis-0.8 and PyGObject (``.ci/run`` installs both where it can);
skipped, saying why, where Aravis cannot be imported.
"""

import json
import os
import re
import signal
import subprocess
import sys
import time
import uuid

import pytest
import yaml
from conftest import run_cli

from inspect_validate.errors import DeviceError

try:
    from inspect_validate.camera.grabbers.aravis import AravisGrabber, import_aravis

    import_aravis()
except DeviceError as exc:  # no Aravis on this machine
    pytest.skip(str(exc), allow_module_level=True)


#: What a GigE Vision stream of Aravis reports of its acquisition (issue 50).
GIGE_HEALTH = (
    "frames_delivered",
    "frames_incomplete",
    "frames_lost",
    "packets_lost",
    "resend_requests",
    "packets_resent",
)


@pytest.fixture
def fake_gige():
    """``start(*options, serial=None) -> (serial, process)``: a GigE Vision fake camera on
    ``lo`` (``options``: its command line's, e.g. ``--packet-loss 0.01``; ``serial``: a
    new one unless given, as for a camera brought back)."""
    procs = []

    def start(*options, serial=None):
        serial = serial or f"IV{uuid.uuid4().hex[:6].upper()}"
        proc = subprocess.Popen(
            [sys.executable, "-m", "inspect_validate.simulation.fake_gige", serial, *options],
            stdout=subprocess.PIPE,
            text=True,
        )
        procs.append(proc)
        assert proc.stdout.readline().strip() == "ready"
        return serial, proc

    yield start
    for proc in procs:
        proc.kill()
        proc.wait()
        proc.stdout.close()


def test_configure_trigger_grab_by_legacy_names(fake_gige):
    serial, _ = fake_gige()
    with AravisGrabber(serial=serial) as cam:
        assert cam.name == f"Aravis Fake (serial {serial})"
        # ExposureTimeAbs stands in for ExposureTime; GainRaw is not dB, so gain is missing.
        assert cam.missing == {"gain"}
        has = cam.features()
        assert has.software_trigger and has.trigger_lines == ("Line0",) and not has.chunks
        for fmt, dtype in (("Mono8", "uint8"), ("Mono16", "uint16")):
            cam.configure(pixel_format=fmt, exposure_us=5000)
            cam.arm("software-trigger")
            with pytest.raises(DeviceError, match=r"no frame within 0\.2 s \(frame 1 of 1\)"):
                cam.grab(1, timeout_s=0.2)  # armed, not triggered
            cam.trigger()
            (frame,) = cam.grab(1, timeout_s=2)
            assert frame.pixel_format == fmt and str(frame.data.dtype) == dtype
            assert frame.data.shape == (512, 512) and frame.exposure_us == 5000
            assert frame.data.flags.writeable
        with pytest.raises(DeviceError, match="pixel format Mono12 not offered"):
            cam.configure(pixel_format="Mono12")
    with AravisGrabber(serial=serial, gain_raw=3) as cam:  # the camera's own gain units
        cam.configure()
        assert cam._dev.get_integer_feature_value("GainRaw") == 3


def test_selection_errors_name_what_was_found(fake_gige):
    serial, _ = fake_gige()
    with pytest.raises(DeviceError, match=rf"no Aravis camera with serial NOPE; found: .*{serial}"):
        AravisGrabber(serial="NOPE")
    with pytest.raises(DeviceError, match="cannot open Aravis camera Nowhere-1"):
        AravisGrabber(device_id="Nowhere-1")


def _station(tmp_path, serial, camera="", controller="", frames=3):
    path = tmp_path / "aravis.yaml"
    path.write_text(
        f"camera: {{backend: aravis, serial: {serial}, pixel_format: Mono16, exposure_us: 4000,"
        f" gain_db: 0, timeout_s: 1{camera}}}\n"
        f"controller: {{backend: simulated, channels: 2{controller}}}\n"
        "illuminations:\n  - {name: one, channels: {1: 100}}\n  - {name: two, channels: {2: 100}}\n"
        f"frames: {frames}\ndark_frames: 2\nbrightness_tolerance: 0.05\n"
    )
    return path


@pytest.mark.parametrize("acquisition", ["software-trigger", "free-run"])
def test_capture_from_the_cli(tmp_path, capsys, fake_gige, acquisition):
    serial, _ = fake_gige()
    out = tmp_path / "cap"
    code = run_cli(
        ["capture", _station(tmp_path, serial, f", acquisition: {acquisition}"), "--out", out]
    )
    err = capsys.readouterr().err
    assert code == 0, err
    assert "warning: the camera has no gain setting" in err  # only GainRaw, not dB
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["camera"]["acquisition"] == acquisition
    assert manifest["camera"]["not_applied"] == ["gain"]
    for step, n in (("one", 3), ("two", 3), ("dark", 2)):
        metas = [json.loads(p.read_text()) for p in sorted((out / step).glob("frame_*.json"))]
        assert len(metas) == n and manifest["steps"][step]["complete"]
        assert all(m["pixel_format"] == "Mono16" and m["exposure_us"] == 4000 for m in metas)
        assert len({m["frame_id"] for m in metas}) == n
        assert all(m["stale_frames_possible"] is False for m in metas)


def test_a_hardware_trigger_nobody_fires_times_out(tmp_path, capsys, fake_gige):
    """Line0 is wired to nothing here: the first frame never comes (exit 3, named)."""
    serial, _ = fake_gige()
    station = _station(
        tmp_path,
        serial,
        ", acquisition: hardware-trigger, trigger_line: Line0",
        ", pulse: {width_us: 4500}",
    )
    assert run_cli(["capture", station, "--out", tmp_path / "cap"]) == 3
    assert f"Aravis Fake (serial {serial}): no frame within 1 s" in capsys.readouterr().err


@pytest.mark.slow
def test_camera_killed_mid_capture_keeps_every_grabbed_frame(tmp_path, fake_gige):
    """The camera's process dies during the first step: exit 3 naming it, every frame
    already saved kept, and the step marked failed, not complete."""
    serial, proc = fake_gige()
    out = tmp_path / "cap"
    capture = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "inspect_validate",
            "capture",
            str(_station(tmp_path, serial, frames=400)),
            "--out",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while not (out / "one" / "frame_0005.json").exists():
        assert capture.poll() is None and time.monotonic() < deadline, capture.communicate()
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    _, err = capture.communicate(timeout=60)
    assert capture.returncode == 3, err
    assert f"Aravis Fake (serial {serial})" in err
    manifest = json.loads((out / "manifest.json").read_text())
    step = manifest["steps"]["one"]
    assert not step["complete"] and "error" in step
    saved = sorted((out / "one").glob("frame_*.tif"))
    assert len(saved) >= 5 and len(saved) == len(list((out / "one").glob("frame_*.json")))


# -- the simulated station streamed by the fake camera (camera.simulate) ------------------


@pytest.mark.parametrize(
    ("acquisition", "pixel_format"), [("software-trigger", "Mono16"), ("free-run", "Mono8")]
)
def test_verify_over_gige_recovers_a_dimmer_light(cli, tmp_path, acquisition, pixel_format):
    """`verify` end to end with every frame through GVCP/GVSP: the fake camera streams the
    scene under the simulated controller's lights, in a world whose amber light gives
    40 % of its stated irradiance; the fitted calibration finds the 40 %."""
    from conftest import copy_station, through_sdk

    path = through_sdk(
        copy_station(tmp_path, world={"irradiance": {1: 0.4}}),
        "aravis",
        acquisition=acquisition,
        pixel_format=pixel_format,
    )
    code, out, err = cli(["verify", path, "--report", tmp_path / "report"])
    assert code == 0, out + err
    result = json.loads((tmp_path / "report" / "verification.json").read_text())
    assert result["verdict"] == "pass"
    meta = json.loads((tmp_path / "report" / "frames" / "amber" / "frame_0001.json").read_text())
    assert meta["device"].startswith("Aravis Fake") and meta["pixel_format"] == pixel_format
    assert meta["acquisition"] == acquisition
    assert f"amber: {acquisition}, 4 frames at 8000 µs" in out
    scale = re.search(r"amber: irradiance scale ([0-9.]+)", out)
    assert abs(float(scale[1]) - 0.4) < 0.01, out


@pytest.mark.slow
@pytest.mark.parametrize("acquisition", ["software-trigger", "free-run"])
def test_watch_over_gige_names_a_brighter_light(cli, tmp_path, golden, acquisition):
    """`watch` on the fake camera: the red LED 5 % brighter from cycle 2 is flagged and
    attributed by the next cycle, the cycles before it pass (the golden file trained
    on the simulated camera: the same scene through another camera stack)."""
    from conftest import copy_station, through_sdk, watch_cycles

    path = through_sdk(
        copy_station(tmp_path, world={"changes": [{"start": 2, "irradiance": {2: 1.05}}]}),
        "aravis",
        acquisition=acquisition,
    )
    # Another camera has other settings than the golden file's: not what is watched here.
    doc = yaml.safe_load(path.read_text())
    doc["acceptance"]["health"] = {"settings": False}
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    db = tmp_path / "w" / "history.sqlite"
    code, out, err, rows = watch_cycles(cli, path, golden, db, 4)
    assert code == 1, out + err
    assert [r[1] for r in rows[:2]] == ["pass", "pass"], rows
    assert rows[-1][1] != "pass" and "illumination red brighter" in rows[-1][2], rows


def test_simulated_fake_camera_refuses_a_hardware_trigger(cli, tmp_path):
    from conftest import copy_station, through_sdk

    controller = {"backend": "simulated", "channels": 2, "pulse": {"width_us": 9000}}
    path = through_sdk(
        copy_station(tmp_path, controller=controller),
        "aravis",
        acquisition="hardware-trigger",
        trigger_line="Line1",
    )
    code, _, err = cli(["capture", path, "--out", tmp_path / "cap"])
    assert code == 2 and "hardware-trigger cannot run on Aravis' fake camera" in err
    assert "its Line1 input" in err and "Line0" not in err  # the line the station named
    assert str(path) in err and not (tmp_path / "cap" / "manifest.json").exists()


@pytest.mark.slow
def test_characterize_over_gige(cli, tmp_path):
    """The EMVA 1288 series through the fake camera (a uniform target at each exposure
    set over GVCP): the camera file's system gain within 5 % of the scene camera's
    0.0255 DN/e⁻ (its 8-bit quantisation biases K by about +2.5 %), 16-bit as streamed."""
    import yaml
    from conftest import copy_station, through_sdk

    path = through_sdk(
        copy_station(tmp_path, characterize={"points": 8, "frames_spatial": 3}), "aravis"
    )
    code, out, err = cli(["characterize", path, "--out", tmp_path / "series"])
    assert code == 0, out + err
    camera = yaml.safe_load((tmp_path / "series" / "camera.yaml").read_text())["camera"]
    assert abs(camera["gain"] / 0.0255 - 1) < 0.05 and camera["bit_depth"] == 16, camera


def test_devices_lists_the_fake_camera_and_what_it_offers(fake_gige, cli):
    serial, _ = fake_gige()
    code, out, err = cli(["devices", "--backend", "aravis", "--features", serial, "--json", "-"])
    assert code == 0, err
    doc = json.loads(out)
    (cam,) = [c for c in doc["cameras"] if c["serial"] == serial]
    assert (cam["vendor"], cam["model"]) == ("Aravis", "Fake")
    assert cam["interface"] == "GigEVision 127.0.0.1"
    assert cam["station"] == {"backend": "aravis", "serial": serial}
    f = doc["features"]
    assert f["monochrome"] == ["Mono8", "Mono16"] and f["bit_depth"] == 16
    assert f["exposure_us"] == [10.0, 10_000_000.0] and f["gain_db"] is None  # GainRaw only
    assert f["trigger_lines"] == ["Line0"] and f["software_trigger"] is True
    assert f["max_size"][0] >= 512
    # a GigE Vision stream counts packets; the fake camera has no temperature node
    assert f["health"] == list(GIGE_HEALTH)
    code, out, err = cli(["devices", "--backend", "aravis", "--features", serial])
    assert "health (acceptance.health)" in out and "packets_lost" in out


def test_a_camera_answering_for_another_is_refused(fake_gige):
    """Two fake cameras on lo share 127.0.0.1: the first answers for both. The camera
    that opened is checked against the serial asked for, not trusted (it captured the
    other camera's 512 × 512 frames before)."""
    first, _ = fake_gige()
    second, _ = fake_gige()
    refused = 0
    for serial in (first, second):
        try:
            with AravisGrabber(serial=serial) as cam:
                assert cam.name == f"Aravis Fake (serial {serial})"
        except DeviceError as exc:
            assert f"asked for the Aravis camera with serial {serial}" in str(exc)
            assert "two cameras share it" in str(exc)
            refused += 1
    assert refused == 1


def test_a_camera_that_does_not_see_the_lights_is_a_verdict(cli, tmp_path, fake_gige):
    """Aravis' fake camera streams its own test pattern whatever the lights do, as a camera
    does behind a lens cap or on a controller wired to other channels: verify fails a check
    per illumination saying no light reaches the camera (exit 1, reports written), and
    train refuses to make a golden file of such captures (exit 2, the step named)."""
    import yaml
    from conftest import copy_station

    serial, _ = fake_gige()
    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["camera"] = {
        "backend": "aravis",
        "serial": serial,
        "pixel_format": "Mono16",
        "exposure_us": 4000,
        "timeout_s": 2,
    }
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    code, out, err = cli(
        ["verify", path, "--frames-out", tmp_path / "c", "--report", tmp_path / "r"]
    )
    assert code == 1, out + err
    assert "Traceback" not in err and "no light within" not in err
    result = json.loads((tmp_path / "r" / "verification.json").read_text())
    assert result["verdict"] == "fail"
    light = {c["name"]: c for c in result["checks"] if c["kind"] == "light"}
    assert set(light) == {"amber: light above dark", "red: light above dark"}
    assert all(c["verdict"] == "fail" for c in light.values())
    assert "no light reaches the camera (lit" in light["amber: light above dark"]["detail"]
    assert result["calibration"]["illuminations"] == {}  # nothing fitted on a dead light
    code, out, err = cli(["train", path, "--frames", tmp_path / "c", "--out", tmp_path / "g.json"])
    assert code == 2 and "step 'amber': no light reaches the camera" in err, err
    assert not (tmp_path / "g.json").exists()


def test_init_simulate_warns_of_a_fake_camera_already_running(cli, tmp_path, fake_gige):
    """init --camera-backend aravis --simulate did not notice another fake camera on the loopback,
    which then answered for the station's own (capture exit 3)."""
    from conftest import ROOT

    serial, _ = fake_gige()
    code, _, err = cli(
        ["init", tmp_path / "s.yaml", "--scene", ROOT / "sample_images/scenes/paperboard/scene.yaml",
         "--camera-backend", "aravis", "--simulate", "--irradiance", "1=5", "--irradiance", "2=5",
         "--no-interactive"]
    )  # fmt: skip
    assert code == 0, err
    assert f"Aravis' fake camera {serial} already runs on this machine" in err, err


def test_a_setting_changed_by_a_second_process_between_captures_is_named(
    tmp_path, capsys, fake_gige
):
    """Issue 50: two captures of the fake camera; between them another process opens it
    and sets AcquisitionFrameRate (which the station does not set), as a vendor's viewer
    left running would. The second capture's settings snapshot differs by that node,
    and the check verify makes against the first names it, old value and new."""
    from types import SimpleNamespace

    from inspect_validate.camera.storage import changed_settings
    from inspect_validate.cli import main
    from inspect_validate.verification.golden_checks import settings_checks

    serial, _ = fake_gige()
    path = _station(tmp_path, serial, frames=2)

    def capture(out):
        with pytest.raises(SystemExit) as done:
            main(["capture", str(path), "--out", str(tmp_path / out)])
        assert done.value.code == 0, capsys.readouterr()
        return json.loads((tmp_path / out / "manifest.json").read_text())["settings"]["values"]

    before = capture("a")
    other = subprocess.run(
        [
            sys.executable,
            "-c",
            "from inspect_validate.camera.grabbers.aravis import AravisGrabber\n"
            f"g = AravisGrabber(serial={serial!r})\n"
            "g._write('AcquisitionFrameRate', 12.5, 'frame rate')\n"
            "g.close()\n",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert other.returncode == 0, other.stderr
    after = capture("b")
    assert changed_settings(before, after) == [
        f"AcquisitionFrameRate {before['AcquisitionFrameRate']} → 12.5"
    ]
    (check,), notes = settings_checks(
        SimpleNamespace(settings=before), {"settings": {"values": after}}
    )
    assert not check.passed and "AcquisitionFrameRate" in check.detail and not notes


# -- acquisition health: packets really lost on the way (issue 50) ------------------------


def test_packets_the_fake_camera_drops_are_counted_by_the_stream(fake_gige):
    """The fake camera drops GVSP packets (its ``gvsp-lost-ratio``); Aravis' stream
    statistics count them, its frames arrive incomplete and are refused as frames; the
    counts survive the stream being made anew (restart_stream)."""
    from inspect_validate.errors import IncompleteFrame

    serial, _ = fake_gige("--packet-loss", "0.01")  # a 512×512 frame: 84 % arrive incomplete
    with AravisGrabber(serial=serial) as cam:
        offered = cam.health()
        assert set(offered) == set(GIGE_HEALTH)
        assert not any(offered.values())
        cam.configure(pixel_format="Mono8")
        good = bad = 0
        while good < 6 and good + bad < 200:
            try:
                cam.grab(1, timeout_s=2)
                good += 1
            except IncompleteFrame:
                bad += 1
            if good == 3:
                cam.restart_stream()
        health = cam.health()
    assert bad >= 1 and health["frames_incomplete"] >= bad
    assert health["frames_delivered"] >= good and health["packets_lost"] >= 1


def test_verify_over_a_lossy_gige_link_fails_naming_the_lost_packets(cli, tmp_path):
    """The issue's end to end: the station streamed by the fake camera over a link that
    loses packets (``world.packet_loss``). The capture discards the incomplete frames and
    goes on; verify reports the packets lost and the resends asked, and fails its limit."""
    from conftest import copy_station, through_sdk

    # 1 % of ~110 packets a frame: 2 frames in 3 arrive incomplete, so that none in a
    # capture is a 1e-5 chance; the steps may discard as many as that takes
    station = copy_station(tmp_path, world={"packet_loss": 0.01}, discard_max=200)
    path = through_sdk(station, "aravis")
    code, out, err = cli(["verify", path, "--report", tmp_path / "report"])
    result = json.loads((tmp_path / "report" / "verification.json").read_text())
    checks = {c["name"]: c for c in result["checks"]}
    lost = checks["camera: packets lost"]
    assert code == 1 and lost["verdict"] == "fail" and lost["value"] >= 1, out + err
    assert "resends asked" in lost["detail"]
    assert checks["camera: frames arriving incomplete"]["verdict"] == "fail"
    assert re.search(
        r"frames: \w+: software-trigger, 4 frames .*discarded: \d+ arrived incomplete", out
    )
    assert "packets lost" in out
    # the frames kept are whole: the station itself verifies
    failing = {n for n, c in checks.items() if c["verdict"] != "pass"}
    assert failing == {"camera: packets lost", "camera: frames arriving incomplete"}


@pytest.mark.slow
def test_one_of_two_cameras_killed_mid_capture_is_named_and_the_rounds_before_kept(
    tmp_path, fake_gige
):
    """Several cameras (issue 51): the simulated camera and Aravis' fake GigE camera on one
    trigger; the fake camera's process dies during the second step. Exit 3 naming the
    camera by its station name; the first step complete in both folders, matched round
    for round; the second marked failed in both, its whole rounds kept; and once the camera
    is back, --resume completes the capture in matched rounds."""
    from conftest import capture_running, copy_station, resume_two_cameras

    serial, proc = fake_gige()
    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    top = {**doc.pop("camera"), "name": "top", "acquisition": "software-trigger"}
    side = {"backend": "aravis", "serial": serial, "name": "side", "pixel_format": "Mono16",
            "exposure_us": 4000, "timeout_s": 1}  # fmt: skip
    doc.update(cameras=[top, side], frames=60, brightness_tolerance=0.05)
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    out = tmp_path / "cap"
    capture = capture_running(path, out, out / "side" / "red" / "frame_0003.json")
    os.kill(proc.pid, signal.SIGKILL)
    _, err = capture.communicate(timeout=120)
    assert capture.returncode == 3, err
    assert "cameras 'side'" in err, err
    manifests = [json.loads((out / n / "manifest.json").read_text()) for n in ("top", "side")]
    amber = [m["steps"]["amber"] for m in manifests]
    assert all(s["complete"] for s in amber) and amber[0]["rounds"] == amber[1]["rounds"]
    red = [m["steps"]["red"] for m in manifests]
    assert all(not s.get("complete") and "cameras 'side'" in s["error"] for s in red)
    kept = [len(list((out / n / "red").glob("frame_*.tif"))) for n in ("top", "side")]
    assert kept[0] == kept[1] >= 3  # whole rounds only, in both
    # The camera is back (its power cycled): --resume takes the failed step again in both
    # folders, its earlier attempt set aside in both, and the rounds match.
    fake_gige(serial=serial)
    resume_two_cameras(path, out, 60)


@pytest.mark.slow
def test_two_fake_gige_cameras_verify_as_one_station(tmp_path):
    """Two of Aravis' fake GigE cameras (issue 51), each on its own loopback address
    (``simulate_interface``), in a network namespace of their own (``unshare --net``, with
    127.0.0.2 added to its ``lo``; this machine's network is left as it is): each frame
    taken by both over GVCP/GVSP, matched round for round, each camera verified and the
    two held to each other; the side camera's exposure 10 % up fails only that check."""
    import shutil

    from conftest import copy_station, through_sdk, two_cameras

    if (
        not (shutil.which("unshare") and shutil.which("ip"))
        or subprocess.run(["unshare", "--net", "true"], capture_output=True).returncode
    ):
        pytest.skip(
            "no network namespace here (unshare --net, and ip to give it 127.0.0.2): two "
            "fake cameras need two addresses"
        )
    path = two_cameras(
        through_sdk(copy_station(tmp_path), "aravis", acquisition="software-trigger"),
        top={"simulate_interface": "127.0.0.1"},
        side={"simulate_interface": "127.0.0.2"},
    )
    changed = tmp_path / "changed.yaml"
    doc = yaml.safe_load(path.read_text())
    doc["cameras"][1]["world"] = {"exposure": 1.1}
    changed.write_text(yaml.safe_dump(doc, sort_keys=False))
    verify = [sys.executable, "-m", "inspect_validate", "verify"]
    script = " && ".join(
        [
            "ip link set lo up",
            "ip addr add 127.0.0.2/32 dev lo",
            " ".join(map(str, [*verify, path, "--report", tmp_path / "good"])),
            "{ "
            + " ".join(map(str, [*verify, changed, "--report", tmp_path / "bad"]))
            + "; echo changed exit $?; }",
        ]
    )
    run = subprocess.run(
        ["unshare", "--net", "sh", "-c", script], capture_output=True, text=True, timeout=900
    )
    assert run.returncode == 0 and "changed exit 1" in run.stdout, run.stdout + run.stderr
    good = json.loads((tmp_path / "good" / "verification.json").read_text())
    assert good["verdict"] == "pass", run.stdout
    frames = tmp_path / "good" / "frames"
    manifests = [json.loads((frames / n / "manifest.json").read_text()) for n in ("top", "side")]
    assert manifests[0]["steps"]["amber"]["rounds"] == manifests[1]["steps"]["amber"]["rounds"]
    devices = {
        json.loads((frames / n / "amber" / "frame_0001.json").read_text())["device"]
        for n in ("top", "side")
    }
    assert len(devices) == 2 and all(d.startswith("Aravis Fake") for d in devices)
    bad = json.loads((tmp_path / "bad" / "verification.json").read_text())
    assert {n: c["verdict"] for n, c in bad["cameras"].items()} == {"top": "pass", "side": "pass"}
    assert [c["verdict"] for c in bad["checks"]] == ["fail", "fail"]


def test_two_fake_cameras_on_one_address_are_refused_before_any_capture(tmp_path, capsys):
    """Two fake cameras listening on one address answer for each other: the station file
    is refused naming both cameras and the key (exit 2)."""
    from conftest import copy_station, through_sdk, two_cameras

    path = two_cameras(through_sdk(copy_station(tmp_path), "aravis"))
    assert run_cli(["capture", path, "--out", tmp_path / "cap"]) == 2
    says = "cameras 'top' and 'side' are the same device (aravis simulate_interface lo)"
    assert says in capsys.readouterr().err
    assert not (tmp_path / "cap").exists()
