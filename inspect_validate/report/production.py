"""A production verdict (``verify --production``) as text, as ``production.json``, and as
the page ``report.html`` (with ``junit.xml``, :func:`~inspect_validate.report.verification.write_junit`)."""

from __future__ import annotations

import html
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

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

__all__ = ["format_production", "production_document", "production_html", "write_production_html"]


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
    out += _field_lines(v)
    if parts.measured:
        ms = [p.measurement for p in parts.measured]
        for j, comp in enumerate(ms[0].comparisons):
            snr = float(np.mean([m.comparisons[j].snr_db for m in ms]))
            cnr = float(np.mean([m.comparisons[j].cnr_db for m in ms]))
            out.append(f"{comp.label}: SNR_dB {snr:.2f}, CNR {cnr:.2f} dB (the parts' mean)")
        # SNR_dB divides the difference by the variances' sum, not its root: a wide gap
        # between noisy classes reads low, beside a high CNR.
        out.append(
            "  SNR_dB (36) is 20·log10(|Δμ| / (σ₁² + σ₂²)), in DN⁻¹ and so lower the noisier "
            "the classes; CNR is 20·log10(|Δμ| / √(σ₁² + σ₂²)) (the manual's model page)"
        )
    rows = [cells for _, cells in check_rows(v.checks)]
    out += ["", false_alarm_line(v), verdict_table(rows, terminal_width(sys.stdout))]
    for item in v.skipped:
        out.append(labelled("skipped", item, stream=sys.stdout))
    for item in v.notes:
        out.append(labelled("note", item, stream=sys.stdout))
    for frame, why in list(parts.not_measured.items())[:10]:
        out.append(labelled("not measured", f"{frame}: {why}", stream=sys.stdout))
    if len(parts.not_measured) > 10:
        out.append(f"… and {len(parts.not_measured) - 10} more frames without a measured part")
    if v.cause:
        out.append(labelled("likely cause", v.cause, stream=sys.stdout))
    out += ["", f"{'PASS' if v.passed else 'FAIL'}: {count_failed(v.checks)}"]
    return "\n".join(out)


def _field_lines(v: ProductionVerification) -> list[str]:
    """The light's field as the parts show it, per class (where they move enough)."""

    def pair(s) -> str:
        return f"x {100 * s[0]:+.2f} ± {100 * s[2]:.2f} %, y {100 * s[1]:+.2f} ± {100 * s[3]:.2f} %"

    rows = []
    for name, found in v.field.items():
        batch, golden = found["batch"], found.get("golden")
        if not np.isfinite(batch[:2]).all():
            continue
        was = f" (golden parts: {pair(golden)})" if golden and np.isfinite(golden[:2]).all() else ""
        rows.append(f"  {name}: {pair(batch)}{was}")
    if not rows:
        return []
    return ["the light's field as the parts show it (μ per 100 px of where a part lies):", *rows]


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
        "skipped": list(v.skipped),
        "notes": list(v.notes),
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
        "field": {
            name: {
                which: dict(zip(("x", "y", "x_se", "y_se"), values, strict=True))
                for which, values in found.items()
            }
            for name, found in v.field.items()
        },
    }


def write_production_html(v: ProductionVerification, path: str | Path) -> Path:
    """Write :func:`production_html` of ``v`` to ``path`` (atomically)."""
    from inspect_validate.files import atomic_write

    return atomic_write(path, production_html(v).encode())


def production_html(v: ProductionVerification) -> str:
    """The page of a production verdict: the verdict and its likely cause, the checks, the
    parts not measured, and charts of every part's values against the golden parts'
    (their mean, ±3 standard deviations shaded) and of where the parts lay."""
    from inspect_validate.report.html import charts, checks_table, page, table

    e = html.escape
    verdict = "pass" if v.passed else "fail"
    parts = v.parts
    total = len(parts.measured) + len(parts.not_measured)
    body = [
        f"<h1>{e(v.station.name)}: on the running line</h1>",
        f'<div class="verdict {verdict}">{verdict.upper()}: {e(count_failed(v.checks))}</div>',
        f'<p class="meta">station {e(str(v.station.path))}, illumination '
        f"{e(next(iter(v.golden.illuminations)))}, {len(parts.measured)} parts measured of "
        f"{total} frames against {v.golden.repeats} golden parts, inspect-validate "
        f"{e(__version__)}</p>",
    ]
    if v.cause:
        body.append(f"<p><b>likely cause:</b> {e(v.cause)}</p>")
    body += [
        "<h2>Checks</h2>",
        f'<p class="meta">{e(false_alarm_line(v))}: each statistical limit holds a batch '
        "mean of good parts within the golden parts' spread at the check's share of the rate."
        "</p>",
        checks_table(v.checks, v.skipped),
    ]
    if parts.not_measured:
        body += [
            "<h2>Frames without a measured part</h2>",
            table(["frame", "why"], [[f, why] for f, why in parts.not_measured.items()]),
        ]
    if parts.measured:
        body += ["<h2>The parts</h2>", charts(_part_charts(v), what="parts")]
    return page(f"verify --production {v.station.name}: {verdict.upper()}", body)


def _part_charts(v: ProductionVerification) -> list[dict[str, Any]]:
    """Each class's μ and σ² and each comparison's SNR_dB per part against the golden
    parts', then the parts' positions, the golden parts' in grey."""
    from inspect_validate.report.charts import COLOURS, chart_series

    golden = next(iter(v.golden.illuminations.values()))
    ms = [p.measurement for p in v.parts.measured]
    index = np.arange(1, len(ms) + 1)
    quantities = []
    for k, c in enumerate(ms[0].classes):
        g = golden.classes[c.name]
        quantities.append((f"{c.name} μ", "DN", g.mean, [m.classes[k].mean for m in ms]))
        quantities.append((f"{c.name} σ²", "DN²", g.variance, [m.classes[k].variance for m in ms]))
    for j, comp in enumerate(ms[0].comparisons):
        ref = golden.comparisons[comp.label].snr_db
        quantities.append(
            (f"{comp.label} SNR_dB", "dB", ref, [m.comparisons[j].snr_db for m in ms])
        )
    out: list[dict[str, Any]] = []
    for title, unit, ref, values in quantities:
        spec: dict[str, Any] = {
            "title": title,
            "xlabel": "part",
            "ylabel": f"{title} [{unit}]",
            "xinteger": True,
            "series": [chart_series("this batch", index, values, kind="points", color=COLOURS[0])],
        }
        if np.isfinite(ref.std):
            spec["hband"] = [ref.mean - 3 * ref.std, ref.mean + 3 * ref.std]
        out.append(spec)
    positions = np.array([p.position for p in v.parts.measured])
    series = [
        chart_series(
            "this batch", positions[:, 0], positions[:, 1], kind="points", color=COLOURS[0]
        )
    ]
    if golden.pose is not None:
        series.insert(
            0,
            chart_series(
                "golden parts",
                golden.pose.x.values,
                golden.pose.y.values,
                kind="points",
                color="#b3b3b3",
            ),
        )
    out.append(
        {
            "title": "where the parts lay (template centre)",
            "xlabel": "x [px]",
            "ylabel": "y [px]",
            "series": series,
        }
    )
    return out
