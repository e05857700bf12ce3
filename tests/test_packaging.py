"""What users install is what the tests run: the wheel holds every module of the source tree.

The tests import the project from an editable install, which finds every module whatever
``pyproject.toml`` lists; a wheel holds only the listed packages. A package left off the
list (``inspect_validate.watch`` once was) breaks a normal install and no other test.
"""

import shutil
import subprocess
import sys
import zipfile

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
        if name.endswith(".py"):
            top, _, rest = name.partition("/")
            modules.add(f"{_ROOTS[top]}/{rest}")
    return modules


def test_wheel_holds_every_module(tmp_path):
    # Built from a copy: setuptools reuses the checkout's build/ folder, whose stale
    # modules would hide a package the list leaves out.
    source = tmp_path / "source"
    shutil.copytree(
        ROOT, source, ignore=shutil.ignore_patterns(".git", "build", "*.egg-info", "__pycache__")
    )
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp_path), str(source)],
        check=True,
        capture_output=True,
    )
    (wheel,) = tmp_path.glob("inspect_validate-*.whl")
    in_wheel = set(zipfile.ZipFile(wheel).namelist())
    modules = _tracked_modules()
    assert "inspect_validate/watch/loop.py" in modules  # the list is the tree's, not empty
    assert sorted(modules - in_wheel) == []
