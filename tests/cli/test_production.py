"""``train --production`` and ``verify --production`` end to end, on frames no one here drew
(scikit-image's photograph as the part, moved and rotated as on a belt): a batch of good
parts passes, a dimmer light, a defocused lens and a folder without parts fail naming
what moved, and the golden files of bench and line are not mixed up."""

import json
import re
import xml.etree.ElementTree as ET

import cv2
import numpy as np
import pytest
from conftest import moved_part, production_station, run_cli

rng = np.random.default_rng(7)


def parts(folder, n, *, seed=0, reach=40.0, turn=5.0, offset=(0.0, 0.0), **fault):
    """``n`` frames of parts at random poses (shift up to ``reach`` px, rotation up to
    ``turn`` °), all moved by ``offset`` (a camera that moved)."""
    folder.mkdir(parents=True, exist_ok=True)
    r = np.random.default_rng(seed)
    for i in range(n):
        (dx, dy), deg = r.uniform(-reach, reach, 2) + offset, r.uniform(-turn, turn)
        frame = moved_part(dx, dy, deg, seed=seed * 1000 + i, **fault)
        cv2.imwrite(str(folder / f"part_{i:03d}.png"), frame)
    return folder


@pytest.fixture
def trained(tmp_path):
    """A station of the photograph's frames alone, trained on 16 good parts."""
    station = production_station(tmp_path, alone=True)
    golden = tmp_path / "golden.json"
    good = parts(tmp_path / "good", 16, seed=1)
    assert run_cli(["train", station.path, "--production", "--frames", good, "--out", golden]) == 0
    return station.path, golden


def test_good_parts_pass_and_the_golden_file_holds_the_parts(trained, tmp_path, capsys):
    station, golden = trained
    doc = json.loads(golden.read_text())
    assert doc["mode"] == "production" and doc["repeats"] == 16
    assert set(doc["illuminations"]) == {"amber"}
    assert len(doc["illuminations"]["amber"]["classes"]["face"]["focus"]["values"]) == 16
    batch = parts(tmp_path / "batch", 8, seed=2)
    code = run_cli(["verify", station, "--production", "--frames", batch, "--golden", golden,
                    "--report", tmp_path / "r"])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0, out
    assert "8 parts measured of 8 frames, against 16 golden parts" in out and "PASS" in out
    # SNR_dB beside CNR, and what sets them apart, so a wide gap at a low SNR_dB is read
    # as the chapter's measure, not a contradiction.
    line = next(x for x in out.splitlines() if x.startswith("coat vs face: SNR_dB"))
    assert re.fullmatch(
        r"coat vs face: SNR_dB -?\d+\.\d\d, CNR -?\d+\.\d\d dB \(the parts' mean\)", line
    )
    assert "(the manual's model page)" in out
    report = json.loads((tmp_path / "r" / "production.json").read_text())
    assert report["verdict"] == "pass" and len(report["parts"]) == 8
    page = (tmp_path / "r" / "report.html").read_text()
    assert "PASS: all" in page and "where the parts lay" in page and "face μ" in page
    suite = ET.parse(tmp_path / "r" / "junit.xml").getroot()[0]
    assert suite.get("name").startswith("inspect-validate verify --production")
    assert int(suite.get("tests")) == len(report["checks"]) and suite.get("failures") == "0"


@pytest.mark.parametrize(
    ("fault", "failing", "cause"),
    [
        ({"gain": 0.9}, "μ drift", "the light is dimmer by about 10.0 %"),
        ({"blur": 1.5}, "focus drift", "the focus measure fell by"),
    ],
)
def test_a_dimmer_light_or_a_blurred_lens_fails_naming_what_moved(trained, tmp_path, capsys, fault,
                                                                  failing, cause):  # fmt: skip
    station, golden = trained
    batch = parts(tmp_path / "batch", 8, seed=3, **fault)
    capsys.readouterr()
    code = run_cli(["verify", station, "--production", "--frames", batch, "--golden", golden])
    out = capsys.readouterr().out
    assert code == 1 and "FAIL" in out
    failed = [line for line in out.splitlines() if line.startswith("FAIL ") or " FAIL " in line]
    assert any(failing in line for line in failed), out
    assert f"likely cause: {cause}" in out, out


def test_a_moved_camera_fails_the_pose_checks_in_a_fixture(tmp_path, capsys):
    """Parts held in a fixture (within 2 px and 0.5°): a camera knocked by 8 px moves them
    all, their statistics steady; the pose check fails and says so."""
    station = production_station(tmp_path)
    golden = tmp_path / "golden.json"
    good = parts(tmp_path / "good", 16, seed=1, reach=2.0, turn=0.5)
    assert run_cli(["train", station.path, "--production", "--frames", good, "--out", golden]) == 0
    assert "pose" in json.loads(golden.read_text())["illuminations"]["amber"]
    steady = parts(tmp_path / "steady", 8, seed=4, reach=2.0, turn=0.5)
    capsys.readouterr()
    args = ["verify", station.path, "--production", "--golden", golden, "--frames"]
    assert run_cli([*args, steady]) == 0, capsys.readouterr().out
    knocked = parts(tmp_path / "knocked", 8, seed=5, reach=2.0, turn=0.5, offset=(8.0, 0.0))
    assert run_cli([*args, knocked]) == 1
    out = capsys.readouterr().out
    assert "FAIL     pose x drift" in out and "the camera or the fixture moved" in out, out


def test_a_folder_without_parts_fails_its_own_check(trained, tmp_path, capsys):
    station, golden = trained
    empty = tmp_path / "belt"
    empty.mkdir()
    for i in range(5):
        belt = np.clip(30 + rng.normal(0, 2, (640, 800)), 0, 255).astype(np.uint8)
        cv2.imwrite(str(empty / f"f{i}.png"), belt)
    capsys.readouterr()
    code = run_cli(["verify", station, "--production", "--frames", empty, "--golden", golden])
    out = capsys.readouterr().out
    assert code == 1 and "parts found" in out and "no part found (5)" in out
    assert "likely cause: most frames hold no part" in out


def test_bench_and_line_golden_files_are_not_mixed_up(trained, tmp_path, capsys):
    station, golden = trained
    capsys.readouterr()
    # A production golden file where the bench checks drift against one.
    from inspect_validate.acceptance import Drift
    from inspect_validate.errors import InputError
    from inspect_validate.station.file import read_station
    from inspect_validate.verification.golden import read_golden
    from inspect_validate.verification.golden_checks import validate_golden

    with pytest.raises(InputError, match="trained on parts of the running line"):
        validate_golden(read_golden(golden), read_station(station), Drift(golden=str(golden)),
                        classes=["face"], comparisons=[], source=str(golden))  # fmt: skip
    # A bench golden file given to production mode.
    doc = json.loads(golden.read_text())
    doc["mode"] = "bench"
    (tmp_path / "bench.json").write_text(json.dumps(doc))
    capsys.readouterr()
    code = run_cli(["verify", station, "--production", "--frames", tmp_path / "good",
                    "--golden", tmp_path / "bench.json"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and "trained on the bench" in err and "bench.json" in err


def _golden_edited(golden, tmp_path, edit):
    doc = json.loads(golden.read_text())
    edit(doc, next(iter(doc["illuminations"].values())))
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (lambda doc, ill: ill["classes"].pop(next(iter(ill["classes"]))), "lacks class"),
        (lambda doc, ill: ill.pop("pose"), "the parts' pose"),
        (lambda doc, ill: ill["comparisons"].clear(), "lacks comparison"),
        (lambda doc, ill: next(iter(ill["classes"].values())).pop("focus"), "focus"),
    ],
    ids=["class", "pose", "comparisons", "focus"],
)
def test_a_golden_file_lacking_what_the_verdict_checks_is_refused(
    trained, tmp_path, cli, edit, says
):
    """A class, the pose, a comparison or a focus removed: exit 2 naming the golden file
    (it was a KeyError traceback, or a pass with the pose checks gone)."""
    station, golden = trained
    code, _out, err = cli(["verify", station, "--production", "--frames", tmp_path / "good",
                          "--golden", _golden_edited(golden, tmp_path, edit)])  # fmt: skip
    assert code == 2 and says in err and "edited.json" in err and "Traceback" not in err, err


def test_a_golden_file_of_another_station_version_is_said(trained, tmp_path, cli):
    station, golden = trained
    edited = _golden_edited(golden, tmp_path, lambda doc, ill: doc.update(station_sha256="0" * 64))
    code, out, err = cli(["verify", station, "--production", "--frames", tmp_path / "good",
                          "--golden", edited])  # fmt: skip
    assert code == 0 and "note: the golden file was trained with another version" in out, err
    code, out, _err = cli(["verify", station, "--production", "--frames", tmp_path / "good",
                          "--golden", golden])  # fmt: skip
    assert code == 0 and "another version" not in out


def test_production_options_need_their_parts(trained, tmp_path, capsys):
    station, golden = trained
    assert run_cli(["verify", station, "--production", "--golden", golden]) == 2
    assert run_cli(["verify", station, "--golden", golden, "--frames", tmp_path]) == 2
    assert run_cli(["train", station, "--production", "--out", tmp_path / "g.json"]) == 2
    colour = tmp_path / "colour"
    colour.mkdir()
    frame = np.dstack([moved_part(0, 0, 0)] * 3)
    frame[..., 0] //= 2
    cv2.imwrite(str(colour / "c.png"), frame)
    capsys.readouterr()
    code = run_cli(["verify", station, "--production", "--frames", colour, "--golden", golden])
    assert code == 2 and "colour" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("make", "says"),
    [
        (lambda d: (d / "readme.txt").write_text("hello"), "holds no images"),
        (lambda d: (d / "cut.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\x00" * 40), "cannot read"),
        (lambda d: cv2.imwrite(str(d / "small.png"), np.zeros((100, 100), np.uint8)),
         "the frame is 100×100, the reference 800×640"),
        (lambda d: None, "holds no images"),
    ],
)  # fmt: skip
def test_hostile_frame_folders_are_refused_naming_the_file(trained, tmp_path, capsys, make, says):
    """A folder of no images, a half-written PNG, a frame of another size, an empty
    folder: exit 2 naming the file (once), nothing written."""
    station, golden = trained
    folder = tmp_path / "hostile"
    folder.mkdir()
    make(folder)
    capsys.readouterr()
    code = run_cli(["verify", station, "--production", "--frames", folder, "--golden", golden,
                    "--report", tmp_path / "r"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and says in err and "Traceback" not in err, err
    assert err.count("station.yaml") == 0 and not (tmp_path / "r").exists()


def test_a_frame_with_a_blank_block_is_neither_trained_nor_verified(tmp_path, capsys):
    """Issue 62: a frame whose part lies partly in a blank block (40 rows at 255 across the
    face, as a frame cut short with a white fill leaves) is left out by train, which names
    it and why, and by verify, which says so in its parts count; the golden spread is the
    good parts' alone."""
    station = production_station(tmp_path, alone=True)
    good = parts(tmp_path / "good", 8, seed=1)
    frame = cv2.imread(str(good / "part_003.png"), cv2.IMREAD_UNCHANGED)
    clean = tmp_path / "clean.json"
    assert run_cli(["train", station.path, "--production", "--frames", good, "--out", clean]) == 0
    frame[130:170] = 255
    cv2.imwrite(str(good / "part_003.png"), frame)
    capsys.readouterr()
    golden = tmp_path / "golden.json"
    assert run_cli(["train", station.path, "--production", "--frames", good, "--out", golden]) == 0
    out = capsys.readouterr().out
    assert "7 good parts" in out and "1 of 8 frames not measured:" in out
    assert re.search(r"part_003\.png: a blank block: \d+% of class 'face' .*\(255 DN\)", out), out
    face = json.loads(golden.read_text())["illuminations"]["amber"]["classes"]["face"]["mean"]
    clean_face = json.loads(clean.read_text())["illuminations"]["amber"]["classes"]["face"]
    assert face["std"] < 2 * clean_face["mean"]["std"]  # ~0.03 DN; with the blank 10 DN
    code = run_cli(["verify", station.path, "--production", "--frames", good, "--golden", golden])
    out = capsys.readouterr().out
    assert code == 0 and "7 of 8 frames hold a part; a blank block (1)" in out, out


def test_training_on_fewer_than_two_parts_is_refused_saying_why(tmp_path, capsys):
    """One good part and a frame of the empty belt: no spread to train (exit 2), the
    message naming the folder, the count, and why the other frame held no part; with
    two parts it trains. Through the API too (iv.train on a production station)."""
    station = production_station(tmp_path, alone=True)
    folder = parts(tmp_path / "one", 1, seed=3)
    belt = np.clip(30 + np.random.default_rng(3).normal(0, 2, (640, 800)), 0, 255)
    cv2.imwrite(str(folder / "belt.png"), belt.astype(np.uint8))
    capsys.readouterr()
    code = run_cli(["train", station.path, "--production", "--frames", folder,
                    "--out", tmp_path / "g.json"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and not (tmp_path / "g.json").exists(), err
    assert re.search(
        rf"{re.escape(str(folder))}: 1 part measured: golden statistics need the spread of two "
        r"or more good parts \(no part found: match score [-0-9.]+ below production.min_score 0.8\)",
        err,
    ), err
    from inspect_validate.errors import InputError
    from inspect_validate.station.file import read_station
    from inspect_validate.verification.parts_golden import train_production

    with pytest.raises(InputError, match="1 part measured"):
        train_production(read_station(station.path), folder)
    parts(folder, 2, seed=4)  # part_000 replaced, part_001 added: two parts
    golden = train_production(read_station(station.path), folder)
    assert golden.repeats == 2 and golden.mode == "production"
