"""Each input read once per command: a bench ``verify`` of a capture folder reads the
station file, the scene file and the ROI file once each, and each frame's sidecar once
(the capture's audit reads it; every later reader gets what it read). Counted with
Python's audit hook on every file the process opens."""

import sys
from collections import Counter
from pathlib import Path

from conftest import copy_station, run_cli

_OPENED: Counter | None = None  # counting while set; the hook stays (it cannot be removed)


def _hook(event, args):
    if _OPENED is not None and event == "open" and isinstance(args[0], (str, Path)):
        _OPENED[Path(args[0]).resolve()] += 1


sys.addaudithook(_hook)


def test_a_bench_verify_reads_the_station_scene_and_each_sidecar_once(tmp_path):
    global _OPENED
    station = copy_station(tmp_path)
    assert run_cli(["capture", station, "--out", tmp_path / "cap"]) == 0
    _OPENED = Counter()
    try:
        run_cli(["verify", station, "--frames", tmp_path / "cap", "--report", tmp_path / "r"])
    finally:
        opened, _OPENED = _OPENED, None
    sidecars = sorted((tmp_path / "cap").glob("*/frame_*.json"))
    assert len(sidecars) == 12
    assert {opened[p.resolve()] for p in sidecars} == {1}, {
        p.name: opened[p.resolve()] for p in sidecars
    }
    scene = next(p for p in opened if p.name == "scene.yaml")
    for path in (station, scene, tmp_path / "rois.yaml"):
        assert opened[Path(path).resolve()] == 1, (path, opened[Path(path).resolve()])
