"""Hostile inputs across the commands: no traceback, no hang, no NaN or absurd number out.

Hypothesis generates scene, ROI, station and spectrum files and frames from a
mix of valid and malformed parts (wrong types, NaN, ±inf, negative, huge and
tiny numbers, unknown keys, empty collections). Each command must either do its
job (exit 0, or 1 for a failed check) or refuse with exit 2 and an ``error:``
line — never the internal-error exit 70 — and whatever it prints or writes holds
no NaN. A valid file is never refused: the generators also produce valid files,
and those must pass.
"""

import json
import math
import shutil
import tempfile
from csv import DictReader
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import ROOT
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from inspect_validate.cli import main

SCENE = ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml"

SETTINGS = settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e-300, 1e300, 0.5, 2.8, 550, 30, 4000, 1e6]),
    st.integers(-(2**70), 2**70),
)
junk = st.one_of(numbers, st.text(max_size=8), st.none(), st.booleans(), st.just([]), st.just({}))
maybe = lambda good: st.one_of(good, good, good, junk)  # noqa: E731 - mostly good, sometimes not


def rarely_junk(good):
    """``good``, one draw in six junk. (maybe() flattens into one one_of with junk's many
    branches, so most of its draws are junk; a mapped junk is one branch.)"""
    return st.one_of(*[good] * 5, junk.map(lambda x: x))


def run(args, capsys):
    """Exit code, stdout and stderr of the CLI; numeric warnings (which pytest would catch,
    a user sees on stderr) are appended to stderr."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        try:
            main([str(a) for a in args])
            code = 0
        except SystemExit as exc:
            code = exc.code
    out = capsys.readouterr()
    shown = "".join(
        f"{w.filename}:{w.lineno}: {w.category.__name__}: {w.message}\n"
        for w in caught
        if issubclass(w.category, RuntimeWarning)
    )
    return code, out.out, out.err + shown


def assert_clean(code, out, err, allowed=(0, 2)):
    assert code in allowed, f"exit {code}\n{err}"
    assert "Traceback" not in err and "internal error" not in err, err
    assert "RuntimeWarning" not in err, err  # an overflow or invalid value leaked to the user
    if code == 2:
        assert "error" in err.lower() or "usage" in err.lower(), err
    for word in out.replace("|", " ").split():
        assert word.lower() not in ("nan", "nan%"), out


def csv(rows):
    return "\n".join(
        ",".join(f"{v!r}" if isinstance(v, float) else str(v) for v in r) for r in rows
    )


def reflectance_rows(level, spread):
    return [(w, level, level * (1 + spread), level * (1 - spread)) for w in range(380, 781, 10)]


lights = st.lists(
    st.one_of(
        st.fixed_dictionaries(
            {
                "led": st.fixed_dictionaries(
                    {"peak": maybe(st.floats(380, 780)), "fwhm": maybe(st.floats(1, 100))}
                )
            },
            optional={
                "irradiance": maybe(st.floats(0.01, 1e3)),
                "name": st.text(min_size=1, max_size=5),
            },
        ),
        st.fixed_dictionaries({"blackbody": maybe(st.floats(500, 20000))}),
        st.fixed_dictionaries({"cie": st.sampled_from(["D65", "FL2", "HP1", "A", "nope"])}),
        st.dictionaries(st.sampled_from(["led", "gain", "file", "laser"]), junk, max_size=3),
    ),
    max_size=3,
)
cameras = st.lists(
    st.one_of(
        st.sampled_from(["cmos-visible", "cmos-nir-enhanced", "ingaas-swir", "other"]),
        st.fixed_dictionaries(
            {"builtin": st.just("cmos-visible")},
            optional={
                "gain": maybe(st.floats(0.01, 5)),
                "bit_depth": maybe(st.integers(1, 32)),
                "saturation": maybe(st.floats(10, 1e6)),
            },
        ),
    ),
    max_size=2,
)
optics = st.lists(
    st.one_of(
        st.sampled_from(["ideal", "visible", "uv", "bogus"]),
        st.fixed_dictionaries(
            {"lens": st.sampled_from(["visible", "swir"])},
            optional={"f_number": maybe(st.floats(0.5, 32))},
        ),
        st.fixed_dictionaries(
            {"material": st.sampled_from(["BK7", "ZnSe", "x"])},
            optional={"thickness_mm": maybe(st.floats(0.1, 50))},
        ),
    ),
    max_size=2,
)
exposures = st.one_of(
    st.none(),
    st.fixed_dictionaries(
        {"mode": st.just("auto")},
        optional={"target": maybe(st.floats(0.05, 1)), "max_time": maybe(st.floats(1e-6, 1))},
    ),
    st.fixed_dictionaries({"mode": st.just("fixed"), "time": maybe(st.floats(1e-6, 1))}),
)


@SETTINGS
@given(
    lights=lights,
    optics=optics,
    cameras=cameras,
    exposure=exposures,
    levels=st.tuples(st.floats(0, 1.5), st.floats(0, 1.5)),
    spread=st.floats(0, 0.5),
)
def test_predict_never_crashes(capsys, lights, optics, cameras, exposure, levels, spread):
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, level in zip("ab", levels, strict=True):
            (tmp / f"{name}.csv").write_text(csv(reflectance_rows(level, spread)))
        doc = {
            "classes": {"A": {"file": "a.csv"}, "B": {"file": "b.csv"}},
            "lights": lights,
            "optics": optics,
            "cameras": cameras,
        }
        if exposure is not None:
            doc["exposure"] = exposure
        (tmp / "s.yaml").write_text(yaml.safe_dump(doc))
        code, out, err = run(["predict", tmp / "s.yaml", "--json", tmp / "p.json"], capsys)
        assert_clean(code, out, err)
        if code == 0:
            doc = json.loads((tmp / "p.json").read_text())
            for row in doc["ranking"]:
                for c in row["classes"]:
                    assert c["mean"] is not None and 0 <= c["saturated_fraction"] <= 1
                    assert c["variance"] is not None and c["variance"] >= 0
                for comp in row["comparisons"]:
                    assert comp["error_gaussian"] is not None and 0 <= comp["error_gaussian"] <= 0.5


shapes = st.one_of(
    st.fixed_dictionaries({"rect": st.lists(maybe(st.integers(-50, 700)), min_size=0, max_size=5)}),
    st.fixed_dictionaries(
        {"ellipse": st.lists(maybe(st.floats(-10, 700)), min_size=0, max_size=5)}
    ),
    st.fixed_dictionaries(
        {
            "polygon": st.lists(
                st.lists(maybe(st.floats(-10, 700)), min_size=2, max_size=2), max_size=5
            )
        }
    ),
    st.dictionaries(st.sampled_from(["rect", "circle", "mask"]), junk, max_size=2),
)


@SETTINGS
@given(
    classes=st.dictionaries(
        st.text(min_size=0, max_size=4), st.lists(shapes, max_size=3), max_size=4
    ),
    erode=maybe(st.integers(0, 5)),
)
def test_measure_with_hostile_roi_files(capsys, paperboard, classes, erode):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "rois.yaml"
        path.write_text(yaml.safe_dump({"erode": erode, "classes": classes}))
        code, out, err = run(
            ["measure", paperboard / "optimized.png", "--rois", path, "--kde", "never"], capsys
        )
        assert_clean(code, out, err, allowed=(0, 1, 2))


frames = st.one_of(
    st.builds(
        lambda dtype, level, noise, seed: np.clip(
            level + noise * np.random.default_rng(seed).standard_normal((3, 24, 32)),
            *_limits(dtype),
        ).astype(dtype),
        st.sampled_from([np.uint8, np.uint16, np.int32, np.float32, np.float64]),
        st.floats(-1e6, 1e6),
        st.floats(0, 1e4),
        st.integers(0, 2**16),
    ),
    st.sampled_from(
        [
            np.zeros((24, 32), np.uint16),
            np.full((24, 32), 65535, np.uint16),
            np.full((24, 32), 255, np.uint8),
            np.full((24, 32), np.nan, np.float32),
            np.full((24, 32), np.inf),
            np.full((24, 32), 1e300),
            np.full((24, 32), 0.25, np.float32),
            (np.arange(24 * 32).reshape(24, 32) % 7 / 4095).astype(np.float32),
            np.full((24, 32), 2**63 + 1, np.uint64),
            np.zeros((0, 32), np.uint16),
            np.zeros((2, 2, 24, 32), np.uint16),
        ]
    ),
)


def _limits(dtype):
    if np.dtype(dtype).kind == "f":
        return -np.inf, np.inf
    info = np.iinfo(dtype)
    return info.min, info.max


@SETTINGS
@given(frame=frames, dark=st.booleans(), kde=st.sampled_from(["auto", "always", "never"]))
def test_measure_with_hostile_frames(capsys, frame, dark, kde):
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        np.save(tmp / "f.npy", frame)
        (tmp / "rois.yaml").write_text(
            "classes:\n  A: [{rect: [0, 0, 32, 10]}]\n  B: [{rect: [0, 12, 32, 12]}]\n"
        )
        args = ["measure", tmp / "f.npy", "--rois", tmp / "rois.yaml", "--json", tmp / "m.json"]
        if dark:
            args += ["--dark", tmp / "f.npy"]
        args += ["--kde", kde]
        code, out, err = run(args, capsys)
        assert_clean(code, out, err, allowed=(0, 1, 2))
        if code in (0, 1):
            doc = json.loads((tmp / "m.json").read_text())
            for c in doc["classes"]:
                assert c["mean"] is not None and math.isfinite(c["mean"])
                assert c["variance"] is not None and c["variance"] >= 0
            for comp in doc["comparisons"]:
                assert comp["error_gaussian"] is not None and 0 <= comp["error_gaussian"] <= 0.5
                counted = comp["error_counted"]  # a fixed rule's: may exceed ½ on odd data
                assert counted is None or 0 <= counted <= 1
                if kde == "always" or comp["error_kde"] is not None:
                    assert comp["error_kde"] is not None and 0 <= comp["error_kde"] <= 0.5 + 1e-12
                else:  # not computed: said so
                    assert any("ε KDE" in s for s in doc["skipped"])


edges = st.builds(
    lambda degrees, sigma, contrast, offset, noise, seed, dtype: np.clip(
        offset
        + contrast
        * (
            (
                np.arange(32)[None, :]
                - 16
                - np.tan(np.radians(degrees)) * (np.arange(24)[:, None] - 12)
            )
            / max(sigma, 1e-3)
        ).clip(-1, 1)
        + noise * np.random.default_rng(seed).standard_normal((24, 32)),
        *_limits(dtype),
    ).astype(dtype),
    st.floats(-60, 60),
    st.floats(0, 10),
    st.floats(-1e5, 1e5),
    st.floats(-1e5, 1e5),
    st.floats(0, 1e4),
    st.integers(0, 2**16),
    st.sampled_from([np.uint8, np.uint16, np.int32, np.float32, np.float64]),
)


@SETTINGS
@given(frame=st.one_of(edges, frames), region=st.sampled_from(
    ["0,0,32,24", "4,2,24,20", "0,0,8,8", "30,20,8,8", "0,0,32,25", "9,9,1,1"]
))  # fmt: skip
def test_measure_edge_with_hostile_frames(capsys, frame, region):
    """Edges at any angle, blur, contrast (either sign), offset and noise in every pixel
    type, and the hostile frames above, in regions inside, across and outside the frame:
    the MTF or a refusal, never a traceback, and every number written finite."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        np.save(tmp / "f.npy", frame)
        code, out, err = run(
            ["measure", tmp / "f.npy", "--edge", region, "--json", tmp / "m.json"], capsys
        )
        assert_clean(code, out, err, allowed=(0, 2))
        if code == 0:
            found = json.loads((tmp / "m.json").read_text())["edge"]
            assert 1 <= abs(found["angle_deg"]) <= 30
            assert found["mtf"][0] == 1.0 and all(math.isfinite(v) for v in found["mtf"])
            assert found["mtf50_cycles_per_px"] is None or 0 < found["mtf50_cycles_per_px"] <= 1


lines = st.lists(
    st.one_of(
        st.tuples(st.floats(allow_nan=True), st.floats(allow_nan=True)).map(
            lambda t: f"{t[0]},{t[1]}"
        ),
        st.text(max_size=12),
        st.sampled_from(
            ["wavelength,a,b", "# comment", "", "400;0.5;0.4", "500\t0.6\t0.5", "600 0.7 0.6"]
        ),
    ),
    max_size=8,
)


@SETTINGS
@given(rows=lines)
def test_analyze_spectra_with_hostile_csv(capsys, rows):
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "a.csv").write_text("\n".join(rows))
        (tmp / "b.csv").write_text(csv(reflectance_rows(0.5, 0.1)))
        (tmp / "s.yaml").write_text(
            "classes: {A: {file: a.csv}, B: {file: b.csv}}\nlights: [{cie: D65}]\noptics: [ideal]\ncameras: [cmos-visible]\n"
        )
        code, out, err = run(["analyze-spectra", tmp / "s.yaml", "--kde", "never"], capsys)
        assert_clean(code, out, err)


@SETTINGS
@given(
    camera=st.dictionaries(
        st.sampled_from(
            [
                "backend",
                "exposure_us",
                "gain_db",
                "pixel_format",
                "cti",
                "latency",
                "world",
                "model",
                "timeout_s",
            ]
        ),
        junk,
        max_size=4,
    ),
    controller=st.dictionaries(
        st.sampled_from(["backend", "port", "channels", "timeout_s", "protocol"]), junk, max_size=3
    ),
    illuminations=st.lists(
        st.fixed_dictionaries(
            {
                "name": maybe(st.text(min_size=1, max_size=4)),
                "channels": st.dictionaries(
                    st.one_of(st.integers(-2, 70), st.text(max_size=3), st.floats()),
                    maybe(st.floats(0, 100)),
                    max_size=3,
                ),
            }
        ),
        max_size=3,
    ),
    channels=st.dictionaries(
        st.one_of(st.integers(-2, 70), st.text(max_size=3)),
        st.one_of(junk, st.fixed_dictionaries({"light": junk}, optional={"irradiance": junk})),
        max_size=3,
    ),
    scene=maybe(st.sampled_from(["missing.yaml", "", str(SCENE)])),
)
def test_station_files_are_validated_not_crashed_on(
    capsys, camera, controller, illuminations, channels, scene
):
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        doc = {"camera": camera, "controller": controller, "illuminations": illuminations}
        doc.update({"channels": channels} if channels else {})
        doc.update({"scene": scene} if scene is not None else {})
        (tmp / "st.yaml").write_text(yaml.safe_dump(doc))
        code, out, err = run(["capture", tmp / "st.yaml", "--out", tmp / "o"], capsys)
        # A generated station that validates may still fail to open its devices (exit 3).
        assert_clean(code, out, err, allowed=(0, 2, 3))


@settings(SETTINGS, max_examples=20)
@given(
    line=st.dictionaries(
        st.sampled_from(["part", "shift", "rotation_deg", "cut", "missing", "belt", "seed"]),
        rarely_junk(st.floats(0, 1)),
        max_size=4,
    ),
    dust=rarely_junk(
        st.lists(
            st.fixed_dictionaries(
                {"x": rarely_junk(st.floats(0, 1)), "y": rarely_junk(st.floats(0, 1))},
                optional={
                    "radius_px": rarely_junk(st.floats(0.1, 500)),
                    "depth": rarely_junk(st.floats(0.01, 1)),
                },
            ),
            max_size=2,
        )
    ),
    parts=st.integers(-1, 4),
)
@example(line={"part": 0.9, "shift": 0.5, "cut": 1.0}, dust=[], parts=3)
@example(line={"missing": 1.0}, dust=[{"x": 0.5, "y": 0.5, "depth": 1.0}], parts=3)
def test_a_simulated_line_is_validated_not_crashed_on(capsys, line, dust, parts):
    """``capture --production`` of the shipped line with a generated ``world.line`` and
    ``world.dust``: frames, or a message naming the key (exit 2); parts pushed wholly off
    the frame, every frame a gap, dust that takes all the light are all frames."""
    line_dir = Path(__file__).parent.parent / "sample_images" / "line"
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        doc = yaml.safe_load((line_dir / "station.yaml").read_text())
        doc["scene"] = str(SCENE)
        doc["camera"]["world"] = {"line": line, "dust": dust}
        (tmp / "st.yaml").write_text(yaml.safe_dump(doc))
        for name in ("rois.yaml", "reference.tiff"):
            shutil.copy(line_dir / name, tmp / name)
        code, out, err = run(["capture", tmp / "st.yaml", "--production", "--parts", parts,
                              "--out", tmp / "o"], capsys)  # fmt: skip
        assert_clean(code, out, err)
        if code == 0:
            assert len(list((tmp / "o" / "amber").glob("*.tif"))) == parts


@settings(SETTINGS, max_examples=25)
@given(
    block=st.dictionaries(
        st.sampled_from(
            [
                "illumination",
                "reference",
                "template",
                "margin",
                "motion",
                "min_score",
                "min_pixels",
                "parts",
            ]
        ),
        st.one_of(
            junk,
            st.sampled_from(["amber", "red", "reference.tiff", "rois.yaml", "affine"]),
            st.lists(st.integers(-10, 600), min_size=4, max_size=4),
            st.floats(0, 1),
        ),
        max_size=4,
    )
)
@example(block={"template": [0, 0, 480, 360], "motion": "affine"})
@example(block={"reference": "rois.yaml"})
@example(block={"min_score": 1.0, "min_pixels": 10**6})
def test_production_blocks_are_validated_not_crashed_on(capsys, block):
    """``train --production`` of two frames of the line with a generated ``production:``
    block: a golden file, or a message naming the file and key (exit 2)."""
    line_dir = Path(__file__).parent.parent / "sample_images" / "line"
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        doc = yaml.safe_load((line_dir / "station.yaml").read_text())
        doc["scene"] = str(SCENE)
        doc["production"] = {**doc["production"], **block}
        (tmp / "st.yaml").write_text(yaml.safe_dump(doc))
        for name in ("rois.yaml", "reference.tiff"):
            shutil.copy(line_dir / name, tmp / name)
        (tmp / "frames").mkdir()
        for k in range(2):
            shutil.copy(line_dir / "reference.tiff", tmp / "frames" / f"f{k}.tiff")
        code, out, err = run(["train", tmp / "st.yaml", "--production", "--frames",
                              tmp / "frames", "--out", tmp / "g.json"], capsys)  # fmt: skip
        assert_clean(code, out, err)
        assert (code == 0) == (tmp / "g.json").is_file()


@settings(SETTINGS, max_examples=15)
@given(
    precision=rarely_junk(
        st.fixed_dictionaries(
            {
                "mean": rarely_junk(st.floats(1e-9, 0.5)),
                "variance": rarely_junk(st.floats(1e-9, 0.5)),
            },
            optional={"min_frames": rarely_junk(st.integers(3, 6))},
        )
    ),
    # Junk, but never a valid count above 6: a precision that is not reached takes every
    # frame allowed, 10 ms each (4000 frames held a fresh clone's run for minutes).
    frames=rarely_junk(st.integers(1, 6)).filter(
        lambda x: isinstance(x, bool) or not isinstance(x, int | float) or not 6 < x <= 100_000
    ),
    rois=st.sampled_from(["rois.yaml", "missing.yaml", "outside.yaml"]),
)
@example(precision={"mean": 0.01, "variance": 0.1}, frames=5, rois="rois.yaml")
@example(precision={"mean": 1e-9, "variance": 0.1, "min_frames": 4}, frames=4, rois="rois.yaml")
@example(precision={"mean": 0.01, "variance": 0.1}, frames=5, rois="outside.yaml")
@example(precision={"mean": 0.01, "variance": 0.1}, frames=5, rois="missing.yaml")
def test_sequential_stopping_settings(capsys, precision, frames, rois):
    """The simulated station with hostile precision:, frames and ROIs: a clean refusal or
    a capture whose steps hold between min_frames and frames."""
    with tempfile.TemporaryDirectory() as tmp:
        from conftest import copy_station

        tmp = Path(tmp)
        path = copy_station(tmp, precision=precision, frames=frames, rois=rois)
        (tmp / "outside.yaml").write_text("classes: {A: [{rect: [300, 200, 50, 50]}]}\n")
        code, out, err = run(["capture", path, "--out", tmp / "o"], capsys)
        assert_clean(code, out, err)
        event(f"exit {code}")
        if code == 0:
            saved = len(list((tmp / "o" / "amber").glob("frame_*.tif")))
            least = frames if precision is None else min(precision.get("min_frames", 3), frames)
            assert least <= saved <= frames
        elif rois == "outside.yaml" and (tmp / "o" / "manifest.json").exists():
            assert "outside.yaml" in err


@pytest.mark.parametrize(
    "args",
    [
        ["measure", "{p}/optimized.png", "--rois", "{p}/rois.yaml", "--json", "{p}"],
        [
            "measure",
            "{p}/optimized.png",
            "--rois",
            "{p}/rois.yaml",
            "--json",
            "{p}/optimized.png/x.json",
        ],
        ["measure", "{p}/optimized.png", "--rois", "{p}/rois.yaml", "--saturation-level", "inf"],
        ["measure", "{p}/optimized.png", "--rois", "{p}", "--kde", "never"],
        ["predict", "{p}/optimized.png"],
        ["analyze-spectra", "{p}/rois.yaml"],
    ],
)
def test_output_and_input_paths_that_are_wrong(capsys, paperboard, args):
    code, out, err = run([a.format(p=paperboard) for a in args], capsys)
    assert_clean(code, out, err)
    assert code == 2


@pytest.mark.parametrize("value", ["nan", "-nan", "inf"])
@pytest.mark.parametrize(
    "args",
    [
        ["measure", "f.png", "--rois", "r.yaml", "--max-saturated"],
        ["measure", "f.png", "--rois", "r.yaml", "--max-zero"],
        ["measure", "f.png", "--rois", "r.yaml", "--saturation-level"],
        ["rois", "propose", "f.png", "--out", "r.yaml", "--edge"],
        ["watch", "s.yaml", "--interval"],
        ["watch", "s.yaml", "--retry-delay"],
    ],
)
def test_a_number_option_refuses_nan(capsys, args, value):
    """click's float range lets NaN through (every comparison with it is false):
    --interval nan watched without a pause, --max-saturated nan never failed a class."""
    code, out, err = run([*args, value], capsys)
    assert_clean(code, out, err)
    assert (
        code == 2 and f"{args[-1]}': " in err and ("not a finite number" in err or "range" in err)
    )


@pytest.mark.parametrize("kind", ["folder", "fifo", "device", "link loop", "dangling link"])
@pytest.mark.parametrize(
    "args, what",
    [
        (["measure", "{x}", "--rois", "{p}/rois.yaml"], "image file"),
        (["predict", "{x}"], "scene file"),
        (["design", "{x}"], "scene file"),
        (["analyze-spectra", "{x}"], "scene file"),
        (["verify", "{x}"], "station file"),
        (["history", "{x}"], "--db file"),
        (["rois", "import", "{x}", "--out", "{tmp}/r.yaml"], "labelme"),
        (["measure", "{p}/optimized.png", "--rois", "{x}"], "ROI file"),
    ],
)
def test_an_input_file_that_is_a_folder_a_pipe_or_a_device(
    capsys, paperboard, tmp_path, args, what, kind
):
    """Every reader of an input file says what the path is, by its name, and what to give;
    a FIFO is refused without opening it (a read would block until a writer came)."""
    import os

    if kind == "folder":
        x = tmp_path / "folder"
        x.mkdir()
    elif kind == "fifo":
        x = tmp_path / "fifo"
        os.mkfifo(x)
    elif kind == "link loop":
        x = tmp_path / "loop.tif"
        x.symlink_to(x.name)
    elif kind == "dangling link":
        x = tmp_path / "dangling.tif"
        x.symlink_to(tmp_path / "gone.tif")
    else:
        x = Path("/dev/zero")
    code, out, err = run([a.format(p=paperboard, x=x, tmp=tmp_path) for a in args], capsys)
    assert_clean(code, out, err)
    said = {
        "folder": "a folder",
        "link loop": "a symbolic link to nothing",
        "dangling link": "a symbolic link to nothing",
    }.get(kind, "not a regular file (a device or a pipe)")
    if what == "image file" and kind == "folder":  # frames may be a folder: an empty one
        assert code == 2 and f"{x}: folder holds no images" in err, err
        return
    assert code == 2 and f"{x}: {said}" in err and "; give" in err and what in err, err


@pytest.mark.parametrize(
    "args, what",
    [
        (["predict", "{x}"], "scene file"),
        (["design", "{x}"], "scene file"),
        (["verify", "{x}"], "station file"),
        (["measure", "{p}/optimized.png", "--rois", "{x}"], "ROI file"),
    ],
)
def test_a_file_larger_than_any_of_its_kind_is_refused_unread(
    capsys, paperboard, tmp_path, args, what
):
    """A sparse 8 GB file: refused by its size before a byte is read (it was read whole,
    then 'out of memory; measure fewer or smaller frames')."""
    x = tmp_path / "huge.yaml"
    with open(x, "wb") as f:
        f.truncate(8 * 2**30)
    code, out, err = run([a.format(p=paperboard, x=x) for a in args], capsys)
    assert_clean(code, out, err)
    assert code == 2 and f"{x}: 8,192 MB is larger than any {what} (at most 64 MB" in err, err


@pytest.mark.parametrize("kind", ["fifo", "device", "huge"])
def test_a_scene_whose_spectrum_file_is_a_pipe_or_a_device(capsys, tmp_path, kind):
    """A spectrum named by a scene is read as the scene is: a FIFO would block predict, and
    /dev/zero filled the memory until the kernel killed it."""
    import os
    import shutil

    scene = tmp_path / "paperboard"
    shutil.copytree(ROOT / "sample_images" / "scenes" / "paperboard", scene)
    shutil.copytree(
        ROOT / "sample_images" / "scenes" / "chapter_table2", tmp_path / "chapter_table2"
    )
    (scene / "A.csv").unlink()
    if kind == "fifo":
        os.mkfifo(scene / "A.csv")
    elif kind == "device":
        (scene / "A.csv").symlink_to("/dev/zero")
    else:
        with open(scene / "A.csv", "wb") as f:
            f.truncate(3 * 2**30)
    code, out, err = run(["predict", scene / "scene.yaml"], capsys)
    assert_clean(code, out, err)
    said = (
        "3,072 MB is larger than any spectrum file (at most 64 MB is read)"
        if kind == "huge"
        else "not a regular file (a device or a pipe)"
    )
    assert code == 2 and f"A.csv: {said}; give a CSV" in err, err


@pytest.fixture(scope="module")
def verified_capture(tmp_path_factory):
    """A capture of the simulated station and a golden file trained on six: enough repeats
    for the drift limits of any level the valid strategies ask (k up to 4)."""
    from conftest import copy_station, run_cli

    folder = tmp_path_factory.mktemp("verify_fuzz")
    path = copy_station(folder)
    args = ["train", path, "--out", folder / "golden.json", "--repeats", 6]
    assert run_cli(args) == 0
    return path, folder / "golden-frames" / "repeat_01", folder / "golden.json"


def verify_sections(*, hostile: bool):
    """Strategies for a station's acceptance, calibration, comparisons and stated irradiance:
    each value valid, or (``hostile``) now and then junk or a name that does not exist."""

    def pick(good):
        return rarely_junk(good) if hostile else good

    names = ["A vs B,C", "A vs B", "B vs A,C"] + (["A vs D", "", " vs ", "A"] if hostile else [])
    comparison_texts = st.sampled_from(names)
    illuminations = ["amber", "red"] + (["blue"] if hostile else [])
    goldens = ["golden.json"] + (["missing.json", "frames"] if hostile else [])
    acceptance = st.fixed_dictionaries(
        {},
        optional={
            "illumination": pick(st.sampled_from(illuminations)),
            "separation": pick(
                st.lists(
                    st.fixed_dictionaries(
                        {"comparison": pick(comparison_texts)},
                        optional={
                            "min_snr_db": pick(st.floats(-60, 20)),
                            "min_cnr_db": pick(st.floats(-60, 20)),
                            "max_error": pick(st.floats(0, 1)),
                            "max_error_kde": pick(st.floats(0, 1)),
                        },
                    ),
                    max_size=3,
                )
            ),
            "max_saturated": pick(st.floats(0, 1)),
            "max_zero": pick(st.floats(0, 1)),
            "agreement": pick(
                st.one_of(
                    st.none(),
                    st.fixed_dictionaries(
                        {},
                        optional={
                            "mean_relative": pick(st.floats(0.001, 1)),
                            "variance_relative": pick(st.floats(0.001, 1)),
                            "snr_db": pick(st.floats(0.01, 10)),
                            "snr_floor_db": pick(st.floats(-60, 0)),
                        },
                    ),
                )
            ),
            "ranking": pick(st.booleans()),
            "gain_relative": pick(st.floats(0.001, 1)),
            "drift": pick(
                st.fixed_dictionaries(
                    {"golden": pick(st.sampled_from(goldens))},
                    optional={
                        # A valid level: six repeats set its limits (k 10, a false-alarm
                        # rate of 1e-23, needs more: refused, naming how many).
                        "k": pick(st.floats(0.1, 4)),
                        "mean_dn": pick(st.floats(0.001, 10)),
                        "snr_db": pick(st.floats(0.001, 10)),
                    },
                )
            ),
        },
    )
    weights = ["equal", "pixels", {"A": 0.5, "B": 0.3, "C": 0.2}] + ([{"A": 1}] if hostile else [])
    # Valid groups hold every comparison a separation check may name.
    groups = ["default", ["A vs B,C", "A vs B", "B vs A,C", "B vs C"]] + (
        ["pairs", "rest", []] if hostile else []
    )
    methods = ["fit", "reference", "absolute"]
    return {
        "acceptance": pick(acceptance),
        "calibration": pick(
            st.one_of(
                st.fixed_dictionaries({"method": pick(st.sampled_from(["fit", "absolute"]))}),
                st.fixed_dictionaries(
                    {
                        "method": pick(st.sampled_from(methods)),
                        "reference": pick(st.sampled_from(["A", "white"] if hostile else ["A"])),
                    }
                ),
            )
        ),
        "comparisons": pick(
            st.fixed_dictionaries(
                {},
                optional={
                    "groups": pick(st.sampled_from(groups)),
                    "weights": pick(st.sampled_from(weights)),
                },
            )
        ),
        # Up to 10× the irradiance that lights the objects: the fit absorbs it.
        "irradiance": pick(st.floats(0.5, 50)),
    }


golden_edits = st.sampled_from(
    ["keep", "truncate", "nan values", "no classes", "empty values", "other exposure", "inf snr"]
)


def _edit_golden(text: str, edit: str) -> str:
    if edit == "truncate":
        return text[: len(text) // 2]
    doc = json.loads(text)
    ill = doc["illuminations"]["amber"]
    if edit == "nan values":
        ill["classes"]["A"]["mean"]["values"] = [None, None]
    elif edit == "no classes":
        ill["classes"] = {}
    elif edit == "empty values":
        ill["comparisons"]["A vs B"]["snr_db"]["values"] = []
    elif edit == "other exposure":
        doc["exposure_us"] = 1
    elif edit == "inf snr":
        ill["comparisons"]["A vs B,C"]["snr_db"]["values"] = ["inf", "-inf"]
    return json.dumps(doc)


@SETTINGS
@given(**verify_sections(hostile=True), golden=golden_edits)
def test_verify_with_hostile_station_sections(
    capsys, verified_capture, acceptance, calibration, comparisons, irradiance, golden
):
    path, frames, golden_path = verified_capture
    doc = yaml.safe_load(path.read_text())
    doc.update(acceptance=acceptance, calibration=calibration, comparisons=comparisons)
    doc["channels"] = {1: {"light": "amber LED", "irradiance": irradiance}, 2: "red LED"}
    with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
        tmp = Path(tmp)
        (tmp / "rois.yaml").write_text((path.parent / "rois.yaml").read_text())
        (tmp / "golden.json").write_text(_edit_golden(golden_path.read_text(), golden))
        (tmp / "st.yaml").write_text(yaml.safe_dump(doc))
        code, out, err = run(["verify", tmp / "st.yaml", "--frames", frames], capsys)
        event(f"exit {code}")  # --hypothesis-show-statistics: how many reach a verdict
        assert_clean(code, out, err, allowed=(0, 1, 2))


@settings(SETTINGS, max_examples=25)
@given(**verify_sections(hostile=False))
def test_verify_never_refuses_a_valid_station(
    capsys, verified_capture, acceptance, calibration, comparisons, irradiance
):
    path, frames, golden_path = verified_capture
    doc = yaml.safe_load(path.read_text())
    doc.update(acceptance=acceptance, calibration=calibration, comparisons=comparisons)
    doc["channels"] = {
        1: {"light": "amber LED", "irradiance": irradiance},
        2: {"light": "red LED", "irradiance": 5.0},  # calibration 'absolute' needs both
    }
    with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
        tmp = Path(tmp)
        (tmp / "rois.yaml").write_text((path.parent / "rois.yaml").read_text())
        (tmp / "golden.json").write_text(golden_path.read_text())
        (tmp / "st.yaml").write_text(yaml.safe_dump(doc))
        code, out, err = run(["verify", tmp / "st.yaml", "--frames", frames], capsys)
        assert_clean(code, out, err, allowed=(0, 1))


design_leds = st.lists(
    st.fixed_dictionaries(
        {
            "led": st.fixed_dictionaries({"peak": st.floats(200, 1200), "fwhm": st.floats(1, 150)}),
            "irradiance": rarely_junk(st.sampled_from([1e-300, 1e-6, 0.5, 2.0, 2.0, 1e3, 1e6])),
        }
    ),
    min_size=1,
    max_size=4,
)


def _design_scene(tmp, leds, levels, spreads, band, time, bits):
    """A scene for ``design``: classes with reflectances over ``band`` nm only."""
    classes = {}
    for name, level, spread in zip("ABC", levels, spreads, strict=False):
        rows = [r for r in reflectance_rows(level, spread) if band[0] <= r[0] <= band[1]]
        (tmp / f"{name}.csv").write_text(csv(rows))
        classes[name] = {"file": f"{name}.csv"}
    doc = {
        "classes": classes,
        "lights": leds,
        "optics": ["visible"],
        "cameras": [{"builtin": "cmos-visible", "bit_depth": bits}],
        "exposure": {"mode": "fixed", "time": time},
    }
    (tmp / "s.yaml").write_text(yaml.safe_dump(doc))
    return tmp / "s.yaml"


def _check_design(tmp, code):
    if code != 0:
        return
    doc = json.loads((tmp / "d.json").read_text())
    assert all(0 <= w <= 1 for w in doc["levels"].values())
    # The entry to paste lights what the design lights, however dim (no empty mix).
    assert all(float(p) > 0 for p in doc["illumination"]["channels"].values())
    assert bool(doc["illumination"]["channels"]) == any(doc["levels"].values())
    assert 0 < doc["exposure_time_s"] <= 100
    for part in (doc["mix"], doc["best_single"]):
        for c in part["comparisons"]:
            assert 0 <= c["error_gaussian"] <= 0.5
            assert c["cnr_db"] == "-inf" or math.isfinite(c["cnr_db"])
        for c in part["classes"]:
            assert math.isfinite(c["mean"]) and c["variance"] >= 0
    path = doc["path"]
    assert all(0 <= e <= 0.5 for row in path["error_gaussian"] for e in row)
    assert all(0 <= r < math.inf for row in path["cnr"] for r in row)


# what the design is after and at which exposure
design_options = st.sampled_from(
    [[], ["--objective", "cnr"], ["--auto-exposure"], ["--objective", "cnr", "--auto-exposure"]]
)


@SETTINGS
@given(
    leds=design_leds,
    levels=st.lists(st.sampled_from([0.0, 1e-9, 0.05, 0.3, 0.3, 0.7, 1.0]), min_size=2, max_size=3),
    spreads=st.lists(st.sampled_from([0.0, 1e-12, 0.02, 0.3]), min_size=3, max_size=3),
    band=st.sampled_from([(380, 780)] * 4 + [(500, 600), (380, 450), (700, 780)]),
    time=st.sampled_from([1e-9, 1e-4, 0.04, 10.0]),
    bits=st.sampled_from([8, 12, 16]),
    choose=st.sampled_from([None, 1, 2]),
    options=design_options,
)
@example(  # a light so bright its level is 1e-6 over classes without spread: NaN starts
    leds=[{"led": {"peak": 623.0, "fwhm": 1.0}, "irradiance": 1e6}],
    levels=[0.0, 0.05],
    spreads=[0.0, 0.0, 0.0],
    band=(380, 780),
    time=0.04,
    bits=8,
    choose=None,
    options=["--auto-exposure"],
)
def test_design_with_hostile_scenes(
    capsys, leds, levels, spreads, band, time, bits, choose, options
):
    # Lights outside the reflectances' band, lights of equal brightness (repeats),
    # classes without spread, exposures that saturate everything or give no signal.
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        path = _design_scene(tmp, leds, levels, spreads, band, time, bits)
        args = ["design", path, "--json", tmp / "d.json", *options]
        code, out, err = run([*args, *(["--choose", choose] if choose else [])], capsys)
        event(f"exit {code}")
        assert_clean(code, out, err)
        _check_design(tmp, code)


@settings(SETTINGS, max_examples=20)
@given(
    peaks=st.lists(st.floats(420, 680), min_size=1, max_size=4),
    repeat=st.booleans(),
    levels=st.lists(st.floats(0.05, 0.9), min_size=2, max_size=3),
    spreads=st.lists(st.floats(0.005, 0.2), min_size=3, max_size=3),
    options=design_options,
)
@pytest.mark.slow
def test_design_never_refuses_a_valid_scene(capsys, peaks, repeat, levels, spreads, options):
    leds = [
        {"led": {"peak": p, "fwhm": 25}, "irradiance": 2.0, "name": f"L{i}"}
        for i, p in enumerate(peaks)
    ]
    if repeat:
        leds.append(dict(leds[0], name="twin"))  # two identical LEDs of equal brightness
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        path = _design_scene(tmp, leds, levels, spreads, (380, 780), 0.01, 12)
        code, out, err = run(["design", path, "--json", tmp / "d.json", *options], capsys)
        assert_clean(code, out, err, allowed=(0,))
        _check_design(tmp, code)


# A watch history: hostile rows in an untyped copy of its tables, and sound ones written
# the way watch writes them.
history_cycles = st.lists(
    st.tuples(
        rarely_junk(st.integers(0, 10**6)),
        rarely_junk(st.floats(1e9, 2e9)),
        rarely_junk(st.floats(0, 1e4)),
        rarely_junk(st.sampled_from(["pass", "fail", "drift", "error"])),
        rarely_junk(st.sampled_from([None, 0, 1])),
        rarely_junk(st.one_of(st.none(), st.text(max_size=30))),
        rarely_junk(st.one_of(st.none(), st.text(max_size=30))),
        rarely_junk(st.one_of(st.none(), st.text(max_size=30))),
    ),
    max_size=6,
    unique_by=lambda c: repr(c[0]),
)
history_values = st.floats(-1e6, 1e6, allow_nan=False) | st.sampled_from([0.0, 1e-300, 1e99])
_history_point = (
    rarely_junk(st.integers(0, 7)),
    rarely_junk(st.sampled_from(["amber", "red", "a/b", ""])),
    rarely_junk(st.sampled_from(["class", "comparison"])),
    rarely_junk(st.sampled_from(["A", "A vs B", "ü"])),
    rarely_junk(st.sampled_from(["mean", "variance", "snr_db", "log_error"])),
    rarely_junk(history_values | st.none()),
    rarely_junk(history_values),
    rarely_junk(history_values),
    rarely_junk(history_values),
)
history_points = st.lists(st.tuples(*_history_point), max_size=20) | st.lists(
    # a history of several cameras: each point with its camera's name
    st.tuples(*_history_point, rarely_junk(st.sampled_from(["", "top", "side", "a b"]))),
    max_size=20,
)


def _storable(value):
    """``value`` as SQLite can hold it: what it cannot (a list, an integer beyond 64 bits)
    as its text, the way another tool would have put it there."""
    if isinstance(value, (list, dict)) or (isinstance(value, int) and abs(value) >= 2**63):
        return json.dumps(value)
    return value


@SETTINGS
@given(
    cycles=history_cycles,
    points=history_points,
    meta=rarely_junk(st.just({"station": "/s.yaml", "golden": "/g.json", "created": "1.7e9"})),
    plot=st.sampled_from([False, False, False, True]),
)
def test_history_with_hostile_databases(capsys, cycles, points, meta, plot):
    from conftest import lenient_history

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        rows = (
            [[_storable(v) for v in row] for row in cycles],
            [[_storable(v) for v in row] for row in points],
        )
        lenient_history(tmp / "h.sqlite", *rows, meta if isinstance(meta, dict) else {})
        args = ["history", tmp / "h.sqlite", "--csv", tmp / "h.csv"]
        code, out, err = run([*args, *(["--plot", tmp / "p"] if plot else [])], capsys)
        event(f"exit {code}")
        assert_clean(code, out, err)
        if code == 0:  # every number exported is finite (an empty cell: none that cycle)
            with open(tmp / "h.csv", newline="") as f:
                for row in DictReader(f):
                    for column in ("seconds", "value", "ewma", "low", "high"):
                        assert row[column] == "" or math.isfinite(float(row[column])), row


@settings(SETTINGS, max_examples=25)
@given(
    steps=st.lists(
        st.tuples(
            st.sampled_from(["pass", "fail", "drift", "error"]),
            st.floats(-1e6, 1e6, allow_nan=False) | st.just(math.nan),  # not finite: NaN
            st.floats(-1e6, 1e6, allow_nan=False),
            st.floats(0, 1e6, allow_nan=False),
        ),
        min_size=1,
        max_size=6,
    ),
    plot=st.sampled_from([False, False, False, True]),
    cameras=st.sampled_from([(), ("top", "side")]),
)
def test_history_never_refuses_what_watch_writes(capsys, steps, plot, cameras):
    from inspect_validate.watch.history import CycleRecord
    from inspect_validate.watch.history_writer import HistoryWriter

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        history = HistoryWriter(tmp / "h.sqlite", station="/s.yaml", golden="/g.json")
        for n, (status, value, target, half) in enumerate(steps):
            ewma = 0.0 if not math.isfinite(value) else value / 2
            points = (
                {}
                if status == "error"
                else {
                    ("amber", "class", "A", "mean", *camera): (
                        value,
                        ewma,
                        target - abs(half),
                        target + abs(half),
                    )
                    for camera in ([(c,) for c in cameras] or [()])  # a watch of several
                }
            )
            reason = "timeout" if status == "error" else None
            history.commit(
                CycleRecord(n, 1.7e9 + n, 0.5, status, status != "fail", reason, None, None), points
            )
        history.close()
        args = ["history", tmp / "h.sqlite", "--csv", tmp / "h.csv"]
        code, out, err = run([*args, *(["--plot", tmp / "p"] if plot else [])], capsys)
        assert_clean(code, out, err, allowed=(0,))
        rows = 1 + sum(1 if s[0] == "error" else max(len(cameras), 1) for s in steps)
        assert len((tmp / "h.csv").read_text().splitlines()) == rows


@settings(SETTINGS, max_examples=20)
@given(
    camera=st.dictionaries(
        st.sampled_from(
            [
                "acquisition",
                "trigger_line",
                "strobe_line",
                "trigger_delay_us",
                "settle_ms",
                "chunks",
                "exposure_us",
            ]
        ),
        st.one_of(
            junk,
            st.sampled_from(
                ["auto", "free-run", "software-trigger", "hardware-trigger", "Line1", "Line2"]
            ),
            st.floats(0, 2e4),
        ),
        max_size=5,
    ),
    pulse=maybe(
        st.dictionaries(
            st.sampled_from(["width_us", "delay_us", "max_duty", "trigger_channel"]),
            st.one_of(junk, st.floats(0, 2e4), st.integers(-1, 70)),
            max_size=4,
        )
    ),
)
@example(
    camera={"acquisition": "hardware-trigger", "trigger_line": "Line1"}, pulse={"width_us": 9e3}
)
@example(
    camera={"acquisition": "software-trigger", "strobe_line": "Line2"}, pulse={"width_us": 9e3}
)
@example(camera={"acquisition": "free-run", "chunks": True}, pulse=None)
def test_acquisition_settings_are_validated_not_crashed_on(capsys, camera, pulse):
    """Hostile trigger, strobe, chunk and pulse settings on the simulated station: refused
    naming the field (2), captured (0), or a device's clear failure (3)."""
    doc = yaml.safe_load((ROOT / "sample_images" / "station" / "station.yaml").read_text())
    doc["scene"] = str(SCENE)
    doc.update(frames=1, dark_frames=1)
    doc["camera"].update(camera, timeout_s=0.3)
    if pulse is not None:
        doc["controller"]["pulse"] = pulse
    _captured_cleanly(doc, capsys)


def _captured_cleanly(doc: dict, capsys) -> tuple[int, list[str]]:
    """Capture the station ``doc`` (beside the shipped ROIs) in a folder of its own:
    refused (2), captured (0) or a device's clear failure (3), never a traceback; the exit
    code and the folders the capture made."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "rois.yaml").write_text(
            (ROOT / "sample_images" / "station" / "rois.yaml").read_text()
        )
        (tmp / "st.yaml").write_text(yaml.safe_dump(doc))
        code, out, err = run(["capture", tmp / "st.yaml", "--out", tmp / "o"], capsys)
        event(f"exit {code}")
        assert_clean(code, out, err, allowed=(0, 2, 3))
        made = sorted(p.name for p in (tmp / "o").iterdir() if p.is_dir()) if code == 0 else []
    return code, made


@settings(SETTINGS, max_examples=20)
@given(
    values=st.dictionaries(
        st.sampled_from(
            ["gain", "dark_noise", "saturation", "bit_depth", "dark_offset", "dsnu", "prnu", "x"]
        ),
        st.one_of(junk, st.floats(-1, 1e5), st.integers(-5, 40)),
        max_size=6,
    ),
    measured=st.one_of(junk, st.dictionaries(st.just("gain_db"), junk, max_size=1)),
    raw=st.sampled_from(["", "[1, 2]", "camera: 3", "{{", None]),
)
@example(values={"gain": 0.03, "dark_noise": 10.0, "saturation": 9000.0}, measured={}, raw=None)
@example(values={"gain": 0.03, "prnu": 0.02, "dsnu": 3.0}, measured={"gain_db": 6}, raw=None)
@example(values={"dark_offset": 1e6, "bit_depth": 8}, measured={}, raw=None)
@example(values={"gain": 1e-300}, measured={}, raw=None)
def test_measured_camera_files_are_validated_not_crashed_on(
    capsys, verified_capture, values, measured, raw
):
    """A hostile camera file named by camera.measured: verify refuses it naming the file
    and the field (2), or predicts with it (0/1); never a traceback."""
    path, frames, _ = verified_capture
    doc = yaml.safe_load(path.read_text())
    doc.pop("acceptance", None)
    with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
        tmp = Path(tmp)
        text = raw if raw is not None else yaml.safe_dump({"camera": values, "measured": measured})
        (tmp / "camera.yaml").write_text(text)
        doc["camera"]["measured"] = "camera.yaml"
        (tmp / "rois.yaml").write_text((path.parent / "rois.yaml").read_text())
        (tmp / "st.yaml").write_text(yaml.safe_dump(doc))
        code, out, err = run(["verify", tmp / "st.yaml", "--frames", frames], capsys)
        event(f"exit {code}")
        assert_clean(code, out, err, allowed=(0, 1, 2))
        if code == 2:
            assert "camera.yaml" in err or "st.yaml" in err


@settings(SETTINGS, max_examples=25)
@given(
    cameras=rarely_junk(
        st.lists(
            st.dictionaries(
                st.sampled_from(
                    [
                        "name",
                        "rois",
                        "model",
                        "acquisition",
                        "trigger_line",
                        "width",
                        "gain_db",
                        "serial",
                        "backend",
                        "world",
                    ]
                ),
                st.one_of(
                    junk,
                    st.sampled_from(["top", "side", "x y", "", "../up", "dark", "Line1"]),
                    st.sampled_from(["software-trigger", "hardware-trigger", "free-run"]),
                    st.integers(-5, 400),
                ),
                max_size=4,
            ),
            max_size=3,
        )
    ),
    with_camera=st.booleans(),
)
@example(cameras=[{"name": "top"}, {"name": "side"}], with_camera=False)
@example(cameras=[{"name": "top"}, {"name": "top"}], with_camera=False)
@example(cameras=[], with_camera=False)
@example(cameras=[{"name": "a", "backend": "pylon", "serial": 1}] * 2, with_camera=False)
def test_several_cameras_are_validated_not_crashed_on(capsys, cameras, with_camera):
    """Hostile ``cameras:`` lists on the simulated station (issue 51): refused naming the
    camera and key (2), captured (0), or a device's clear failure (3); never a traceback,
    and a capture of several cameras leaves one folder per camera."""
    base = yaml.safe_load((ROOT / "sample_images" / "station" / "station.yaml").read_text())
    doc = {k: v for k, v in base.items() if k != "camera" or with_camera}
    doc["scene"] = str(SCENE)
    doc.update(frames=1, dark_frames=1)
    if isinstance(cameras, list):
        cameras = [
            {**base["camera"], "timeout_s": 0.3, **c} if isinstance(c, dict) else c for c in cameras
        ]
    doc["cameras"] = cameras
    code, made = _captured_cleanly(doc, capsys)
    if code == 0 and isinstance(cameras, list) and cameras:
        assert made == sorted(c["name"] for c in cameras)


@pytest.fixture(scope="module")
def measured_field(tmp_path_factory):
    """The shipped station's targets captured and characterized once: its station file,
    field.json and sharpness.json, for the hostile versions below to replace."""
    from conftest import copy_station

    folder = tmp_path_factory.mktemp("field")
    station = copy_station(folder, world={"vignetting": 0.1})
    for target in ("flat", "edge"):
        assert main_code(["capture", station, "--target", target, "--out", folder / target]) == 0
    args = ["characterize", station, "--field", folder / "flat", "--sharpness", folder / "edge"]
    assert main_code([*args, "--out", folder / "cal"]) == 0
    return station


def main_code(args) -> int:
    try:
        main([str(a) for a in args])
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


def _hostile(doc, draw_keys, value):
    """``doc`` with the values at each path of ``draw_keys`` replaced by ``value``."""
    doc = json.loads(json.dumps(doc))
    for path in draw_keys:
        node = doc
        for key in path[:-1]:
            node = node[key] if isinstance(node, dict) else node[int(key)]
        node[path[-1]] = json.loads(json.dumps(value))  # a copy: never itself inside itself
    return doc


FIELD_PATHS = [
    ("width",), ("height",), ("schema",), ("schema_version",), ("illuminations",),
    ("illuminations", "amber"), ("illuminations", "amber", "coefficients"),
    ("illuminations", "amber", "coefficients", 0), ("illuminations", "amber", "coefficients", 3),
    ("illuminations", "amber", "signal_dn"), ("illuminations", "amber", "residual"),
]  # fmt: skip
SHARPNESS_PATHS = [
    ("illuminations",), ("illuminations", "red"), ("illuminations", "red", "mtf50"),
    ("illuminations", "red", "mtf_half_nyquist"), ("illuminations", "red", "angle_deg"),
    ("illuminations", "red", "mtf"), ("schema",),
]  # fmt: skip


@SETTINGS
@given(
    which=st.sampled_from(["field", "sharpness"]),
    paths=st.lists(st.integers(0, 10), min_size=1, max_size=3),
    value=st.one_of(junk, st.lists(numbers, max_size=20), st.floats(-2, 2)),
)
def test_field_and_sharpness_files_are_validated_not_crashed_on(
    capsys, measured_field, which, paths, value
):
    """The station's field.json or sharpness.json with any of its values replaced by
    junk, numbers at the extremes, lists of them: verify refuses it naming the file
    (exit 2) or verifies (0, 1), never a traceback, a warning or a NaN in its report."""
    station = measured_field
    cal = station.parent / "cal"
    keys = FIELD_PATHS if which == "field" else SHARPNESS_PATHS
    doc = json.loads((cal / f"{which}.json").read_text())
    try:
        bad = _hostile(doc, [keys[i % len(keys)] for i in paths], value)
    except (KeyError, IndexError, TypeError, ValueError):
        event("a path through a value replaced before")
        return
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / f"{which}.json").write_text(json.dumps(bad, allow_nan=True))
        doc = yaml.safe_load(station.read_text())
        doc["scene"] = str(SCENE)
        doc["rois"] = str(station.parent / "rois.yaml")
        doc["field"] = str(tmp / "field.json") if which == "field" else str(cal / "field.json")
        doc["sharpness"] = str(tmp / f"{which}.json") if which == "sharpness" else None
        (tmp / "station.yaml").write_text(yaml.safe_dump(doc))
        code, out, err = run(["verify", tmp / "station.yaml", "--report", tmp / "r"], capsys)
        assert_clean(code, out, err, allowed=(0, 1, 2))
        event(f"{which}: exit {code}")
        if code == 2:
            assert f"{which}.json" in err, err
        else:
            text = (tmp / "r" / "verification.json").read_text()
            assert "NaN" not in text and "Infinity" not in text


@SETTINGS
@given(
    frame=frames,
    falloff=st.floats(-2, 2),
    offset=st.floats(-1e4, 1e4),
)
def test_a_flat_targets_frames_are_fitted_or_refused(frame, falloff, offset):
    """Any frame the measure fuzz makes, and ramps of any falloff and offset: a finite
    field no brighter than 1 and above MIN_FIELD over the frame, or a refusal."""
    import warnings

    from inspect_validate.characterization.field import MIN_FIELD, fit_field, lowest
    from inspect_validate.errors import InputError

    images = [np.asarray(frame, float)]
    x = np.arange(64) / 63.0
    images.append(offset + 100.0 * (1.0 - falloff * x)[None, :] * np.ones((48, 1)))
    for image in images:
        if image.ndim != 2:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # what a user would see
            try:
                f = fit_field(image)
            except InputError:
                continue
        assert np.isfinite(f.coefficients).all()
        assert lowest(f) > MIN_FIELD and f.map().max() == pytest.approx(1.0, abs=1e-3)
