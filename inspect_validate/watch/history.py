"""The history of a watched station: an SQLite database (WAL mode), one row per cycle,
and how it is read back.

Tables::

    meta(key, value)                         station, golden, schema version
    cycles(cycle, started, seconds, status, passed, reason, cause, frames)
    points(cycle, illumination, kind, name, quantity, value, ewma, low, high, camera)
    health(cycle, quantity, value, camera)   what the camera reported (a table added
                                             later: older histories gain it empty)

``camera`` is the camera's name on a station of several (``cameras:``), and empty for
the station's one camera and for what the watch itself counts (its reconnects); older
histories gain the column empty.

``status`` is ``pass`` (every check passed, no drift), ``fail`` (a check
failed), ``drift`` (checks passed, a chart alarmed) or ``error`` (no
measurement: a device fault, with ``reason``). A point alarmed when its
smoothed value lies outside [low, high]; the chart's target is their middle.

:func:`read_history` reads a history back (``inspect-validate history``, the
trends in ``verify``'s report) without writing to it, also while ``watch``
appends to it; :mod:`inspect_validate.watch.history_writer` writes it.
"""

from __future__ import annotations

import itertools
import math
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.files import input_file

if TYPE_CHECKING:
    from inspect_validate.station.file import Station

__all__ = [
    "CAMERAS",
    "CHARTED",
    "HISTORY_SCHEMA_VERSION",
    "RECONNECTS",
    "SCHEMA",
    "STATUSES",
    "ChartSeries",
    "CycleRecord",
    "HistoryLog",
    "add_health",
    "cycle_health",
    "health_rows",
    "not_history",
    "read_history",
    "read_station_history",
    "validate_history",
]

HISTORY_SCHEMA_VERSION = 1
STATUSES = ("pass", "fail", "drift", "error")
"""A cycle's status: see the module's text."""

SCHEMA = """
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
    camera TEXT NOT NULL DEFAULT '',
    PRIMARY KEY (cycle, camera, illumination, kind, name, quantity)
);
CREATE TABLE IF NOT EXISTS health (
    cycle INTEGER NOT NULL REFERENCES cycles (cycle),
    quantity TEXT NOT NULL,
    value REAL NOT NULL,
    camera TEXT NOT NULL DEFAULT '',
    PRIMARY KEY (cycle, camera, quantity)
);
"""

RECONNECTS = "reconnects"
"""The watch's own health quantity beside the camera's (:data:`~inspect_validate.camera.
health.HEALTH`): 1 in a cycle that reopened the devices after an error cycle."""


CAMERAS = "cameras"
"""The key of a cycle's health under which each camera of several has its own
(:func:`cycle_health`): no quantity is named so, and any camera may be."""


def cycle_health(health: dict) -> dict:
    """The quantities of ``health`` a history keeps: the camera's and the watch's own, as
    finite numbers (counters not below 0); anything else is dropped. ValueError where a
    quantity it keeps holds something else.

    A cycle's health holds the quantities of the station's one camera and the watch's
    own, and on a station of several cameras, under :data:`CAMERAS`, each camera's name
    and its quantities (kept the same way; a camera with none is dropped)."""
    from inspect_validate.camera.health import COUNTERS, HEALTH

    out: dict = {}
    for name, value in health.items():
        if name == CAMERAS:
            if not isinstance(value, dict):
                raise ValueError(f"health {CAMERAS} {value!r} is not a mapping of cameras")
            cameras = {}
            for camera, quantities in value.items():
                if not (isinstance(camera, str) and camera and isinstance(quantities, dict)):
                    raise ValueError(f"health of camera {camera!r} is not a camera's")
                kept = cycle_health({q: v for q, v in quantities.items() if q != CAMERAS})
                if kept:
                    cameras[camera] = kept
            if cameras:
                out[CAMERAS] = cameras
            continue
        if name not in (*HEALTH, RECONNECTS):
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"health {name} {value!r} is not a number")
        if not (abs(value) < 1e100 and (value >= 0 or name not in (*COUNTERS, RECONNECTS))):
            raise ValueError(f"health {name} {value!r} is not a finite count or reading")
        out[name] = float(value)
    return out


def health_rows(health: dict) -> list[tuple[str, str, float]]:
    """``(camera, quantity, value)`` of a cycle's :func:`cycle_health` (camera empty for the
    station's own quantities): the ``health`` table's rows."""
    cameras = [("", health), *(health.get(CAMERAS) or {}).items()]
    return [
        (camera, quantity, value)
        for camera, quantities in cameras
        for quantity, value in quantities.items()
        if quantity != CAMERAS
    ]


def add_health(health: dict, camera: str, quantity: str, value: float) -> None:
    """Add ``value`` to ``health``'s ``quantity`` of ``camera`` (empty: the station's own),
    the inverse of :func:`health_rows`."""
    into = health if not camera else health.setdefault(CAMERAS, {}).setdefault(camera, {})
    into[quantity] = into.get(quantity, 0.0) + value


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


@dataclass(frozen=True)
class ChartSeries:
    """One chart over the cycles that measured it (arrays of equal length)."""

    cycle: np.ndarray  # int
    value: np.ndarray  # the cycle's measured value (NaN: not finite that cycle)
    ewma: np.ndarray
    low: np.ndarray
    high: np.ndarray

    @property
    def target(self) -> float:
        """The golden mean the chart is centred on."""
        return float((self.low[-1] + self.high[-1]) / 2)

    @property
    def alarm(self) -> np.ndarray:
        return (self.ewma < self.low) | (self.ewma > self.high)

    @property
    def deviation(self) -> np.ndarray:
        """(EWMA − target) in half-widths of the band: beyond ±1 is an alarm."""
        with np.errstate(over="ignore", invalid="ignore"):  # read_history bounds them
            half = (self.high - self.low) / 2
            centre = (self.high + self.low) / 2
            return np.divide(self.ewma - centre, half, out=np.zeros_like(half), where=half > 0)


@dataclass(frozen=True)
class HistoryLog:
    """A history as read back: its cycles in order and its charts by key
    (illumination, "class" | "comparison" | "pose", name, quantity, camera), the camera
    empty on a station of one."""

    path: Path
    station: str
    golden: str
    created: float  # Unix time, s
    cycles: tuple[CycleRecord, ...]
    charts: dict[tuple, ChartSeries]
    total: int  # cycles in the database (``cycles`` may be the last few)
    health: dict[int, dict] = field(default_factory=dict)
    """Per cycle read, what the cameras reported (:func:`cycle_health`; none: not
    recorded)."""

    @property
    def illuminations(self) -> list[str]:
        """The illuminations charted, sorted."""
        return sorted({key[0] for key in self.charts})

    def of_camera(self, name: str) -> HistoryLog:
        """This history with the charts of camera ``name`` of several alone (and those
        of a watch of it alone, which name no camera)."""
        from dataclasses import replace

        charts = {k: s for k, s in self.charts.items() if k[4] in ("", name)}
        return replace(self, charts=charts)

    def counts(self) -> dict[str, int]:
        """Cycles read per status."""
        return {s: sum(r.status == s for r in self.cycles) for s in STATUSES}


def read_history(path: str | Path, *, last: int | None = None) -> HistoryLog:
    """Read the history at ``path``: every cycle, or the ``last`` ones.

    Raises
    ------
    InputError
        No such file, not a history ``watch`` wrote, or a damaged one (a cycle or a
        chart point whose fields do not hold what ``watch`` writes).
    """
    path = Path(path)
    todo = "give the --db file 'watch' wrote"
    input_file(path, "history database", todo=todo)
    db = _read_only(path, todo)
    try:
        meta = dict(db.execute("SELECT key, value FROM meta"))
        (total,) = db.execute("SELECT COUNT(*) FROM cycles").fetchone()
        (since,) = db.execute(
            "SELECT MIN(cycle) FROM (SELECT cycle FROM cycles ORDER BY cycle DESC LIMIT ?)",
            # SQLite's LIMIT is a 64-bit integer: more than that many is every cycle
            (-1 if last is None or last >= 2**63 else last,),
        ).fetchone()
        cycles = db.execute(
            "SELECT cycle, started, seconds, status, passed, reason, cause, frames FROM cycles "
            "WHERE cycle >= ? ORDER BY cycle",
            (since,),
        ).fetchall()
        camera = _camera_column(db, "points")
        rows = db.execute(
            f"SELECT illumination, kind, name, quantity, {camera}, cycle, value, ewma, low, "
            "high FROM points WHERE cycle IN (SELECT cycle FROM cycles WHERE cycle >= ?) "
            f"ORDER BY {camera}, illumination, kind, name, quantity, cycle",
            (since,),
        ).fetchall()
        try:
            camera = _camera_column(db, "health")
            rows_of_health = db.execute(
                f"SELECT cycle, {camera}, quantity, value FROM health WHERE cycle >= ?", (since,)
            ).fetchall()
        except sqlite3.OperationalError:  # a history from before health was kept
            rows_of_health = []
    except sqlite3.DatabaseError as exc:
        raise not_history(path, exc, todo) from None
    finally:
        db.close()
    health: dict[int, dict] = {}
    for cycle, camera, quantity, value in rows_of_health:
        try:
            one = {quantity: value}
            kept = cycle_health({CAMERAS: {camera: one}} if camera else one)
            for _, q, v in health_rows(kept):
                add_health(health.setdefault(cycle, {}), camera, q, v)
        except (ValueError, TypeError) as exc:
            raise _damaged(path, f"cycle {cycle!r}: {exc}") from None
    try:
        created = float(meta["created"])
        station = str(meta["station"])
        if not math.isfinite(created):
            raise ValueError
    except (KeyError, ValueError, TypeError):
        raise not_history(path, "no station or start time in its meta table", todo) from None
    return HistoryLog(
        path=path,
        station=station,
        golden=str(meta.get("golden") or ""),
        created=created,
        cycles=tuple(_cycle_record(path, row) for row in cycles),
        charts=_chart_series(path, rows),
        total=int(total),
        health=health,
    )


def read_station_history(path: str | Path, station: Station) -> HistoryLog:
    """:func:`read_history`, refused unless the history was kept of ``station`` (a
    :class:`~inspect_validate.station.file.Station` read from its file): ``verify
    --history`` puts its trends in that station's report."""
    log = read_history(path)
    if Path(log.station) != station.file.resolve():
        raise InputError(
            f"this history was kept of station {log.station}, not {station.file.resolve()}; "
            "give the history of this station",
            source=str(path),
        )
    return log


def _read_only(path: Path, todo: str) -> sqlite3.Connection:
    """A connection that cannot change the file: read-only, so closing it neither
    checkpoints nor removes a running watch's -wal; on read-only media (no -shm can be
    made) the file is read as immutable."""
    base = path.resolve().as_uri()
    for query in ("?mode=ro", "?mode=ro&immutable=1"):
        try:
            db = sqlite3.connect(base + query, uri=True, timeout=10.0)
            db.execute("SELECT 1 FROM sqlite_master LIMIT 1").fetchall()
            return db
        except sqlite3.OperationalError as exc:
            last = exc
            if "unable to open" not in str(exc) and "readonly" not in str(exc):
                break
        except sqlite3.DatabaseError as exc:
            raise not_history(path, exc, todo) from None
    raise not_history(path, last, todo) from None


def _damaged(path, what: str) -> InputError:
    return InputError(
        f"damaged history: {what}; restore a backup or start a new --db", source=str(path)
    )


def _cycle_record(path, row) -> CycleRecord:
    cycle, started, seconds, status, passed, reason, cause, frames = row
    texts = (reason, cause, frames)
    if not (
        isinstance(cycle, int)
        and all(isinstance(x, (int, float)) and math.isfinite(x) for x in (started, seconds))
        and 0 <= started < 1e11  # Unix time before the year 5000
        and seconds >= 0
        and status in STATUSES
        and passed in (None, 0, 1)
        and all(x is None or isinstance(x, str) for x in texts)
    ):
        raise _damaged(path, f"cycle {cycle!r} holds {row!r}")
    return CycleRecord(
        cycle,
        float(started),
        float(seconds),
        status,
        None if passed is None else bool(passed),
        *texts,
    )


#: What watch charts (watch.drift.series_of, and on the line series_of_parts): a chart of
#: anything else was not written by it.
CHARTED = {
    "class": ("mean", "variance", "focus"),
    "comparison": ("snr_db", "log_error"),
    "pose": ("x", "y", "angle"),
    "field": ("slope_x", "slope_y"),  # the light's field over the parts (per 100 px)
}


def _camera_column(db: sqlite3.Connection, table: str) -> str:
    """``camera``, or an empty one where ``table`` is from a history before it was kept."""
    columns = {row[1] for row in db.execute(f"PRAGMA table_info({table})")}
    return "camera" if "camera" in columns else "''"


def _chart_series(path, rows) -> dict[tuple, ChartSeries]:
    """Rows sorted by chart key then cycle → the charts."""
    charts = {}
    for key, group in itertools.groupby(rows, key=lambda r: tuple(r[:5])):
        if key[3] not in CHARTED.get(key[1], ()):
            raise _damaged(path, f"chart {key!r} is not one watch keeps")
        try:
            if not all(isinstance(k, str) for k in key):
                raise ValueError
            rows_of_chart = list(group)
            # Cycle numbers as integers (a float loses them past 2⁵³), the values as floats.
            cycles = np.array([r[5] for r in rows_of_chart], dtype=np.int64)
            block = np.array([r[6:] for r in rows_of_chart], dtype=float)  # NULL → NaN
        except (ValueError, TypeError, OverflowError):
            raise _damaged(path, f"chart {key!r} holds values that are not numbers") from None
        if not (np.abs(block[:, 1:]) < 1e100).all():  # watch writes finite, physical values
            raise _damaged(path, f"chart {key!r} has a smoothed value or band that is not finite")
        charts[key] = ChartSeries(cycles, *block.T)
    return charts


def validate_history(path: Path) -> None:
    """Refuse a history that is damaged before anything is appended to it: the checks
    :func:`read_history` makes, and SQLite's quick_check of its pages (read-only)."""
    read_history(path)
    db = _read_only(path, "give another --db")
    try:
        result = [r[0] for r in db.execute("PRAGMA quick_check")]
    except sqlite3.DatabaseError as exc:
        raise not_history(path, exc, "give another --db") from None
    finally:
        db.close()
    if result != ["ok"]:
        raise InputError(
            f"the history is damaged ({'; '.join(map(str, result[:3]))}); give another --db "
            "(the frames of its cycles are kept beside it)",
            source=str(path),
        )


def not_history(path: str | Path, exc: object, todo: str) -> InputError:
    """The error of a file that is not a history (SQLite could not read it as one)."""
    return InputError(f"not a watch history database ({exc}); {todo}", source=str(path))
