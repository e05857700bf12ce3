"""Reports of a verification: the verdict table, ``verification.json`` and ``junit.xml``.

``verification.json`` (schema ``inspect-validate/verification``, version 2)
holds every input (station file and its SHA-256, tool version, the frame
files), the calibration (system gain K, one irradiance scale per illumination
with its method and uncertainty), predicted against measured per class and
comparison, the ranking, the false-alarm rate, and every check with value, limit,
unit, basis, margin and verdict. Version 2 added ``false_alarm`` and each check's
``basis``, ``given_limit``, ``standard_error``, ``df``, ``false_alarm`` and the
verdict ``too close``; the ranking check's value became how far the predicted best
measures behind the measured best. A drift check's ``confidence`` (added within
version 2; null elsewhere) is the probability over the training that its golden file's
limit fails an unchanged station at most its ``false_alarm`` share.
``junit.xml`` has one test case per check, as CI systems read it.
"""

from __future__ import annotations

import sys
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate import __version__
from inspect_validate.text import labelled, render_table, terminal_width

if TYPE_CHECKING:
    from collections.abc import Iterable, Sequence

    from inspect_validate.verification.checks import Check
    from inspect_validate.verification.results import Verification
    from inspect_validate.verification.rig import RigVerification
    from inspect_validate.verification.verdict import Verdict

__all__ = [
    "CHECK_COLUMNS",
    "VERIFICATION_SCHEMA_VERSION",
    "check_rows",
    "false_alarm_document",
    "false_alarm_line",
    "format_rig_verdict",
    "format_verdict",
    "rig_document",
    "rig_rate_line",
    "rig_summary",
    "verdict_documents",
    "verdict_table",
    "verification_document",
    "write_junit",
]

VERIFICATION_SCHEMA_VERSION = 2


CHECK_COLUMNS = ("verdict", "check", "value", "limit", "unit", "basis", "detail")


def check_rows(checks: Iterable[Check]) -> list[tuple[Check, list[str]]]:
    """``(check, cells under CHECK_COLUMNS)`` for each check, failures first, then in the
    order the checks were made: the verdict table and the HTML report show these."""
    return [
        (c, [c.verdict, c.name, _number(c), _limit(c), c.unit, c.basis, c.detail])
        for c in sorted(checks, key=lambda c: (c.passed, not c.undecided))
    ]


def false_alarm_line(v: Verdict) -> str:
    """How often these checks fail a station that has not changed, and how the rate is
    shared: ``false-alarm rate 0.27 % (3σ) shared by 24 checks, 0.011 % each; 12 fixed``."""
    from inspect_validate.verification.checks import (
        confidence_text,
        count_tests,
        normal_equivalent,
    )

    m = count_tests(v.checks)
    fixed = sum(c.basis == "fixed" for c in v.checks)
    rate = v.false_alarm
    text = (
        f"false-alarm rate {100 * rate:.3g} % ({normal_equivalent(rate):.2g}σ) for the station "
        f"unchanged, shared by {m} statistical and tolerance checks"
    )
    if m:
        text += f", {100 * rate / m:.2g} % each"
    held = [c.confidence for c in v.checks if c.confidence is not None]
    if held:
        text += (
            f" (the drift limits hold that share for this golden file with confidence "
            f"{confidence_text(min(held))} or more)"
        )
    if fixed:
        text += f"; {fixed} fixed limit{'s' if fixed > 1 else ''}"
    return text


def verdict_table(rows: list[list[str]], width: int | None) -> str:
    """The checks as a table; where it would be wider than ``width`` (a terminal), each
    check's basis and detail go on an indented line under its row instead of in columns."""
    table = render_table(list(CHECK_COLUMNS), rows)
    if width is None or max(map(len, table.splitlines())) <= width:
        return table
    import textwrap

    lines = render_table(list(CHECK_COLUMNS[:-2]), [r[:-2] for r in rows]).splitlines()
    out = lines[:2]
    for line, row in zip(lines[2:], rows, strict=True):
        out.append(line)
        under = f"{row[-2]}: {row[-1]}" if row[-1] else row[-2]
        out += textwrap.wrap(under, width, initial_indent=" " * 9, subsequent_indent=" " * 11)
    return "\n".join(out)


def format_verdict(v: Verification) -> str:
    """The calibration lines, the checks table (failures first) and the verdict line."""
    out = []
    if v.gain is not None:
        g = v.gain
        out.append(
            f"system gain K (photon transfer, {len(g.points)} points): {g.value:.4g} ± "
            f"{g.standard_error:.2g} DN/e⁻, declared {g.declared:.4g} "
            f"({100 * g.relative_deviation:+.1f} %)"
        )
    for scale in v.scales.values():
        extra = ""
        if scale.residuals:
            extra = f", residuals up to {100 * max(map(abs, scale.residuals)):.2g} %"
        out.append(
            f"{scale.illumination}: irradiance scale {scale.scale:.4g} ± {scale.standard_error:.2g} "
            f"({scale.method}{extra}) → {scale.irradiance:.4g} W/m² at the object"
        )
    if v.ranking:
        r = v.ranking
        out.append(
            f"ranking by {r.comparison}: predicted best {r.predicted_best}, measured best "
            f"{r.measured_best} ({r.tau_text})"
        )
    rows = [cells for _, cells in check_rows(v.checks)]
    if rows:
        out += ["", false_alarm_line(v), verdict_table(rows, terminal_width(sys.stdout))]
    for item in v.skipped:
        out.append(labelled("skipped", item, stream=sys.stdout))
    for n in v.notes:
        out.append(labelled("note", n, stream=sys.stdout))
    out += [f"frames: {describe_acquisition(a)}" for a in v.acquisition]
    if v.cause:
        out.append(labelled("likely cause", v.cause, stream=sys.stdout))
    out.append("")
    out.append(f"{'PASS' if v.passed else 'FAIL'}: {count_failed(v.checks)}")
    return "\n".join(out)


def count_failed(checks: Sequence[Check]) -> str:
    """``all 12 checks passed`` or ``2 of 12 checks failed (1 could not run)``; checks too
    close to call are counted apart (they fail nothing)."""
    failed = sum(not c.passed for c in checks)
    notes = []
    not_run = sum(not c.ran for c in checks)
    if failed and not_run:
        notes.append(f"{not_run} could not run")
    close = sum(c.undecided for c in checks)
    if close:
        notes.append(f"{close} too close to call")
    tail = f" ({', '.join(notes)})" if notes else ""
    if not failed:
        return f"all {len(checks) - close} checks passed{tail}"
    return f"{failed} of {len(checks)} checks failed{tail}"


def _limit(c) -> str:
    return f"{c.relation} {c.limit:.4g}"


def _number(c) -> str:
    if not c.ran:
        return "—"
    if c.unit == "" and c.kind == "separation":  # ε, a fraction
        return f"{c.value:.3g}"
    return f"{c.value:.4g}"


def _row_document(row) -> dict:
    """A predicted-against-measured row as the JSON has it (``class_name`` is ``class``)."""
    return {("class" if k == "class_name" else k): x for k, x in asdict(row).items()}


def format_rig_verdict(v: RigVerification) -> str:
    """Each camera's verdict (as :func:`format_verdict`, under its name), the checks across
    the cameras, and the station's one verdict line."""
    out = []
    for name, result in v.cameras.items():
        out += [f"== camera {name} ==", format_verdict(result), ""]
    out.append("== across cameras ==")
    rows = [cells for _, cells in check_rows(v.across)]
    if rows:
        out.append(verdict_table(rows, terminal_width(sys.stdout)))
    for item in v.skipped:
        out.append(labelled("skipped", item, stream=sys.stdout))
    out += ["", rig_rate_line(v), ("PASS" if v.passed else "FAIL") + f": {rig_summary(v)}"]
    return "\n".join(out)


def rig_summary(v: RigVerification) -> str:
    """``2 cameras, every camera passed; 0 of 2 checks across cameras failed``."""
    failed = [name for name, r in v.cameras.items() if not r.passed]
    across = sum(not c.passed for c in v.across)
    return (
        f"{len(v.cameras)} cameras, "
        + (f"{', '.join(failed)} failed" if failed else "every camera passed")
        + f"; {across} of {len(v.across)} checks across cameras failed"
    )


def rig_rate_line(v: RigVerification) -> str:
    """How the station's false-alarm rate is shared among its cameras."""
    return (
        f"false-alarm rate {100 * v.false_alarm:.3g} % for the station unchanged, "
        f"{100 * v.share:.2g} % to each camera's verification and to the checks across them"
    )


def rig_document(v: RigVerification) -> dict:
    """The top ``verification.json`` of a station of several cameras: the one verdict,
    the checks across cameras, and each camera's verdict and report folder."""
    return {
        "schema": "inspect-validate/rig-verification",
        "schema_version": 1,
        "tool_version": __version__,
        "station": str(v.station.path),
        "verdict": "pass" if v.passed else "fail",
        "false_alarm": {
            "rate": v.false_alarm,
            "per_verification": v.share,
        },
        "cameras": {
            name: {"verdict": "pass" if r.passed else "fail", "report": name}
            for name, r in v.cameras.items()
        },
        "checks": verdict_documents(v.across),
        "skipped": list(v.skipped),
    }


def verification_document(v: Verification) -> dict:
    """The ``verification.json`` document (:func:`~inspect_validate.report.write_json` makes it JSON-safe)."""
    from inspect_validate.report.jsonfile import measurement_document

    return {
        "schema": "inspect-validate/verification",
        "schema_version": VERIFICATION_SCHEMA_VERSION,
        "tool_version": __version__,
        "verdict": "pass" if v.passed else "fail",
        "inputs": v.inputs,
        "acceptance": v.station.acceptance.model_dump(),
        "calibration": {
            "method": v.station.calibration.method,
            "reference": v.station.calibration.reference,
            "gain": None
            if v.gain is None
            else {
                "value": v.gain.value,
                "standard_error": v.gain.standard_error,
                "declared": v.gain.declared,
                "relative_deviation": v.gain.relative_deviation,
                "unit": "DN/e-",
                "points": [list(p) for p in v.gain.points],
            },
            "illuminations": {k: asdict(s) for k, s in v.scales.items()},
        },
        "exposure_time_s": float(v.prediction.exposure_time[0]),
        "classes": [_row_document(r) for r in v.classes],
        "comparisons": [_row_document(r) for r in v.comparisons],
        "ranking": None if v.ranking is None else asdict(v.ranking),
        "false_alarm": false_alarm_document(v),
        "checks": verdict_documents(v.checks),
        "skipped": list(v.skipped),
        "notes": list(v.notes),
        "cause": v.cause,
        "acquisition": list(v.acquisition),
        "measurements": {
            ill: measurement_document(m, limits=v.limits) for ill, m in v.measurements.items()
        },
    }


def verdict_documents(checks: Iterable[Check]) -> list[dict]:
    """Every check as the JSON documents have it, failures first."""
    return [
        {
            "name": c.name,
            "kind": c.kind,
            "illumination": c.illumination,
            "subject": c.subject,
            "quantity": c.quantity,
            "value": c.value,
            "limit": c.limit,
            "relation": c.relation,
            "unit": c.unit,
            "basis": c.basis,
            "given_limit": c.given,
            "standard_error": c.standard_error,
            "df": c.df if c.df != float("inf") else None,
            "false_alarm": c.false_alarm,
            "confidence": c.confidence,
            "verdict": c.verdict.lower(),
            "detail": c.detail,
        }
        for c, _ in check_rows(checks)
    ]


def false_alarm_document(v: Verdict) -> dict:
    """The false-alarm rate and how it is shared, as the JSON documents have it."""
    from inspect_validate.verification.checks import count_tests, normal_equivalent

    m = count_tests(v.checks)
    return {
        "rate": v.false_alarm,
        "normal_equivalent_k": normal_equivalent(v.false_alarm),
        "checks_sharing": m,
        "per_check": v.false_alarm / m if m else None,
    }


def write_junit(v: Verdict, path: str | Path) -> Path:
    """One ``<testcase>`` per check in one ``<testsuite>``; failures carry value and limit.
    A station of several cameras: a suite per camera (its checks' class names carry the
    camera) and one of the checks across them."""
    import xml.etree.ElementTree as ET

    from inspect_validate.files import atomic_write
    from inspect_validate.verification.production import ProductionVerification
    from inspect_validate.verification.rig import RigVerification

    root = ET.Element("testsuites")
    if isinstance(v, RigVerification):
        station = v.station.name
        for name, result in v.cameras.items():
            root.append(
                _junit_suite(
                    f"inspect-validate verify {station} · {name}",
                    f"{station}.{name}",
                    result.checks,
                    result.skipped,
                )
            )
        root.append(
            _junit_suite(
                f"inspect-validate verify {station} · across cameras",
                f"{station}.cameras",
                v.across,
                v.skipped,
            )
        )
    else:
        production = isinstance(v, ProductionVerification)
        skipped = () if production else v.skipped  # the line's suite holds its checks alone
        name = f"inspect-validate verify {'--production ' if production else ''}{v.station.name}"
        root.append(_junit_suite(name, v.station.name, v.checks, skipped))
    ET.indent(root)
    text = ET.tostring(root, encoding="unicode", xml_declaration=True)
    return atomic_write(path, (_xml_chars(text) + "\n").encode())


def _junit_suite(name: str, prefix: str, checks, skipped):
    """A ``<testsuite>`` of ``checks`` (class names ``prefix.kind``) and ``skipped``."""
    import xml.etree.ElementTree as ET

    suite = ET.Element(
        "testsuite",
        name=name,
        tests=str(len(checks)),
        failures=str(sum(not c.passed for c in checks)),
        errors="0",
        skipped=str(len(skipped)),
    )
    for c in checks:
        case = ET.SubElement(suite, "testcase", classname=f"{prefix}.{c.kind}", name=c.name)
        if not c.passed:
            message = (
                f"{c.value:.6g} {c.unit} is not {c.relation} {c.limit:.6g} {c.unit}".replace(
                    "  ", " "
                )
                if c.ran
                else c.detail
            )
            fail = ET.SubElement(case, "failure", message=message, type=c.kind)
            fail.text = c.detail
        elif c.detail:
            ET.SubElement(case, "system-out").text = c.detail
    for s in skipped:
        case = ET.SubElement(suite, "testcase", classname=f"{prefix}.skipped", name=s)
        ET.SubElement(case, "skipped", message=s)
    return suite


def _xml_chars(text: str) -> str:
    """``text`` with the characters XML 1.0 forbids (control characters but tab, line
    feed and carriage return; a station name or a device's reply may hold them) written
    as ``\\xNN``: ElementTree writes them as they are, and no reader takes the file."""
    import re

    return re.sub(
        r"[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]", lambda m: f"\\x{ord(m[0]):02x}", text
    )


def describe_acquisition(a: dict) -> str:
    """``amber: software-trigger, 4 frames at 8000 µs (chunk); discarded: none; camera: 4
    delivered, 0 incomplete, 4 triggers, 0 missed``."""
    from inspect_validate.camera.health import health_text

    exposure = "/".join(f"{x:g}" for x in a["exposure_us"])
    at = f" at {exposure} µs ({a['exposure_source']})" if exposure else ""
    why = ", ".join(f"{n} {reason}" for reason, n in a["discarded"].items()) or "none"
    health = f"; camera: {health_text(a['health'])}" if a.get("health") is not None else ""
    return f"{a['step']}: {a['mode']}, {a['frames']} frames{at}; discarded: {why}{health}"
