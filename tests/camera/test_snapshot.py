"""The camera's settings snapshot (issue 50, item 2): what shapes the image, read from
the camera's own node map at the start of every capture, recorded in the manifest with
its hash, audited, and compared by verify with what the golden file was trained at.

Real node maps: pypylon's camera emulator (in a subprocess: pylon reads PYLON_CAMEMU as
it starts) and the genicam wheel's GenTL producers through harvesters. Aravis' fake
camera, changed by a second process between two captures, is in test_aravis.py.
"""

import json
import os

import pytest
import yaml
from conftest import copy_station, run_cli, run_with_emulator

from inspect_validate.camera.storage import changed_settings, settings_sha256


def test_the_pylon_emulator_reports_what_shapes_its_image(tmp_path):
    out = run_with_emulator(
        """
        import json
        from inspect_validate.camera.grabbers.pylon import PylonGrabber
        with PylonGrabber(index=0) as cam:
            cam.configure(pixel_format="Mono8", exposure_us=5000, gain_db=0)
            before = cam.settings()
            cam.nodes.Gamma.Value = 0.7
            print(json.dumps([before, cam.settings()]))
        """,
        tmp_path,
    )
    before, after = json.loads(out.strip().splitlines()[-1])
    assert before["PixelFormat"] == "Mono8" and float(before["ExposureTime"]) == 5000
    assert {"Gamma", "BlackLevel", "BinningHorizontal", "TriggerMode"} <= set(before)
    assert not {"DeviceTemperature", "Timestamp"} & set(before)  # volatile: never hashed
    assert changed_settings(before, after) == [f"Gamma {before['Gamma']} → {after['Gamma']}"]


@pytest.mark.parametrize("producer", ["viky", "TLSimu"])
def test_genicam_producers_report_their_nodes(producer, tlsimu_cti):
    import genicam

    from inspect_validate.camera.grabbers.genicam import GenICamGrabber

    cti = (
        os.path.join(os.path.dirname(genicam.__file__), "viky.cti")
        if producer == "viky"
        else str(tlsimu_cti)
    )
    with GenICamGrabber(cti) as cam:
        values = cam.settings()
    assert {"PixelFormat", "Width", "Height", "AcquisitionMode"} <= set(values)
    assert all(isinstance(v, str) and v for v in values.values())


def test_a_camera_answering_garbage_is_cut_to_something_comparable():
    from test_grab_path import MemoryCamera

    cam = MemoryCamera([])
    cam.nodes["Gamma"] = "0.7\x00\x1b[2J" + "9" * 10_000
    values = cam.settings()
    assert values["Gamma"].startswith("0.7[2J") and len(values["Gamma"]) == 200
    assert values["PixelFormat"] == "Mono8" and "TriggerSoftware" not in values


def _station(tmp_path, **world):
    path = copy_station(tmp_path, world=world or None)
    doc = yaml.safe_load(path.read_text())
    doc["acceptance"]["drift"] = {"golden": "golden.json", "k": 3}
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_the_manifest_keeps_the_snapshot_and_the_audit_refuses_an_edited_one(cli, tmp_path):
    path = copy_station(tmp_path)
    code, out, err = cli(["capture", path, "--out", tmp_path / "c"])
    assert code == 0, out + err
    manifest = json.loads((tmp_path / "c" / "manifest.json").read_text())
    snapshot = manifest["settings"]
    assert snapshot["values"]["ExposureTime"] == "8000" and snapshot["values"]["Gamma"] == "1"
    assert snapshot["sha256"] == settings_sha256(snapshot["values"])
    snapshot["values"]["Gamma"] = "0.7"
    (tmp_path / "c" / "manifest.json").write_text(json.dumps(manifest))
    code, out, err = cli(["verify", path, "--frames", tmp_path / "c"])
    assert code == 2 and "settings snapshot is not the one recorded" in err, out + err


def test_a_resumed_capture_refuses_settings_changed_meanwhile(tmp_path):
    """A capture resumed after the camera's settings changed would stack frames of two
    settings: refused, naming the node; the same settings resume."""
    from inspect_validate.camera.storage import CaptureStore
    from inspect_validate.errors import InputError

    def store():
        return CaptureStore(
            tmp_path / "c", station_path=tmp_path / "s.yaml", station_sha256="0", resume=True
        )

    values = {"Gamma": "1", "ExposureTime": "8000"}
    first = store()
    first.record("settings", {"values": values, "sha256": settings_sha256(values)})
    first.release()
    same = store()
    same.record("settings", {"values": values, "sha256": settings_sha256(values)})
    same.release()
    changed = {**values, "BlackLevel": "12"}
    later = store()
    with pytest.raises(InputError, match="settings changed since the frames here were taken"):
        later.record("settings", {"values": changed, "sha256": settings_sha256(changed)})
    later.release()


def test_verify_fails_naming_a_node_another_program_changed(cli, tmp_path):
    """Trained with the camera as the station sets it; then another program leaves Gamma
    at 0.7 and BlackLevel at 12 (world.nodes): verify fails one check naming both, old
    value and new, and nothing else; a golden file from before snapshots is read, with a
    note, and passes."""
    path = _station(tmp_path)
    assert run_cli(["train", path, "--repeats", 5, "--out", tmp_path / "golden.json"]) == 0
    golden = json.loads((tmp_path / "golden.json").read_text())
    assert golden["settings"]["Gamma"] == "1"
    doc = yaml.safe_load(path.read_text())
    doc["camera"]["world"] = {"nodes": {"Gamma": "0.7", "BlackLevel": "12"}}
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    code, out, err = cli(
        ["verify", path, "--frames-out", tmp_path / "v", "--report", tmp_path / "r"]
    )
    assert code == 1, out + err
    report = json.loads((tmp_path / "r" / "verification.json").read_text())
    (failed,) = [c for c in report["checks"] if c["verdict"] == "fail"]
    assert failed["kind"] == "settings"
    assert "BlackLevel absent → 12" in failed["detail"] and "Gamma 1 → 0.7" in failed["detail"]
    del golden["settings"]
    (tmp_path / "golden.json").write_text(json.dumps(golden))
    code, out, err = cli(["verify", path, "--frames-out", tmp_path / "w"])
    assert code == 0, out + err
    assert "no settings snapshot to compare: the golden file was trained" in out


def test_training_captures_of_two_settings_are_refused(cli, tmp_path):
    path = _station(tmp_path)
    assert run_cli(["capture", path, "--out", tmp_path / "a"]) == 0
    doc = yaml.safe_load(path.read_text())
    doc["camera"]["world"] = {"nodes": {"Gamma": "0.7"}}
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    assert run_cli(["capture", path, "--out", tmp_path / "b"]) == 0
    code, out, err = cli(
        [
            "train",
            path,
            "--frames",
            tmp_path / "a",
            "--frames",
            tmp_path / "b",
            "--out",
            tmp_path / "g.json",
        ]
    )
    assert code == 2 and "Gamma 1 → 0.7" in err, out + err
    assert not (tmp_path / "g.json").exists()


def test_a_node_changing_while_read_is_left_out_and_named():
    """A feature tree that changes while it is read (issue 50, bad input): a node changed
    once between two reads is recorded at its new value; one that keeps changing has no
    value to record, and is left out and named rather than recorded half-changed."""
    from test_grab_path import MemoryCamera

    class Moving(MemoryCamera):
        reads = 0

        def _text(self, name):
            if name == "Gamma":
                self.reads += 1
                return f"{self.reads / 10:g}"  # another program sweeping it
            if name == "BlackLevel":
                return "12" if self.reads else "0"  # set once, during the first read
            return super()._text(name)

    cam = Moving([])
    cam.nodes.update(Gamma="1", BlackLevel="0")
    values = cam.settings()
    assert "Gamma" not in values and cam.unstable_settings == ("Gamma",)
    assert values["BlackLevel"] == "12" and values["PixelFormat"] == "Mono8"
    steady = MemoryCamera([])
    assert steady.settings() and steady.unstable_settings == ()
