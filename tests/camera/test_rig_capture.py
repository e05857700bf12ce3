"""Several cameras on one trigger (issue 51): the station file's ``cameras:``, a capture
that triggers every camera for each frame and keeps whole rounds only, each camera's
frames in a folder of its own, matched by round. On the simulated station (two
simulated cameras on one simulated controller), and on real parts: two of pylon's
emulated cameras, two of Aravis' fake GigE cameras, one of them killed mid-capture.
"""

import json
import os
import subprocess
import sys

import pytest
import tifffile
import yaml
from conftest import copy_station, run_cli, two_cameras


def _manifest(folder):
    return json.loads((folder / "manifest.json").read_text())


def test_two_simulated_cameras_capture_matched_rounds(tmp_path, capsys):
    path = two_cameras(copy_station(tmp_path), {"exposure": 1.1})
    assert run_cli(["capture", path, "--out", tmp_path / "cap"]) == 0
    out = capsys.readouterr().out
    assert "amber: 4 frames from each camera, matched by trigger" in out
    top, side = (_manifest(tmp_path / "cap" / name) for name in ("top", "side"))
    assert top["rig"]["id"] == side["rig"]["id"] and len(top["rig"]["id"]) == 32
    for name, manifest in (("top", top), ("side", side)):
        assert manifest["rig"] == {
            "id": top["rig"]["id"],
            "camera": name,
            "cameras": ["top", "side"],
            "trigger": "software-trigger",
        }
    for step in ("amber", "red", "dark"):
        a, b = top["steps"][step], side["steps"][step]
        assert a["complete"] and b["complete"] and a["rounds"] == b["rounds"]
        assert len(a["rounds"]) == 4 and a["trigger_skew_us"] == b["trigger_skew_us"]
        for i in range(1, 5):
            metas = [
                json.loads((tmp_path / "cap" / name / step / f"frame_{i:04d}.json").read_text())
                for name in ("top", "side")
            ]
            assert metas[0]["round"] == metas[1]["round"] == a["rounds"][i - 1]
        assert a["health"]["triggers_sent"] == b["health"]["triggers_sent"]
    # the side camera collects 10 % more light: its frames, not the top's, are brighter
    means = [
        tifffile.imread(tmp_path / "cap" / name / "amber" / "frame_0001.tif").mean()
        for name in ("top", "side")
    ]
    assert 1.08 < (means[1] - 4) / (means[0] - 4) < 1.12


def test_a_round_with_one_cameras_frame_refused_is_retaken_for_both(tmp_path):
    """The side camera loses packets: its incomplete frames make their rounds retaken for
    both cameras (the top counts why), so the frames kept still match round for round."""
    path = two_cameras(copy_station(tmp_path), {"packet_loss": 0.002})
    assert run_cli(["capture", path, "--out", tmp_path / "cap"]) == 0
    top, side = (_manifest(tmp_path / "cap" / name) for name in ("top", "side"))
    retaken = [top["steps"][s]["discarded"] for s in ("amber", "red", "dark")]
    assert any("round retaken (side arrived incomplete" in k for d in retaken for k in d), retaken
    for step in ("amber", "red", "dark"):
        assert top["steps"][step]["rounds"] == side["steps"][step]["rounds"]


@pytest.mark.parametrize(
    ("change", "says"),
    [
        ({"camera": {"backend": "simulated"}}, "give camera: (one camera) or cameras:"),
        ({"unnamed": True}, "give it a name"),
        ({"same_name": True}, "'top' names two cameras"),
        ({"acquisition": "free-run"}, "free-run cannot be"),
        ({"mixed": True}, "either every camera is hardware-triggered"),
        ({"same_serial": True}, "are the same device (pylon serial 0815-0000)"),
    ],
)
def test_a_station_of_several_cameras_is_refused_naming_the_camera_and_key(
    tmp_path, capsys, change, says
):
    path = two_cameras(copy_station(tmp_path))
    doc = yaml.safe_load(path.read_text())
    if "camera" in change:
        doc["camera"] = change["camera"]
    if change.get("unnamed"):
        del doc["cameras"][1]["name"]
    if change.get("same_name"):
        doc["cameras"][1]["name"] = "top"
    if "acquisition" in change:
        doc["cameras"][1]["acquisition"] = change["acquisition"]
    if change.get("mixed"):
        doc["cameras"][0].update(acquisition="hardware-trigger", trigger_line="Line1")
        doc["controller"]["pulse"] = {"width_us": 8100}
    if change.get("same_serial"):
        for cam in doc["cameras"]:
            cam.clear()
            cam.update(backend="pylon", serial="0815-0000")
        doc["cameras"][1]["name"] = "side"
        doc["cameras"][0]["name"] = "top"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    assert run_cli(["capture", path, "--out", tmp_path / "cap"]) == 2
    assert says in capsys.readouterr().err
    assert not (tmp_path / "cap").exists()


def test_commands_of_one_camera_refuse_several_saying_what_to_do(tmp_path, capsys):
    """(watch takes several cameras: tests/watch/test_rig_watch.py.)"""
    path = two_cameras(copy_station(tmp_path))
    for args in (
        ["train", path, "--out", tmp_path / "g.json"],
        ["characterize", path, "--out", tmp_path / "c"],
        ["capture", path, "--production", "--out", tmp_path / "p"],
    ):
        assert run_cli(args) == 2, args
        err = capsys.readouterr().err
        assert "takes a station of one camera, and this one has 2 (top, side): give --camera" in err


def test_two_of_pylons_emulated_cameras_capture_matched_rounds(tmp_path):
    """Two cameras of pylon's emulator (PYLON_CAMEMU=2), each chosen by its serial, one in
    Mono8 and one in Mono16, on the simulated controller: every round triggers both, and
    each keeps its frames in its own format."""
    pytest.importorskip("pypylon")
    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    del doc["camera"]
    doc["cameras"] = [
        {"backend": "pylon", "serial": f"0815-000{i}", "name": name, "pixel_format": fmt,
         "exposure_us": 5000, "acquisition": "software-trigger"}
        for i, (name, fmt) in enumerate((("left", "Mono8"), ("right", "Mono16")))
    ]  # fmt: skip
    doc.pop("scene"), doc.pop("channels")
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "inspect_validate",
            "capture",
            str(path),
            "--out",
            str(tmp_path / "cap"),
        ],
        env={**os.environ, "PYLON_CAMEMU": "2"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    left, right = (_manifest(tmp_path / "cap" / n) for n in ("left", "right"))
    assert left["camera"]["name"].endswith("(serial 0815-0000)")
    assert right["camera"]["name"].endswith("(serial 0815-0001)")
    for step in ("amber", "red", "dark"):
        assert left["steps"][step]["rounds"] == right["steps"][step]["rounds"]
        assert left["steps"][step]["frames"] == right["steps"][step]["frames"] == 4
    # cameras of two pixel formats, each frame as its camera delivered it
    sidecars = [
        json.loads((tmp_path / "cap" / n / "amber" / "frame_0001.json").read_text())
        for n in ("left", "right")
    ]
    assert [(s["pixel_format"], s["dtype"]) for s in sidecars] == [
        ("Mono8", "uint8"),
        ("Mono16", "uint16"),
    ]


def test_two_devices_of_one_gentl_producer_share_it(tmp_path, tlsimu_cti):
    """TLSimu's two monochrome devices through harvesters: both cameras open on the one
    producer (a second Harvester of it found none of its devices) and capture matched
    rounds; each camera's warnings name it."""
    cameras = [
        {"backend": "genicam", "cti": str(tlsimu_cti), "serial": serial, "name": name,
         "pixel_format": "Mono8", "acquisition": "software-trigger"}
        for name, serial in (("a", "SN_InterfaceA_0"), ("b", "SN_InterfaceB_0"))
    ]  # fmt: skip
    path = tmp_path / "tl.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "cameras": cameras,
                "controller": {"backend": "simulated", "channels": 1},
                "illuminations": [{"name": "one", "channels": {1: 100}}],
                "frames": 3,
                "dark_frames": 2,
            }
        )
    )
    assert run_cli(["capture", path, "--out", tmp_path / "cap"]) == 0
    a, b = (_manifest(tmp_path / "cap" / name) for name in ("a", "b"))
    assert a["camera"]["name"].endswith("(serial SN_InterfaceA_0)")
    assert b["camera"]["name"].endswith("(serial SN_InterfaceB_0)")
    assert a["steps"]["one"]["rounds"] == b["steps"]["one"]["rounds"] == [1, 2, 3]
    # TLSimu's test pattern does not see the simulated light: said per camera
    assert [w.split(":")[0] for w in a["warnings"]] == ["step 'one'"]


def test_one_controller_pulse_fires_every_camera(tmp_path):
    """Hardware-triggered: one pulse of the simulated controller's trigger output, wired
    to both simulated cameras' Line1, takes every round (no skew by wiring)."""
    hardware = {"acquisition": "hardware-trigger", "trigger_line": "Line1"}
    path = two_cameras(copy_station(tmp_path), top=hardware, side=hardware)
    doc = yaml.safe_load(path.read_text())
    doc["controller"]["pulse"] = {"width_us": 8100}
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    assert run_cli(["capture", path, "--out", tmp_path / "cap"]) == 0
    top, side = (_manifest(tmp_path / "cap" / name) for name in ("top", "side"))
    assert top["rig"]["trigger"] == "hardware-trigger"
    for step in ("amber", "red", "dark"):
        assert top["steps"][step]["rounds"] == side["steps"][step]["rounds"]
        assert set(top["steps"][step]["trigger_skew_us"]) == {0.0}
        # a pulse a round at least (rounds retaken cost more)
        assert top["steps"][step]["health"]["triggers_sent"] >= len(top["steps"][step]["rounds"])


def test_a_stopped_capture_of_two_cameras_resumes_into_matched_rounds(tmp_path):
    """SIGTERM during the second step of a two-camera capture: exit 130, the first step
    complete in both folders; --resume takes the rest, the interrupted attempt's frames
    set aside in both, and every step's rounds the same in both."""
    import signal

    from conftest import capture_running, resume_two_cameras

    path = two_cameras(copy_station(tmp_path, frames=40))
    out = tmp_path / "cap"
    capture = capture_running(path, out, out / "side" / "red" / "frame_0003.json")
    capture.send_signal(signal.SIGTERM)
    _, err = capture.communicate(timeout=60)
    assert capture.returncode == 130, err
    for name in ("top", "side"):
        steps = _manifest(out / name)["steps"]
        assert steps["amber"]["complete"] and not steps["red"].get("complete")
    resume_two_cameras(path, out, 40)
