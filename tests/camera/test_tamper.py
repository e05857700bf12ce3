"""Captures changed after they were written: `verify` and `train` refuse them (exit 2),
naming the folder and what disagrees, instead of giving a verdict on other frames
than the camera's. Each frame's SHA-256 is in the manifest; sidecars, the TIFFs' own
descriptions and the counts are cross-checked."""

import json
import shutil

import pytest
from conftest import copy_station, run_cli


@pytest.fixture(scope="module")
def captured(tmp_path_factory):
    """A station copy and one complete capture of it."""
    folder = tmp_path_factory.mktemp("tamper")
    path = copy_station(folder)
    assert run_cli(["capture", path, "--out", folder / "cap"]) == 0
    return path, folder / "cap"


def _copy(captured, tmp_path):
    path, cap = captured
    shutil.copytree(cap, tmp_path / "cap")
    return path, tmp_path / "cap"


def _delete(cap):
    (cap / "amber" / "frame_0003.tif").unlink()
    (cap / "amber" / "frame_0003.json").unlink()


def _recount(cap):  # a step marked complete with fewer frames, its manifest edited to match
    _delete(cap)
    manifest = json.loads((cap / "manifest.json").read_text())
    manifest["steps"]["amber"]["frames"] = 3
    (cap / "manifest.json").write_text(json.dumps(manifest))


def _duplicate(cap):
    for ext in ("tif", "json"):
        shutil.copy(cap / "amber" / f"frame_0001.{ext}", cap / "amber" / f"frame_0002.{ext}")


def _red_in_amber(cap):  # the TIFF alone: its sidecar still says amber
    shutil.copy(cap / "red" / "frame_0002.tif", cap / "amber" / "frame_0002.tif")


def _red_with_sidecar(cap):
    for ext in ("tif", "json"):
        shutil.copy(cap / "red" / f"frame_0002.{ext}", cap / "amber" / f"frame_0002.{ext}")


def _flip(cap):
    frame = cap / "dark" / "frame_0004.tif"
    data = bytearray(frame.read_bytes())
    data[-100] ^= 0x10
    frame.write_bytes(bytes(data))


def _manifest(cap, edit):
    manifest = json.loads((cap / "manifest.json").read_text())
    edit(manifest)
    (cap / "manifest.json").write_text(json.dumps(manifest))


def _unhash(cap):  # one step's hashes deleted: the audit must not quietly turn off
    _manifest(cap, lambda m: m["steps"]["amber"].pop("sha256"))
    _flip(cap)


def _text_count(cap):
    _manifest(cap, lambda m: m["steps"]["amber"].update(frames="4"))


def _fifo(cap):  # a pipe would block the audit's read for ever
    import os

    (cap / "amber" / "frame_0002.tif").unlink()
    os.mkfifo(cap / "amber" / "frame_0002.tif")


def _fifo_sidecar(cap):
    import os

    (cap / "amber" / "frame_0003.json").unlink()
    os.mkfifo(cap / "amber" / "frame_0003.json")


def _fifo_manifest(cap):
    import os

    (cap / "manifest.json").unlink()
    os.mkfifo(cap / "manifest.json")


def _added(cap):
    for ext in ("tif", "json"):
        shutil.copy(cap / "amber" / f"frame_0004.{ext}", cap / "amber" / f"frame_0005.{ext}")


@pytest.mark.parametrize(
    ("tamper", "named"),
    [
        (_delete, "amber: the manifest records 4 frames, the folder holds 3"),
        (_recount, "amber: frame_0003.tif recorded but missing"),
        (_duplicate, "amber/frame_0002.tif is the same frame as amber/frame_0001.tif"),
        (_red_in_amber, "amber/frame_0002.tif: the TIFF's description and the sidecar disagree"),
        (_red_with_sidecar, "amber/frame_0002.tif: its sidecar is of red/frame_0002.tif"),
        (_flip, "dark/frame_0004.tif changed since it was written"),
        (_added, "amber: frame_0005.tif not written by this capture"),
        (_unhash, "amber: the manifest's frame hashes (sha256) are missing or damaged"),
        (_text_count, "amber: the manifest's frame count '4' is not a whole number"),
        (_fifo, "amber/frame_0002.tif is not a regular file"),
        (_fifo_sidecar, "amber/frame_0003.tif: its sidecar frame_0003.json is not a regular file"),
        (_fifo_manifest, "the capture's manifest is damaged (not a regular file)"),
    ],
)
def test_verify_refuses_a_tampered_capture_naming_what_disagrees(
    cli, tmp_path, captured, tamper, named
):
    path, cap = _copy(captured, tmp_path)
    tamper(cap)
    code, out, err = cli(["verify", path, "--frames", cap])
    assert code == 2, out + err
    assert named in err and str(cap) in err and "PASS" not in out


def test_the_untouched_capture_passes_and_one_without_hashes_is_refused(cli, tmp_path, captured):
    """Frames rewritten 16× with their hashes removed were measured ('lower the
    exposure'); then the same with the manifest edited back to version 1, as a build
    before hashes wrote it. Without hashes nothing tells a rewritten frame from the one
    captured, so no manifest is read without them, whatever version it claims."""
    path, cap = _copy(captured, tmp_path)
    code, out, err = cli(["verify", path, "--frames", cap])
    assert code == 0, out + err
    manifest = json.loads((cap / "manifest.json").read_text())
    assert all(len(step["sha256"]) == step["frames"] for step in manifest["steps"].values())
    for step in manifest["steps"].values():
        del step["sha256"]
    for version in (2, 1):
        manifest["schema_version"] = version
        (cap / "manifest.json").write_text(json.dumps(manifest))
        code, out, err = cli(["verify", path, "--frames", cap])
        assert code == 2 and "frame hashes (sha256) are missing" in err, out + err
        assert "capture again" in err


def test_a_frame_added_under_empty_hashes_is_refused(cli, tmp_path, captured):
    """A step whose hash record was emptied ({}) still names every frame as not written
    by the capture (the comparison ran only on a non-empty record)."""
    path, cap = _copy(captured, tmp_path)
    manifest = json.loads((cap / "manifest.json").read_text())
    step = next(iter(manifest["steps"]))
    manifest["steps"][step]["sha256"] = {}
    (cap / "manifest.json").write_text(json.dumps(manifest))
    code, out, err = cli(["verify", path, "--frames", cap])
    assert code == 2 and "not written by this capture" in err, out + err


def test_train_refuses_the_same_capture_twice(cli, tmp_path, captured):
    path, cap = _copy(captured, tmp_path)
    shutil.copytree(cap, tmp_path / "again")
    code, out, err = cli(
        [
            "train",
            path,
            "--out",
            tmp_path / "g.json",
            "--frames",
            cap,
            "--frames",
            tmp_path / "again",
        ]
    )
    assert code == 2 and "the same capture given twice" in err, out + err
    assert not (tmp_path / "g.json").exists()
