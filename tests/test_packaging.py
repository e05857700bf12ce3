"""What users install is what the tests run: the wheel holds every module of the source tree.

The tests import the project from an editable install, which finds every module whatever
``pyproject.toml`` lists; a wheel holds only the listed packages. A package left off the
list (``inspect_validate.watch`` once was) breaks a normal install and no other test.
"""

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from conftest import ROOT

# Source folder → the package it is installed as (pyproject's package-dir).
_ROOTS = {"inspect_validate": "inspect_validate", "camera": "inspect_validate/camera"}


def _tracked_modules() -> set[str]:
    listed = subprocess.run(
        ["git", "ls-files", "--", *_ROOTS],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    modules = set()
    for name in listed:
        if name.endswith(".py") or "/static/" in name:  # the report's embedded scripts too
            top, _, rest = name.partition("/")
            modules.add(f"{_ROOTS[top]}/{rest}")
    return modules


def _build_wheel(tmp_path):
    """The wheel built from a copy of the checkout: setuptools reuses the checkout's
    build/ folder, whose stale modules would hide a package the list leaves out."""
    source = tmp_path / "source"
    shutil.copytree(
        ROOT,
        source,
        ignore=shutil.ignore_patterns(".git", "build", "_build", "*.egg-info", "__pycache__"),
    )
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp_path), str(source)],
        check=True,
        capture_output=True,
    )
    (wheel,) = tmp_path.glob("inspect_validate-*.whl")
    return wheel


def test_wheel_holds_every_module(tmp_path):
    wheel = _build_wheel(tmp_path)
    in_wheel = set(zipfile.ZipFile(wheel).namelist())
    modules = _tracked_modules()
    assert "inspect_validate/watch/loop.py" in modules  # the list is the tree's, not empty
    assert "inspect_validate/report/static/uPlot.iife.min.js" in modules
    assert sorted(modules - in_wheel) == []


@pytest.mark.slow
def test_every_command_runs_from_the_installed_wheel(tmp_path):
    """The wheel installed (not editable) in a fresh virtual environment, its
    dependencies taken from this one: every command runs from it on the shipped samples
    — predict, analyze-spectra, measure, capture, verify, train, watch, history, design,
    characterize — and the package imported is the wheel's."""
    import os

    wheel = _build_wheel(tmp_path)
    env_dir = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(env_dir)], check=True)
    python = env_dir / "bin" / "python"
    # The dependencies are this environment's, whatever the base interpreter holds
    # (--system-site-packages gives the base's, which may lack them). Paths in a .pth
    # file are added after the venv's own site-packages, and their own .pth files are
    # not run, so this checkout's editable install does not shadow the wheel.
    own = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    ours = [p for p in sys.path if p.endswith(("site-packages", "dist-packages"))]
    (Path(own) / "dependencies.pth").write_text("\n".join(ours) + "\n")
    subprocess.run(
        [str(python), "-m", "pip", "install", "-q", "--no-deps", str(wheel)],
        check=True,
        capture_output=True,
    )
    work = tmp_path / "work"
    work.mkdir()
    # Outside the checkout, so that nothing is imported from the source tree.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    where = subprocess.run(
        [str(python), "-c", "import inspect_validate.watch.loop as m; print(m.__file__)"],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert where.startswith(str(env_dir)), where
    samples = ROOT / "sample_images"
    station = shutil.copy(samples / "station" / "station.yaml", work / "station.yaml")
    shutil.copy(samples / "station" / "rois.yaml", work / "rois.yaml")
    text = (work / "station.yaml").read_text()
    (work / "station.yaml").write_text(text.replace("../scenes/", f"{samples / 'scenes'}/"))
    script = env_dir / "bin" / "inspect-validate"
    commands = [
        ["predict", samples / "scenes" / "paperboard" / "scene.yaml"],
        ["analyze-spectra", samples / "scenes" / "paperboard" / "scene.yaml"],
        [
            "measure",
            samples / "paperboard" / "optimized.png",
            "--rois",
            samples / "paperboard" / "rois.yaml",
        ],
        ["capture", station, "--out", "cap"],
        ["verify", station, "--frames", "cap", "--report", "report"],
        ["train", station, "--out", "golden.json", "--repeats", 5],
        ["watch", station, "--golden", "golden.json", "--cycles", 1, "--interval", 0],
        ["history", "watch-station/history.sqlite"],
        ["design", samples / "scenes" / "mix" / "scene.yaml"],
        ["characterize", station, "--out", "series"],
    ]
    for args in commands:
        done = subprocess.run(
            [str(script), *map(str, args)], cwd=work, env=env, capture_output=True, text=True
        )
        assert done.returncode == 0, (args, done.stdout[-2000:], done.stderr[-2000:])
        assert "Traceback" not in done.stderr, (args, done.stderr)
