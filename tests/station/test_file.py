"""The station file's names: an illumination's is a folder of the capture, the station's
is written into reports that XML readers parse."""

import xml.etree.ElementTree as ET

import pytest
import yaml
from conftest import copy_station


@pytest.mark.parametrize(
    ("name", "says"),
    [
        ("..", "illuminations[0].name"),  # its frames were written outside --out
        (".", "illuminations[0].name"),
        (".capture.lock", "illuminations[0].name"),
        ("manifest.json", "not 'dark' or 'manifest.json'"),
        ("dark", "not 'dark' or 'manifest.json'"),
    ],
)
def test_an_illumination_named_as_a_path_is_refused(cli, tmp_path, name, says):
    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["illuminations"][0]["name"] = name
    path.write_text(yaml.safe_dump(doc))
    code, _, err = cli(["capture", path, "--out", tmp_path / "c" / "d"])
    assert code == 2 and says in err, err
    assert not (tmp_path / "c").exists()


def test_a_station_name_with_control_characters_is_refused(cli, tmp_path):
    """verify wrote a junit.xml that was no XML for a name with a bell in it."""
    path = copy_station(tmp_path, name="line 3\x07")
    code, _, err = cli(["verify", path, "--frames-out", tmp_path / "c"])
    assert code == 2 and "name" in err, err


def test_junit_text_is_xml_whatever_it_holds():
    from inspect_validate.report.verification import _xml_chars

    element = ET.Element("testcase", name="Err 7\x1b]0;x\x07")
    text = _xml_chars(ET.tostring(element, encoding="unicode"))
    assert ET.fromstring(text).get("name") == "Err 7\\x1b]0;x\\x07"


def test_a_simulated_frame_too_low_for_its_classes_is_refused_naming_the_height(cli, tmp_path):
    """20 rows for 3 classes: 'negative dimensions are not allowed' (exit 70) before."""
    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["camera"]["height"] = 20
    path.write_text(yaml.safe_dump(doc))
    code, _, err = cli(["capture", path, "--out", tmp_path / "c"])
    assert code == 2 and "station.yaml" in err and "give camera.height 36 or more" in err, err


def test_a_simulated_channel_without_irradiance_says_what_it_renders(cli, tmp_path):
    """It was captured at an irradiance nobody stated, without a word."""
    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["channels"][2] = {"light": "red LED"}  # the scene's red LED states none either
    path.write_text(yaml.safe_dump(doc))
    code, _, err = cli(["capture", path, "--out", tmp_path / "c"])
    assert code == 0, err
    assert "note: channel 2 (red LED) has no irradiance" in err
    assert "at the nominal 1 W/m²" in err


def test_a_field_is_a_path_or_a_file_with_its_correction_and_is_written_absolute(tmp_path):
    """``field: cal/field.json`` is ``{file: cal/field.json, corrected: false}``; a mapping
    without its file, or with another key, is refused naming ``field``; write_station
    writes the field's and the sharpness's paths absolute, as the scene's."""
    from inspect_validate.errors import InputError
    from inspect_validate.station.file import read_station, write_station

    station = copy_station(tmp_path)
    doc = yaml.safe_load(station.read_text())
    mapping = {"file": "cal/field.json", "corrected": True}
    for given, corrected in (("cal/field.json", False), (mapping, True)):
        station.write_text(yaml.safe_dump({**doc, "field": given, "sharpness": "cal/s.json"}))
        read = read_station(station)
        assert read.field is not None and read.field.file == "cal/field.json"
        assert read.field.corrected is corrected
    written = yaml.safe_load(
        write_station(read, tmp_path / "elsewhere" / "s.yaml").file.read_text()
    )
    assert written["field"]["file"] == str((tmp_path / "cal" / "field.json").resolve())
    assert written["sharpness"] == str((tmp_path / "cal" / "s.json").resolve())
    for bad in ({"corrected": True}, {"file": "f.json", "correct": True}):
        station.write_text(yaml.safe_dump({**doc, "field": bad}))
        with pytest.raises(InputError, match="field"):
            read_station(station)


@pytest.mark.parametrize("key", ["path", "sha256"])
def test_what_reading_sets_is_refused_in_the_file(tmp_path, key):
    """``path`` and ``sha256`` are set when a station file is read; a file giving them
    (it was silently overridden) is refused, naming the key."""
    from inspect_validate.errors import InputError
    from inspect_validate.station.file import read_station, station_hash

    station = copy_station(tmp_path)
    read = read_station(station)
    assert read.sha256 == station_hash(station) and read.path == station
    station.write_text(station.read_text() + f"{key}: /etc/passwd\n")
    with pytest.raises(InputError, match=f"'{key}' is not a key of a station file"):
        read_station(station)
