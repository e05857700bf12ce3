"""A production verdict (``verify --production``) as text and as ``production.json``."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from inspect_validate import __version__
from inspect_validate.report.verification import (
    check_rows,
    count_failed,
    false_alarm_document,
    false_alarm_line,
    verdict_documents,
    verdict_table,
)
from inspect_validate.text import labelled, terminal_width

if TYPE_CHECKING:
    from inspect_validate.verification.production import ProductionVerification

__all__ = ["format_production", "production_document"]


def format_production(v: ProductionVerification) -> str:
    """The parts read, the checks table (failures first) and the verdict line."""
    parts = v.parts
    out = [
        f"{len(parts.measured)} parts measured of {len(parts.measured) + len(parts.not_measured)} "
        f"frames, against {v.golden.repeats} golden parts"
    ]
    if parts.measured:
        shifts = [p.pose.shift for p in parts.measured]
        angles = [p.pose.angle_deg for p in parts.measured]
        out.append(
            f"poses: shift x {min(s[0] for s in shifts):+.1f} to {max(s[0] for s in shifts):+.1f}"
            f" px, y {min(s[1] for s in shifts):+.1f} to {max(s[1] for s in shifts):+.1f} px, "
            f"rotation {min(angles):+.2f} to {max(angles):+.2f}°"
        )
    rows = [cells for _, cells in check_rows(v.checks)]
    out += ["", false_alarm_line(v), verdict_table(rows, terminal_width(sys.stdout))]
    for frame, why in list(parts.not_measured.items())[:10]:
        out.append(labelled("not measured", f"{frame}: {why}", stream=sys.stdout))
    if len(parts.not_measured) > 10:
        out.append(f"… and {len(parts.not_measured) - 10} more frames without a measured part")
    if v.cause:
        out.append(labelled("likely cause", v.cause, stream=sys.stdout))
    out += ["", f"{'PASS' if v.passed else 'FAIL'}: {count_failed(v.checks)}"]
    return "\n".join(out)


def production_document(v: ProductionVerification) -> dict:
    """The ``production.json`` document: the verdict, the checks, and every part."""
    return {
        "schema": "inspect-validate/production",
        "schema_version": 1,
        "tool_version": __version__,
        "verdict": "pass" if v.passed else "fail",
        "cause": v.cause,
        "station": str(v.station.path),
        "illumination": next(iter(v.golden.illuminations)),
        "false_alarm": false_alarm_document(v),
        "checks": verdict_documents(v.checks),
        "parts": [
            {
                "frame": p.frame,
                "shift_px": list(p.pose.shift),
                "angle_deg": p.pose.angle_deg,
                "score": p.pose.score,
                "classes": {
                    c.name: {
                        "mean": c.mean,
                        "variance": c.variance,
                        "pixels": c.n_pixels,
                        "focus": p.focus[c.name],
                    }
                    for c in p.measurement.classes
                },
                "comparisons": {
                    c.label: {"snr_db": c.snr_db, "error_gaussian": c.error_gaussian}
                    for c in p.measurement.comparisons
                },
            }
            for p in v.parts.measured
        ],
        "not_measured": dict(v.parts.not_measured),
    }
