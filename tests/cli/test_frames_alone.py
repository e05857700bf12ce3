"""A station of the line's frames alone: a station file with ``rois:`` and ``production:``
and nothing else trains, verifies and watches the frames the line's own program wrote
(scikit-image's photograph as the part, with a class in its darkest corner), names the
cause of a dimmer light and of a blur with one class dark, and the same cause and size
in ``verify`` and ``watch``; what needs a camera, a controller or a scene says so when
asked for."""

import json
import sqlite3
import threading
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from conftest import PART_FRAME, moved_part, part_reference, run_cli

from inspect_validate.errors import InputError
from inspect_validate.station.file import read_station

REGIONS = {
    "face": [{"rect": [380, 120, 60, 80]}],
    "coat": [{"rect": [300, 300, 120, 120]}],
    "sky": [{"rect": [170, 90, 100, 60]}],
    "shadow": [{"rect": [184, 376, 40, 40]}],  # μ about 5 DN: under a tenth of the sky's
}


def frames_station(folder, **production):
    """The station file of the photograph's line: regions, a reference, nothing else."""
    folder.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(folder / "reference.png"), part_reference())
    rois = {"frame": [PART_FRAME[1], PART_FRAME[0]], "classes": REGIONS}
    (folder / "parts.yaml").write_text(yaml.safe_dump(rois))
    doc = {"rois": "parts.yaml", "production": {"reference": "reference.png", **production}}
    (folder / "station.yaml").write_text(yaml.safe_dump(doc))
    return folder / "station.yaml"


def parts(folder, n, *, seed, **fault):
    """``n`` frames of parts at random poses (±40 px, ±5°), as the line's program writes."""
    folder.mkdir(parents=True, exist_ok=True)
    r = np.random.default_rng(seed)
    for i in range(n):
        dx, dy, deg = *r.uniform(-40, 40, 2), r.uniform(-5, 5)
        cv2.imwrite(
            str(folder / f"part_{i:03d}.png"),
            moved_part(dx, dy, deg, seed=seed * 1000 + i, **fault),
        )
    return folder


@pytest.fixture(scope="module")
def line(tmp_path_factory):
    """The station of frames alone (batches of 10), trained on 60 good parts."""
    tmp = tmp_path_factory.mktemp("frames-alone")
    station = frames_station(tmp / "s", parts=10)
    golden = tmp / "golden.json"
    good = parts(tmp / "good", 60, seed=1)
    assert run_cli(["train", station, "--production", "--frames", good, "--out", golden]) == 0
    return station, golden


def test_the_station_file_needs_nothing_but_regions_and_a_reference(line):
    station = read_station(line[0])
    assert station.camera.backend == "none" and station.controller.backend == "none"
    assert [i.name for i in station.illuminations] == ["production"]
    assert station.production.illumination == "production" and station.scene is None
    doc = json.loads(line[1].read_text())
    assert doc["mode"] == "production" and list(doc["illuminations"]) == ["production"]


def test_good_parts_pass(line, tmp_path, capsys):
    station, golden = line
    batch = parts(tmp_path / "batch", 10, seed=2)
    code = run_cli(["verify", station, "--production", "--frames", batch, "--golden", golden])
    assert code == 0, capsys.readouterr().out


@pytest.mark.parametrize(
    ("fault", "cause"),
    [
        # No camera model: a light and a gain are one cause, and the verdict says so.
        ({"gain": 0.97}, r"the light is dimmer by about (2\.9|3\.0|3\.1) %, or the camera's gain "
                         r"lower .*no camera model to tell them apart"),
        ({"blur": 1.0}, r"the focus measure fell by \d+ % at steady μ: the lens lost focus"),
    ],
    ids=["light -3 %", "blur σ 1 px"],
)  # fmt: skip
def test_a_failing_batch_keeps_its_verdict_and_names_its_cause(
    line, tmp_path, capsys, fault, cause
):
    """The verdict a failing batch exists for: exit 1, the report written, the cause
    named, with one class (the shadow) dark; before, a station without a scene lost it
    (exit 2, no report) exactly when the line was bad."""
    import re

    station, golden = line
    batch = parts(tmp_path / "batch", 10, seed=3, **fault)
    capsys.readouterr()
    code = run_cli(["verify", station, "--production", "--frames", batch, "--golden", golden,
                    "--report", tmp_path / "r"])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 1, out
    assert re.search(cause, out.split("likely cause: ")[1].splitlines()[0]), out
    report = json.loads((tmp_path / "r" / "production.json").read_text())
    assert report["verdict"] == "fail" and len(report["parts"]) == 10


def test_verify_and_watch_name_the_same_cause_and_size(line, tmp_path, capsys):
    """The same frames, verified and watched: one diagnosis of the batch's own change
    (watch's EWMA only decides that something drifts; its smoothed step was "0.6 %" of
    a 3 % change)."""
    station, golden = line
    dimmed = parts(tmp_path / "dim", 10, seed=4, gain=0.97)
    capsys.readouterr()
    assert run_cli(["verify", station, "--production", "--frames", dimmed, "--golden", golden]) == 1
    verdict = capsys.readouterr().out.split("likely cause: ")[1].splitlines()[0]
    folder = tmp_path / "feed"
    folder.mkdir()

    def land():
        time.sleep(0.5)
        for f in sorted(dimmed.glob("*.png")):
            (folder / f.name).write_bytes(f.read_bytes())

    writer = threading.Thread(target=land)
    writer.start()
    db = tmp_path / "w" / "h.sqlite"
    try:
        code = run_cli(["watch", station, "--production", "--frames", folder, "--golden", golden,
                        "--db", db, "--cycles", 1, "--interval", 0])  # fmt: skip
    finally:
        writer.join()
    assert code == 1, capsys.readouterr()
    with sqlite3.connect(db) as con:
        [(status, cause, kept)] = con.execute("SELECT status, cause, frames FROM cycles").fetchall()
    assert status == "drift" and cause == verdict
    # The drifting cycle keeps the frames it judged (the line's folder is the program's).
    assert sorted(p.name for p in Path(kept).iterdir()) == sorted(p.name for p in dimmed.iterdir())


def test_what_needs_a_camera_controller_or_scene_says_so(line, tmp_path, capsys):
    station, _ = line
    capsys.readouterr()
    assert run_cli(["capture", station, "--production", "--out", tmp_path / "c"]) == 2
    err = capsys.readouterr().err
    assert "no camera and no light controller" in err and "--production --frames" in err
    assert not (tmp_path / "c").exists() or not any((tmp_path / "c").rglob("*.png"))
    assert run_cli(["verify", station]) == 2
    assert "verify its parts with --production --frames FOLDER" in capsys.readouterr().err
    db = tmp_path / "w" / "h.sqlite"
    args = ["watch", station, "--production", "--golden", line[1], "--db", db, "--cycles", 1]
    assert run_cli(args) == 2
    assert "give --frames FOLDER" in capsys.readouterr().err
    assert not db.exists()  # refused before a history was begun


def test_what_a_station_of_frames_alone_refuses(tmp_path):
    """A setting on a camera nobody here opens is refused, not ignored; several
    illuminations need the production one named; one is taken as it."""
    path = frames_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    path.write_text(yaml.safe_dump({**doc, "camera": {"backend": "none", "exposure_us": 900}}))
    with pytest.raises(InputError, match="exposure_us: backend none opens no camera"):
        read_station(path)
    two = [{"name": "amber", "channels": {}}, {"name": "red", "channels": {}}]
    path.write_text(yaml.safe_dump({**doc, "illuminations": two}))
    with pytest.raises(InputError, match="no illumination 'production'"):
        read_station(path)
    path.write_text(yaml.safe_dump({**doc, "illuminations": two[:1]}))
    assert read_station(path).production.illumination == "amber"


def test_a_part_that_cannot_be_measured_is_a_part_not_measured(tmp_path):
    """A class of one pixel (min_pixels 1) on a part at its home keeps one pixel, which
    has no variance: that part is not measured, named by its frame, and the batch goes
    on (it raised out of the batch, and ended a watch)."""
    from inspect_validate.verification.parts import measure_frames

    path = frames_station(tmp_path, min_pixels=1)
    rois = yaml.safe_load((tmp_path / "parts.yaml").read_text())
    rois["classes"] = {"face": REGIONS["face"], "dot": [{"rect": [300, 300, 1, 1]}]}
    (tmp_path / "parts.yaml").write_text(yaml.safe_dump(rois))
    home, moved = part_reference(), moved_part(3.3, -2.6, 1.5, seed=5)
    parts = measure_frames(read_station(path), [("home.png", home), ("moved.png", moved)])
    assert [p.frame for p in parts.measured] == ["moved.png"]
    assert "2 pixels for its variance" in parts.not_measured["home.png"]
