import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
PAPERBOARD = ROOT / "sample_images" / "paperboard"


@pytest.fixture(autouse=True)
def _work_in_tmp(tmp_path, monkeypatch):
    """Every test runs in its own folder: a default output path lands there, not in the checkout."""
    monkeypatch.chdir(tmp_path)


@pytest.fixture
def paperboard():
    return PAPERBOARD


@pytest.fixture
def simulator(tmp_path):
    """Start simulated controller processes: ``start(*args) -> (port, state_path, process)``."""
    procs = []

    def start(*args):
        state = tmp_path / f"state{len(procs)}.json"
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "inspect_validate.simulation.controller",
                "--state",
                str(state),
                *args,
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        procs.append(proc)
        return proc.stdout.readline().strip(), state, proc

    yield start
    for p in procs:
        p.kill()
        p.wait()
        p.stdout.close()


def write_mix_scene(path, edit=lambda text: text) -> Path:
    """The shipped inks scene (sample_images/scenes/mix) changed by ``edit`` (its text), at
    ``path`` with the files it names made absolute."""
    mix = ROOT / "sample_images" / "scenes" / "mix"
    text = edit((mix / "scene.yaml").read_text())
    for name in ("A", "B", "C"):
        text = text.replace(f"file: {name}.csv", f"file: {mix / name}.csv")
    text = text.replace("../chapter_table2/", f"{mix.parent / 'chapter_table2'}/")
    Path(path).write_text(text)
    return Path(path)


def run_cli(args) -> int | None:
    """Run the CLI in-process; its exit code (None when it returned without exiting)."""
    from inspect_validate.cli import main

    try:
        main([str(a) for a in args])
    except SystemExit as exc:
        return exc.code
    return None


def pytest_sessionstart(session):
    """Under mutmut, each mutant's tests run in a process forked after a clean run: the
    clean run's cached results (a tolerance factor, a quantile) would hide the mutant."""
    if os.environ.get("MUTANT_UNDER_TEST"):
        import functools
        import gc

        for cached in gc.get_objects():
            if isinstance(cached, functools._lru_cache_wrapper):
                cached.cache_clear()


def copy_station(tmp_path, *, world=None, **top):
    """The shipped station in ``tmp_path`` with ``camera.world`` and top-level keys replaced."""
    doc = yaml.safe_load((ROOT / "sample_images" / "station" / "station.yaml").read_text())
    doc["scene"] = str(ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml")
    if world:
        doc["camera"]["world"] = world
    doc.update(top)
    path = tmp_path / "station.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    shutil.copy(ROOT / "sample_images" / "station" / "rois.yaml", tmp_path / "rois.yaml")
    return path


def station_copy(tmp_path, camera=None, **controller_extra):
    """The shipped station as its text (the tests edit its lines), with the scene
    reference made absolute, plus ``camera`` (a dict) and controller options added to
    those sections (:func:`copy_station` rewrites it as YAML)."""
    text = (
        (ROOT / "sample_images" / "station" / "station.yaml")
        .read_text()
        .replace("../scenes/", f"{ROOT / 'sample_images' / 'scenes'}/")
    )
    if camera:
        extra = "".join(f"  {k}: {json.dumps(v)}\n" for k, v in camera.items())
        text = text.replace(
            "camera:\n  backend: simulated\n", "camera:\n  backend: simulated\n" + extra
        )
    if controller_extra:
        extra = "".join(f"  {k}: {json.dumps(v)}\n" for k, v in controller_extra.items())
        text = text.replace(
            "controller:\n  backend: simulated\n", "controller:\n  backend: simulated\n" + extra
        )
    path = tmp_path / "station.yaml"
    path.write_text(text)
    shutil.copy(ROOT / "sample_images" / "station" / "rois.yaml", tmp_path / "rois.yaml")
    return path


def through_sdk(path: Path, backend: str = "pylon", **camera) -> Path:
    """The station file at ``path`` with its simulated camera's frames served through a
    real camera stack, rewritten in place (Mono16 unless ``camera`` says otherwise):
    ``"pylon"``, pypylon's camera emulator; ``"aravis"``, Aravis' fake GigE Vision camera
    over GVCP/GVSP on ``lo`` (``simulate: true``)."""
    doc = yaml.safe_load(path.read_text())
    keep = ("exposure_us", "gain_db", "width", "height", "world")
    doc["camera"] = {
        "backend": backend,
        "simulate": True,
        "pixel_format": "Mono16",
        **{k: doc["camera"][k] for k in keep if k in doc["camera"]},
        **camera,
    }
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def two_cameras(path: Path, *second_world, **cameras) -> Path:
    """The station file at ``path`` rewritten with two cameras, ``top`` (its camera as it
    was) and ``side`` (the same, in the world ``second_world[0]`` where given); ``cameras``:
    name → keys to set on that camera."""
    doc = yaml.safe_load(path.read_text())
    first = doc.pop("camera")
    doc["cameras"] = [{**first, "name": "top"}, {**first, "name": "side"}]
    if second_world:
        doc["cameras"][1]["world"] = second_world[0]
    for cam in doc["cameras"]:
        cam.update(cameras.get(cam["name"], {}))
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def watch_cycles(cli, station, golden, db, cycles):
    """Run ``watch`` for ``cycles`` (no pause) into ``db``: its exit code and output,
    and the history's (cycle, status, cause) rows."""
    import sqlite3

    code, out, err = cli(
        ["watch", station, "--golden", golden, "--db", db, "--interval", 0, "--cycles", cycles]
    )
    with sqlite3.connect(db) as con:
        rows = con.execute("SELECT cycle, status, cause FROM cycles ORDER BY cycle").fetchall()
    return code, out, err, rows


@pytest.fixture
def cli(capsys):
    """Run the CLI in-process: ``cli(args) -> (exit code, stdout, stderr)``."""

    def call(args):
        capsys.readouterr()
        code = run_cli(args)
        captured = capsys.readouterr()
        return code, captured.out, captured.err

    return call


@pytest.fixture(scope="session")
def golden(tmp_path_factory):
    """A golden file trained on five captures of the shipped simulated station."""
    folder = tmp_path_factory.mktemp("golden")
    path = copy_station(folder)
    assert run_cli(["train", path, "--out", folder / "golden.json", "--repeats", 5]) == 0
    return folder / "golden.json"


@pytest.fixture(scope="session")
def tlsimu_cti(tmp_path_factory) -> Path:
    """TLSimu, the GenTL producer with a software trigger that the genicam 1.5.0 wheel
    ships (1.6 ships only viky, which free-runs): fetched from PyPI once per machine into
    ~/.cache/inspect-validate, or taken from IV_TLSIMU_CTI. Skips where neither works."""
    import os
    import zipfile

    given = os.environ.get("IV_TLSIMU_CTI")
    if given:
        return Path(given)
    cache = Path.home() / ".cache" / "inspect-validate" / "genicam-1.5.0"
    cti = cache / "TLSimu.cti"
    if not cti.is_file():
        download = tmp_path_factory.mktemp("genicam-wheel")
        fetched = subprocess.run(
            [
                sys.executable,
                "-m",
                "pip",
                "download",
                "-q",
                "--no-deps",
                "--only-binary",
                ":all:",
                "genicam==1.5.0",
                "-d",
                str(download),
            ],
            capture_output=True,
            text=True,
        )
        wheels = list(download.glob("genicam-1.5.0-*.whl"))
        if fetched.returncode or not wheels:
            pytest.skip(f"cannot fetch the genicam 1.5.0 wheel for TLSimu: {fetched.stderr[-300:]}")
        cache.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(wheels[0]) as wheel:
            for name in wheel.namelist():  # the producer and the library it loads beside it
                if name.endswith(("/TLSimu.cti", "/libVirtualFG.so")):
                    (cache / Path(name).name).write_bytes(wheel.read(name))
    return cti


@pytest.fixture(scope="session")
def emva1288_python() -> Path:
    """A Python with the ``emva1288`` reference implementation, in an environment of its
    own (it needs numpy < 1.24, which this project's cannot have): made once per machine
    in ~/.cache/inspect-validate/emva1288-venv from PyPI. Skips where that fails."""
    venv = Path.home() / ".cache" / "inspect-validate" / "emva1288-venv"
    python = venv / "bin" / "python"
    check = [str(python), "-c", "import emva1288.process"]
    if python.is_file() and subprocess.run(check, capture_output=True).returncode == 0:
        return python
    made = subprocess.run([sys.executable, "-m", "venv", "--clear", str(venv)], capture_output=True)
    pins = ["emva1288==1.0.2", "numpy<1.24", "scipy<1.12", "matplotlib<3.9"]
    installed = made.returncode == 0 and (
        subprocess.run(
            [str(python), "-m", "pip", "install", "-q", *pins], capture_output=True, text=True
        ).returncode
        == 0
    )
    if not installed or subprocess.run(check, capture_output=True).returncode:
        pytest.skip("cannot make an environment with the emva1288 package (needs PyPI)")
    return python


def lenient_history(path, cycles=(), points=(), meta=None):
    """A database shaped like a history but without its types and constraints."""
    import sqlite3

    con = sqlite3.connect(path)
    # points of ten values: with the camera column (a history of several cameras' time)
    camera = ", camera" if any(len(p) == 10 for p in points) else ""
    con.executescript(
        "CREATE TABLE meta (key, value); CREATE TABLE cycles (cycle, started, seconds, status, "
        "passed, reason, cause, frames); CREATE TABLE points (cycle, illumination, kind, name, "
        f"quantity, value, ewma, low, high{camera});"
    )
    meta = {"station": "/s.yaml", "golden": "/g.json", "created": "1.7e9"} if meta is None else meta
    con.executemany("INSERT INTO meta VALUES (?, ?)", list(meta.items()))
    con.executemany("INSERT INTO cycles VALUES (?, ?, ?, ?, ?, ?, ?, ?)", cycles)
    marks = ", ".join("?" * (10 if camera else 9))
    con.executemany(f"INSERT INTO points VALUES ({marks})", points)
    con.commit()
    con.close()
    return path


_PROBE = """<script>
window.addEventListener('load', () => {
  const bad = [...document.images].filter(i => !(i.complete && i.naturalWidth > 0));
  // A chart drawn: its canvas has pixels that are not the background.
  const drawn = [...document.querySelectorAll('div.chart canvas')].filter(c => {
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    for (let i = 3; i < d.length; i += 4) { if (d[i] > 0) return true; }
    return false;
  });
  // A legend value off the chart that reads as unfinished ("--", uPlot's own).
  const dashes = [...document.querySelectorAll('.u-legend .u-value')].filter(
    v => v.textContent.trim() === '--');
  document.body.setAttribute('data-probe', document.images.length + ':' + bad.length +
    ':' + document.querySelectorAll('div.chart').length + ':' + drawn.length + ':' +
    dashes.length);
});
</script>"""


def chromium_probe(page: Path, tmp_path: Path) -> dict:
    """A report page as headless Chromium loads it: pictures and pictures not decoded,
    charts and charts drawn, and the console's messages. A copy of the page gets a probe
    script that writes them into the DOM once the page has loaded. Skips where Debian's
    chromium is absent."""
    import re
    import shutil

    if shutil.which("chromium") is None:
        pytest.skip("Debian's chromium is not installed")
    probe = tmp_path / "probe.html"
    probe.write_text(page.read_text().replace("</body>", _PROBE + "</body>"))
    run = subprocess.run(
        ["chromium", "--headless", "--no-sandbox", "--disable-gpu",
         "--virtual-time-budget=10000", "--enable-logging=stderr", "--v=0", "--dump-dom",
         probe.as_uri()],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    found = re.search(r'data-probe="(\d+):(\d+):(\d+):(\d+):(\d+)"', run.stdout)
    assert found, "the page did not finish loading"
    images, bad, charts, drawn, dashes = map(int, found.groups())
    console = [line for line in run.stderr.splitlines() if ":CONSOLE" in line]
    return {
        "images": images,
        "bad": bad,
        "charts": charts,
        "drawn": drawn,
        "dashes": dashes,
        "console": console,
    }


PART_FRAME = (640, 800)
"""Rows and columns of the production frames of :func:`part_reference`."""


def part_reference():
    """A reference frame no one here drew: scikit-image's photograph of a cameraman as
    the part, on a darker belt."""
    import numpy as np
    from skimage import data

    frame = np.full(PART_FRAME, 30, np.uint8)
    frame[64:576, 144:656] = data.camera()
    return frame


def moved_part(dx, dy, degrees, *, blur=0.0, gain=1.0, seed=0):
    """The reference's part shifted and turned about the frame's centre (``gain``: the
    light's factor, ``blur``: a defocus's Gaussian σ, px), with 2 DN noise."""
    import cv2
    import numpy as np

    cx, cy = PART_FRAME[1] / 2 - 0.5, PART_FRAME[0] / 2 - 0.5
    m = cv2.getRotationMatrix2D((cx, cy), -degrees, 1.0)
    m[:, 2] += (dx, dy)
    image = cv2.warpAffine(
        part_reference().astype(np.float32) * gain, m, PART_FRAME[::-1],
        flags=cv2.INTER_CUBIC, borderValue=30 * gain,
    )  # fmt: skip
    if blur:
        image = cv2.GaussianBlur(image, (0, 0), blur)
    noise = np.random.default_rng(seed).normal(0, 2, image.shape)
    return np.clip(image + noise, 0, 255).astype(np.uint8)


def production_station(tmp_path, *, alone=False, **block):
    """The shipped station with a production block on the photograph and three regions
    (the face, the coat, the sky) in the reference's coordinates, read. ``alone``: a
    station of the line's frames alone (``rois:`` and ``production:``, no camera, scene
    or light: the photograph was never the simulated camera's)."""
    import cv2

    from inspect_validate.station.file import read_station

    cv2.imwrite(str(tmp_path / "reference.png"), part_reference())
    rois = {
        "frame": [PART_FRAME[1], PART_FRAME[0]],
        "classes": {
            "face": [{"rect": [380, 120, 60, 80]}],
            "coat": [{"rect": [300, 300, 120, 120]}],
            "sky": [{"rect": [170, 90, 100, 60]}],
        },
    }
    path = copy_station(tmp_path)
    (tmp_path / "parts.yaml").write_text(yaml.safe_dump(rois))
    doc = yaml.safe_load(path.read_text())
    doc["rois"] = "parts.yaml"
    doc["production"] = {"illumination": "amber", "reference": "reference.png", **block}
    if alone:
        doc = {"name": "photograph line", "rois": "parts.yaml",
               "production": {"illumination": "amber", "reference": "reference.png", **block}}  # fmt: skip
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return read_station(path)


def rendered_part(size, matrix, *, seed=0, noise=2.0, quantised=True):
    """A frame ``size`` + 200 px square holding a textured part ``size`` px across, drawn
    exactly under ``matrix`` (pixel corners): the texture (16 cosines of 0.01–0.12
    cycles/px) and the part's soft edge are evaluated at each pixel centre's point on
    the part, so the truth carries no interpolation's error; ``noise`` DN of noise,
    8-bit (float64 and unrounded where not ``quantised``). And the part's window on the
    reference (``matrix`` the identity)."""
    import numpy as np

    n, x0 = size + 200, 100
    rng = np.random.default_rng(1234)  # one part; ``seed`` draws the noise
    freq = rng.uniform(0.01, 0.12, 16) * np.exp(2j * np.pi * rng.uniform(0, 1, 16))
    phase, amp = rng.uniform(0, 2 * np.pi, 16), rng.uniform(5, 15, 16)
    a, b = matrix[:, :2], matrix[:, 2]
    v, u = np.mgrid[0:n, 0:n].astype(np.float64) + 0.5
    inv = np.linalg.inv(a)
    rx = inv[0, 0] * (u - b[0]) + inv[0, 1] * (v - b[1])
    ry = inv[1, 0] * (u - b[0]) + inv[1, 1] * (v - b[1])
    texture = 120 + sum(
        amp[k] * np.cos(2 * np.pi * (freq[k].real * rx + freq[k].imag * ry) + phase[k])
        for k in range(16)
    )

    def inside(t):  # a soft edge, 0.8 px wide
        return 0.5 * (1 + np.tanh((t - x0) / 0.8)) * 0.5 * (1 + np.tanh((x0 + size - t) / 0.8))

    window = inside(rx) * inside(ry)
    image = 30 + window * (texture - 30) + np.random.default_rng(seed).normal(0, noise, (n, n))
    if not quantised:
        return image, (x0, x0, size, size)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8), (x0, x0, size, size)


LINE = ROOT / "sample_images" / "line"
"""The shipped simulated line: a station with a production block and a moving part."""


def line_station(folder, parts=None, **world):
    """The shipped line in ``folder`` with ``world`` (and ``line``'s keys under "line")
    added to its simulated world, and ``parts`` a production capture (default 40)."""
    folder.mkdir(parents=True, exist_ok=True)
    doc = yaml.safe_load((LINE / "station.yaml").read_text())
    doc["scene"] = str(ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml")
    line = world.pop("line", {})
    doc["camera"]["world"] = {**doc["camera"]["world"], **world}
    doc["camera"]["world"]["line"].update(line)
    if parts is not None:
        doc["production"]["parts"] = parts
    for name in ("rois.yaml", "reference.tiff"):
        shutil.copy(LINE / name, folder / name)
    path = folder / "station.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def capture_running(station, out, until, *, timeout=120.0):
    """``capture STATION --out OUT`` started in a process of its own (its output piped), once
    the file ``until`` exists; the process."""
    import subprocess
    import sys
    import time

    proc = subprocess.Popen(
        [sys.executable, "-m", "inspect_validate", "capture", str(station), "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + timeout
    while not Path(until).exists():
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    return proc


def resume_two_cameras(station, out, frames):
    """``capture --resume`` of a two-camera capture whose red step did not finish: every
    step complete in both folders with the same rounds, red's ``frames`` taken again in
    both, its earlier attempt set aside in both."""
    import json
    import subprocess
    import sys

    argv = [sys.executable, "-m", "inspect_validate", "capture", str(station), "--out", str(out)]
    resumed = subprocess.run([*argv, "--resume"], capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert "amber: already complete, skipped" in resumed.stdout
    top, side = (json.loads((out / n / "manifest.json").read_text()) for n in ("top", "side"))
    for step in ("amber", "red", "dark"):
        assert top["steps"][step]["complete"] and side["steps"][step]["complete"]
        assert top["steps"][step]["rounds"] == side["steps"][step]["rounds"]
    for name in ("top", "side"):
        assert len(list((out / name / "red").glob("frame_*.tif"))) == frames
        assert list((out / name / "red").glob("partial-*"))  # the earlier attempt, kept


def line_frames(station, out, parts=40):
    """``capture --production`` of ``parts`` frames of the line into ``out``; the folder
    of the frames."""
    assert run_cli(["capture", station, "--production", "--parts", parts, "--out", out]) == 0
    return out / "amber"


def run_with_emulator(code: str, tmp_path) -> str:
    """Run ``code`` (dedented) in a Python of its own with pylon's camera emulator
    (pylon reads PYLON_CAMEMU as its transport layers start); its stdout. Skips where
    pypylon is not installed."""
    import textwrap

    pytest.importorskip("pypylon")
    script = tmp_path / "emulated.py"
    script.write_text(textwrap.dedent(code))
    done = subprocess.run(
        [sys.executable, str(script)],
        env={**os.environ, "PYLON_CAMEMU": "1"},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout
