"""Acquisition health (issue 50, item 1 and 3): what the camera and its transport report
of a capture, read through each backend (never faked: a quantity a backend cannot
report is absent), recorded per step in the manifest, and checked by verify.

Real parts: pypylon's camera emulator with its forced failed buffers, the genicam
wheel's GenTL producers through harvesters, and the simulated station (its lossy link
and deaf trigger are world deviations). Aravis' fake GigE camera dropping real GVSP
packets is in test_aravis.py.
"""

import json
import os

import hypothesis.strategies as st
import pytest
import yaml
from conftest import copy_station, run_cli, run_with_emulator
from hypothesis import HealthCheck, given, settings

from inspect_validate.camera.health import COUNTERS, GAUGES, HEALTH, capture_health, step_health


def test_a_step_counts_what_grew_and_reads_gauges_at_its_end():
    before = {"frames_delivered": 10, "packets_lost": 3, "temperature_c": 40.0}
    after = {"frames_delivered": 14, "packets_lost": 3, "temperature_c": 41.5}
    assert step_health(before, after) == {
        "frames_delivered": 4,
        "packets_lost": 0,
        "temperature_c": 41.5,
    }
    # a counter read lower was reset (a new stream): it counts from 0
    assert step_health({"frames_delivered": 10}, {"frames_delivered": 3}) == {"frames_delivered": 3}
    # not offered at the end: absent, never 0
    assert step_health({"packets_lost": 2}, {}) == {}


def test_a_capture_sums_its_steps_and_skips_what_is_not_a_count():
    steps = [
        {"health": {"frames_delivered": 4, "temperature_c": 40.0, "link_speed_mbps": 1000}},
        {"health": {"frames_delivered": 5, "frames_incomplete": 1, "temperature_c": 44.0}},
        {"health": {"frames_delivered": -3, "packets_lost": float("nan"), "Gamma": 2}},
        {"health": {"frames_delivered": True, "link_speed_mbps": 100}},
        {"health": "garbage"},
        {},
        "not a step",
    ]
    assert capture_health(steps) == {
        "frames_delivered": 9,
        "frames_incomplete": 1,
        "temperature_c": 44.0,
        "link_speed_mbps": 100,
    }


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.lists(
        st.dictionaries(
            st.sampled_from([*HEALTH, "x"]), st.floats() | st.text(max_size=3), max_size=6
        ),
        max_size=6,
    )
)
def test_any_health_records_give_finite_non_negative_totals(records):
    total = capture_health([{"health": r} for r in records])
    assert set(total) <= set(HEALTH)
    for name, value in total.items():
        assert value == value and abs(value) != float("inf")
        assert name not in COUNTERS or value >= 0


def test_every_quantity_is_named_once():
    """A quantity is a counter (summed over a capture) or a gauge (read), never both."""
    assert not set(COUNTERS) & set(GAUGES)


def test_the_pylon_emulator_counts_the_buffers_it_fails(tmp_path):
    """``ForceFailedBufferCount`` makes the emulator deliver real failed buffers: the
    grabber discards each (IncompleteFrame) and its stream grabber's statistics count
    them; the emulator is not GigE, so no packet counts are offered."""
    out = run_with_emulator(
        """
            import json
            from inspect_validate.camera.grabbers.pylon import PylonGrabber
            from inspect_validate.errors import IncompleteFrame
            with PylonGrabber(index=0) as cam:
                cam.configure(pixel_format="Mono8", exposure_us=1000)
                offered = cam.health()
                cam.grab(3)
                cam.nodes.ForceFailedBufferCount.Value = 2
                cam.nodes.ForceFailedBuffer.Execute()
                failed = 0
                for _ in range(8):
                    try:
                        cam.grab(1)
                    except IncompleteFrame:
                        failed += 1
                cam.restart_stream()  # pylon counts again from here; the totals stand
                cam.grab(2)
                print(json.dumps([offered, failed, cam.health()]))
            """,
        tmp_path,
    )
    offered, failed, health = json.loads(out.strip().splitlines()[-1])
    assert set(offered) == {"frames_delivered", "frames_incomplete", "frames_lost"}
    assert failed == 2 and health["frames_incomplete"] == 2
    assert health["frames_delivered"] >= 11  # 13 grabbed, less the 2 failed, plus queued
    assert "packets_lost" not in health and "temperature_c" not in health


@pytest.mark.parametrize("producer", ["viky", "TLSimu"])
def test_genicam_producers_report_their_stream_counts(producer, tlsimu_cti):
    import genicam

    from inspect_validate.camera.grabbers.genicam import GenICamGrabber

    cti = (
        tlsimu_cti
        if producer == "TLSimu"
        else os.path.join(os.path.dirname(genicam.__file__), "viky.cti")
    )
    with GenICamGrabber(str(cti)) as cam:
        cam.configure(pixel_format="Mono8")
        before = cam.health()
        assert {"frames_delivered", "frames_incomplete", "frames_lost"} <= set(before)
        cam.grab(3, timeout_s=5)
        cam.restart_stream()
        cam.grab(2, timeout_s=5)
        after = cam.health()
    assert after["frames_delivered"] >= 5 and after["frames_incomplete"] == 0
    assert "packets_lost" not in after  # GenTL's stream info has no packet counts


def _station(tmp_path, *, world=None, health=None, camera=None):
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    if camera:
        doc["camera"].update(camera)
    if world:
        doc["camera"]["world"] = {**doc["camera"].get("world", {}), **world}
    if health is not None:
        doc["acceptance"]["health"] = health
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _verified(tmp_path, station):
    code = run_cli(["verify", station, "--report", tmp_path / "out"])
    doc = json.loads((tmp_path / "out" / "verification.json").read_text())
    return code, {c["name"]: c for c in doc["checks"]}, doc


def test_a_lossy_link_fails_verify_with_the_frames_kept(tmp_path):
    """Frames arriving incomplete are discarded and the capture goes on; verify then
    fails its health limit, naming how many, and the frames kept are measured."""
    station = _station(tmp_path, world={"packet_loss": 0.002})
    code, checks, _ = _verified(tmp_path, station)
    bad = checks["camera: frames arriving incomplete"]
    assert code == 1 and bad["verdict"] == "fail" and bad["basis"] == "fixed"
    assert "frames arrived incomplete" in bad["detail"]
    manifest = json.loads((tmp_path / "out" / "frames" / "manifest.json").read_text())
    health = capture_health(manifest["steps"].values())
    assert health["frames_incomplete"] >= 1
    assert health["triggers_sent"] == health["frames_delivered"] + health["frames_incomplete"]
    assert all(checks[f"{ill}: light above dark"]["verdict"] == "pass" for ill in ("amber", "red"))


def test_a_deaf_trigger_is_sent_again_and_fails_the_missed_triggers_limit(tmp_path):
    station = _station(tmp_path, world={"missed_trigger_every": 5})
    code, checks, _ = _verified(tmp_path, station)
    missed = checks["camera: missed triggers"]
    assert code == 1 and missed["verdict"] == "fail" and missed["value"] >= 1
    assert "triggers brought no frame" in missed["detail"]
    # the frames are whole: the other checks see a good station
    failed = [name for name, c in checks.items() if not c["verdict"] == "pass"]
    assert failed == ["camera: missed triggers"]


def test_a_limit_asked_for_and_not_offered_fails_a_default_one_is_skipped(tmp_path):
    station = _station(
        tmp_path, world={"temperature_c": 48.5}, health={"packets_lost": 0, "temperature_c": 45}
    )
    code, checks, doc = _verified(tmp_path, station)
    assert code == 1
    lost = checks["camera: packets lost"]  # given in the file; the simulated camera has no packets
    assert lost["verdict"] == "not run" and "could not run" in lost["detail"]
    hot = checks["camera: temperature"]
    assert hot["verdict"] == "fail" and hot["value"] == 48.5 and hot["unit"] == "°C"

    station = _station(tmp_path / "default", health={})
    code, checks, doc = _verified(tmp_path / "default", station)
    assert code == 0 and "camera: packets lost" not in checks
    assert any(
        s.startswith("camera: packets lost: the transport does not count") for s in doc["skipped"]
    )
    assert "camera: temperature" not in checks  # not limited by default, and not reported


def test_health_limits_are_validated(tmp_path):
    for bad in ({"incomplete_frames": 2}, {"packets_lost": -1}, {"temperature_c": "hot"}, {"x": 1}):
        station = _station(tmp_path, health=bad)
        assert run_cli(["verify", station, "--report", tmp_path / "out"]) == 2


def test_a_capture_without_health_records_is_verified_saying_so(tmp_path):
    station = _station(tmp_path)
    assert run_cli(["capture", station, "--out", tmp_path / "frames"]) == 0
    manifest_path = tmp_path / "frames" / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    for step in manifest["steps"].values():  # as a capture made before health was recorded
        step.pop("health")
        step.pop("health_sha256")
    manifest_path.write_text(json.dumps(manifest))
    code = run_cli(
        ["verify", station, "--frames", tmp_path / "frames", "--report", tmp_path / "out"]
    )
    doc = json.loads((tmp_path / "out" / "verification.json").read_text())
    assert code == 0
    assert any("holds no health record" in s for s in doc["skipped"])


# An edited health record, of each kind the hostile kit tried: a string, a mapping, a list,
# null, NaN, inf, 1e308, a negative or a huge count, a boolean; its record removed; a key
# given twice.
EDITS = [
    ("frames_incomplete", "2"),
    ("frames_incomplete", {"n": 1}),
    ("frames_incomplete", [1]),
    ("frames_incomplete", None),
    ("frames_incomplete", float("nan")),
    ("frames_incomplete", float("inf")),
    ("frames_incomplete", 1e308),
    ("frames_incomplete", -1),
    ("triggers_missed", 1.15e18),
    ("triggers_missed", True),
]


@pytest.fixture(scope="module")
def healthy_capture(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("healthy")
    station = _station(tmp)
    assert run_cli(["capture", station, "--out", tmp / "frames"]) == 0
    return station, tmp / "frames"


def _edited(healthy_capture, tmp_path, edit):
    import shutil

    station, frames = healthy_capture
    copy = tmp_path / "frames"
    shutil.copytree(frames, copy)
    manifest_path = copy / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    edit(manifest["steps"]["red"])
    manifest_path.write_text(json.dumps(manifest))
    return station, copy, manifest


@pytest.mark.parametrize(("quantity", "value"), EDITS, ids=[repr(v) for _, v in EDITS])
def test_an_edited_health_record_is_an_edited_capture(
    cli, healthy_capture, tmp_path, quantity, value
):
    """Refused by verify as edited frames are (exit 2, naming the step), never dropped
    into 'the camera does not report them' and a pass; and where the record is read
    without the audit (a production verdict), every health check could not run."""
    from inspect_validate.acceptance import Health
    from inspect_validate.camera.health import health_text
    from inspect_validate.verification.health_checks import health_checks

    station, frames, manifest = _edited(
        healthy_capture, tmp_path, lambda step: step["health"].__setitem__(quantity, value)
    )
    code, _out, err = cli(["verify", station, "--frames", frames])
    assert code == 2 and "red: its health record is not the one the capture wrote" in err, err
    assert "Traceback" not in err
    checks, _ = health_checks(Health(), manifest)
    assert checks and all(not c.passed and "could not run: step 'red'" in c.detail for c in checks)
    label = {"frames_incomplete": "incomplete", "triggers_missed": "missed"}[quantity]
    assert label in health_text(manifest["steps"]["red"]["health"])  # shown, never raises


def test_a_health_record_removed_or_a_key_given_twice_is_refused(cli, healthy_capture, tmp_path):
    station, frames, _ = _edited(healthy_capture, tmp_path, lambda step: step.pop("health"))
    code, _, err = cli(["verify", station, "--frames", frames])
    assert code == 2 and "red: its health record was removed" in err
    manifest_path = frames / "manifest.json"
    text = manifest_path.read_text().replace(
        '"complete": true', '"complete": true, "complete": true', 1
    )
    manifest_path.write_text(text)
    code, _, err = cli(["verify", station, "--frames", frames])
    assert code == 2 and "the key 'complete' is given twice" in err


def test_a_step_without_health_beside_steps_with_it_is_not_checked(healthy_capture, tmp_path):
    from inspect_validate.acceptance import Health
    from inspect_validate.verification.health_checks import health_checks

    def drop(step):
        step.pop("health")
        step.pop("health_sha256")

    _, _, manifest = _edited(healthy_capture, tmp_path, drop)
    checks, _ = health_checks(Health(), manifest)
    assert checks and all("step 'red' holds no health record" in c.detail for c in checks)
    assert not any(c.passed for c in checks)


def test_a_triggered_capture_without_a_trigger_count_is_not_called_free_running():
    from inspect_validate.acceptance import Health
    from inspect_validate.camera.health import health_sha256
    from inspect_validate.verification.health_checks import health_checks

    record = {"frames_delivered": 4}
    step = {"complete": True, "health": record, "health_sha256": health_sha256(record)}
    for mode, says in (
        ("software-trigger", "the capture recorded no trigger count"),
        ("free-run", "the capture was free-running (no triggers)"),
    ):
        manifest = {"steps": {"amber": {**step, "acquisition": mode}}}
        checks, _ = health_checks(Health(missed_triggers=0), manifest)
        (missed,) = [c for c in checks if c.name == "camera: missed triggers"]
        assert not missed.passed and says in missed.detail, missed.detail


def test_a_quantity_added_to_the_table_is_limited_checked_shown_exported_and_documented(
    monkeypatch,
):
    """The quantities' table is the one definition: a fake gauge added to it is a limit in
    ``acceptance.health`` (with its docstring), a check failing beyond it, a part of a
    step's text, a Prometheus gauge and a row of the manual's table."""
    import sys

    from conftest import ROOT

    from inspect_validate.acceptance import _health_model
    from inspect_validate.camera import health
    from inspect_validate.camera.health import BACKENDS, Limit, Quantity, health_sha256
    from inspect_validate.verification.health_checks import health_checks
    from inspect_validate.watch.serve import _health_lines

    fake = Quantity(
        "fan_rpm", "gauge", "the camera fan's speed, rpm", "fan {:g} rpm",
        "inspect_validate_camera_fan_rpm", ("`FanSpeed`",) * len(BACKENDS),
        limit=Limit(
            "fan_rpm", None, "Slowest fan speed, rpm.", "camera: fan", "rpm", "at_least",
            "number", (0, 1e5), "the camera has no fan", lambda t: (t["fan_rpm"], "the slowest"),
        ),
        over_capture="min",
    )  # fmt: skip
    monkeypatch.setattr(health, "QUANTITIES", (*health.QUANTITIES, fake))
    model = _health_model()
    assert model.model_fields["fan_rpm"].description == "Slowest fan speed, rpm."
    record = {"frames_delivered": 4, "fan_rpm": 900.0}
    step = {"complete": True, "health": record, "health_sha256": health_sha256(record)}
    checks, _ = health_checks(model(fan_rpm=1000), {"steps": {"amber": step}})
    (fan,) = [c for c in checks if c.name == "camera: fan"]
    assert not fan.passed and fan.value == 900 and fan.relation == "≥"
    assert "fan 900 rpm" in health.health_text(record)
    assert "inspect_validate_camera_fan_rpm 900.0" in _health_lines(
        {"health": {"fan_rpm": 900.0}, "health_totals": {}}
    )
    monkeypatch.syspath_prepend(str(ROOT / "docs" / "_ext"))
    sys.modules.pop("file_models", None)
    from file_models import health_markdown

    assert "| `fan_rpm` | `FanSpeed` | the same |" in health_markdown()


def test_a_link_below_its_limit_fails_and_every_quantity_has_a_limit_or_a_reason():
    from inspect_validate.acceptance import Health
    from inspect_validate.camera.health import QUANTITIES, health_sha256
    from inspect_validate.verification.health_checks import health_checks

    assert all((q.limit is None) != (q.unlimited == "") for q in QUANTITIES)
    record = {"frames_delivered": 4, "link_speed_mbps": 100.0}
    step = {"complete": True, "health": record, "health_sha256": health_sha256(record)}
    checks, _ = health_checks(Health(link_speed_mbps=1000), {"steps": {"amber": step}})
    (link,) = [c for c in checks if c.name == "camera: link speed"]
    assert not link.passed and link.value == 100 and link.limit == 1000
    checks, _ = health_checks(Health(link_speed_mbps=100), {"steps": {"amber": step}})
    assert [c.passed for c in checks if c.name == "camera: link speed"] == [True]
