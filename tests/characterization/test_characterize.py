"""`inspect-validate characterize`: EMVA 1288 on the station's own camera.

Against the simulated camera's known truth (a 12-bit sensor with a gain error, dark
current, DSNU and PRNU), against the ``emva1288`` reference implementation reading the
same frames, through pylon's grab engine, and the run's refusals and resumption.
"""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import ROOT, chromium_probe, copy_station, run_cli, through_sdk

TRUTH = {"gain": 0.1 * 1.12, "dark_noise": 12.0, "full_well": 30000.0}
WORLD = {"gain_error": 0.12, "dark_current": 2000.0, "dsnu": 8.0, "prnu": 0.01, "transmission": 0.9}


def saturation_1288(*, gain, dark_noise, full_well, prnu, dark_electrons=0.0, offset=20.0):
    """The saturation capacity as EMVA 1288 defines it, for the simulated sensor: the
    signal (e⁻) where the pixels' mean temporal variance peaks. Each pixel (gain factor
    1 + PRNU·z, Gauss–Hermite over z) is a normal of variance K²(μ_e + σ_d²) clipped at
    the full well, with the clipped normal's closed-form moments; independent of the
    analysis it checks. ``dark_electrons`` (the dark current's, at that exposure) fill
    the well too, and are not signal."""
    from scipy.stats import norm

    clip = offset + gain * full_well
    offset += gain * dark_electrons
    full_well -= dark_electrons
    z, w = np.polynomial.hermite_e.hermegauss(41)
    w = w / w.sum()
    mu_e = np.linspace(0.8, 1.05, 20001) * full_well
    m = offset + gain * np.outer(mu_e, 1 + prnu * z)
    s = gain * np.sqrt(np.outer(mu_e, 1 + prnu * z) + dark_noise**2)
    a = (clip - m) / s
    phi, cdf = norm.pdf(a), norm.cdf(a)
    mean = m * cdf - s * phi + clip * (1 - cdf)
    second = (m**2 + s**2) * cdf - s * (m + clip) * phi + clip**2 * (1 - cdf)
    variance = (second - mean**2) @ w
    peak = int(np.argmax(variance))
    return float((mean[peak] @ w - offset) / gain)


def twelve_bit_station(tmp_path, *, world=WORLD, **top):
    """The shipped station with a 12-bit camera (K 0.1 DN/e⁻ declared, σ_d 12 e⁻,
    30,000 e⁻, 20 DN black level) whose real sensor is ``world``."""
    base = ROOT / "sample_images" / "scenes" / "paperboard"
    scene = yaml.safe_load((base / "scene.yaml").read_text())
    for spec in scene["classes"].values():
        spec["file"] = str(base / spec["file"])
    scene["cameras"] = [
        {
            "file": str((base / "../chapter_table2/camera1_qe.csv").resolve()),
            "name": "mono 12-bit",
            "gain": 0.1,
            "dark_noise": 12,
            "saturation": 30000,
            "bit_depth": 12,
            "dark_offset": 20,
        }
    ]
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene, sort_keys=False))
    path = copy_station(tmp_path, world=world, **top)
    doc = yaml.safe_load(path.read_text())
    doc["scene"] = str(tmp_path / "scene.yaml")
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def characterized(tmp_path_factory):
    """One characterization of the 12-bit station, shared by the checks below."""
    folder = tmp_path_factory.mktemp("characterize")
    station = twelve_bit_station(folder)
    code = run_cli(
        ["characterize", station, "--out", folder / "cap", "--report", folder / "report"]
    )
    assert code == 0
    return folder


def _resumable(characterized, tmp_path):
    import shutil

    out = tmp_path / "cap"
    shutil.copytree(characterized / "cap", out)
    station = characterized / "station.yaml"
    return station, out


def test_a_resumed_series_audits_its_frames(characterized, tmp_path, capsys):
    """Frames of a finished series altered, then --resume: refused naming the frame
    (it used to rerun the analysis on them, exit 0, and write K 0.146 for 0.026)."""
    station, out = _resumable(characterized, tmp_path)
    before = (out / "camera.yaml").read_bytes()
    frame = sorted((out / "b_003").glob("frame_*.tif"))[0]
    data = bytearray(frame.read_bytes())
    data[-64:] = bytes(64)  # pixels changed, the file still a TIFF
    frame.write_bytes(bytes(data))
    assert run_cli(["characterize", station, "--out", out, "--resume"]) == 2
    err = capsys.readouterr().err
    assert "b_003/frame_0001.tif changed since it was written" in err, err
    assert (out / "camera.yaml").read_bytes() == before  # nothing written from them
    frame.unlink()
    assert run_cli(["characterize", station, "--out", out, "--resume"]) == 2
    assert "b_003: frame_0001.tif recorded but missing" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("bits", 64, r"bits: Input should be less than or equal to 32"),
        ("exposure_us", "12345", r"exposure_us: Input should be a valid tuple"),
        (
            "exposure_us",
            [1e300],
            r"exposure_us\[0\]: Input should be less than or equal to 100000000",
        ),
        ("level", [0.5], r"exposures but 1 levels"),
        ("varies", "luck", r"varies: Input should be 'exposure' or 'level'"),
        ("level", "DEEP", r"nested too deeply"),
    ],
)
def test_an_edited_plan_is_refused_before_it_captures(
    characterized, tmp_path, capsys, key, value, message
):
    """An edited characterize.json: refused naming the file and field (they were a
    TypeError, 'lam value too large', or a camera file its own reader refused)."""
    station, out = _resumable(characterized, tmp_path)
    plan = json.loads((out / "characterize.json").read_text())
    plan[key] = value
    text = json.dumps(plan)
    if value == "DEEP":  # JSON nested 10⁵ deep: a RecursionError traceback before
        text = text.replace('"DEEP"', "[" * 100_000 + "]" * 100_000)
    (out / "characterize.json").write_text(text)
    assert run_cli(["characterize", station, "--out", out, "--resume"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert re.search(
        r"characterize\.json: the characterization plan is not as .*" + message, err
    ), err


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda p: {**p, "bits": 16}, "bits 16, where the frames were recorded at 12 bits"),
        (
            lambda p: {**p, "exposure_us": [2 * t for t in p["exposure_us"]]},
            "step b_000 was exposed",
        ),
        (lambda p: {**p, "exposure_us": p["exposure_us"][::-1]}, "was exposed"),
        (
            lambda p: {**p, "exposure_us": p["exposure_us"][:5], "level": p["level"][:5]},
            "step b_005 was captured, but the plan has no such point",
        ),
        (lambda p: {**p, "varies": "level"}, "varies the level, but its exposures differ"),
        (lambda p: {**p, "illumination": "red"}, "illumination 'red', where the station"),
    ],
    ids=["bits", "doubled", "reversed", "fewer", "varies", "illumination"],
)
def test_a_plan_edited_to_contradict_its_frames_is_refused(
    characterized, tmp_path, capsys, edit, message
):
    """After a kill, --resume took an edited plan that still parsed (exit 0): bits 16 went
    into the camera file; exposures doubled gave a linearity error of 35 % and QE 0.62
    where it is 0.97. The plan is checked against what its frames recorded."""
    station, out = _resumable(characterized, tmp_path)
    before = (out / "camera.yaml").read_bytes()
    plan = json.loads((out / "characterize.json").read_text())
    (out / "characterize.json").write_text(json.dumps(edit(plan)))
    assert run_cli(["characterize", station, "--out", out, "--resume"]) == 2
    err = capsys.readouterr().err
    assert "the characterization plan contradicts the frames captured by it" in err, err
    assert message in err, err
    assert (out / "camera.yaml").read_bytes() == before


def test_a_plan_that_is_a_pipe_is_refused_not_waited_on(characterized, tmp_path, capsys):
    import os

    station, out = _resumable(characterized, tmp_path)
    (out / "characterize.json").unlink()
    os.mkfifo(out / "characterize.json")
    assert run_cli(["characterize", station, "--out", out, "--resume"]) == 2
    err = capsys.readouterr().err
    assert "characterize.json: the characterization plan is not as" in err
    assert "not a regular file" in err


@pytest.mark.slow
def test_the_simulated_sensor_is_measured_within_emva_tolerances(characterized):
    sheet = json.loads((characterized / "report" / "characterization.json").read_text())
    values = {k: v["value"] for k, v in sheet["datasheet"].items() if isinstance(v, dict)}
    assert values["system_gain"] == pytest.approx(TRUTH["gain"], rel=0.01)
    assert values["dark_noise"] == pytest.approx(TRUTH["dark_noise"], rel=0.05)
    # EMVA 1288's saturation is where the variance peaks: below the full well by the
    # clipping of noise and PRNU (3.4 % here), which the reference computes.
    series = sheet["series"]
    peak = int(np.argmax(series["variance"]))
    truth = saturation_1288(
        gain=TRUTH["gain"],
        dark_noise=TRUTH["dark_noise"],
        full_well=TRUTH["full_well"],
        prnu=WORLD["prnu"],
        dark_electrons=WORLD["dark_current"] * series["abscissa"][peak] * 1e-6,
    )
    assert truth == pytest.approx(0.966 * TRUTH["full_well"], rel=0.005)
    assert values["saturation_capacity"] == pytest.approx(truth, rel=0.02)
    assert values["dsnu"] == pytest.approx(WORLD["dsnu"], rel=0.10)
    assert values["prnu"] == pytest.approx(WORLD["prnu"], rel=0.10)
    assert values["dark_current"] == pytest.approx(WORLD["dark_current"], rel=0.10)
    assert values["linearity_error"] < 0.01
    # A lens transmitting 90 % of what the scene says: the series sees 0.9 × the QE the
    # stated irradiance, optics and camera predict (QE and lens are one product to it).
    assert values["quantum_efficiency_scale"] == pytest.approx(0.9, rel=0.02)
    for name in ("photon_transfer", "snr", "linearity", "dark_signal", "nonuniformity"):
        assert (characterized / "report" / f"{name}.png").stat().st_size > 10_000
    # One page with the datasheet and the series as charts, the maps embedded: offline.
    page = (characterized / "report" / "characterization.html").read_text()
    assert "<h2>Datasheet</h2>" in page and "system gain K" in page and "DN/e⁻" in page
    assert page.count('<div class="chart" role') == 4 and "data:image/png;base64," in page
    assert "uPlot 1.6.32" in page and 'src="http' not in page
    camera = yaml.safe_load((characterized / "cap" / "camera.yaml").read_text())
    assert camera["camera"]["gain"] == pytest.approx(values["system_gain"], rel=1e-5)
    assert camera["measured"]["standard_errors"]["gain"] > 0
    # The QE factor the terminal prints is the camera file's, with its standard error,
    # and the model uses it (it said "not measured" before, cut off mid-sentence).
    assert camera["camera"]["qe_scale"] == pytest.approx(
        values["quantum_efficiency_scale"], rel=1e-5
    )
    assert 0 < camera["measured"]["standard_errors"]["qe_scale"] < 0.02
    assert "× qe_scale" in camera["measured"]["qe"]
    from inspect_validate.components.camera_file import measured_sensor
    from inspect_validate.scene import read_scene

    scene = read_scene(ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml")
    declared = scene.cameras[0]
    measured = measured_sensor(declared, characterized / "cap" / "camera.yaml")
    ratio = measured.qe.values / declared.qe.values
    np.testing.assert_allclose(ratio[np.isfinite(ratio)], camera["camera"]["qe_scale"], rtol=1e-12)


def test_the_emva1288_reference_reads_the_same_run_alike(characterized, emva1288_python):
    """The run's descriptor file through the emva1288 package (its own environment):
    K and σ_d within 1 % of ours, saturation, DSNU and PRNU within 2 %."""
    script = """
import json, sys
from emva1288.process import Data1288, LoadImageData, ParseEmvaDescriptorFile, Results1288
parsed = ParseEmvaDescriptorFile(sys.argv[1])
r = Results1288(Data1288(LoadImageData(parsed.images).data).data)
print(json.dumps({"K": r.K, "sigma_d": r.sigma_d, "u_e_sat": r.u_e_sat,
                  "DSNU": r.DSNU1288, "PRNU": r.PRNU1288}))
"""
    descriptor = characterized / "cap" / "emva1288_descriptor.txt"
    done = subprocess.run(
        [str(emva1288_python), "-c", script, str(descriptor)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    theirs = json.loads(done.stdout.strip().splitlines()[-1])
    sheet = json.loads((characterized / "report" / "characterization.json").read_text())
    ours = {k: v["value"] for k, v in sheet["datasheet"].items() if isinstance(v, dict)}
    assert ours["system_gain"] == pytest.approx(theirs["K"], rel=0.01)
    assert ours["dark_noise"] == pytest.approx(theirs["sigma_d"], rel=0.01)
    assert ours["saturation_capacity"] == pytest.approx(theirs["u_e_sat"], rel=0.02)
    assert ours["dsnu"] == pytest.approx(theirs["DSNU"], rel=0.02)
    assert 100 * ours["prnu"] == pytest.approx(theirs["PRNU"], rel=0.02)  # theirs in %


@pytest.mark.slow
def test_characterize_then_verify_with_the_measured_camera(tmp_path, capsys):
    """The shipped station whose sensor's K is 12 % above the declared one fails a 5 %
    K check; characterised, and verified with the measured camera file, it passes, and
    the calibration no longer mistakes the gain for the lights (scales near 1)."""
    world = {"gain_error": 0.12}
    station = copy_station(tmp_path, world=world, acceptance={"gain_relative": 0.05})
    report = tmp_path / "before"
    assert run_cli(["verify", station, "--report", report]) == 1
    before = json.loads((report / "verification.json").read_text())
    assert before["calibration"]["illuminations"]["amber"]["scale"] == pytest.approx(1.12, abs=0.03)

    assert run_cli(["characterize", station, "--out", tmp_path / "series"]) == 0
    out = capsys.readouterr().out
    assert f"camera file: {tmp_path / 'series' / 'camera.yaml'}" in out
    doc = yaml.safe_load(station.read_text())
    doc["camera"]["measured"] = str(tmp_path / "series" / "camera.yaml")
    station.write_text(yaml.safe_dump(doc, sort_keys=False))
    report = tmp_path / "after"
    code = run_cli(["verify", station, "--report", report])
    after = json.loads((report / "verification.json").read_text())
    assert code == 0, [c for c in after["checks"] if c["verdict"] != "pass"]
    gain = after["calibration"]["gain"]
    measured = yaml.safe_load((tmp_path / "series" / "camera.yaml").read_text())["camera"]
    assert gain["declared"] == pytest.approx(measured["gain"], rel=1e-9)
    assert after["calibration"]["illuminations"]["amber"]["scale"] == pytest.approx(1.0, abs=0.03)


def test_a_series_interrupted_by_the_controller_resumes_with_the_same_plan(tmp_path, capsys):
    """The controller vanishes mid-series: exit 3, every frame kept; --resume finishes
    with the plan it wrote, and gives the run's camera file."""
    station = copy_station(
        tmp_path,
        characterize={"points": 8, "frames_spatial": 4},
    )
    doc = yaml.safe_load(station.read_text())
    doc["controller"]["simulator_args"] = ["--vanish-after", "30"]
    station.write_text(yaml.safe_dump(doc, sort_keys=False))
    out = tmp_path / "series"
    assert run_cli(["characterize", station, "--out", out]) == 3
    assert "the device may have been unplugged" in capsys.readouterr().err
    plan = json.loads((out / "characterize.json").read_text())
    saved = sorted(out.glob("*/frame_*.tif"))
    assert saved
    for _ in range(12):  # each resumed run's simulator vanishes after 30 commands again
        code = run_cli(["characterize", station, "--out", out, "--resume"])
        if code == 0:
            break
        assert code == 3
    assert code == 0
    final = json.loads((out / "characterize.json").read_text())
    n = len(plan["exposure_us"])  # the even series; refining adds points near saturation
    assert final["exposure_us"][:n] == plan["exposure_us"] and final["refined"]
    assert all(p.exists() for p in saved)  # nothing captured before was lost
    assert (out / "camera.yaml").is_file()
    assert run_cli(["characterize", station, "--out", out]) == 2  # exists: needs --resume


def test_a_camera_that_does_not_see_the_light_is_refused(tmp_path, capsys):
    """viky renders its own picture whatever the lights: lit and dark agree, and there is
    nothing to characterise with. A GenTL producer run end to end up to that refusal."""
    genicam = pytest.importorskip("genicam")
    cti = next(iter(Path(genicam.__file__).parent.glob("*.cti")), None)
    if cti is None:
        pytest.skip("this genicam wheel ships no simulated producer")
    station = tmp_path / "viky.yaml"
    station.write_text(
        f"camera: {{backend: genicam, cti: '{cti}', serial: '0', pixel_format: Mono8}}\n"
        "controller: {backend: simulated, channels: 2}\n"
        "illuminations:\n  - {name: one, channels: {1: 100}}\nbrightness_tolerance: 0.05\n"
    )
    assert run_cli(["characterize", station, "--out", tmp_path / "series"]) == 2
    err = capsys.readouterr().err
    assert "the illumination 'one' gives" in err and "nothing to characterise with" in err


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            {"characterize": {"illumination": "blue"}},
            "characterize.illumination: no illumination 'blue'",
        ),
        ({"characterize": {"points": 3}}, "characterize.points"),
        (
            {"characterize": {"region": [0, 0, 5000, 10]}},
            "characterize.region [0, 0, 5000, 10] lies outside",
        ),
    ],
)
def test_bad_characterize_sections_are_refused(tmp_path, capsys, change, message):
    station = copy_station(tmp_path, **change)
    assert run_cli(["characterize", station, "--out", tmp_path / "series"]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_characterize_through_pylons_grab_engine(tmp_path):
    """The simulated station on pypylon's camera emulator: the series runs end to end
    through pylon (software-triggered), the bit depth its Mono16 format's."""
    pytest.importorskip("pypylon")
    import os

    station = through_sdk(copy_station(tmp_path, characterize={"points": 8, "frames_spatial": 3}))
    out = tmp_path / "series"
    done = subprocess.run(
        [sys.executable, "-m", "inspect_validate", "characterize", str(station), "--out", str(out)],
        env={**os.environ, "PYLON_CAMEMU": "1"},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "16-bit" in done.stdout and "system gain K" in done.stdout
    meta = json.loads(next((out / "b_000").glob("frame_*.json")).read_text())
    assert (
        meta["device"].startswith("Basler Emulation") and meta["acquisition"] == "software-trigger"
    )
    camera = yaml.safe_load((out / "camera.yaml").read_text())["camera"]
    assert camera["gain"] == pytest.approx(0.0255, rel=0.05)  # 8-bit data: quantised darks


def test_a_scene_camera_takes_its_values_from_a_camera_file(tmp_path):
    """A scene's camera may name a measured camera file too: its values (K brought back to
    0 dB) replace the stated ones; a hostile file is refused naming the file and field."""
    from inspect_validate.errors import InputError
    from inspect_validate.scene import read_scene

    base = ROOT / "sample_images" / "scenes" / "paperboard"
    scene = yaml.safe_load((base / "scene.yaml").read_text())
    for spec in scene["classes"].values():
        spec["file"] = str(base / spec["file"])
    scene["cameras"][0]["file"] = str((base / scene["cameras"][0]["file"]).resolve())
    scene["cameras"][0]["measured"] = "camera.yaml"
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene, sort_keys=False))
    camera_file = tmp_path / "camera.yaml"
    camera_file.write_text(
        "camera: {gain: 0.0572, dark_noise: 13.5, saturation: 9100}\nmeasured: {gain_db: 6.0}\n"
    )
    (camera,) = read_scene(tmp_path / "scene.yaml").cameras
    assert camera.gain == pytest.approx(0.0572 / 10 ** (6 / 20), rel=1e-12)
    assert (camera.dark_noise, camera.saturation, camera.bit_depth) == (13.5, 9100, 8)
    stated = camera.qe.values
    camera_file.write_text(
        "camera: {gain: 0.0572, dark_noise: 13.5, saturation: 9100, qe_scale: 0.5}\n"
    )
    (camera,) = read_scene(tmp_path / "scene.yaml").cameras  # qe_scale was a TypeError here
    np.testing.assert_allclose(camera.qe.values, 0.5 * stated, rtol=1e-12)
    camera_file.write_text("camera: {gain: -1}\n")
    with pytest.raises(InputError, match=r"camera.yaml: camera.gain: Input should be greater"):
        read_scene(tmp_path / "scene.yaml")
    # Values possible alone but not together, or with the scene's camera: refused naming
    # the file and what to check (they were read, and verify failed on "predicted 255 DN").
    for text, message in (
        ("camera: {dark_offset: 1.0e6, bit_depth: 8}", r"dark_offset 1e\+06 DN fills the 8-bit"),
        ("camera: {dark_offset: 300}", r"dark_offset 300 DN fills the 8-bit range"),
        (
            "camera: {bit_depth: 1}",
            r"camera\.bit_depth: Input should be greater than or equal to 8",
        ),
        (
            "camera: {gain: 1.0e-300}",
            r"gain × saturation is 1e-296 DN, so the full well spans less than one grey",
        ),
    ):
        camera_file.write_text(text + "\n")
        with pytest.raises(InputError, match=r"camera\.yaml: .*" + message) as caught:
            read_scene(tmp_path / "scene.yaml")
        assert "Traceback" not in str(caught.value)


EMVA_SIMULATOR = """
import sys, numpy as np
from emva1288.camera import Camera
out, u_esat = sys.argv[1], float(sys.argv[2])
cam = Camera(bit_depth=12, K=0.1, width=160, height=120, blackoffset=40, u_esat=u_esat, seed=7)
sat = cam.get_radiance_for()
for i, f in enumerate([0.1, 0.25, 0.4, 0.55, 0.7, 0.85, 1.3, 2.0]):
    np.save(f"{out}/lit_{i}.npy", np.stack([cam.grab(sat * f) for _ in range(4)]).astype(np.uint16))
np.save(f"{out}/dark.npy", np.stack([cam.grab(0) for _ in range(4)]).astype(np.uint16))
print(cam.K, cam.img_max)
"""


@pytest.mark.parametrize("u_esat", [20_000, 60_000])
def test_photon_transfer_on_the_emva1288_simulators_frames(tmp_path, emva1288_python, u_esat):
    """Frames of the emva1288 package's own camera simulator (12-bit in uint16, K known,
    black level 40 DN), from dark to twice saturation: a full well that clips at 2040 DN,
    or the bit depth at 4095. K within 1 % of the simulator's: the clipped points, whose
    variance collapses, are left out (fitting every point is far off); and a frame
    clipped at 4095 counts as saturated at the 12-bit level, not at uint16's 65535."""
    from types import SimpleNamespace

    from inspect_validate.measurement import measure_classes
    from inspect_validate.verification.calibration import photon_transfer

    done = subprocess.run(
        [str(emva1288_python), "-c", EMVA_SIMULATOR, str(tmp_path), str(u_esat)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    k_true, top = (float(x) for x in done.stdout.split()[-2:])
    mask = {"A": np.ones((120, 160), bool)}

    def measured(name, level):
        return SimpleNamespace(
            classes=measure_classes(np.load(tmp_path / name), mask, saturation_level=level)
        )

    dark = measured("dark.npy", top)
    lit = [measured(f"lit_{i}.npy", top) for i in range(8)]
    gain, left_out = photon_transfer(lit, dark, declared=k_true, saturation_level=top)
    assert gain.value == pytest.approx(k_true, rel=0.01)
    assert sum(left_out.values()) >= 3  # the points at and past saturation
    x = np.array([m.classes[0].mean - dark.classes[0].mean for m in lit])
    y = np.array([m.classes[0].temporal_variance - dark.classes[0].temporal_variance for m in lit])
    assert abs(x @ y / (x @ x) / k_true - 1) > 0.1  # every point: the bias this avoids
    clipped = measured("lit_7.npy", top).classes[0].saturated_fraction
    as_uint16 = measured("lit_7.npy", None).classes[0].saturated_fraction
    if u_esat == 60_000:  # the bit depth clips: every pixel at 4095
        assert clipped == 1.0 and as_uint16 == 0.0


def test_the_characterization_page_draws_in_headless_chromium(characterized, tmp_path):
    seen = chromium_probe(characterized / "report" / "characterization.html", tmp_path)
    assert seen["charts"] == seen["drawn"] == 4 and seen["bad"] == 0  # every chart drawn
    assert seen["console"] == []


def test_progress_into_a_pipe_is_one_line_not_one_per_step(tmp_path):
    """Without a terminal (a log, CI), the series' steps are not each a line of progress
    (about 245 lines before)."""
    import subprocess
    import sys

    doc = yaml.safe_load(copy_station(tmp_path).read_text())
    doc["characterize"] = {"points": 8, "frames_spatial": 2}
    station = tmp_path / "quick.yaml"
    station.write_text(yaml.safe_dump(doc))
    run = subprocess.run(
        [sys.executable, "-m", "inspect_validate", "characterize", str(station), "--out", str(tmp_path / "c")],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr[-1000:]
    progress = [line for line in run.stderr.splitlines() if "characterizing" in line]
    assert 1 <= len(progress) <= 2, progress[:5]
