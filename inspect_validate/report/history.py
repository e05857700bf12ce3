"""A watch history as text (cycles and trends) and as CSV (one row per cycle and chart)."""

from __future__ import annotations

import csv
import io
import itertools
import math
import time
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.text import render_table

if TYPE_CHECKING:
    from inspect_validate.watch.history import HistoryLog

__all__ = [
    "chart_label",
    "format_history",
    "history_csv",
    "local_time",
    "status_counts",
    "trend_table",
    "write_history_csv",
]

_CSV_COLUMNS = [
    "cycle",
    "time",
    "seconds",
    "status",
    "passed",
    "reason",
    "cause",
    "frames",
    "illumination",
    "kind",
    "name",
    "quantity",
    "value",
    "ewma",
    "low",
    "high",
    "alarm",
    "camera",
]


# What each charted quantity is called where people read it (the database and the
# exports keep the column names: mean, variance, snr_db, log_error).
QUANTITY_LABELS = {
    "mean": "μ [DN]",
    "variance": "σ² [DN²]",
    "snr_db": "SNR_dB [dB]",
    "log_error": "log₁₀ ε Gauss",
    "focus": "focus [DN²]",
    "x": "position x [px]",
    "y": "position y [px]",
    "angle": "rotation [°]",
}


def chart_label(key: tuple[str, ...]) -> str:
    """``[camera] illumination: class-or-comparison quantity [unit]`` of a chart key
    (illumination, kind, name, quantity[, camera])."""
    ill, _, name, quantity, *camera = key
    where = f"{camera[0]} {ill}" if camera and camera[0] else ill
    return f"{where}: {name} {QUANTITY_LABELS.get(quantity, quantity)}"


def local_time(t: float) -> str:
    """Unix time ``t`` as local ``YYYY-MM-DD HH:MM:SS``."""
    return time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(t))


def _g(x) -> str:
    return "—" if not math.isfinite(x) else f"{float(x):.5g}"


def trend_table(
    log: HistoryLog, *, limit: int | None = None
) -> tuple[list[str], list[list[str]], list[bool]]:
    """Per chart, furthest from its target first: the target, the first and last smoothed
    value, the last band, how far off target in band half-widths (beyond ±1 alarms), the
    alarmed cycles, and the cycle the current run of alarms began ("—" when the last
    point is inside the band). The header, the rows as text and, per row, whether it
    alarms now."""
    trends = []
    for key, s in log.charts.items():
        alarm, off = s.alarm, float(s.deviation[-1])
        since = "—"
        if alarm[-1]:
            inside = np.flatnonzero(~alarm)
            since = str(int(s.cycle[inside[-1] + 1] if inside.size else s.cycle[0]))
        cells = [
            chart_label(key),
            _g(s.target),
            _g(s.ewma[0]),
            _g(s.ewma[-1]),
            f"{_g(s.low[-1])} … {_g(s.high[-1])}",
            f"{off:+.2f}",
            str(int(alarm.sum())),
            since,
        ]
        trends.append((-abs(off), cells))
    trends.sort(key=lambda t: t[0])
    header = ["chart", "target", "first", "now", "band now", "off", "alarms", "since"]
    rows = [cells for _, cells in trends[:limit]]
    return header, rows, [-neg > 1 for neg, _ in trends[:limit]]


def missing_cycles(cycles: list[int]) -> list[tuple[int, int]]:
    """The runs of cycle numbers absent between the first and the last of ``cycles``
    (sorted), as (first missing, last missing)."""
    return [(a + 1, b - 1) for a, b in itertools.pairwise(cycles) if b - a > 1]


def status_counts(log: HistoryLog) -> str:
    """``n pass, n fail, n drift, n error`` of the cycles read."""
    return ", ".join(f"{n} {s}" for s, n in log.counts().items())


def format_history(log: HistoryLog, *, recent: int = 10) -> str:
    """The history's summary, its ``recent`` last cycles and the trend of every chart."""
    lines = [
        f"history {log.path}",
        f"station {log.station}",
        f"golden {log.golden or '—'}",
    ]
    if not log.cycles:
        lines.append("no cycles yet")
        return "\n".join(lines)
    first, last = log.cycles[0], log.cycles[-1]
    shown = "" if len(log.cycles) == log.total else f" (the last {len(log.cycles)} of {log.total})"
    lines.append(
        f"cycles {first.cycle}–{last.cycle}{shown}, {local_time(first.started)} to "
        f"{local_time(last.started)}: {status_counts(log)}"
    )
    gaps = missing_cycles([r.cycle for r in log.cycles])
    if gaps:
        lines.append(
            "warning: cycles missing from the history (watch numbers them one by one): "
            + ", ".join(f"{a}" if a == b else f"{a}–{b}" for a, b in gaps[:10])
            + (f" and {len(gaps) - 10} more gaps" if len(gaps) > 10 else "")
            + "; deleted from the file, or a file restored from a copy"
        )
    lines.append(
        f"last: cycle {last.cycle} {last.status.upper()}"
        + (f" — {last.cause}" if last.cause else "")
        + (f" ({last.reason})" if last.reason and last.status != "pass" else "")
    )
    rows = [
        [
            str(r.cycle),
            local_time(r.started),
            r.status,
            f"{r.seconds:.2f}",
            "; ".join(x for x in (r.cause, r.reason if r.status != "pass" else None) if x) or "",
        ]
        for r in log.cycles[max(len(log.cycles) - recent, 0) :]
    ]
    if rows:
        lines += ["", "recent cycles"]
        lines.append(
            render_table(["cycle", "time", "status", "s", "cause; reason"], rows, left=(1, 2, 4))
        )
    header, cells, _ = trend_table(log)
    if cells:
        lines += ["", "trends (EWMA against the golden target; off target in band half-widths)"]
        lines.append(render_table(header, cells))
    return "\n".join(lines)


def history_csv(log: HistoryLog) -> str:
    """One row per cycle and chart (tidy: a cycle without measurement, an error, is one row
    with the chart columns empty); times in ISO 8601 with the UTC offset."""
    by_cycle: dict[int, list] = {}
    for key, s in log.charts.items():
        alarm = s.alarm
        for i, c in enumerate(s.cycle.tolist()):
            values = (s.value[i], s.ewma[i], s.low[i], s.high[i])
            numbers = ("" if not math.isfinite(v) else repr(float(v)) for v in values)
            by_cycle.setdefault(c, []).append([*key[:4], *numbers, int(alarm[i]), *key[4:]])
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(_CSV_COLUMNS)
    for r in log.cycles:
        head = [
            r.cycle,
            datetime.fromtimestamp(r.started).astimezone().isoformat(timespec="milliseconds"),
            f"{r.seconds:.3f}",
            r.status,
            "" if r.passed is None else int(r.passed),
            r.reason or "",
            r.cause or "",
            r.frames or "",
        ]
        for point in by_cycle.get(r.cycle) or [[""] * (len(_CSV_COLUMNS) - len(head))]:
            writer.writerow(head + point)
    return out.getvalue()


def write_history_csv(log: HistoryLog, path: str | Path) -> Path:
    """Write :func:`history_csv` of ``log`` to ``path`` (atomically)."""
    from inspect_validate.files import atomic_write

    return atomic_write(path, history_csv(log).encode())
