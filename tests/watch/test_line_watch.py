"""``watch --production`` on the simulated line: batches of parts from the station's camera
or from a folder the line's program writes into (files taken whole, in order, once;
frames that land faster than measured dropped and counted), charted against golden parts;
a dimmer light drifts with its cause named; unreadable files and frames of another size
are counted, not fatal; a bench golden file is refused."""

import itertools
import json
import shutil
import sqlite3
import threading
import time

import pytest
from conftest import line_frames, line_station, run_cli

PARTS = 10


@pytest.fixture(scope="module")
def line_golden(tmp_path_factory):
    """A golden file of 120 good parts of the line (batches of 10 chart against it)."""
    tmp = tmp_path_factory.mktemp("line-golden")
    station = line_station(tmp / "good")
    path = tmp / "golden.json"
    frames = line_frames(station, tmp / "g", parts=120)
    assert run_cli(["train", station, "--production", "--frames", frames, "--out", path]) == 0
    return path


def _charts(db):
    with sqlite3.connect(db) as con:
        keys = con.execute("SELECT DISTINCT kind, quantity FROM points").fetchall()
        cycles = con.execute("SELECT cycle, status, reason, cause FROM cycles").fetchall()
    return set(keys), cycles


def test_the_cameras_batches_are_charted_with_focus_and_position(cli, tmp_path, line_golden):
    station = line_station(tmp_path / "s", parts=PARTS)
    db = tmp_path / "w" / "h.sqlite"
    code, out, err = cli(["watch", station, "--production", "--golden", line_golden, "--db", db,
                          "--cycles", 2, "--interval", 0])  # fmt: skip
    assert code == 0, out + err
    keys, cycles = _charts(db)
    assert {("class", "focus"), ("pose", "x"), ("pose", "angle"), ("comparison", "snr_db"),
            ("field", "slope_x"), ("field", "slope_y")} <= keys  # fmt: skip
    assert [c[1] for c in cycles] == ["pass", "pass"]
    status = json.loads((tmp_path / "w" / "status.json").read_text())
    assert any(v["kind"] == "pose" for v in status["values"])


def test_a_dimmer_light_drifts_with_its_cause(cli, tmp_path, line_golden):
    station = line_station(tmp_path / "s", parts=PARTS, irradiance={1: 0.97})
    db = tmp_path / "w" / "h.sqlite"
    code, out, _ = cli(["watch", station, "--production", "--golden", line_golden, "--db", db,
                        "--cycles", 2, "--interval", 0])  # fmt: skip
    assert code == 1, out
    _, cycles = _charts(db)
    assert cycles[-1][1] == "drift" and "dimmer by" in cycles[-1][3], cycles


def test_a_shade_on_the_lens_moves_the_fields_chart(cli, tmp_path, line_golden):
    """A speck of dust over the frame's upper edge (σ 150 px, 30 % at its centre), which
    the golden parts never had: the upper band's μ now falls as a part moves up, and its
    field slope along y alarms; /metrics-ready values carry it under kind "field"."""
    dust = [{"x": 0.5, "y": 0.0, "radius_px": 150, "depth": 0.3}]
    station = line_station(tmp_path / "s", parts=PARTS, dust=dust)
    db = tmp_path / "w" / "h.sqlite"
    code, out, _ = cli(["watch", station, "--production", "--golden", line_golden, "--db", db,
                        "--cycles", 2, "--interval", 0])  # fmt: skip
    assert code == 1, out
    with sqlite3.connect(db) as con:
        alarmed = con.execute(
            "SELECT name, quantity FROM points WHERE kind = 'field' AND (ewma < low OR ewma > high)"
        ).fetchall()
    assert ("A", "slope_y") in alarmed, alarmed
    status = json.loads((tmp_path / "w" / "status.json").read_text())
    field = {(v["name"], v["quantity"]): v for v in status["values"] if v["kind"] == "field"}
    assert field["A", "slope_y"]["alarm"] and field["A", "slope_y"]["value"] > 0.02
    # the history reads them back, and draws them
    code, out, err = cli(["history", db, "--plot", tmp_path / "plot"])
    assert code == 0 and "slope_y" in (tmp_path / "plot" / "history.html").read_text(), err


def _watched(cli, station, folder, golden, db, cycles, write):
    """``watch --production`` of ``folder`` for ``cycles`` while ``write()``, started half
    a second in, lands the line's frames there: ``(exit code, stdout, stderr)``."""
    writer = threading.Thread(target=lambda: (time.sleep(0.5), write()))
    writer.start()
    try:
        return cli(["watch", station, "--production", "--frames", folder, "--golden", golden,
                    "--db", db, "--cycles", cycles, "--interval", 0])  # fmt: skip
    finally:
        writer.join()


def _write_slowly(frames, folder, *, chunks=4, pause=0.03):
    """Copy each frame into ``folder`` a few bytes at a time, as a camera program that is
    slow to write would (each pause well under the feed's 0.2 s of settling)."""
    for src in frames:
        data = src.read_bytes()
        with open(folder / src.name, "wb") as f:
            for k in range(chunks):
                f.write(data[k * len(data) // chunks : (k + 1) * len(data) // chunks])
                f.flush()
                time.sleep(pause)


def test_frames_from_a_folder_are_taken_whole_and_in_order(cli, tmp_path, line_golden):
    """20 frames land in the folder while watch waits: two cycles of 10, no frame read
    half-written; a file already there when the watch started is not new; a file that
    stays cut short and one that is no image are counted, not fatal."""
    station = line_station(tmp_path / "s", parts=PARTS)
    frames = sorted(line_frames(station, tmp_path / "c", parts=2 * PARTS - 2).glob("*.tif"))
    folder = tmp_path / "line"
    folder.mkdir()
    shutil.copy(frames[0], folder / "aaa_old.tif")  # there before the watch: not new
    db = tmp_path / "w" / "h.sqlite"
    code, out, err = _watched(
        cli, station, folder, line_golden, db, 2,
        lambda: (
            (folder / "frame_0000_cut.tif").write_bytes(frames[0].read_bytes()[:5000]),
            (folder / "frame_0000_text.png").write_text("not an image"),
            _write_slowly(frames, folder),
        ),
    )  # fmt: skip
    assert code == 0, out + err
    _, cycles = _charts(db)
    assert [c[1] for c in cycles] == ["pass", "pass"], cycles
    # The two unusable files leave their trace in the passing cycle's reason.
    assert "2 frames not measured: cannot be read" in (cycles[0][2] or ""), cycles


def test_frames_landing_faster_than_measured_are_dropped_and_counted(tmp_path):
    """The feed keeps at most twice a batch waiting: 35 frames landed at once for batches
    of 10 → the 15 oldest dropped, the next 10 taken in the folder's order."""
    from inspect_validate.watch.feed import FolderFeed

    folder = tmp_path / "line"
    folder.mkdir()
    feed = FolderFeed(folder, 10, settle_s=0.0)
    for k in range(35):
        (folder / f"f{k:03d}.npy").write_bytes(b"x" * 100)
    feed.ready()  # first look: sizes noted
    taken, dropped = feed.take()
    assert dropped == 15 and [p.name for p in taken] == [f"f{k:03d}.npy" for k in range(15, 25)]
    taken, dropped = feed.take()
    assert dropped == 0 and [p.name for p in taken] == [f"f{k:03d}.npy" for k in range(25, 35)]
    assert feed.dropped == 15
    feed.ready()
    assert feed.ready() == []  # what was taken or dropped is never offered again


def test_the_feed_takes_numbered_frames_by_number_and_forgets_files_gone(tmp_path):
    """img_9 comes before img_10 (a camera program's counter, unpadded); a name the line's
    program removed is forgotten (the feed remembers what the folder holds, not every
    name of a run of days), and a new frame of that name is new."""
    from inspect_validate.watch.feed import FolderFeed

    folder = tmp_path / "line"
    folder.mkdir()
    feed = FolderFeed(folder, 3, settle_s=0.0)
    for k in (10, 9, 11, 8, 100, 12):
        (folder / f"img_{k}.npy").write_bytes(b"x" * 100)
    feed.ready()
    taken, _ = feed.take()
    assert [p.name for p in taken] == ["img_8.npy", "img_9.npy", "img_10.npy"]
    for path in taken:
        path.unlink()
    feed.ready()
    assert feed._seen == set() and set(feed._changing) == {
        "img_11.npy",
        "img_12.npy",
        "img_100.npy",
    }
    (folder / "img_9.npy").write_bytes(b"y" * 100)  # the counter started again
    feed.ready()
    taken, _ = feed.take()
    assert [p.name for p in taken] == ["img_9.npy", "img_11.npy", "img_12.npy"]
    # The folder emptied (the program cleared it), then the counter started again.
    for path in folder.iterdir():
        path.unlink()
    assert feed.ready() == []  # the empty folder looked at: every name forgotten
    for k in (9, 11, 13):
        (folder / f"img_{k}.npy").write_bytes(b"z" * 100)
    feed.ready()  # sizes noted
    assert [p.name for p in feed.ready()] == ["img_9.npy", "img_11.npy", "img_13.npy"]


def test_the_feed_takes_a_file_once_it_has_settled(tmp_path):
    """A file is taken once its size and time stayed the same for settle_s: not at the
    first look, not at a second look sooner, nor while it still grows; then it is."""
    from inspect_validate.watch.feed import FolderFeed

    folder = tmp_path / "line"
    folder.mkdir()
    feed = FolderFeed(folder, 1, settle_s=1.0)  # a second: no loaded machine stalls so
    frame = folder / "a.npy"
    frame.write_bytes(b"x" * 100)
    assert feed.ready() == [] and feed.ready() == []  # noted, then not yet settled
    time.sleep(0.2)
    with frame.open("ab") as f:  # still being written
        f.write(b"x" * 100)
    time.sleep(0.2)
    assert feed.ready() == []  # grew: its settling starts again
    time.sleep(1.05)
    assert feed.ready() == [frame]


def test_the_feed_says_once_what_it_waits_on_and_only_after_quiet_s(tmp_path):
    """A wait notifies its reason once (not each poll) and only after quiet_s; without
    anyone to notify, a wait simply waits."""
    from inspect_validate.watch.feed import FolderFeed

    folder = tmp_path / "line"
    folder.mkdir()

    def land(after: float):
        time.sleep(after)
        for name in ("a.npy", "b.npy"):
            (folder / name).write_bytes(b"x" * 100)

    for quiet_s, notify in ((0.0, True), (60.0, True), (0.0, False)):
        for path in folder.iterdir():
            path.unlink()
        told: list[str] = []
        feed = FolderFeed(folder, 2, settle_s=0.0, poll_s=0.01, quiet_s=quiet_s,
                          notify=told.append if notify else None)  # fmt: skip
        writer = threading.Thread(target=land, args=(0.3,))
        writer.start()
        taken, _ = feed.take()
        writer.join()
        assert [p.name for p in taken] == ["a.npy", "b.npy"]
        if notify and quiet_s == 0:
            # Once, and again only when the reason changed (1 of 2 between the writes).
            assert told[0] == (
                f"waiting for 0 of 2 new frames in {folder}: no new image file has landed"
            )
            assert len(told) <= 2 and all(a != b for a, b in itertools.pairwise(told)), told
        else:
            assert told == []


def test_the_feed_orders_names_as_a_file_manager_does():
    """Runs of digits by value, digits before letters (as in ASCII and natsort), the name
    itself last."""
    from pathlib import Path

    from inspect_validate.watch.feed import natural_key

    names = ["img_10.png", "img_a.png", "img_9.png", "img_09.png", "img_1b.png", "img_1a.png",
             "b.png", "2.png", "10.png"]  # fmt: skip
    got = sorted((Path(n) for n in names), key=natural_key)
    assert [p.name for p in got] == [
        "2.png", "10.png", "b.png", "img_1a.png", "img_1b.png", "img_09.png", "img_9.png",
        "img_10.png", "img_a.png",
    ]  # fmt: skip


def test_a_file_gone_between_the_listing_and_its_look_leaves_the_rest_taken(tmp_path):
    """The line's program removes a file between the feed's listing and its look at it
    (a race no test can time, so the listing names a file already gone): the files
    after it in the listing are still taken."""
    from inspect_validate.watch.feed import FolderFeed

    folder = tmp_path / "line"
    folder.mkdir()
    feed = FolderFeed(folder, 2, settle_s=0.0)
    for name in ("a.npy", "b.npy"):
        (folder / name).write_bytes(b"x" * 100)
    listing = feed._images
    feed._images = lambda: [folder / "0_gone.npy", *listing()]  # type: ignore[method-assign]
    feed.ready()
    assert [p.name for p in feed.ready()] == ["a.npy", "b.npy"]


def test_the_feed_passes_over_files_that_cannot_be_frames_and_says_what_it_waits_on(tmp_path):
    """A pipe, a link to /dev/zero, an empty file and a loop of links are passed over,
    never opened (a read would block or never end), and the wait says so; a folder
    deleted or replaced by a file is said too; frames landing after are taken."""
    import os

    from inspect_validate.watch.feed import FolderFeed

    folder = tmp_path / "line"
    folder.mkdir()
    told: list[str] = []
    feed = FolderFeed(folder, 2, settle_s=0.0, poll_s=0.01, quiet_s=0.0, notify=told.append)
    os.mkfifo(folder / "a_pipe.tif")
    (folder / "b_zero.tif").symlink_to("/dev/zero")
    (folder / "c_empty.tif").write_bytes(b"")
    (folder / "d_loop.tif").symlink_to(folder / "d_loop.tif")
    for _ in range(4):  # sizes noted, then settled, then looked at again
        assert feed.ready() == []
    assert set(feed.unusable) == {"a_pipe.tif", "b_zero.tif", "c_empty.tif", "d_loop.tif"}
    assert feed.passed_over == 4  # each once, however often the folder is looked at
    why = feed.waiting_on(0)
    assert why.endswith(
        "new files that cannot be frames were passed over (2 not a regular file (a pipe, a "
        "device or a folder); 1 a symbolic link to no file; 1 empty (0 bytes))"
    ) and why.startswith("0 of 2 new frames"), why

    def land():
        while not told:
            time.sleep(0.01)
        for name in ("e.npy", "f.npy"):
            (folder / name).write_bytes(b"x" * 100)

    writer = threading.Thread(target=land)
    writer.start()
    taken, _ = feed.take()
    writer.join()
    assert [p.name for p in taken] == ["e.npy", "f.npy"] and "passed over" in told[0]
    shutil.rmtree(folder)
    assert "the folder is gone" in feed.waiting_on(0)
    folder.write_text("a file")
    assert "it is a file now" in feed.waiting_on(0)


def test_frames_unlike_the_reference_are_the_named_cause_not_missing_parts(
    cli, tmp_path, line_golden
):
    """Frames of another pixel type (float copies of the line's): verify --production
    refuses them naming the type; a watch counts them and names them as the cause, not
    'a wrong reference, a moved camera' (what it said)."""
    import numpy as np
    import tifffile

    station = line_station(tmp_path / "s", parts=PARTS)
    frames = sorted(line_frames(station, tmp_path / "c", parts=PARTS).glob("*.tif"))
    batch = tmp_path / "batch"
    batch.mkdir()
    for path in frames:
        tifffile.imwrite(batch / path.name, tifffile.imread(path).astype(np.float32))
    code, out, err = cli(["verify", station, "--production", "--frames", batch,
                          "--golden", line_golden])  # fmt: skip
    assert code == 2 and "the frame's pixels are float32, the reference's uint" in err, out + err
    folder = tmp_path / "line"
    folder.mkdir()
    db = tmp_path / "w" / "h.sqlite"
    _watched(cli, station, folder, line_golden, db, 1,
             lambda: _write_slowly(sorted(batch.glob("*.tif")), folder))  # fmt: skip
    _, cycles = _charts(db)
    assert cycles[0][1] == "fail", cycles
    assert f"{PARTS} of {PARTS} frames cannot be used" in cycles[0][3], cycles
    assert "the frame's pixels are float32" in cycles[0][3], cycles


def test_a_production_capture_is_read_whole_and_as_it_was_written(cli, tmp_path, line_golden):
    """The capture folder itself is taken (its production step), and refused as the
    bench refuses a capture when a frame was replaced or added since, or a frame is
    there twice; a frame copied among the line's own is refused as one part twice."""
    station = line_station(tmp_path / "s", parts=PARTS)
    step = line_frames(station, tmp_path / "c", parts=PARTS)
    args = ["verify", station, "--production", "--golden", line_golden, "--frames"]
    code, out, err = cli([*args, tmp_path / "c"])
    assert code == 0 and "holds no images" not in err, out + err
    first, second = sorted(step.glob("frame_*.tif"))[:2]
    copy = tmp_path / "copy"
    shutil.copytree(tmp_path / "c", copy)
    shutil.copy(copy / "amber" / first.name, copy / "amber" / second.name)
    code, out, err = cli([*args, copy])
    assert code == 2 and f"amber/{second.name} changed since it was written" in err, err
    extra = tmp_path / "extra"
    shutil.copytree(tmp_path / "c", extra)
    shutil.copy(first, extra / "amber" / "frame_9999.tif")
    code, out, err = cli([*args, extra / "amber"])
    assert code == 2 and "frame_9999.tif not written by this capture" in err, err
    loose = tmp_path / "loose"
    loose.mkdir()
    for path in sorted(step.glob("frame_*.tif")):
        shutil.copy(path, loose / path.name)
    (loose / "zz_link.tif").symlink_to(loose / first.name)
    code, out, err = cli([*args, loose])
    assert code == 2 and f"the same frame as {loose / first.name}" in err, err
    code, out, err = cli(["train", station, "--production", "--frames", loose, "--out",
                          tmp_path / "g.json"])  # fmt: skip
    assert code == 2 and "a part is one frame" in err and not (tmp_path / "g.json").exists()


def test_a_bench_golden_file_or_a_missing_folder_is_refused(cli, tmp_path, golden, line_golden):
    station = line_station(tmp_path / "s", parts=PARTS)
    code, _, err = cli(["watch", station, "--production", "--golden", golden,
                        "--db", tmp_path / "w" / "h.sqlite"])  # fmt: skip
    assert code == 2 and "trained on the bench" in err, err
    code, _, err = cli(["watch", station, "--production", "--golden", line_golden, "--frames",
                        tmp_path / "nowhere", "--db", tmp_path / "w" / "h.sqlite"])  # fmt: skip
    assert code == 2 and "not a folder" in err and "nowhere" in err, err
    code, _, err = cli(["watch", station, "--frames", tmp_path, "--golden", line_golden])
    assert code == 2 and "--frames goes with --production" in err, err


def test_sigterm_ends_a_watch_waiting_for_frames(tmp_path, line_golden):
    """A watch of a folder into which no frame lands waits; SIGTERM ends it at once
    (exit 130), nothing committed and nothing left behind."""
    import signal
    import subprocess
    import sys

    station = line_station(tmp_path / "s", parts=PARTS)
    folder = tmp_path / "line"
    folder.mkdir()
    db = tmp_path / "w" / "h.sqlite"
    proc = subprocess.Popen(
        [sys.executable, "-m", "inspect_validate", "watch", str(station), "--production",
         "--frames", str(folder), "--golden", str(line_golden), "--db", str(db)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert "watching" in proc.stdout.readline()
        time.sleep(0.5)  # in the feed's wait
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 130 and "Traceback" not in err, err
    assert "stopped after cycle —" in out
    _, cycles = _charts(db)
    assert cycles == []


def test_the_cameras_health_is_held_on_the_line_too(cli, tmp_path, line_golden):
    """verify --production and watch --production of frames the tool captured hold what the
    camera reported to acceptance.health: a camera ignoring every third trigger fails
    "missed triggers", named as the likely cause (the parts' statistics held); frames from
    the line's own program have no such record, and say so."""
    deaf = line_station(tmp_path / "d", parts=PARTS, missed_trigger_every=3)
    frames = line_frames(deaf, tmp_path / "batch", parts=PARTS)
    args = ["verify", deaf, "--production", "--frames", frames, "--golden", line_golden]
    code, out, _ = cli([*args, "--report", tmp_path / "r"])
    assert code == 1, out
    assert "FAIL     camera: missed triggers" in out
    assert "likely cause: the camera or its link: missed triggers" in out
    report = json.loads((tmp_path / "r" / "production.json").read_text())
    assert [c["name"] for c in report["checks"] if c["verdict"] == "fail"] == [
        "camera: missed triggers"
    ]
    assert "camera: missed triggers" in (tmp_path / "r" / "report.html").read_text()
    # the same frames copied out of the capture: no health record, said
    loose = tmp_path / "loose"
    loose.mkdir()
    for f in frames.glob("*.tif"):
        (loose / f.name).write_bytes(f.read_bytes())
    code, out, _ = cli(["verify", deaf, "--production", "--frames", loose, "--golden", line_golden])
    assert code == 0 and "skipped: camera health: the capture holds no health record" in out
    db = tmp_path / "w" / "h.sqlite"
    code, out, _ = cli(["watch", deaf, "--production", "--golden", line_golden, "--db", db,
                        "--cycles", 1, "--interval", 0])  # fmt: skip
    assert code == 1 and "the camera or its link: missed triggers" in out, out
