"""Backends as plugins: the camera package the manual shows ("A camera or controller of
your own") is built, installed into a folder of its own and captured through, in a
process that finds it by its entry point; a plugin that does not load is named when a
station asks for it. The code is read from the manual, so the manual's example runs."""

import json
import os
import re
import subprocess
import sys

import pytest
import yaml
from conftest import ROOT, copy_station

GUIDE = ROOT / "docs" / "guide" / "station.md"
# Offline: the build backend is this environment's setuptools (the test extra's).
PIP_INSTALL = [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation"]


def _manual_files() -> dict[str, str]:
    """File name → content of each code block the guide marks ``<!-- plugin: NAME -->``."""
    text = GUIDE.read_text()
    blocks = re.findall(r"<!-- plugin: (\S+) -->\n```\w+\n(.*?)```", text, re.S)
    assert {name for name, _ in blocks} == {"pyproject.toml", "acme_iv.py"}
    return dict(blocks)


@pytest.fixture(scope="module")
def plugin_site(tmp_path_factory):
    """The manual's plugin, installed with pip into a folder of its own (its entry point
    found by whoever puts it on the path)."""
    source = tmp_path_factory.mktemp("acme-iv")
    for name, content in _manual_files().items():
        (source / name).write_text(content)
    site = tmp_path_factory.mktemp("site")
    done = subprocess.run(
        [*PIP_INSTALL, "--target", str(site), str(source)],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    return site


def _run(args, site, cwd):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(site)]))}
    return subprocess.run(
        [sys.executable, "-m", "inspect_validate", *map(str, args)],
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd,
    )


def _station(tmp_path, camera):
    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["camera"] = camera
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@pytest.mark.slow
def test_a_plugin_camera_captures_as_a_shipped_one(tmp_path, plugin_site):
    path = _station(tmp_path, {"backend": "acme", "serial": "ACME-7", "exposure_us": 2000})
    done = _run(["capture", path, "--out", tmp_path / "cap"], plugin_site, tmp_path)
    assert done.returncode == 0, done.stderr
    manifest = json.loads((tmp_path / "cap" / "manifest.json").read_text())
    assert manifest["camera"]["name"] == "Acme camera (serial ACME-7)"
    assert manifest["camera"]["not_applied"] == []  # no gain was asked for
    for step in ("amber", "red", "dark"):
        assert manifest["steps"][step]["complete"]
        assert len(list((tmp_path / "cap" / step).glob("frame_*.tif"))) == 4
    sidecar = json.loads((tmp_path / "cap" / "amber" / "frame_0001.json").read_text())
    assert sidecar["device"] == "Acme camera (serial ACME-7)" and sidecar["exposure_us"] == 2000
    # its keys are validated like a shipped backend's
    path = _station(tmp_path, {"backend": "acme", "serail": "x"})
    done = _run(["capture", path, "--out", tmp_path / "cap2"], plugin_site, tmp_path)
    assert done.returncode == 2 and "camera.serail" in done.stderr, done.stderr


def test_without_the_plugin_its_backend_is_unknown(tmp_path):
    path = _station(tmp_path, {"backend": "acme"})
    done = _run(["capture", path, "--out", tmp_path / "cap"], None, tmp_path)
    assert done.returncode == 2
    assert "camera: backend must be one of aravis, genicam, none, pylon, replay" in done.stderr


def test_a_plugin_that_does_not_load_is_named(tmp_path):
    """An installed entry point whose module is missing: the shipped backends still work,
    and a station asking for it is told which and why."""
    site = tmp_path / "site"
    info = site / "broken_iv-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-iv\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(
        "[inspect_validate.cameras]\nbroken = broken_iv_missing:BACKEND\n"
    )
    path = _station(tmp_path, {"backend": "broken"})
    done = _run(["capture", path, "--out", tmp_path / "cap"], site, tmp_path)
    assert done.returncode == 2, done.stderr
    assert "backend 'broken' is installed but cannot be used" in done.stderr
    assert "broken_iv_missing:BACKEND does not load" in done.stderr
    (tmp_path / "good").mkdir()
    good = copy_station(tmp_path / "good")
    done = _run(["capture", good, "--out", tmp_path / "ok"], site, tmp_path)
    assert done.returncode == 0, done.stderr
