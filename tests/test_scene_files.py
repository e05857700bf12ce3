"""Scene files are validated field by field: every bad value is refused with its file and field.

A corpus of malformed and out-of-range scenes, each run through the CLI: exit
code 2, the file and field named, no traceback. And the fields that used to be
ignored now take effect (a built-in camera's gain).
"""

import json
import re

import numpy as np
import pytest
from conftest import ROOT, write_mix_scene
from conftest import run_cli as run

from inspect_validate.scene import read_scene

LIGHT = "[{led: {peak: 550, fwhm: 30}}]"


def write(tmp_path, text, csv_rows=None):
    g = np.arange(380, 781, 5)
    rows = csv_rows or "\n".join(f"{w},0.3,0.31,0.29" for w in g)
    (tmp_path / "a.csv").write_text(rows + "\n")
    (tmp_path / "b.csv").write_text("\n".join(f"{w},0.6,0.61,0.59" for w in g) + "\n")
    (tmp_path / "tiny.csv").write_text("\n".join(f"{w},1e-300,1.1e-300" for w in g) + "\n")
    (tmp_path / "s.yaml").write_text(text)
    return tmp_path / "s.yaml"


def scene(
    classes="{A: {file: a.csv}, B: {file: b.csv}}",
    lights=LIGHT,
    optics="[ideal]",
    cameras="[cmos-visible]",
    extra="",
):
    return f"classes: {classes}\nlights: {lights}\noptics: {optics}\ncameras: {cameras}\n{extra}"


BAD = [
    (
        scene(lights="[{led: {peak: 550, fwhm: 30}, irradiance: 0}]"),
        r"lights\[0\]\.irradiance: Input should be greater than 0",
    ),
    (
        scene(lights="[{led: {peak: 550, fwhm: 30}, irradiance: .nan}]"),
        r"lights\[0\]\.irradiance: Input should be a finite number",
    ),
    (
        scene(lights="[{led: {peak: 550, fwhm: 30}, gain: 5}]"),
        r"lights\[0\]\.gain: Extra inputs are not permitted",
    ),
    (
        scene(lights="[{led: {peak: 550, fwhm: -3}}]"),
        r"lights\[0\]\.led\.fwhm: Input should be greater than 0",
    ),
    (
        scene(lights="[{led: {peak: 1e300, fwhm: 3}}]"),
        r"lights\[0\]\.led\.peak: Input should be less than or equal to 100000",
    ),
    (
        scene(lights="[{led: {peak: five, fwhm: 3}}]"),
        r"lights\[0\]\.led\.peak: Input should be a valid number",
    ),
    (
        scene(lights="[{led: {peak: 550, fwhm: 30}, blackbody: 3000}]"),
        r"lights\[0\]: a light: give exactly one of",
    ),
    (
        scene(lights="[{daylight: 1000}]"),
        r"lights\[0\]\.daylight: Input should be greater than or equal to 4000",
    ),
    (
        scene(lights="[{led: {peak: 550, fwhm: 30}, irradiance: 1, irradiance_band: [700, 400]}]"),
        r"irradiance_band: .*\[shortest, longest\]",
    ),
    (scene(lights="[{cie: D99}]"), r"lights\[0\]: unknown CIE illuminant 'D99'"),
    (scene(lights="[]"), r"lights: List should have at least 1 item"),
    (scene(lights="{led: {peak: 550, fwhm: 30}}"), r"lights: Input should be a valid list"),
    (
        scene(optics="[{lens: visible, f_number: -2}]"),
        r"optics\[0\]\.f_number: Input should be greater than or equal to 0\.5",
    ),
    (
        scene(optics="[{material: BK7, thickness_mm: -1}]"),
        r"optics\[0\]\.thickness_mm: Input should be greater than 0",
    ),
    (scene(optics="[{material: glass}]"), r"optics\[0\]\.material: Input should be 'BK7'"),
    (scene(optics="[telescope]"), r"optics\[0\]\.lens: Input should be 'visible', 'uv' or 'swir'"),
    (
        scene(cameras="[{builtin: cmos-visible, pixel_pitch: -3.45}]"),
        r"cameras\[0\]\.pixel_pitch: Input should be greater than 0",
    ),
    (
        scene(cameras="[{builtin: cmos-visible, bit_depth: 64}]"),
        r"cameras\[0\]\.bit_depth: Input should be less than or equal to 32",
    ),
    (
        scene(cameras="[{builtin: cmos-visible, gain: 1e400}]"),
        r"cameras\[0\]\.gain: Input should be a finite number",
    ),
    (scene(cameras="[nikon]"), r"cameras\[0\]: unknown camera 'nikon'"),
    (
        scene(cameras="[{file: a.csv, gain: 0.1}]"),
        r"cameras\[0\]: a camera from a QE file needs its EMVA 1288 parameters: dark_noise, saturation",
    ),
    (scene(classes="{}"), r"classes: Dictionary should have at least 2 items"),
    (scene(classes="[a.csv, b.csv]"), r"classes: Input should be a valid dictionary"),
    (scene(classes="{A: {file: a.csv}}"), r"classes: Dictionary should have at least 2 items"),
    (
        scene(classes="{'A,B': {file: a.csv}, C: {file: b.csv}}"),
        r"classes\.A,B: String should match pattern",
    ),
    (
        scene(classes="{A: {file: a.csv}, B: {file: b.csv, gloss: {phong: {}}}}"),
        r"classes\.B\.gloss: gloss: give exactly one",
    ),
    (
        scene(classes="{A: {file: a.csv}, B: {file: missing.csv}}"),
        r"missing\.csv: spectrum file not found",
    ),
    (
        scene(extra="wavelength: {start: 380, stop: 780, step: 1e-12}\n"),
        r"wavelength: 380–780 nm in 1e-12 nm steps is 4e\+14 points",
    ),
    (
        scene(extra="wavelength: {start: 380, stop: 1e300}\n"),
        r"wavelength\.stop: Input should be less than or equal to 100000",
    ),
    (scene(extra="exposure: {mode: fixed}\n"), r"exposure: a fixed exposure needs 'time'"),
    (
        scene(extra="exposure: {mode: sometimes}\n"),
        r"exposure\.mode: Input should be 'auto' or 'fixed'",
    ),
    (
        scene(extra="exposure: {target: 1.5}\n"),
        r"exposure\.target: Input should be less than or equal to 1",
    ),
    (
        scene(extra="exposure: {mode: fixed, time: 1e300}\n"),
        r"exposure\.time: Input should be less than or equal to 100",
    ),
    (
        scene(extra="exposure: {mode: fixed, time: 1e-300}\n"),
        r"exposure\.time: Input should be greater than or equal to",
    ),
    (
        scene(classes="{A: {file: tiny.csv}, B: {file: tiny.csv}}"),
        r"the brightest class needs an exposure of \S+e\+\d+ s to reach the target",
    ),
    (scene(extra="rank: {by: luck}\n"), r"rank\.by: Input should be 'error', 'snr_db' or 'cnr_db'"),
    (scene(extra="rank: {comparison: A vs Z}\n"), r"rank\.comparison: no comparison 'A vs Z'"),
    (
        scene(extra="lights: " + LIGHT + "\n"),
        r"line \d+: not valid YAML: key 'lights' first given on line 2",
    ),
    ("", r"the scene file is empty"),
    ("- 1\n- 2\n", r"the scene file is a list"),
    ("a: " + "[" * 200 + "]" * 200 + "\n", r"nested"),
    ("classes: {A: [1,\n", r"not valid YAML"),
    (
        scene(extra="exposure:\n  mode fixed\n  time: 0.01\n"),
        r"line 6: not valid YAML: 'mode fixed' has no ':' after its key",
    ),
    (
        scene(extra="exposure: {mode: fixed}\nrank 1\nwavelength: {start: 380}\n"),
        r"line 6: not valid YAML: 'rank 1' has no ':' after its key",
    ),
    ("classes: 'A\nlights: []\n", r"line 1: not valid YAML: while scanning a quoted scalar"),
]


@pytest.mark.parametrize(("text", "message"), BAD, ids=[m for _, m in BAD])
def test_bad_scene_exits_2_naming_file_and_field(tmp_path, capsys, text, message):
    path = write(tmp_path, text)
    assert run(["predict", path]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert re.search(message, err), err
    assert str(tmp_path) in err


CSV_BAD = [
    ("0.38,0.3,0.31\n0.78,0.3,0.31", r"a\.csv: wavelengths 0\.38–0\.78 look like µm"),
    (
        "380,30,31\n780,30,31",
        r"a\.csv: line 1: reflectance 30 at 380 nm is above 2; values in percent\? divide by 100",
    ),
    ("380,1e300,0.3\n780,0.3,0.3", r"a\.csv: line 1: reflectance 1e\+300 at 380 nm is above 2"),
    ("380,nan,0.3\n780,0.3,0.3", r"a\.csv: line 1: NaN or infinite value"),
    ("380,-0.5,0.3\n780,0.3,0.3", r"a\.csv: line 1: value -0\.5 at 380 nm is below zero"),
    ("380,0.3,0.3\n380,0.3,0.3", r"a\.csv: line 2: duplicate wavelength"),
    ("380,0.3\n-5,0.3", r"a\.csv: line 2: decreasing wavelength"),
    ("380,0.3,0.3", r"a\.csv: needs at least two wavelengths"),
]


@pytest.mark.parametrize(("rows", "message"), CSV_BAD, ids=[m for _, m in CSV_BAD])
def test_bad_spectrum_file_names_file_and_line(tmp_path, capsys, rows, message):
    path = write(tmp_path, scene(), csv_rows=rows)
    assert run(["predict", path]) == 2
    err = capsys.readouterr().err
    assert re.search(message, err), err


def test_qe_above_one_is_refused(tmp_path, capsys):
    (tmp_path / "qe.csv").write_text("380,50\n780,60\n")
    path = write(
        tmp_path, scene(cameras="[{file: qe.csv, gain: 0.1, dark_noise: 2, saturation: 1e4}]")
    )
    assert run(["predict", path]) == 2
    assert (
        "qe.csv: line 1: qe 50 at 380 nm is above 1.02; values in percent?"
        in capsys.readouterr().err
    )


def test_builtin_camera_overrides_take_effect(tmp_path):
    sc = read_scene(write(tmp_path, scene(cameras="[{builtin: cmos-visible, gain: 5, name: hot}]")))
    assert sc.cameras[0].gain == 5 and sc.cameras[0].name == "hot"
    assert sc.cameras[0].saturation == 10500  # the rest stays built-in
    sc = read_scene(write(tmp_path, scene(cameras="[{builtin: cmos-visible, bit_depth: 8}]")))
    assert sc.cameras[0].bit_depth == 8 and "bit_depth 8" in sc.cameras[0].name


def test_an_empty_option_mapping_for_an_ideal_lens_is_accepted(tmp_path):
    """``{ideal: {}, f_number: 5.6}``: valid YAML a user writes for an option-less lens."""
    sc = read_scene(write(tmp_path, scene(optics="[{ideal: {}, f_number: 5.6}]")))
    assert sc.optics[0].f_number == 5.6
    from inspect_validate.errors import InputError

    with pytest.raises(InputError, match=r"optics\[0\]\.ideal"):
        read_scene(write(tmp_path, scene(optics="[{ideal: {x: 1}}]")))


def test_yaml_1_1_booleans_stay_strings(tmp_path):
    """``off:``/``yes``/``on`` are not booleans (YAML 1.2): a name 'on' stays 'on'."""
    sc = read_scene(write(tmp_path, scene(lights="[{led: {peak: 550, fwhm: 30}, name: on}]")))
    assert sc.lights[0].name == "on"


def test_irradiance_is_bounded_like_in_station_files(tmp_path):
    # 1e300 W/m² overflowed the variances' squares in predict (exit 70, found by the fuzz test).
    from inspect_validate.errors import InputError

    path = write_mix_scene(
        tmp_path / "s.yaml", lambda t: t.replace("irradiance: 2.0}", "irradiance: 1e300}", 1)
    )
    with pytest.raises(InputError, match=r"lights\[0\]\.irradiance: Input should be less than"):
        read_scene(path)


def test_default_grid_leaves_out_what_no_light_lens_and_camera_see(tmp_path, capsys):
    """Undeclared, the grid spans where a light, a lens and a camera can all be non-zero
    (a lens file with zeros outside 400–700 nm bounds it; one step more each side), says
    what it left out, and the prediction is the one on the spectra's whole joined range:
    the integrand is zero there. Tolerance 1e-12 relative (summation order). A 5 nm step
    on a 1 nm-wide band keeps that band's full trapezoid weight."""
    lens = "\n".join(f"{w},{0.9 if 400 < w < 700 else 0.0}" for w in range(300, 1001, 50))
    (tmp_path / "t.csv").write_text(lens + "\n")
    path = write(tmp_path, scene(optics="[{file: t.csv}]"))
    sc = read_scene(path)
    assert (sc.grid[0], sc.grid[-1]) == (399, 701)
    assert len(sc.skipped) == 1 and "narrowed to 399–701 nm" in sc.skipped[0]
    spectra = [c.reflectance for c in sc.classes]
    spectra += [sc.lights[0].spd, sc.optics[0].transmission, sc.cameras[0].qe]
    joined = np.arange(min(s.range[0] for s in spectra), max(s.range[1] for s in spectra) + 1)
    assert joined.size > 2 * sc.grid.size
    narrow, full = sc.predict(), sc.predict(grid=joined)
    np.testing.assert_allclose(narrow.mean, full.mean, rtol=1e-12)
    np.testing.assert_allclose(narrow.variance, full.variance, rtol=1e-12)
    np.testing.assert_allclose(narrow.snr_db, full.snr_db, rtol=0, atol=1e-9)

    assert run(["predict", path, "--json", tmp_path / "p.json"]) in (0, None)
    assert (
        f"not computed: wavelengths {joined[0]:g}–{joined[-1]:g} nm (the spectra's ranges) "
        "narrowed to 399–701 nm" in capsys.readouterr().err
    )
    doc = json.loads((tmp_path / "p.json").read_text())
    assert doc["skipped_work"][0] == sc.skipped[0]
    assert doc["wavelength_nm"]["start"] == 399

    (tmp_path / "t.csv").write_text("300,0\n600,0\n650,1\n651,0\n1000,0\n")
    lens = scene(optics="[{file: t.csv}]", extra="wavelength: {step: 5}")
    coarse = read_scene(write(tmp_path, lens))
    assert coarse.grid[0] < 650 < coarse.grid[-1]
    on_joined = coarse.predict(grid=np.arange(joined[0], joined[-1] + 1, 5.0))
    np.testing.assert_allclose(coarse.predict().mean, on_joined.mean, rtol=1e-12)

    declared = scene(optics="[{file: t.csv}]", extra="wavelength: {start: 380, stop: 780}")
    declared = read_scene(write(tmp_path, declared))
    assert (declared.grid[0], declared.grid[-1], declared.skipped) == (380, 780, ())


@pytest.mark.parametrize(
    ("command", "path", "kind", "expects"),
    [
        ("predict", "station/station.yaml", "station file", "scene file"),
        ("verify", "scenes/paperboard/scene.yaml", "scene file", "station file"),
    ],
)
def test_a_file_of_another_kind_is_named_as_such(capsys, command, path, kind, expects):
    """A station file given to predict (or a scene to verify) is one message saying
    what it is, not a dozen schema errors."""
    from conftest import ROOT

    assert run([command, ROOT / "sample_images" / path]) == 2
    err = capsys.readouterr().err
    assert f"this is a {kind}" in err and f"where the command expects the {expects}" in err
    assert err.count("\n") == 1


def test_a_golden_file_is_named_as_itself_wherever_it_is_given(cli, tmp_path, golden):
    """A golden file given as a camera file, a station, a scene or ROIs is called a golden
    file (it has an 'illuminations' key too: it was once called a station file), and a
    station file given as the golden file a station file."""
    import yaml
    from conftest import copy_station

    station = copy_station(tmp_path)
    doc = yaml.safe_load(station.read_text())
    doc["camera"]["measured"] = str(golden)
    measured = tmp_path / "measured.yaml"
    measured.write_text(yaml.safe_dump(doc))
    said = "this is a golden file (its schema is inspect-validate/golden)"
    for args, expects in (
        (["verify", measured, "--frames-out", tmp_path / "c"], "the camera file"),
        (["verify", golden], "the station file"),
        (["predict", golden], "the scene file"),
        (
            ["measure", ROOT / "sample_images/paperboard/optimized.png", "--rois", golden],
            "the ROI file",
        ),
    ):
        code, _, err = cli(args)
        assert code == 2 and said in err and f"where the command expects {expects}" in err, err
    code, _, err = cli(["watch", station, "--golden", station, "--db", tmp_path / "h.sqlite"])
    assert code == 2 and "this is a station file (it has controller, illuminations)" in err, err
    assert "where a golden file is expected" in err
