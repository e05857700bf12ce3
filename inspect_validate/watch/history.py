"""The history of a watched station: an SQLite database (WAL mode), one row per cycle.

A cycle is one transaction — its row, its measured values and their charts —
so it is committed whole or not at all: killing ``watch`` mid-cycle loses no
committed cycle, and a restart continues the same history (cycle numbers and
the charts' smoothed values).

Tables::

    meta(key, value)                         station, golden, schema version
    cycles(cycle, started, seconds, status, passed, reason, cause, frames)
    points(cycle, illumination, kind, name, quantity, value, ewma, low, high)

``status`` is ``pass`` (every check passed, no drift), ``fail`` (a check
failed), ``drift`` (checks passed, a chart alarmed) or ``error`` (no
measurement: a device fault, with ``reason``).
"""

from __future__ import annotations

import sqlite3
import time
from dataclasses import dataclass
from pathlib import Path

from inspect_validate.errors import InputError

__all__ = ["HISTORY_SCHEMA_VERSION", "STATUSES", "CycleRecord", "History"]

HISTORY_SCHEMA_VERSION = 1
STATUSES = ("pass", "fail", "drift", "error")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS cycles (
    cycle INTEGER PRIMARY KEY,
    started REAL NOT NULL,
    seconds REAL NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('pass', 'fail', 'drift', 'error')),
    passed INTEGER,
    reason TEXT,
    cause TEXT,
    frames TEXT
);
CREATE TABLE IF NOT EXISTS points (
    cycle INTEGER NOT NULL REFERENCES cycles (cycle),
    illumination TEXT NOT NULL,
    kind TEXT NOT NULL,
    name TEXT NOT NULL,
    quantity TEXT NOT NULL,
    value REAL,
    ewma REAL,
    low REAL,
    high REAL,
    PRIMARY KEY (cycle, illumination, kind, name, quantity)
);
"""


@dataclass(frozen=True)
class CycleRecord:
    """One cycle as the history holds it."""

    cycle: int
    started: float  # Unix time, s
    seconds: float
    status: str
    passed: bool | None
    reason: str | None
    cause: str | None
    frames: str | None


class History:
    """An open history database.

    Raises
    ------
    InputError
        A file that is not an SQLite database, or the history of another station or
        charted against another golden file (its charts would continue on other targets).
    """

    def __init__(self, path: str | Path, *, station: str, golden: str | None):
        self.path = Path(path)
        try:
            self.db = sqlite3.connect(self.path, timeout=10.0, isolation_level=None)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=FULL")  # a committed cycle survives power loss
            self.db.executescript(_SCHEMA)
            meta = dict(self.db.execute("SELECT key, value FROM meta"))
        except sqlite3.DatabaseError as exc:
            raise InputError(
                f"not a watch history database ({exc}); give another --db", source=str(path)
            ) from None
        if not meta:
            meta = {
                "schema_version": str(HISTORY_SCHEMA_VERSION),
                "station": station,
                "golden": golden or "",
                "created": str(time.time()),
            }
            with self.db:
                self.db.executemany("INSERT INTO meta VALUES (?, ?)", list(meta.items()))
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

    def close(self) -> None:
        self.db.close()

    def next_cycle(self) -> int:
        (last,) = self.db.execute("SELECT MAX(cycle) FROM cycles").fetchone()
        return 0 if last is None else last + 1

    def commit(self, record: CycleRecord, points: dict) -> None:
        """Store ``record`` and its chart ``points`` (key → value, ewma, low, high) in one
        transaction."""
        rows = [(record.cycle, *key, *values) for key, values in points.items()]
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
            self.db.executemany("INSERT INTO points VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", rows)
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        self.db.execute("COMMIT")

    def chart_states(self) -> dict:
        """Per series its last smoothed value and how many cycles it has seen."""
        rows = self.db.execute(
            "SELECT illumination, kind, name, quantity, COUNT(value), "
            "(SELECT ewma FROM points q WHERE q.illumination = p.illumination AND "
            "q.kind = p.kind AND q.name = p.name AND q.quantity = p.quantity "
            "ORDER BY cycle DESC LIMIT 1) FROM points p GROUP BY illumination, kind, name, quantity"
        )
        return {tuple(r[:4]): (r[5], r[4]) for r in rows}
