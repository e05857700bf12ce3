"""What a camera and its transport say about an acquisition: counters and gauges.

A frame can be right while the acquisition around it is failing: packets lost and
resent, frames arriving incomplete or not at all, triggers that bring no frame, a camera
warming up. Each backend reports what its library offers (:meth:`Grabber.health
<inspect_validate.camera.grabbers.base.Grabber.health>`); a quantity it cannot report is
absent — "not offered" — never 0. The capture adds what only it knows (the triggers it
sent and those that brought no frame) and records each step's share in the manifest
(``steps.<name>.health``): counters as the step's increase, gauges as read at its end.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable, Mapping
from typing import Any

__all__ = [
    "COUNTERS",
    "GAUGES",
    "HEALTH",
    "capture_health",
    "health_problem",
    "health_sha256",
    "step_health",
]

COUNTERS: dict[str, str] = {
    "frames_delivered": "frames the stream delivered whole",
    "frames_incomplete": "frames delivered with data missing (packets lost, a timeout inside the frame)",
    "frames_lost": "frames the camera sent that the stream never delivered (no free buffer, a frame missing)",
    "packets_lost": "packets still missing when their frame was closed",
    "resend_requests": "packets the host asked the camera to send again",
    "packets_resent": "packets the camera sent again",
    "triggers_sent": "triggers the capture sent (software, or a pulse of the controller)",
    "triggers_missed": "triggers that brought no frame within the timeout (each taken again once)",
}
"""The counters a capture step records, where offered: they only grow while a camera is
open (the first six are the transport's, the last two the capture's own)."""

GAUGES: dict[str, str] = {
    "temperature_c": "the camera's temperature, °C (the hottest of its DeviceTemperatureSelector places)",
    "link_speed_mbps": "the link's speed, Mbit/s (GevLinkSpeed or DeviceLinkSpeed)",
}
"""The gauges a capture step records, where offered: read at the step's end."""

HEALTH = (*COUNTERS, *GAUGES)
"""Every health quantity, in the order reports list them."""

_LARGEST = 2.0**53  # counts beyond what a float holds exactly are not counts


def health_sha256(record: Any) -> str:
    """The SHA-256 of a step's health record as the manifest stores it beside the record
    (``steps.<name>.health_sha256``): an edited record is an edited capture."""
    text = json.dumps(record, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def health_problem(record: Mapping) -> str | None:
    """What makes a manifest's step record's health unusable, or None where it is whole:
    a record whose hash is absent or differs (edited, or written before records were
    hashed), a hash without its record (removed), a record that is not a mapping of the
    quantities to finite numbers in their range (a counter is a whole number ≥ 0)."""
    has, digest = "health" in record, record.get("health_sha256")
    if not has and digest is None:
        return None
    if not has:
        return "its health record was removed (its hash is still there)"
    health = record["health"]
    if digest != health_sha256(health):
        return (
            "its health record is not the one the capture wrote (its SHA-256 differs or is missing)"
        )
    if not isinstance(health, Mapping):
        return f"its health record is {type(health).__name__}, not a mapping of quantities"
    for name, value in health.items():
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if name not in HEALTH:
            return f"its health record names {name!r}, not a health quantity"
        if not number or not math.isfinite(value) or not abs(value) <= _LARGEST:
            return f"its health record's {name} is {value!r}, not a finite number"
        if name in COUNTERS and (value < 0 or value != int(value)):
            return f"its health record's {name} is {value!r}, not a count"
    return None


def step_health(before: Mapping[str, float], after: Mapping[str, float]) -> dict[str, float]:
    """One step's health from the camera's readings at its start and its end: each
    counter's increase (a counter read lower at the end was reset, and counts from 0),
    each gauge as read at the end. Quantities not offered at the end stay absent."""
    out: dict[str, float] = {}
    for name, value in after.items():
        if name in COUNTERS:
            start = before.get(name, 0)
            out[name] = value - start if value >= start else value
        elif name in GAUGES:
            out[name] = value
    return out


def capture_health(steps: Iterable[Mapping]) -> dict[str, float]:
    """A capture's health from its steps' records (manifest ``steps.<name>.health``,
    missing or malformed ones skipped): counters summed, the temperature's highest
    reading, the link's slowest. Only quantities some step offered are present."""
    total: dict[str, float] = {}
    for record in steps:
        health = record.get("health") if isinstance(record, Mapping) else None
        if not isinstance(health, Mapping):
            continue
        for name, value in health.items():
            if (
                name not in HEALTH
                or isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not abs(value) <= _LARGEST  # NaN, inf, garbage from a 64-bit register
                or (value < 0 and name in COUNTERS)
            ):
                continue
            if name in COUNTERS:
                total[name] = total.get(name, 0) + value
            elif name == "temperature_c":
                total[name] = max(total.get(name, value), value)
            else:
                total[name] = min(total.get(name, value), value)
    return total
