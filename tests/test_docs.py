"""The manual against the code, where a page cannot be generated from it.

The file-format pages of models are generated as the docs build (docs/_ext); the
capture folder has no model (its sidecars and manifest are written key by key), so
its page is checked here against what a real capture writes.
"""

import json
import re
from pathlib import Path

from conftest import ROOT, copy_station, two_cameras

DOCS = ROOT / "docs"


def _table_keys(page: Path, heading: str) -> dict[str, str]:
    """Backticked keys of the first column of the first table under ``heading``, each with
    its row's text."""
    text = page.read_text()
    section = text[text.index(heading) :]
    rows = {}
    for line in section.splitlines()[1:]:
        if line.startswith("#"):
            break
        if not line.startswith("| `"):
            if rows and not line.startswith("|"):
                break
            continue
        first, rest = line.split("|")[1], "|".join(line.split("|")[2:])
        for key in re.findall(r"`([^`]+)`", first):
            rows[key] = rest
    return rows


def test_capture_folder_page_lists_every_key_a_capture_writes(cli, tmp_path):
    station = copy_station(tmp_path, precision={"mean": 0.5, "variance": 0.5})
    code, _, err = cli(["capture", station, "--out", tmp_path / "cap"])
    assert code == 0, err
    page = DOCS / "formats" / "capture-folder.md"
    manifest = json.loads((tmp_path / "cap" / "manifest.json").read_text())
    sidecar = json.loads((tmp_path / "cap" / "amber" / "frame_0001.json").read_text())

    documented = _table_keys(page, "## Sidecar")
    assert set(sidecar) <= set(documented), set(sidecar) - set(documented)
    top = _table_keys(page, "## Manifest")
    assert set(manifest) <= set(top), set(manifest) - set(top)
    camera_row = top["camera"]
    assert all(f"`{k}`" in camera_row for k in manifest["camera"]), manifest["camera"]
    steps = _table_keys(page, "Each step:")
    written = {k for step in manifest["steps"].values() for k in step}
    assert "precision" in written  # the optional keys are exercised, not only the usual
    assert written <= set(steps), written - set(steps)

    # And nothing documented that no capture writes: the keys a good capture leaves out
    # are written by one whose red light never reaches the objects (warnings) and one
    # whose camera stops sending (a step's error). Before, a key passed when its name
    # was spelled anywhere in camera/*.py.
    for name, world in (("dead", {"irradiance": {2: 0.0}}), ("stopped", {"camera_timeout": True})):
        (tmp_path / name).mkdir()
        cli(
            [
                "capture",
                copy_station(tmp_path / name, world=world),
                "--out",
                tmp_path / f"{name}-cap",
            ]
        )
    # and a station of several cameras writes its rounds
    (tmp_path / "rig").mkdir()
    cli(["capture", two_cameras(copy_station(tmp_path / "rig")), "--out", tmp_path / "rig-cap"])
    rig_sidecar = json.loads(
        (tmp_path / "rig-cap" / "top" / "amber" / "frame_0001.json").read_text()
    )
    assert set(rig_sidecar) <= set(documented), set(rig_sidecar) - set(documented)
    sidecar.update(rig_sidecar)
    for folder in ("dead-cap", "stopped-cap", "rig-cap/top"):
        other = json.loads((tmp_path / folder / "manifest.json").read_text())
        manifest.update(other)
        written |= {k for step in other["steps"].values() for k in step}
    assert set(top) <= set(manifest), set(top) - set(manifest)
    assert set(steps) <= written, set(steps) - written
    assert set(documented) <= set(sidecar), set(documented) - set(sidecar)


def test_readme_is_a_readme_and_its_links_resolve():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) < 200
    targets = re.findall(r"\]\(([^)#]+)\)", text)
    assert len(targets) > 15
    for target in targets:
        if target.startswith("http"):
            continue
        assert (ROOT / target).exists(), target


def test_the_readmes_command_table_lists_every_command():
    import click

    from inspect_validate.cli import cli

    text = (ROOT / "README.md").read_text()
    table = text.split("## The commands", 1)[1].split("\n## ", 1)[0]
    listed = set(re.findall(r"^\| `inspect-validate ([a-z-]+)", table, re.M))
    assert listed == set(cli.list_commands(click.Context(cli)))


def test_ci_runs_the_readmes_test_command_as_printed():
    """The quick start's second command is what CI runs, word for word: CI that installs
    more than the README says hid a test command that failed on a fresh machine."""
    text = (ROOT / "README.md").read_text()
    quick = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    commands = re.findall(r"```sh\n(.*?)\n```", quick, re.S)
    assert len(commands) == 2 and "pytest" in commands[1]
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert commands[1] in ci
    # Everything the tests import is in the test extra (docutils came only with docs).
    extras = (ROOT / "pyproject.toml").read_text().split("\ntest = [", 1)[1].split("]", 1)[0]
    assert '"docutils' in extras


def test_every_manual_page_is_in_the_manual():
    # Sphinx warns (an error with -W) about a page outside every toctree; this names it
    # without a docs build. Each section has a page of its own whose toctree lists its
    # pages (the theme's "Section navigation" shows that list beside every page of it).
    listed = set()
    for page in DOCS.rglob("*.md"):
        folder = page.relative_to(DOCS).parent.as_posix()
        for block in re.findall(r"```\{toctree\}\n(.*?)```", page.read_text(), re.S):
            for entry in block.splitlines():
                if entry and not entry.startswith(":"):
                    absolute = entry[1:] if entry.startswith("/") else f"{folder}/{entry}"
                    listed.add(absolute.removeprefix("./"))
    for page in DOCS.rglob("*.md"):
        rel = page.relative_to(DOCS).with_suffix("").as_posix()
        if rel == "index" or rel.startswith(("_build", "auto_examples", "reference/generated")):
            continue
        assert rel in listed, rel
    for section in ("guide", "formats", "reference"):
        assert f"\n{section}/index\n" in (DOCS / "index.md").read_text()


def test_format_pages_hold_their_models_tables_as_written(monkeypatch):
    """The format pages read in a checkout (they were a directive only, empty there):
    each generated block is what its model makes now (run python
    docs/_ext/file_models.py after changing a model)."""
    monkeypatch.syspath_prepend(str(DOCS / "_ext"))
    from file_models import render_page

    blocks = 0
    for page in sorted((DOCS / "formats").glob("*.md")):
        text = page.read_text()
        blocks += text.count("<!-- /file-model -->")
        assert render_page(text) == text, f"{page.name}: run python docs/_ext/file_models.py"
    assert blocks == 6
    capture = (DOCS / "guide" / "capture.md").read_text()
    assert "<!-- /health-table -->" in capture
    assert render_page(capture) == capture, "capture.md: run python docs/_ext/file_models.py"
    station = (DOCS / "formats" / "station.md").read_text()
    assert "| `frames` | integer (1 ≤ x ≤ 100 000) | `4` | Frames per illumination" in station


def test_format_pages_read_each_fields_docstring_and_constraints(monkeypatch):
    # The format pages come from the models; a field's docstring is its meaning (read by
    # the docs build, not by pydantic at import: that cost the command line 50 ms).
    monkeypatch.syspath_prepend(str(DOCS / "_ext"))
    from file_models import model_rst

    from inspect_validate.camera.controllers.gardasoft import GardasoftSettings
    from inspect_validate.config import field_docs
    from inspect_validate.station.file import Station

    assert field_docs(Station)["frames"].startswith("Frames per illumination")
    controller = field_docs(GardasoftSettings)  # a field of its base too
    assert controller["timeout_s"].startswith("How long to wait for a reply")
    assert controller["port"].startswith("Serial port")
    text = "\n".join(model_rst(Station, "station file"))
    assert (
        "* - `frames`\n  - integer (1 ≤ x ≤ 100 000)\n  - `4`\n  - Frames per illumination" in text
    )
    assert "camera (genicam)" in text and "controller (gardasoft)" in text
    # A backend's section is its settings and the station's keys: the docs read both.
    assert "* - `camera.cti`" in text or "`cti`" in text
    assert "which of the scene's cameras" in text.lower()


def test_own_station_page_runs_as_written(tmp_path):
    """Every command of "Your own station, step by step", in order, on pylon's emulator:
    no coordinate typed, and verify passes."""
    import os
    import shlex
    import subprocess
    import sys

    import pytest

    pytest.importorskip("pypylon")
    page = (DOCS / "guide" / "own-station.md").read_text()
    blocks = re.findall(r"```console\n(.*?)```", page, re.S)
    commands = [
        line[2:] for block in blocks for line in block.splitlines() if line.startswith("$ ")
    ]
    assert [c.split()[1] for c in commands if c.startswith("inspect-validate")] == [
        "devices",
        "init",
        "capture",
        "rois",
        "rois",
        "rois",
        "predict",
        "verify",
        "train",
        "watch",
    ]
    (tmp_path / "sample_images").symlink_to(ROOT / "sample_images")
    env = dict(os.environ)
    for command in commands:
        words = shlex.split(command)
        if words[0] == "export":
            key, _, value = words[1].partition("=")
            env[key] = value
            continue
        assert words[0] == "inspect-validate"
        run = subprocess.run(
            [sys.executable, "-m", "inspect_validate", *words[1:]],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert run.returncode == 0, f"{command}\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}"
        if words[1] == "verify":
            assert "PASS" in run.stdout
        if words[1] == "devices":
            assert "Basler" in run.stdout and "exposure (exposure_us)" in run.stdout
    assert "coordinate" not in (tmp_path / "my" / "rois.yaml").read_text()
    assert (tmp_path / "my" / "rois.png").is_file() and (
        tmp_path / "my" / "rois-check.png"
    ).is_file()


def test_the_running_line_page_runs_as_written(tmp_path):
    """Every command of "On the running line"'s walkthrough, in order, on the simulated
    line: the verdict passes and the watch's cycles are in its history."""
    import shlex
    import subprocess
    import sys

    page = (DOCS / "guide" / "production.md").read_text()
    block = re.search(r"## From a reference frame to a watch.*?```console\n(.*?)```", page, re.S)
    commands = [line[2:] for line in block[1].splitlines() if line.startswith("$ ")]
    assert [c.split()[1] for c in commands] == [
        "capture", "train", "capture", "verify", "watch", "history"
    ]  # fmt: skip
    (tmp_path / "sample_images").symlink_to(ROOT / "sample_images")
    for command in commands:
        words = shlex.split(command)
        run = subprocess.run(
            [sys.executable, "-m", "inspect_validate", *words[1:]],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert run.returncode == 0, f"{command}\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}"
        if words[1] == "verify":
            assert "PASS" in run.stdout
    assert (tmp_path / "line" / "report" / "report.html").is_file()
    assert "cycles 0–2" in run.stdout
    # The same frames by the station of frames alone.
    block = re.search(r"station of\nframes alone.*?```console\n(.*?)```", page, re.S)
    commands = [line[2:] for line in block[1].splitlines() if line.startswith("$ ")]
    assert [c.split()[1] for c in commands] == ["train", "verify"]
    for command in commands:
        run = subprocess.run(
            [sys.executable, "-m", "inspect_validate", *shlex.split(command)[1:]],
            cwd=tmp_path, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert run.returncode == 0, f"{command}\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}"
    assert "PASS" in run.stdout


def test_the_field_page_runs_as_written(tmp_path):
    """Every command of "The station's field", in order, on the shipped vignetted station:
    the copy, the two targets, characterize, and a verify that passes; the same station
    without its field fails its SNR_dB agreement, as the page says."""
    import shlex
    import shutil
    import subprocess
    import sys

    page = (DOCS / "guide" / "field.md").read_text()
    block = re.search(r"## From the targets to the checks.*?```console\n(.*?)```", page, re.S)
    commands = [line[2:] for line in block[1].splitlines() if line.startswith("$ ")]
    assert [c.split()[1] for c in commands] == [
        "-r", "capture", "capture", "characterize", "verify"
    ]  # fmt: skip
    (tmp_path / "sample_images").symlink_to(ROOT / "sample_images")
    for command in commands:
        words = shlex.split(command)
        if words[0] == "cp":  # the one shell command: the samples copied
            shutil.copytree(tmp_path / words[2], tmp_path / words[3])
            continue
        run = subprocess.run(
            [sys.executable, "-m", "inspect_validate", *words[1:]],
            cwd=tmp_path, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert run.returncode == 0, f"{command}\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}"
    assert "PASS" in run.stdout and "amber: lens MTF50" in run.stdout
    station = tmp_path / "work" / "field" / "station.yaml"
    station.write_text(station.read_text().replace("field: cal/field.json", ""))
    run = subprocess.run(
        [sys.executable, "-m", "inspect_validate", "verify", str(station)],
        cwd=tmp_path, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 1, run.stdout[-2000:] + run.stderr[-2000:]
    assert re.search(r"FAIL +amber: A vs B SNR_dB deviation", run.stdout)


def test_the_several_cameras_page_runs_as_written(tmp_path):
    """Every command of "Several cameras", in order, on the shipped two-camera station:
    each camera's frames in its folder, and the station's one verdict passes; each camera
    trained, and the two watched together into one history."""
    import shlex
    import subprocess
    import sys

    page = (DOCS / "guide" / "cameras.md").read_text()
    (tmp_path / "sample_images").symlink_to(ROOT / "sample_images")

    def run_block(heading, expected):
        block = re.search(rf"## {heading}.*?```console\n(.*?)```", page, re.S)
        commands = [line[2:] for line in block[1].splitlines() if line.startswith("$ ")]
        assert [c.split()[1] for c in commands] == expected
        for command in commands:
            run = subprocess.run(
                [sys.executable, "-m", "inspect_validate", *shlex.split(command)[1:]],
                cwd=tmp_path,
                capture_output=True,
                text=True,
                timeout=600,
            )
            assert run.returncode == 0, f"{command}\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}"
        return run.stdout

    out = run_block("Capture: one trigger", ["capture", "verify"])
    assert "PASS: 2 cameras, every camera passed" in out
    for name in ("top", "side"):
        assert (tmp_path / "two" / "frames" / name / "manifest.json").is_file()
        assert (tmp_path / "two" / "report" / name / "report.html").is_file()
    out = run_block("Watch: every camera", ["train", "train", "watch", "history"])
    assert "3 pass, 0 fail, 0 drift, 0 error" in out and "side amber: A μ [DN]" in out


FORMAT_MODELS = [
    "inspect_validate.station.file:Station",
    "inspect_validate.scene_file:SceneFile",
    "inspect_validate.components.camera_file:_file_model",
    "inspect_validate.verification.golden:Golden",
    "inspect_validate.roi.file:_FileModel",
    "inspect_validate.roi.file:_ShapeModel",
]


def test_every_key_of_every_format_page_has_a_meaning_and_a_readable_type(monkeypatch):
    """Each row of each format page says what the key means, and its type reads as a
    person writes it (it read "text (at least 1 long, at most 100 long, matches
    `^[^,]+$`)"; 63 keys had no meaning). The pages' directives name these models."""
    import importlib

    from pydantic import BaseModel

    monkeypatch.syspath_prepend(str(DOCS / "_ext"))
    from file_models import model_rst

    pages = "\n".join(p.read_text() for p in (DOCS / "formats").glob("*.md"))
    named = set(re.findall(r"<!-- file-model (\S+)", pages))
    assert named == set(FORMAT_MODELS)
    empty, unreadable = [], []
    for target in FORMAT_MODELS:
        module, _, name = target.partition(":")
        model = getattr(importlib.import_module(module), name)
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            model = model()
        lines = model_rst(model, "top")
        where = "top"
        for i, line in enumerate(lines):
            if line.startswith("```{rubric}"):
                where = line.removeprefix("```{rubric} ")
            if not line.startswith("* - `"):
                continue
            row = f"{name}: {where}: {line[4:]}"
            if not lines[i + 3].removeprefix("  - ").strip():
                empty.append(row)
            kind = lines[i + 1]
            if re.search(r"\d long|matches `|\) \(|≥ \d+, ≤", kind):
                unreadable.append(f"{row}: {kind}")
    assert not empty, "keys without a meaning:\n" + "\n".join(empty)
    assert not unreadable, "types not in words:\n" + "\n".join(unreadable)


def _named_items(text: str) -> set[str]:
    """The first word of each comma-separated item of a layout row's text, outside
    parentheses: the modules (or folders) the row names."""
    items, depth, current = [], 0, ""
    for ch in text:
        depth += (ch == "(") - (ch == ")")
        if ch == "," and depth == 0:
            items.append(current)
            current = ""
        else:
            current += ch if depth == 0 and ch not in "()" else ""
    items.append(current)
    words = (re.match(r"\s*(?:one module per command|and)?\s*`?([\w/]+)`?", i) for i in items)
    return {w.group(1).rstrip("/") for w in words if w}


def test_the_development_pages_layout_is_the_tree():
    """The layout table of docs/development.md names every module of each package (a
    private one at least in backticks), and nothing that is not there: it listed a
    cli.py, a components/cameras and report tables that did not exist, and left out six
    of the eleven verification modules."""
    rows = _table_keys(DOCS / "development.md", "## Layout")
    problems = []
    for where, text in rows.items():
        folder = ROOT / where
        if not where.endswith("/"):
            problems += [] if folder.exists() else [f"{where} named but not in the tree"]
            continue
        if where in ("tests/", "sample_images/", "docs/"):
            continue
        if where == "inspect_validate/":
            modules = {p.stem for p in folder.glob("*.py")} - {"__init__", "__main__"}
            named = _named_items(text)
        else:
            modules = {p.stem for p in folder.glob("*.py")} - {"__init__"}
            modules |= {p.name for p in folder.iterdir() if (p / "__init__.py").exists()}
            named = _named_items(text.split(":", 1)[1] if where == "camera/" else text)
        if where == "inspect_validate/cli/":
            named = set(re.findall(r"\b([a-z_]+)\b", text)) & modules
        public = {m for m in modules if not m.startswith("_")}
        missing = public - named
        private = {m for m in modules - public if f"`{m}`" not in text}
        stray = named - modules
        problems += [f"{where}: {m} not in the table" for m in sorted(missing | private)]
        problems += [f"{where}: {m} named but not in the tree" for m in sorted(stray)]
    packages = {p.parent.name for p in (ROOT / "inspect_validate").glob("*/__init__.py")}
    listed = {
        w.split("/")[1] for w in rows if w.startswith("inspect_validate/") and w.count("/") == 2
    }
    problems += [f"inspect_validate/{p}/ has no row" for p in sorted(packages - listed)]
    assert problems == []


def _resolves(ref: str) -> bool:
    """Whether a dotted name is a module, or an attribute or dataclass field of one."""
    import dataclasses
    import importlib

    parts = ref.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            fields = (
                {f.name for f in dataclasses.fields(obj)}
                if dataclasses.is_dataclass(obj)
                else set()
            )
            if attr in fields and attr == parts[-1]:
                return True
            if not hasattr(obj, attr):
                return False
            obj = getattr(obj, attr)
        return True
    return False


def test_every_cross_reference_in_the_docstrings_names_what_exists():
    """A :class:/:func:/:meth:/:mod: reference by full name in the package's docstrings
    names a module, class, function or field that exists: four pointed at code that was
    gone (camera.station.Station, camera.grabbers.simulated, inspect_validate.camera.capture
    .capture, camera.lights.gardasoft), which the built manual prints as plain text."""
    pattern = re.compile(
        r":(?:class|func|meth|mod|attr|data|exc):`~?((?:inspect_validate|camera)\.[\w.]+)`"
    )
    files = [*ROOT.glob("inspect_validate/**/*.py"), *ROOT.glob("camera/**/*.py")]
    dead = []
    for path in sorted(files):
        text = path.read_text()
        for m in pattern.finditer(text):
            ref = m.group(1)
            full = f"inspect_validate.{ref}" if ref.startswith("camera.") else ref
            if not _resolves(full):
                dead.append(
                    f"{path.relative_to(ROOT)}:{text[: m.start()].count(chr(10)) + 1}: {ref}"
                )
    assert dead == []
