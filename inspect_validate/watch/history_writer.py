"""Writing a watched station's history (:mod:`inspect_validate.watch.history`), one
transaction a cycle, with its journal.

A cycle is one transaction — its row, its measured values and their charts —
so it is committed whole or not at all: killing ``watch`` mid-cycle loses no
committed cycle, and a restart continues the same history (cycle numbers and
the charts' smoothed values).

Beside the database, ``<db>.journal`` keeps every committed cycle as a line of JSON,
written (and synced) before the cycle goes into the database. Before each commit the
watch checks that the file is still the one it wrote (device, inode, size,
modification time): a history truncated, replaced by a restored copy or removed under a running
watch is never written on. The watch stops, and rebuilds its cycles from the journal
into a new database beside the old one (:func:`rebuild_history`).
"""

from __future__ import annotations

import copy
import errno
import itertools
import json
import math
import os
import sqlite3
import time
from dataclasses import dataclass
from pathlib import Path

from inspect_validate.camera.health import COUNTERS
from inspect_validate.errors import InputError
from inspect_validate.files import (
    NotRegularFile,
    exclusive_lock,
    input_file,
    regular_opener,
    release_lock,
)
from inspect_validate.watch.history import (
    CHARTED,
    HISTORY_SCHEMA_VERSION,
    RECONNECTS,
    SCHEMA,
    STATUSES,
    CycleRecord,
    add_health,
    cycle_health,
    health_rows,
    not_history,
    validate_history,
)

__all__ = [
    "JOURNAL_LINE_MAX",
    "HistoryWriter",
    "Rebuilt",
    "history_path",
    "rebuild_history",
]


def history_path(path: str | Path) -> Path:
    """``path`` as a history database to write: a regular file, or none yet.

    Raises
    ------
    InputError
        A device or a pipe: no database, and one made there would be deleted again when
        SQLite failed on it (as root, ``--db /dev/zero`` was).
    """
    path = Path(path)
    if path.exists() and not path.is_file() and not path.is_dir():
        raise InputError(
            "not a regular file (a device or a pipe); give another --db", source=str(path)
        )
    return path


_COUNTED = (*COUNTERS, RECONNECTS)  # the health quantities summed over a history


class HistoryWriter:
    """An open history database, written one cycle at a time.

    Raises
    ------
    InputError
        A file that is not an SQLite database, or the history of another station or
        charted against another golden file (its charts would continue on other targets).
    """

    def __init__(
        self, path: str | Path, *, station: str, golden: str | None, created: float | None = None
    ) -> None:
        self.path = history_path(path)
        self.journal = self.path.with_name(self.path.name + ".journal")
        self._changed: str | None = None
        self._lock = _exclusive(self.path)
        try:
            self._open(station, golden, created)
            self._identity = _identity(self.path)
        except BaseException:
            release_lock(self._lock)
            raise

    def _open(self, station: str, golden: str | None, created: float | None) -> None:
        existed = self.path.exists()
        new = not (existed and self.path.stat().st_size)
        if new and self.journal.exists():
            # The journal of a history that is gone (deleted to start afresh): kept aside,
            # never appended to a new history's, nor deleted.
            self.journal.rename(_aside(self.journal, "old"))
        if not new:
            # Damage from outside is refused before a cycle is appended to it: the same
            # checks `history` makes, and SQLite's own page check.
            validate_history(self.path)
        path = self.path
        fresh = {
            "schema_version": str(HISTORY_SCHEMA_VERSION),
            "station": station,
            "golden": golden or "",
            "created": str(time.time() if created is None else created),
        }
        try:
            self.db = sqlite3.connect(self.path, timeout=10.0, isolation_level=None)
        except BaseException as exc:
            if new and not existed:  # a stop as it was made: no empty file left behind
                path.unlink(missing_ok=True)
            if isinstance(exc, sqlite3.DatabaseError):
                raise not_history(self.path, exc, "give another --db") from None
            raise
        try:
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=FULL")  # a committed cycle survives power loss
            # Tables and meta in one transaction: a history is made whole or not at all.
            self.db.execute("BEGIN IMMEDIATE")
            try:
                for statement in SCHEMA.split(";"):
                    self.db.execute(statement)
                for table in ("points", "health"):  # a history from before cameras were named
                    columns = {r[1] for r in self.db.execute(f"PRAGMA table_info({table})")}
                    if "camera" not in columns:
                        self.db.execute(
                            f"ALTER TABLE {table} ADD COLUMN camera TEXT NOT NULL DEFAULT ''"
                        )
                meta = dict(self.db.execute("SELECT key, value FROM meta"))
                if not meta:
                    meta = fresh
                    self.db.executemany("INSERT INTO meta VALUES (?, ?)", list(meta.items()))
            except BaseException:
                self.db.execute("ROLLBACK")
                raise
            self.db.execute("COMMIT")
        except BaseException as exc:
            self.db.close()
            if new:  # nothing of the user's in it: leave no half-made file to refuse later
                # (also when a stop came while it was being made: a table-less file)
                for suffix in ("", "-wal", "-shm") if not existed else ("-wal", "-shm"):
                    Path(f"{path}{suffix}").unlink(missing_ok=True)
            if not isinstance(exc, sqlite3.DatabaseError):
                raise
            if new:
                raise InputError(
                    f"cannot create the history ({exc}): free space, raise the file size limit "
                    "(ulimit -f) or give another --db",
                    source=str(path),
                ) from None
            raise not_history(path, exc, "give another --db") from None
        for key, value, what in (
            ("station", station, "station"),
            ("golden", golden or "", "golden file"),
        ):
            if meta.get(key) != value:
                raise InputError(
                    f"this history belongs to {what} {meta.get(key)!r}, not {value!r}; "
                    "give another --db",
                    source=str(path),
                )
        self.created = float(meta["created"])  # Unix time, s: when the watch began
        self._meta = {"station": station, "golden": golden, "created": self.created}

    def close(self) -> None:
        """Close the history; a file changed since the last commit is reported (the
        cycles rebuilt from the journal) once it is closed."""
        try:
            self._check_unchanged()
        finally:
            self.db.close()
            release_lock(self._lock)

    def next_cycle(self) -> int:
        (last,) = self.db.execute("SELECT MAX(cycle) FROM cycles").fetchone()
        return 0 if last is None else last + 1

    def commit(self, record: CycleRecord, points: dict, health: dict | None = None) -> None:
        """Store ``record``, its chart ``points`` (key → value, ewma, low, high; the key
        (illumination, kind, name, quantity) of the station's one camera, or with the
        camera's name fifth) and what the cameras reported (``health``:
        :func:`~.history.cycle_health`) in one transaction."""
        rows = [
            (record.cycle, *key[:4], *values, key[4] if len(key) > 4 else "")
            for key, values in points.items()
        ]
        health = cycle_health(health or {})
        self._check_unchanged(record, rows, health)
        try:
            self._journal(record, rows, health)
            self._insert(record, rows, health)
            if self._totals is not None:
                for camera, name, value in health_rows(health):
                    if name in _COUNTED:
                        add_health(self._totals, camera, name, value)
        except OSError as exc:
            if not isinstance(exc, NotRegularFile) and exc.errno not in (
                errno.ENXIO,
                errno.ELOOP,
                errno.EISDIR,
            ):
                raise self._unwritable(record, exc) from None
            raise InputError(  # a FIFO, socket, device or link in the journal's place
                f"cannot write cycle {record.cycle}: its journal {self.journal.name} is not a "
                "regular file; remove it (the history is rebuilt from it after a crash)",
                source=str(self.path),
            ) from None
        except sqlite3.DatabaseError as exc:  # disk full, read-only, damaged
            raise self._unwritable(record, exc) from None
        except OverflowError:
            raise InputError(
                f"cycle number {record.cycle} does not fit the history; start a new --db",
                source=str(self.path),
            ) from None
        finally:
            self._identity = _identity(self.path)  # what this commit wrote, even half, is ours

    def _unwritable(self, record: CycleRecord, exc: Exception) -> InputError:
        return InputError(
            f"cannot write cycle {record.cycle} to the history ({exc}); its frames are "
            f"kept in {record.frames or 'the watch folder'} — free space, raise the file "
            "size limit (ulimit -f) or give another --db",
            source=str(self.path),
        )

    def _insert(self, record: CycleRecord, rows, health: dict) -> None:
        self.db.execute("BEGIN IMMEDIATE")
        try:
            self.db.execute(
                "INSERT INTO cycles VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    record.cycle,
                    record.started,
                    record.seconds,
                    record.status,
                    None if record.passed is None else int(record.passed),
                    record.reason,
                    record.cause,
                    record.frames,
                ),
            )
            # Columns named: a history from before cameras were named has camera last too,
            # but an insert should not hang on where.
            self.db.executemany(
                "INSERT INTO points (cycle, illumination, kind, name, quantity, value, ewma, "
                "low, high, camera) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                rows,
            )
            self.db.executemany(
                "INSERT INTO health (cycle, camera, quantity, value) VALUES (?, ?, ?, ?)",
                [(record.cycle, *row) for row in health_rows(health)],
            )
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        self.db.execute("COMMIT")
        try:
            # Into the main file now: a history this small never reaches SQLite's automatic
            # checkpoint, so every cycle would live in the -wal alone, and losing or
            # damaging that file would lose them all. (PASSIVE: a reader is not waited for.)
            self.db.execute("PRAGMA wal_checkpoint(PASSIVE)")
        except sqlite3.DatabaseError as exc:
            raise InputError(
                f"cycle {record.cycle} is committed, but the history cannot be written back "
                f"into its main file ({exc}), so its -wal keeps growing: free space, raise "
                "the file size limit (ulimit -f) or give another --db",
                source=str(self.path),
            ) from None

    def _journal(self, record: CycleRecord, rows, health: dict) -> None:
        # A FIFO or a link in the journal's place would block the commit or write elsewhere.
        with open(self.journal, "ab+", opener=regular_opener) as f:
            end = f.seek(0, os.SEEK_END)
            if not end:
                f.write((json.dumps({"meta": self._meta}) + "\n").encode())
            else:
                f.seek(end - 1)
                if f.read(1) != b"\n":  # a line cut by a crash: ended, so it stays one
                    f.write(b"\n")
            # a point is its 4 names and 4 values, and its camera's name where it has one
            points = [list(r[1:9]) + ([r[9]] if r[9] else []) for r in rows]
            line = {**record.__dict__, "points": points, "health": health}
            f.write((json.dumps(line, allow_nan=True) + "\n").encode())
            f.flush()
            os.fsync(f.fileno())

    def _check_unchanged(
        self, record: CycleRecord | None = None, rows=(), health: dict | None = None
    ) -> None:
        """Refuse to write on a file this watch did not leave as it is now."""
        if self._changed is not None:  # reported once: the file is not written again
            if record is None:
                return
            raise InputError(self._changed, source=str(self.path))
        now = _identity(self.path)
        if now == self._identity:
            return
        was = self._identity
        if now is None:
            what = "removed"
        elif was is None or now[:2] != was[:2]:
            what = "replaced by another file"
        elif now[2] < was[2]:
            what = f"truncated ({was[2]} → {now[2]} bytes)"
        else:
            what = "rewritten by another program"
        if record is not None:
            self._journal(record, rows, health or {})  # kept, as every cycle before it
        rescue = _aside(self.path, "rescued")
        try:
            rebuilt = rebuild_history(self.journal, rescue)
            kept = f"{rebuilt.text} from {self.journal} into {rescue}"
        except (InputError, OSError, ValueError) as exc:
            kept = f"its cycles are in {self.journal} (they could not be rebuilt: {exc})"
        self._changed = (
            f"the history was {what} while this watch ran, so the watch stops without "
            f"writing {'to it' if record is None else f'cycle {record.cycle} to it'}; "
            f"{kept}. Check which file is right, then "
            "continue with --db and the one you keep"
        )
        raise InputError(self._changed, source=str(self.path))

    def last_status(self) -> str | None:
        """The status of the history's last cycle, None before the first (also across a
        restart of the watch: a cycle after an ``error`` one reopens the devices)."""
        row = self.db.execute("SELECT status FROM cycles ORDER BY cycle DESC LIMIT 1").fetchone()
        return None if row is None else row[0]

    def health_totals(self) -> dict:
        """Each counter summed over every cycle of the history (the cameras', and the
        watch's reconnects), in the form of a cycle's health (:func:`~.history.
        cycle_health`): what Prometheus reads as counters, growing across restarts of the
        watch. Summed in the database once, when the history is opened; each commit adds
        its cycle's."""
        if self._totals is None:
            rows = self.db.execute(
                f"SELECT camera, quantity, SUM(value) FROM health WHERE quantity IN "
                f"({', '.join('?' * len(_COUNTED))}) GROUP BY camera, quantity",
                _COUNTED,
            )
            self._totals = {}
            for camera, name, total in rows:
                add_health(self._totals, camera, name, float(total))
        return copy.deepcopy(self._totals)

    _totals: dict | None = None  # health_totals, kept up by commit

    def chart_states(self) -> dict:
        """Per series (illumination, kind, name, quantity, camera) its last smoothed value
        and how many cycles it has seen."""
        rows = self.db.execute(
            "SELECT illumination, kind, name, quantity, camera, COUNT(value), "
            "(SELECT ewma FROM points q WHERE q.illumination = p.illumination AND "
            "q.kind = p.kind AND q.name = p.name AND q.quantity = p.quantity AND "
            "q.camera = p.camera ORDER BY cycle DESC LIMIT 1) FROM points p "
            "GROUP BY camera, illumination, kind, name, quantity"
        )
        return {tuple(r[:5]): (r[6], r[5]) for r in rows}


def _identity(path: Path) -> tuple[int, int, int, int] | None:
    """What changes when anybody but this process writes, truncates or replaces ``path``:
    device, inode, size and modification time (a hard link by a backup tool, which
    changes the change time, is not a change)."""
    try:
        st = path.stat()
    except FileNotFoundError:
        return None
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


def _aside(path: Path, word: str) -> Path:
    """A new name beside ``path``: ``<stem>-<word>-<time>[-k]<suffix>``."""
    stamp = time.strftime("%Y%m%dT%H%M%S")
    for k in itertools.count(1):
        aside = path.with_name(
            f"{path.stem}-{word}-{stamp}{'' if k == 1 else f'-{k}'}{path.suffix}"
        )
        if not aside.exists():
            return aside
    raise AssertionError("unreachable")


@dataclass(frozen=True)
class Rebuilt:
    """What :func:`rebuild_history` recovered: the cycles, and the journal's lines it could
    not read with why (line number → reason)."""

    cycles: tuple[int, ...]
    lost: dict[int, str]

    @property
    def text(self) -> str:
        def runs(ns) -> str:
            ranges, start = [], None
            for a, b in zip(ns, [*ns[1:], None], strict=True):
                start = a if start is None else start
                if b != a + 1:
                    ranges.append(f"{start}" if start == a else f"{start}–{a}")
                    start = None
            return ", ".join(ranges)

        said = f"cycles {runs(self.cycles)} rebuilt" if self.cycles else "no cycle rebuilt"
        if self.lost:
            said += "; not recovered: " + "; ".join(
                f"line {n} ({why})" for n, why in list(self.lost.items())[:5]
            )
            if len(self.lost) > 5:
                said += f" and {len(self.lost) - 5} more lines"
        return said


#: The longest journal line read (a cycle's points are kilobytes).
JOURNAL_LINE_MAX = 16 * 2**20


def rebuild_history(journal: str | Path, path: str | Path) -> Rebuilt:
    """Rebuild a history database at ``path`` (a new file) from a watch's ``journal``.

    Parameters
    ----------
    journal : str or Path
        A ``<db>.journal`` file: a line of meta, then a line of JSON per committed cycle.
    path : str or Path
        The database to write; it must not exist.

    Returns
    -------
    Rebuilt
        The cycles rebuilt, and each line that could not be (cut by a crash, not a
        cycle, a value no history holds) with why. A cycle given twice (a restart that
        committed again after a crash between journal and database) is taken at its last
        line. The journal is read a line at a time, none longer than
        :data:`JOURNAL_LINE_MAX`.
    """
    journal, path = Path(journal), Path(path)
    if path.exists():
        raise InputError("exists already; give a new file", source=str(path))
    journal = input_file(journal, "watch journal", todo="give the <db>.journal of a watch")
    fields = CycleRecord.__dataclass_fields__
    cycles: dict[int, tuple[CycleRecord, dict, dict]] = {}
    lost: dict[int, str] = {}
    meta = None
    with open(journal, "rb") as f:
        for n, raw in enumerate(iter(lambda: f.readline(JOURNAL_LINE_MAX + 1), b""), start=1):
            if len(raw) > JOURNAL_LINE_MAX:
                raise InputError(
                    f"line {n} is longer than {JOURNAL_LINE_MAX // 2**20} MB: not a watch journal",
                    source=str(journal),
                )
            if not raw.strip():
                continue
            try:
                entry = json.loads(raw)
            except (UnicodeDecodeError, ValueError, RecursionError):
                lost[n] = "not a line of JSON: cut by a crash?"
                continue
            if n == 1:
                meta = entry.get("meta") if isinstance(entry, dict) else None
                ok = isinstance(meta, dict) and all(
                    isinstance(meta.get(k), t)
                    for k, t in (("station", str), ("created", (int, float)))
                ) and isinstance(meta.get("golden"), (str, type(None)))  # fmt: skip
                if not ok:
                    raise InputError(
                        "not a watch journal (its first line has no meta with station, "
                        "golden and created)",
                        source=str(journal),
                    )
                continue
            try:
                record = CycleRecord(**{k: entry[k] for k in fields})
                if any(len(p) not in (8, 9) for p in entry["points"]):
                    raise ValueError("a point is not 4 names, 4 values and a camera's name")
                points = {(*p[:4], *p[8:9]): tuple(p[4:8]) for p in entry["points"]}
                _check_entry(record, points)
                health = entry.get("health") or {}  # none in journals from before it
                if not isinstance(health, dict):
                    raise ValueError(f"health {health!r} is not a mapping")
                health = cycle_health(health)
            except (KeyError, TypeError, ValueError) as exc:
                lost[n] = (
                    f"not a cycle: {exc}"
                    if not isinstance(exc, KeyError)
                    else (f"not a cycle: no {exc}")
                )
                continue
            cycles[record.cycle] = (record, points, health)
    if meta is None:
        raise InputError("not a watch journal (empty, or no meta line)", source=str(journal))
    history = HistoryWriter(
        path, station=meta["station"], golden=meta["golden"], created=meta["created"]
    )
    try:
        for n in sorted(cycles):
            history.commit(*cycles[n])
    finally:
        history.close()
    return Rebuilt(tuple(sorted(cycles)), lost)


def _check_entry(record: CycleRecord, points: dict) -> None:
    """A journal line's cycle as a history holds it: its types, finite numbers."""
    if not isinstance(record.cycle, int) or isinstance(record.cycle, bool) or record.cycle < 0:
        raise ValueError(f"cycle {record.cycle!r} is not a cycle number")
    if record.status not in STATUSES:
        raise ValueError(f"status {record.status!r}")
    for name in ("started", "seconds"):
        value = getattr(record, name)
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise ValueError(f"{name} {value!r} is not a finite number")
    for key, values in points.items():
        if len(key) not in (4, 5) or len(values) != 4 or not all(isinstance(k, str) for k in key):
            raise ValueError(
                f"a point {[*key, *values]!r} is not 4 names and 4 values (and a camera's name)"
            )
        if key[3] not in CHARTED.get(key[1], ()):
            raise ValueError(f"chart {key!r} is not one watch keeps")
        value, *smoothed = values
        numbers = [v for v in (value, *smoothed) if v is not None]
        if any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in numbers) or not all(
            isinstance(v, (int, float)) and abs(v) < 1e100 for v in smoothed
        ):  # as the history's reader holds them (_chart_series)
            raise ValueError(f"a point of {'/'.join(key)} is not a number, or its band not finite")


def _exclusive(path: Path):
    """An exclusive lock on ``<db>.lock`` for as long as the history is open: a second
    watch on the same database is refused at once, naming the holder's process."""
    return exclusive_lock(
        path.with_name(path.name + ".lock"),
        holder="watch",
        what="this history",
        remedy="another --db",
        source=path,
    )
