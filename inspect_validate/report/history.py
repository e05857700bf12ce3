"""A watch history as text (cycles and trends) and as CSV (one row per cycle and chart)."""

from __future__ import annotations

import csv
import io
import math
import time
from datetime import datetime
from pathlib import Path

import numpy as np

from inspect_validate.report.tables import render_table

__all__ = [
    "chart_label",
    "format_history",
    "history_csv",
    "trend_rows",
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
]


def chart_label(key) -> str:
    """``illumination: class-or-comparison quantity`` of a chart key."""
    ill, _, name, quantity = key
    return f"{ill}: {name} {quantity}"


def _stamp(t: float) -> str:
    return time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(t))


def _g(x: float) -> str:
    return "—" if not math.isfinite(x) else f"{x:.5g}"


def trend_rows(log) -> list[dict]:
    """Per chart: its target, first and last smoothed value, the last band, how far off
    target in band half-widths (beyond ±1 alarms), the alarmed cycles, and the cycle
    the current alarm began (None when the last point is inside the band). Furthest
    from target first."""
    rows = []
    for key, s in log.charts.items():
        alarm = s.alarm
        since = None
        if alarm[-1]:
            inside = np.flatnonzero(~alarm)
            since = int(s.cycle[inside[-1] + 1] if inside.size else s.cycle[0])
        rows.append(
            {
                "key": key,
                "target": s.target,
                "first": float(s.ewma[0]),
                "last": float(s.ewma[-1]),
                "low": float(s.low[-1]),
                "high": float(s.high[-1]),
                "deviation": float(s.deviation[-1]),
                "alarms": int(alarm.sum()),
                "since": since,
            }
        )
    rows.sort(key=lambda r: -abs(r["deviation"]))
    return rows


def trend_table(log, *, limit: int | None = None):
    """The trends as a table: header, rows of text and, per row, whether it alarms now."""
    trends = trend_rows(log)[:limit]
    header = ["chart", "target", "first", "now", "band now", "off", "alarms", "since"]
    cells = [
        [
            chart_label(t["key"]),
            _g(t["target"]),
            _g(t["first"]),
            _g(t["last"]),
            f"{_g(t['low'])} … {_g(t['high'])}",
            f"{t['deviation']:+.2f}",
            str(t["alarms"]),
            "—" if t["since"] is None else str(t["since"]),
        ]
        for t in trends
    ]
    return header, cells, [abs(t["deviation"]) > 1 for t in trends]


def format_history(log, *, recent: int = 10) -> str:
    """The history's summary, its ``recent`` last cycles and the trend of every chart."""
    counts = log.counts()
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
        f"cycles {first.cycle}–{last.cycle}{shown}, {_stamp(first.started)} to "
        f"{_stamp(last.started)}: " + ", ".join(f"{n} {s}" for s, n in counts.items())
    )
    lines.append(
        f"last: cycle {last.cycle} {last.status.upper()}"
        + (f" — {last.cause}" if last.cause else "")
        + (f" ({last.reason})" if last.reason and last.status != "pass" else "")
    )
    rows = [
        [
            str(r.cycle),
            _stamp(r.started),
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


def history_csv(log) -> str:
    """One row per cycle and chart (tidy: a cycle without measurement, an error, is one row
    with the chart columns empty); times in ISO 8601 with the UTC offset."""
    by_cycle: dict[int, list] = {}
    for key, s in log.charts.items():
        alarm = s.alarm
        for i, c in enumerate(s.cycle.tolist()):
            values = (s.value[i], s.ewma[i], s.low[i], s.high[i])
            numbers = ("" if not math.isfinite(v) else repr(float(v)) for v in values)
            by_cycle.setdefault(c, []).append([*key, *numbers, int(alarm[i])])
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
        for point in by_cycle.get(r.cycle) or [[""] * 9]:
            writer.writerow(head + point)
    return out.getvalue()


def write_history_csv(log, path: str | Path) -> Path:
    """Write :func:`history_csv` of ``log`` to ``path`` (atomically)."""
    from inspect_validate.files import atomic_write

    return atomic_write(path, history_csv(log).encode())
