"""A watch history read back: `inspect-validate history` prints, plots and exports what
`watch` committed (checked against the database itself), `verify --history` puts the
trends into its report, and a history that is missing, foreign or damaged is refused."""

import csv
import io
import math
import os
import re
import shutil
import sqlite3
import subprocess
import sys
from contextlib import redirect_stdout
from datetime import datetime
from pathlib import Path
from types import SimpleNamespace

import pytest
import yaml
from conftest import copy_station, lenient_history, run_cli

ONSET = 20  # stable cycles before the LED starts ageing


@pytest.fixture(scope="module")
def aged(tmp_path_factory, golden):
    """24 cycles of `watch` on the simulated station: its amber LED loses 1 % per cycle
    from cycle 20, and its camera times out in cycle 3."""
    folder = tmp_path_factory.mktemp("aged")
    changes = [
        {"start": ONSET, "percent_per_cycle": {1: -1.0}},
        {"start": 3, "stop": 4, "camera_timeout": True},
    ]
    path = copy_station(folder, world={"changes": changes})
    doc = yaml.safe_load(path.read_text())
    doc["camera"]["timeout_s"] = 0.2
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    db = folder / "w" / "history.sqlite"
    out = io.StringIO()
    with redirect_stdout(out):
        code = run_cli(
            [
                "watch",
                path,
                "--golden",
                golden,
                "--db",
                db,
                "--interval",
                0,
                "--retry-delay",
                0,
                "--cycles",
                ONSET + 4,
            ]
        )
    return SimpleNamespace(station=path, db=db, code=code, out=out.getvalue(), folder=folder)


def _sql(db, query):
    with sqlite3.connect(db) as con:
        return con.execute(query).fetchall()


@pytest.mark.slow
def test_watch_flags_led_ageing_from_the_cli(aged):
    assert aged.code == 1, aged.out  # the last cycle drifted
    rows = _sql(aged.db, "SELECT cycle, status, reason, cause FROM cycles ORDER BY cycle")
    assert [r[0] for r in rows] == list(range(ONSET + 4))
    # no false alarm while stable; the timeout is an error cycle, none lost
    stable = ["pass"] * 3 + ["error"] + ["pass"] * (ONSET - 4)
    assert [r[1] for r in rows[:ONSET]] == stable, rows
    assert "timeout" in rows[3][2]
    first = next(r for r in rows[4:] if r[1] != "pass")
    assert ONSET <= first[0] <= ONSET + 2, rows  # detected within 2 cycles of the onset
    assert first[1] == "drift" and "amber dimmer" in first[3] and "LED ageing" in first[3]
    assert f"cycle {first[0]}: DRIFT — illumination amber dimmer" in aged.out
    assert all(r[1] == "drift" for r in rows[first[0] :]), rows
    # frames kept: cycle 0 (every 10th passing), the error and every drifting cycle
    kept = sorted(p.name for p in (aged.folder / "w").glob("cycle-*"))
    assert kept[0] == "cycle-000000" and "cycle-000001" not in kept
    assert f"cycle-{first[0]:06d}" in kept


def test_history_prints_the_trend(cli, aged):
    code, out, err = cli(["history", aged.db, "--list", 4])
    assert code == 0, err
    assert "cycles 0–23," in out
    counts = dict(_sql(aged.db, "SELECT status, COUNT(*) FROM cycles GROUP BY status"))
    assert f"{counts['pass']} pass" in out and "1 error" in out
    assert f"{counts['drift']} drift" in out
    assert "last: cycle 23 DRIFT — illumination amber dimmer" in out
    recent = out.split("recent cycles")[1].split("trends")[0]
    assert [line.split()[0] for line in recent.strip().splitlines()[2:]] == ["20", "21", "22", "23"]
    # the trend table, furthest from target first: the amber means, alarmed since the
    # cycle the database says their run of alarms began
    table = out.split("trends")[1].strip().splitlines()[3:]
    top = {line.split()[1] + " " + line.split()[2] for line in table[:3]}
    assert top == {"A μ", "B μ", "C μ"} and all(line.startswith("amber:") for line in table[:3])
    alarms = _sql(
        aged.db,
        "SELECT cycle, ewma < low OR ewma > high FROM points WHERE illumination = 'amber' "
        "AND name = 'A' AND quantity = 'mean' ORDER BY cycle",
    )
    onset = max(c for c, a in alarms if not a) + 1
    row = next(line for line in table if line.startswith("amber: A μ [DN]")).split()
    assert row[-2:] == [str(sum(a for _, a in alarms)), str(onset)]
    assert all(line.split()[-1] == "—" for line in table if line.startswith("red:"))


def test_history_exports_every_point_once(cli, aged, tmp_path):
    code, _, err = cli(["history", aged.db, "--csv", tmp_path / "h.csv"])
    assert code == 0, err
    with open(tmp_path / "h.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    points = _sql(
        aged.db,
        "SELECT cycle, illumination, kind, name, quantity, value, ewma, low, high FROM points",
    )
    errors = _sql(aged.db, "SELECT cycle, reason FROM cycles WHERE status = 'error'")
    assert len(rows) == len(points) + len(errors)
    (error,) = [r for r in rows if r["status"] == "error"]
    assert (int(error["cycle"]), error["reason"]) == errors[0] and error["illumination"] == ""
    by_key = {
        (int(r["cycle"]), r["illumination"], r["kind"], r["name"], r["quantity"]): r
        for r in rows
        if r["illumination"]
    }
    assert len(by_key) == len(points)  # none twice
    for cycle, ill, kind, name, quantity, *numbers in points:
        r = by_key[cycle, ill, kind, name, quantity]
        assert [float(r[k]) for k in ("value", "ewma", "low", "high")] == numbers  # exact
        _value, ewma, low, high = numbers
        assert r["alarm"] == str(int(not low <= ewma <= high))
    started = dict(_sql(aged.db, "SELECT cycle, started FROM cycles"))
    for r in rows:
        when = datetime.fromisoformat(r["time"])
        assert when.tzinfo is not None
        assert when.timestamp() == pytest.approx(started[int(r["cycle"])], abs=1e-3)


def test_history_plots_the_trends(cli, aged, tmp_path):
    """One page of browser-drawn charts by default: the statuses, each illumination's
    charts off target (the band's edges in sight), then every chart of each; PNG figures
    with --plot-format png."""
    import json
    import re

    from matplotlib.image import imread

    code, _out, err = cli(["history", aged.db, "--plot", tmp_path / "page"])
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "page").iterdir()) == ["history.html"]
    page = (tmp_path / "page" / "history.html").read_text()
    specs = [
        json.loads(m) for m in re.findall(r'<script type="application/json">(.*?)</script>', page)
    ]
    titles = [c["title"] for c in specs]
    assert titles[:3] == [
        "status per cycle",
        "illumination amber: charts off target",
        "illumination red: charts off target",
    ]
    off = specs[1]
    assert off["yrange"][0] <= -1 and off["yrange"][1] >= 1 and off["xinteger"]
    alarmed = [s for s in off["series"] if s["color"] != "#b3b3b3"]
    assert alarmed and all(max(map(abs, filter(None, s["y"]))) > 1 for s in alarmed)  # LED ageing
    assert "A mean" in titles and titles.count("A mean") == 2  # one per illumination
    code, _out, err = cli(
        ["history", aged.db, "--plot", tmp_path / "plots", "--plot-format", "png"]
    )
    assert code == 0, err
    names = sorted(p.name for p in (tmp_path / "plots").iterdir())
    assert names == ["history-amber.png", "history-overview.png", "history-red.png"]
    amber, red = (imread(tmp_path / "plots" / f"history-{n}.png") for n in ("amber", "red"))
    assert amber.shape[0] > 400 and amber.shape[1] > 800
    assert amber.shape != red.shape or (amber != red).any()


def test_history_last_cycles(cli, aged, tmp_path):
    code, out, err = cli(["history", aged.db, "--last", 3, "--csv", tmp_path / "h.csv"])
    assert code == 0, err
    assert "cycles 21–23 (the last 3 of 24)" in out
    with open(tmp_path / "h.csv", newline="") as f:
        assert {r["cycle"] for r in csv.DictReader(f)} == {"21", "22", "23"}
    code, out, _ = cli(["history", aged.db, "--last", 100, "--list", 0])
    assert code == 0 and "cycles 0–23," in out and "recent cycles" not in out
    # beyond SQLite's 64-bit integers (an OverflowError, exit 70, before): every cycle
    code, out, err = cli(["history", aged.db, "--last", 10**20, "--list", 0])
    assert code == 0 and "cycles 0–23," in out, err


def test_verify_report_carries_the_history(cli, aged, tmp_path):
    code, out, err = cli(["verify", aged.station, "--report", tmp_path / "r", "--history", aged.db])
    assert code == 0, out + err
    page = (tmp_path / "r" / "report.html").read_text()
    trends = page.split("<h2>Trends (watch history)</h2>")[1]
    assert "LED ageing" in trends and "amber: A μ [DN]" in trends
    assert "data:image/png" not in trends  # charts drawn by the page, not pictures
    for ill in ("amber", "red"):
        assert f'"title":"illumination {ill}: charts off target"' in trends
    assert "value, EWMA, control band" in trends


def test_verify_refuses_another_stations_history(cli, aged, tmp_path):
    other = copy_station(tmp_path)
    code, _, err = cli(["verify", other, "--report", tmp_path / "r", "--history", aged.db])
    assert code == 2 and "history was kept of station" in err, err
    assert not (tmp_path / "r" / "frames").exists()  # refused before capturing
    code, _, err = cli(["verify", aged.station, "--history", aged.db])
    assert code == 2 and "--report" in err


GOOD_CYCLE = (0, 1.7e9, 1.0, "pass", 1, None, None, None)
GOOD_POINT = (0, "amber", "class", "A", "mean", 160.0, 160.0, 159.0, 161.0)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: p, "history database not found"),
        (lambda p: p.write_bytes(b"\x00junk" * 100) and p, "not a watch history database"),
        (lambda p: lenient_history(p, meta={}), "no station or start time"),
        (lambda p: lenient_history(p, meta={"station": "s", "created": "never"}), "no station"),
        (lambda p: lenient_history(p, [(0, "noon", 1.0, "pass", 1, None, None, None)]), "damaged"),
        (
            lambda p: lenient_history(p, [(0, math.inf, 1.0, "pass", 1, None, None, None)]),
            "damaged",
        ),
        (lambda p: lenient_history(p, [(0, 1.7e9, 1.0, "weird", 1, None, None, None)]), "damaged"),
        (lambda p: lenient_history(p, [(0, 1.7e9, -1.0, "pass", 7, None, None, None)]), "damaged"),
        (lambda p: lenient_history(p, [GOOD_CYCLE], [(*GOOD_POINT[:5], "x", 1, 0, 2)]), "damaged"),
        (
            lambda p: lenient_history(p, [GOOD_CYCLE], [(*GOOD_POINT[:6], math.inf, 0, 2)]),
            "damaged",
        ),
        (lambda p: lenient_history(p, [GOOD_CYCLE], [(*GOOD_POINT[:7], None, 2)]), "damaged"),
        (
            lambda p: lenient_history(p, [GOOD_CYCLE], [(0, 5, "class", "A", "mean", 1, 1, 0, 2)]),
            "damaged",
        ),
    ],
)
def test_history_refuses_what_watch_did_not_write(cli, tmp_path, make, message):
    db = tmp_path / "h.sqlite"
    make(db)
    code, _out, err = cli(["history", db, "--csv", tmp_path / "h.csv"])
    assert code == 2 and message in err and str(db) in err, err
    assert "Traceback" not in err and not (tmp_path / "h.csv").exists()
    if message == "history database not found":
        assert not db.exists()  # reading never creates one


def test_history_of_a_lenient_but_sound_database(cli, tmp_path):
    """What watch writes, held in untyped columns (another SQLite tool's copy), with a
    value that was not finite that cycle: read, not refused."""
    db = lenient_history(
        tmp_path / "h.sqlite", [GOOD_CYCLE], [(*GOOD_POINT[:5], None, 160.0, 159, 161)]
    )
    code, out, err = cli(["history", db, "--csv", tmp_path / "h.csv", "--plot", tmp_path / "p"])
    assert code == 0, err
    assert "amber: A μ [DN]" in out and "nan" not in out.lower()
    row = next(csv.DictReader(open(tmp_path / "h.csv", newline="")))
    assert row["value"] == "" and row["ewma"] == "160.0"


def test_history_with_no_cycle_yet(cli, tmp_path):
    from inspect_validate.watch.history_writer import HistoryWriter

    HistoryWriter(tmp_path / "h.sqlite", station="/s.yaml", golden=None).close()
    code, out, err = cli(["history", tmp_path / "h.sqlite", "--plot", tmp_path / "p"])
    assert code == 0, err
    assert "no cycles yet" in out and "plots: none" in out


def _history_with_cycles(path, n=3):
    from inspect_validate.watch.history import CycleRecord
    from inspect_validate.watch.history_writer import HistoryWriter

    history = HistoryWriter(path, station="st.yaml", golden=None)
    for cycle in range(n):
        record = CycleRecord(cycle, 1.7e9 + cycle, 0.5, "pass", True, None, None, None)
        history.commit(record, {("amber", "class", "A", "mean"): (100.0, 100.0, 99.0, 101.0)})
    return history


def test_committed_cycles_survive_the_loss_of_the_wal(tmp_path):
    """Each committed cycle is checkpointed into the main file: a crash that loses the
    -wal (deleted, or never synced) keeps every cycle. Without the checkpoint a history
    this small lived in its -wal alone."""
    from inspect_validate.watch.history import read_history

    db = tmp_path / "history.sqlite"
    history = _history_with_cycles(db)  # still open: the -wal is there, as in a crash
    assert (tmp_path / "history.sqlite-wal").exists()
    survivor = tmp_path / "copy" / "history.sqlite"
    survivor.parent.mkdir()
    shutil.copyfile(db, survivor)  # the main file alone
    assert [c.cycle for c in read_history(survivor).cycles] == [0, 1, 2]
    history.close()


def test_reading_a_history_changes_nothing(tmp_path):
    """`history` is read-only: reading a database a crashed watch left with its -wal keeps
    the main file and the -wal byte for byte (it used to checkpoint and remove the -wal,
    and so failed on read-only media)."""
    import hashlib

    from inspect_validate.watch.history import read_history

    history = _history_with_cycles(tmp_path / "history.sqlite")
    crashed = tmp_path / "crashed"
    crashed.mkdir()
    for suffix in ("", "-wal"):  # the files as a kill -9 leaves them
        shutil.copyfile(tmp_path / f"history.sqlite{suffix}", crashed / f"history.sqlite{suffix}")
    history.close()
    db, wal = crashed / "history.sqlite", crashed / "history.sqlite-wal"

    def digest():
        return [hashlib.sha256(p.read_bytes()).hexdigest() for p in (db, wal)]

    before = digest()
    assert len(read_history(db).cycles) == 3
    assert wal.exists() and digest() == before


def test_a_cycle_killed_twice_within_a_second_is_set_aside_twice(tmp_path):
    from inspect_validate.watch.loop import set_aside

    frames = tmp_path / "cycle-000004"
    kept = []
    for _ in range(2):
        frames.mkdir()
        (frames / "frame.tif").write_bytes(b"x")
        kept.append(set_aside(frames))
    assert len(set(kept)) == 2 and all((p / "frame.tif").exists() for p in kept)


def test_a_second_watch_on_one_history_is_refused_naming_the_holder(tmp_path):
    from inspect_validate.errors import InputError
    from inspect_validate.watch.history_writer import HistoryWriter

    db = tmp_path / "history.sqlite"
    first = HistoryWriter(db, station="st.yaml", golden=None)
    with pytest.raises(InputError, match=r"another watch \(pid \d+\) is writing this history"):
        HistoryWriter(db, station="st.yaml", golden=None)
    first.close()
    HistoryWriter(db, station="st.yaml", golden=None).close()  # free again once closed


@pytest.mark.parametrize("kind", ["fifo", "socket"])
def test_a_history_that_is_no_regular_file_is_refused_and_left_as_it_is(tmp_path, kind):
    """As root, --db /dev/zero was taken for a new history, SQLite failed on it, and the
    half-made history, that is the device node, was deleted. A FIFO and a socket stand
    in for the device here (a test must not risk the machine's /dev)."""
    import socket
    import stat

    from inspect_validate.errors import InputError
    from inspect_validate.watch.history_writer import HistoryWriter

    db = tmp_path / "history.sqlite"
    if kind == "fifo":
        os.mkfifo(db)
    else:
        server = socket.socket(socket.AF_UNIX)
        server.bind(str(db))
    with pytest.raises(
        InputError, match=r"history\.sqlite: not a regular file .*give another --db"
    ):
        HistoryWriter(db, station="st.yaml", golden=None)
    mode = db.lstat().st_mode
    assert stat.S_ISFIFO(mode) if kind == "fifo" else stat.S_ISSOCK(mode)
    assert not (tmp_path / "history.sqlite.lock").exists()
    if kind == "socket":
        server.close()


def test_an_empty_file_is_taken_as_a_new_history(tmp_path):
    """An empty file (made with touch) is a new history, not refused."""
    from inspect_validate.watch.history_writer import HistoryWriter

    db = tmp_path / "history.sqlite"
    db.touch()
    HistoryWriter(db, station="st.yaml", golden=None).close()
    assert db.stat().st_size > 0


def test_a_history_damaged_from_outside_is_not_continued(tmp_path):
    """A chart renamed and a value changed behind watch's back, or pages overwritten:
    watch refuses to append to it (history refuses to print it alike)."""
    from inspect_validate.errors import InputError
    from inspect_validate.watch.history_writer import HistoryWriter

    db = tmp_path / "history.sqlite"
    _history_with_cycles(db).close()
    with sqlite3.connect(db) as con:
        con.execute("UPDATE points SET quantity = 'claqs' WHERE cycle = 1")
    with pytest.raises(InputError, match=r"history\.sqlite: .*'claqs'.* is not one watch keeps"):
        HistoryWriter(db, station="st.yaml", golden=None)
    assert run_cli(["history", db]) == 2

    broken = tmp_path / "broken.sqlite"
    _history_with_cycles(broken).close()
    data = bytearray(broken.read_bytes())
    data[4096 : 4096 + 64] = b"\xff" * 64  # a page header overwritten
    broken.write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"broken.sqlite: (the history is damaged|not a watch)"):
        HistoryWriter(broken, station="st.yaml", golden=None)


def test_a_history_that_cannot_be_written_is_a_clear_error(tmp_path):
    """A cycle the database cannot take — a cycle number beyond SQLite's integers, a
    database gone read-only — is an error naming the file, not a traceback."""
    from inspect_validate.errors import InputError
    from inspect_validate.watch.history import CycleRecord

    history = _history_with_cycles(tmp_path / "history.sqlite", n=1)
    huge = CycleRecord(2**63, 1.7e9, 0.5, "pass", True, None, None, "cycle-x")
    with pytest.raises(InputError, match=r"history.sqlite: cycle number \d+ does not fit"):
        history.commit(huge, {})
    history.db.execute("PRAGMA query_only = ON")  # as a file turned read-only would
    record = CycleRecord(1, 1.7e9, 0.5, "pass", True, None, None, "cycle-000001")
    with pytest.raises(InputError, match=r"cannot write cycle 1 to the history .*cycle-000001"):
        history.commit(record, {})
    history.close()


def _small_station(folder):
    """The shipped station at 64 × 48 pixels (its frames a few KB), its ROIs redrawn."""
    from inspect_validate.model.render import class_bands

    path = copy_station(folder)
    doc = yaml.safe_load(path.read_text())
    doc["camera"].update(width=64, height=48)
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    bands = class_bands(("A", "B", "C"), height=48, width=64, gap=6)
    (folder / "rois.yaml").write_text(
        "classes:\n" + "".join(f"  {k}:\n    - rect: {list(v)}\n" for k, v in bands.items())
    )
    return path


def _limited_watch(path, golden, db, limit_kb, cycles=60):
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_kb * 1024, limit_kb * 1024))

    args = ["watch", path, "--golden", golden, "--db", db, "--interval", 0, "--cycles", cycles]
    return subprocess.run(
        [sys.executable, "-m", "inspect_validate", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=limit,
    )


@pytest.mark.slow
def test_a_history_that_outgrows_the_file_size_limit(tmp_path):
    """Fault injection for real: ``ulimit -f`` (RLIMIT_FSIZE) lets the frames through and
    stops the database growing. watch ends with exit 2 naming the file and the limit,
    no traceback; every committed cycle is readable by history, the failing cycle's
    frames are kept, and the watch continues the same history once the limit is raised.
    Below what a new history needs, it is not created at all (no half-made file)."""
    path = _small_station(tmp_path)
    assert run_cli(["train", path, "--out", tmp_path / "g.json", "--repeats", 5]) == 0
    db = tmp_path / "w" / "history.sqlite"
    done = _limited_watch(path, tmp_path / "g.json", db, 64)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr and "ulimit -f" in done.stderr
    last = re.search(r"history\.sqlite: (?:cannot write )?cycle (\d+)", done.stderr)
    assert last, done.stderr
    shown = subprocess.run(
        [sys.executable, "-m", "inspect_validate", "history", str(db)],
        capture_output=True,
        text=True,
    )
    assert shown.returncode == 0, shown.stderr
    first_last = re.search(r"cycles 0–(\d+)", shown.stdout)
    assert first_last and int(first_last[1]) >= int(last[1]) - 1 >= 1, shown.stdout
    assert (tmp_path / "w" / f"cycle-{int(last[1]):06d}").is_dir()
    code = run_cli(["watch", path, "--golden", tmp_path / "g.json", "--db", db, "--cycles", 1])
    assert code in (0, 1)

    fresh = tmp_path / "w2" / "history.sqlite"
    done = _limited_watch(path, tmp_path / "g.json", fresh, 24, cycles=1)
    assert done.returncode == 2 and "cannot create the history" in done.stderr, done.stderr
    assert not fresh.exists() and not Path(f"{fresh}-wal").exists()


def test_cycles_deleted_from_the_middle_are_named(cli, aged, tmp_path):
    """A history with cycles removed from the middle (by hand, or a restored copy) says
    which are missing instead of listing the rest as if nothing happened."""
    import shutil

    db = tmp_path / "h.sqlite"
    shutil.copy(aged.db, db)
    with sqlite3.connect(db) as con:
        for table in ("points", "cycles"):
            con.execute(f"DELETE FROM {table} WHERE cycle IN (5, 6, 7, 12)")
    code, out, err = cli(["history", db, "--last", 100])
    assert code == 0, err
    assert "cycles missing from the history" in out and "5–7, 12;" in out
    code, out, _ = cli(["history", aged.db, "--last", 100])
    assert "missing" not in out


def test_a_cycle_numbered_past_two_to_the_53_is_read_as_written(cli, aged, tmp_path):
    """Cycle numbers were read as floats: 2⁶³ − 1 leaked a numpy cast warning and lost its
    digits. Read as integers, and the gap it leaves is named."""
    import shutil
    import warnings

    db = tmp_path / "h.sqlite"
    shutil.copy(aged.db, db)
    last = 2**63 - 1
    with sqlite3.connect(db) as con:
        top = con.execute("SELECT max(cycle) FROM cycles").fetchone()[0]
        con.execute("PRAGMA foreign_keys = OFF")
        for table in ("points", "cycles"):
            con.execute(f"UPDATE {table} SET cycle = ? WHERE cycle = ?", (last, top))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code, out, err = cli(["history", db, "--last", 100])
    assert code == 0, err
    assert f"last: cycle {last} " in out and f"{top}–{last - 1}" in out


def _rescued(tmp_path):
    (rescue,) = tmp_path.glob("history-rescued-*.sqlite")
    return rescue


@pytest.mark.parametrize("change", ["truncated", "restored in place", "moved over", "removed"])
def test_a_history_changed_under_the_watch_is_never_written_on(tmp_path, change):
    """Truncated, overwritten by a restored copy, replaced, or removed between two cycles:
    the next commit refuses to write, names what happened, and the watch's cycles are
    rebuilt from its journal into a new database. (The commit used to write on the
    changed file: a truncated history became 'malformed', a restored one lost its
    cycles to the watch's.)"""
    from inspect_validate.errors import InputError
    from inspect_validate.watch.history import CycleRecord, read_history

    restored = tmp_path / "restored" / "history.sqlite"
    restored.parent.mkdir()
    _history_with_cycles(restored, n=5).close()
    db = tmp_path / "history.sqlite"
    history = _history_with_cycles(db, n=3)
    if change == "truncated":
        with open(db, "r+b") as f:
            f.truncate(0)
    elif change == "restored in place":
        shutil.copyfile(restored, db)  # same inode, other content
    elif change == "moved over":
        shutil.copyfile(restored, tmp_path / "other.sqlite")
        os.replace(tmp_path / "other.sqlite", db)
    else:
        db.unlink()
    before = db.read_bytes() if db.exists() else None
    record = CycleRecord(3, 1.7e9 + 3, 0.5, "pass", True, None, None, None)
    words = {"truncated": "truncated", "removed": "removed"}.get(change, "(replaced|rewritten)")
    with pytest.raises(InputError, match=rf"history\.sqlite: the history was {words}.*cycle 3"):
        history.commit(record, {("amber", "class", "A", "mean"): (100.0, 100.0, 99.0, 101.0)})
    history.close()  # reported once: closing says nothing more and writes nothing
    assert (db.read_bytes() if db.exists() else None) == before
    rebuilt = read_history(_rescued(tmp_path))
    assert [c.cycle for c in rebuilt.cycles] == [0, 1, 2, 3]
    assert rebuilt.created == history.created and rebuilt.station == "st.yaml"
    (chart,) = rebuilt.charts.values()
    assert list(chart.value) == [100.0] * 4


def test_a_history_truncated_before_a_stop_is_reported_on_closing(tmp_path):
    """SIGTERM after the file was truncated: no cycle is committed, and closing reports
    the change with the cycles rebuilt (they used to be lost without a word)."""
    from inspect_validate.errors import InputError
    from inspect_validate.watch.history import read_history

    db = tmp_path / "history.sqlite"
    history = _history_with_cycles(db, n=2)
    with open(db, "r+b") as f:
        f.truncate(0)
    with pytest.raises(
        InputError, match=r"the history was truncated .* watch stops without writing to it"
    ):
        history.close()
    assert db.stat().st_size == 0
    assert [c.cycle for c in read_history(_rescued(tmp_path)).cycles] == [0, 1]


def test_a_journal_cut_by_a_crash_or_with_a_cycle_twice_rebuilds(tmp_path):
    from inspect_validate.errors import InputError
    from inspect_validate.watch.history import read_history
    from inspect_validate.watch.history_writer import rebuild_history

    db = tmp_path / "history.sqlite"
    _history_with_cycles(db, n=3).close()
    journal = tmp_path / "history.sqlite.journal"
    lines = journal.read_text().splitlines()
    journal.write_text("\n".join([*lines, lines[-1], lines[-1][:20]]))  # repeated, then cut
    rebuilt = rebuild_history(journal, tmp_path / "new.sqlite")
    assert rebuilt.cycles == (0, 1, 2) and list(rebuilt.lost) == [6]
    assert (
        rebuilt.text
        == "cycles 0–2 rebuilt; not recovered: line 6 (not a line of JSON: cut by a crash?)"
    )
    assert [c.cycle for c in read_history(tmp_path / "new.sqlite").cycles] == [0, 1, 2]
    with pytest.raises(InputError, match=r"new\.sqlite: exists already"):
        rebuild_history(journal, tmp_path / "new.sqlite")
    (tmp_path / "bad.journal").write_text("[1, 2]\n")
    with pytest.raises(InputError, match=r"bad\.journal: not a watch journal"):
        rebuild_history(tmp_path / "bad.journal", tmp_path / "other.sqlite")


def test_a_new_history_sets_an_old_journal_aside(tmp_path):
    db = tmp_path / "history.sqlite"
    _history_with_cycles(db, n=2).close()
    db.unlink()
    _history_with_cycles(db, n=1).close()
    (old,) = tmp_path.glob("history.sqlite-old-*.journal")
    assert len(old.read_text().splitlines()) == 3  # meta and two cycles, kept
    assert len((tmp_path / "history.sqlite.journal").read_text().splitlines()) == 2


def test_a_cycle_after_a_cut_journal_line_is_a_line_of_its_own(tmp_path):
    """A journal whose last line a crash cut: the next cycle is appended after the line is
    ended (it was appended onto it: the rebuild then held cycles 0, 2, 3 where the
    database held 0, 1, 2, 3), and the rebuild names the cut line it could not read."""
    from inspect_validate.watch.history import CycleRecord
    from inspect_validate.watch.history_writer import HistoryWriter, rebuild_history

    db = tmp_path / "history.sqlite"
    _history_with_cycles(db, n=3).close()
    journal = tmp_path / "history.sqlite.journal"
    journal.write_bytes(journal.read_bytes()[:-30])  # cycle 2's line cut by a crash
    history = HistoryWriter(db, station="st.yaml", golden=None)
    record = CycleRecord(3, 1.7e9 + 3, 0.5, "pass", True, None, None, None)
    history.commit(record, {("amber", "class", "A", "mean"): (100.0, 100.0, 99.0, 101.0)})
    history.close()
    rebuilt = rebuild_history(journal, tmp_path / "new.sqlite")
    assert rebuilt.cycles == (0, 1, 3) and list(rebuilt.lost) == [4]
    assert "cycles 0–1, 3 rebuilt; not recovered: line 4" in rebuilt.text


@pytest.mark.parametrize(
    ("line", "says"),
    [
        ('{"cycle": 5}', "no 'started'"),
        ('{"cycle": 5, "started": 1, "seconds": 1, "status": "bogus", "passed": true, '
         '"reason": null, "cause": null, "frames": null, "points": []}', "status 'bogus'"),
        ('{"cycle": 5, "started": NaN, "seconds": 1, "status": "pass", "passed": true, '
         '"reason": null, "cause": null, "frames": null, "points": []}', "started nan"),
        ('{"cycle": 5, "started": 1, "seconds": 1, "status": "pass", "passed": true, '
         '"reason": null, "cause": null, "frames": null, '
         '"points": [["amber", "class", "A", "mean", 1, Infinity, 0, 2]]}', "band not finite"),
        ('{"cycle": 5, "started": 1, "seconds": 1, "status": "pass", "passed": true, '
         '"reason": null, "cause": null, "frames": null, "points": [["a", 1]]}', "4 names"),
    ],
)  # fmt: skip
def test_a_journal_line_no_history_holds_is_named_not_rebuilt(tmp_path, line, says):
    """A line without a status, with NaN or infinite values (the rebuilt database was
    then refused as damaged) is not rebuilt, and the rebuild says which line and why."""
    from inspect_validate.watch.history import read_history
    from inspect_validate.watch.history_writer import rebuild_history

    db = tmp_path / "history.sqlite"
    _history_with_cycles(db, n=2).close()
    journal = tmp_path / "history.sqlite.journal"
    journal.write_text(journal.read_text() + line + "\n")
    rebuilt = rebuild_history(journal, tmp_path / "new.sqlite")
    assert rebuilt.cycles == (0, 1) and says in rebuilt.lost[4], rebuilt.lost
    assert [c.cycle for c in read_history(tmp_path / "new.sqlite").cycles] == [0, 1]


@pytest.mark.parametrize("meta", ["{}", '{"meta": {}}', '{"meta": {"station": 1}}', "[]"])
def test_a_journal_without_its_meta_is_refused_not_a_traceback(tmp_path, meta):
    from inspect_validate.errors import InputError
    from inspect_validate.watch.history_writer import rebuild_history

    (tmp_path / "j.journal").write_text(meta + "\n")
    with pytest.raises(InputError, match=r"j\.journal: not a watch journal"):
        rebuild_history(tmp_path / "j.journal", tmp_path / "new.sqlite")
    assert not (tmp_path / "new.sqlite").exists()


def test_a_journal_that_is_a_fifo_is_refused_at_the_commit_not_blocked(tmp_path):
    """A FIFO in the journal's place blocked the first commit for good (SIGTERM did not
    end it): the commit is refused naming it."""
    import os

    from inspect_validate.errors import InputError

    db = tmp_path / "history.sqlite"
    history = _history_with_cycles(db, n=1)
    history.close()
    journal = tmp_path / "history.sqlite.journal"
    journal.unlink()
    os.mkfifo(journal)
    from inspect_validate.watch.history import CycleRecord
    from inspect_validate.watch.history_writer import HistoryWriter

    history = HistoryWriter(db, station="st.yaml", golden=None)
    record = CycleRecord(1, 1.7e9, 0.5, "pass", True, None, None, None)
    with pytest.raises(
        InputError, match=r"cannot write cycle 1: its journal .* is not a regular file; remove it"
    ):
        history.commit(record, {("amber", "class", "A", "mean"): (1.0, 1.0, 0.0, 2.0)})
    history.close()


def test_history_charts_tick_whole_cycles(tmp_path, monkeypatch):
    """Three cycles were ticked at 0.5, 1.0, 1.5…: a cycle is a whole number."""
    import matplotlib

    matplotlib.use("Agg")
    from inspect_validate.report import plots
    from inspect_validate.watch.history import read_history

    drawn = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, target, **kw: drawn.append(fig))
    db = tmp_path / "history.sqlite"
    _history_with_cycles(db, n=3).close()
    log = read_history(db)
    plots.plot_history_overview(log, tmp_path / "o.png")
    plots.plot_history_charts(log, "amber", tmp_path / "c.png")
    assert len(drawn) == 2
    for fig in drawn:
        fig.canvas.draw()
        for ax in fig.axes:
            if not ax.get_visible():
                continue
            lo, hi = ax.get_xlim()
            ticks = [t for t in ax.get_xticks() if lo <= t <= hi]
            assert ticks and all(float(t).is_integer() for t in ticks), ticks


@pytest.mark.parametrize("at", ["connect", "BEGIN IMMEDIATE", "COMMIT"])
def test_a_stop_while_a_history_is_made_leaves_no_file(tmp_path, monkeypatch, at):
    """SIGTERM while a new history is created (seen in the stop sweep: a file without
    tables, which a later watch would take as a history): no file is left, and the next
    watch makes it afresh."""
    import sqlite3

    from inspect_validate.interruption import Interrupted
    from inspect_validate.watch import history_writer

    real = sqlite3.connect

    class Stopping:
        def __init__(self, con):
            self.con = con

        def execute(self, sql, *args):
            if sql.strip() == at:
                raise Interrupted("SIGTERM")
            return self.con.execute(sql, *args)

        def __getattr__(self, name):
            return getattr(self.con, name)

    def connect(*args, **kwargs):
        con = real(*args, **kwargs)
        if at == "connect":
            raise Interrupted("SIGTERM")
        return Stopping(con)

    monkeypatch.setattr(history_writer.sqlite3, "connect", connect)
    path = tmp_path / "h.sqlite"
    with pytest.raises(Interrupted):
        history_writer.HistoryWriter(path, station="s", golden="g")
    assert not path.exists() and not list(tmp_path.glob("h.sqlite-*"))
    monkeypatch.setattr(history_writer.sqlite3, "connect", real)
    history_writer.HistoryWriter(path, station="s", golden="g").close()
    with real(path) as con:
        assert con.execute("SELECT COUNT(*) FROM cycles").fetchone() == (0,)


def test_a_cycles_health_is_kept_summed_and_rebuilt_from_the_journal(tmp_path):
    """What the camera reported each cycle (issue 50): kept per cycle, its counters summed
    over the history (Prometheus' counters), journalled and rebuilt; garbage refused
    before anything is written; a journal line from before health was kept still
    rebuilds."""
    from inspect_validate.watch.history import CycleRecord, read_history
    from inspect_validate.watch.history_writer import HistoryWriter, rebuild_history

    db = tmp_path / "history.sqlite"
    history = HistoryWriter(db, station="st.yaml", golden=None)
    assert history.last_status() is None and history.health_totals() == {}
    for n, health in enumerate(
        [
            {"frames_delivered": 12, "frames_incomplete": 0, "temperature_c": 40.0},
            {"frames_delivered": 12, "frames_incomplete": 3, "temperature_c": 47.5, "x": "junk"},
            {},
        ]
    ):
        status = "error" if n == 2 else "pass"
        record = CycleRecord(n, 1.7e9 + n, 0.5, status, None, None, None, None)
        history.commit(record, {}, health)
    with pytest.raises(ValueError, match="frames_lost -1"):
        history.commit(
            CycleRecord(3, 1.7e9, 0.5, "pass", True, None, None, None), {}, {"frames_lost": -1}
        )
    assert history.last_status() == "error"
    assert history.health_totals() == {"frames_delivered": 24.0, "frames_incomplete": 3.0}
    history.close()
    log = read_history(db)
    assert log.health == {
        0: {"frames_delivered": 12.0, "frames_incomplete": 0.0, "temperature_c": 40.0},
        1: {"frames_delivered": 12.0, "frames_incomplete": 3.0, "temperature_c": 47.5},
    }
    journal = tmp_path / "history.sqlite.journal"
    old_line = (
        '{"cycle": 7, "started": 1, "seconds": 1, "status": "pass", "passed": true, '
        '"reason": null, "cause": null, "frames": null, "points": []}'
    )
    bad_line = old_line.replace('"cycle": 7', '"cycle": 8').replace(
        '"points": []', '"points": [], "health": {"packets_lost": "many"}'
    )
    journal.write_text(journal.read_text() + old_line + "\n" + bad_line + "\n")
    rebuilt = rebuild_history(journal, tmp_path / "new.sqlite")
    assert rebuilt.cycles == (0, 1, 2, 7) and "packets_lost 'many'" in rebuilt.lost[6]
    assert read_history(tmp_path / "new.sqlite").health == log.health


def test_a_history_from_before_health_is_read_and_continued(tmp_path):
    """A history written before the health table existed: read with no health, and a
    watch continuing it adds the table and keeps the new cycles' health."""
    from inspect_validate.watch.history import CycleRecord, read_history
    from inspect_validate.watch.history_writer import HistoryWriter

    db = tmp_path / "history.sqlite"
    _history_with_cycles(db, n=2).close()
    with sqlite3.connect(db) as conn:
        conn.execute("DROP TABLE health")
    assert read_history(db).health == {} and len(read_history(db).cycles) == 2
    history = HistoryWriter(db, station="st.yaml", golden=None)
    history.commit(
        CycleRecord(2, 1.7e9 + 2, 0.5, "pass", True, None, None, None), {}, {"frames_delivered": 4}
    )
    history.close()
    assert read_history(db).health == {2: {"frames_delivered": 4.0}}
