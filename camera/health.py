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
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

__all__ = [
    "BACKENDS",
    "COUNTERS",
    "GAUGES",
    "HEALTH",
    "QUANTITIES",
    "Limit",
    "Quantity",
    "capture_health",
    "health_problem",
    "health_sha256",
    "health_text",
    "step_health",
]

BACKENDS = (
    "Aravis (GigE Vision)",
    "Aravis (USB3 Vision)",
    "pylon",
    "GenTL (harvesters)",
    "simulated",
)
"""The backends whose sources :attr:`Quantity.sources` names (the manual's table)."""


@dataclass(frozen=True)
class Limit:
    """What ``acceptance.health.<key>`` limits of a quantity, and how its check reads a
    capture's totals (:func:`capture_health`): ``value(totals)`` is the checked value
    and the check's detail; ``absent`` says why it is not checked where the quantity is
    not offered (or, by the capture's acquisition, "triggered" or "free-running")."""

    key: str
    default: float | None
    doc: str
    check: str
    unit: str
    bound: Literal["at_most", "at_least"]
    kind: Literal["fraction", "count", "number"]
    bounds: tuple[float, float]
    absent: str | Mapping[str, str]
    value: Callable[[Mapping[str, float]], tuple[float, str]]


@dataclass(frozen=True)
class Quantity:
    """One health quantity: its record key, a counter (a step's increase, summed over a
    capture) or a gauge (read at a step's end, the capture's ``over_capture`` of its
    steps), what it means, how a line of text shows it (``text`` formatted with the
    value), its Prometheus metric, where each backend of ``BACKENDS`` reads it, and
    its limit, or why it has none."""

    name: str
    kind: Literal["counter", "gauge"]
    meaning: str
    text: str
    metric: str
    sources: tuple[str, ...]
    limit: Limit | None = None
    unlimited: str = ""
    over_capture: Literal["sum", "max", "min"] = "sum"


def _incomplete(t: Mapping[str, float]) -> tuple[float, str]:
    bad = t["frames_incomplete"]
    seen = bad + t.get("frames_delivered", 0)
    return 100 * bad / seen if seen else 0.0, f"{bad:g} of {seen:g} frames arrived incomplete"


def _packets(t: Mapping[str, float]) -> tuple[float, str]:
    resent = ", ".join(
        f"{what} {t[key]:g}"
        for key, what in (("resend_requests", "resends asked"), ("packets_resent", "resent"))
        if key in t
    )
    return t["packets_lost"], "never recovered" + (f"; {resent}" if resent else "")


def _triggers(t: Mapping[str, float]) -> tuple[float, str]:
    missed = t.get("triggers_missed", 0)
    return (
        missed,
        f"{missed:g} of {t['triggers_sent']:g} triggers brought no frame (each sent again once)",
    )


_STREAM = "counted by the capture when triggered"

QUANTITIES: tuple[Quantity, ...] = (
    Quantity(
        "frames_delivered",
        "counter",
        "frames the stream delivered whole",
        "{:g} delivered",
        "inspect_validate_camera_frames_delivered_total",
        (
            "stream `n_completed_buffers`",
            "the same",
            "`Statistic_Total_Buffer_Count` − failed",
            "`STREAM_INFO_NUM_DELIVERED` − incomplete",
            "its own count",
        ),
        unlimited="the denominator of the incomplete frames' share",
    ),
    Quantity(
        "frames_incomplete",
        "counter",
        "frames delivered with data missing (packets lost, a timeout inside the frame)",
        "{:g} incomplete",
        "inspect_validate_camera_frames_incomplete_total",
        (
            "`n_failures`",
            "the same",
            "`Statistic_Failed_Buffer_Count`",
            "each buffer's `BUFFER_INFO_IS_INCOMPLETE`",
            "`world.packet_loss`",
        ),
        limit=Limit(
            "incomplete_frames",
            0.01,
            "Largest share of the frames delivered that arrived incomplete (the capture "
            "discards them; more than a few means a link losing data).",
            "camera: frames arriving incomplete",
            "%",
            "at_most",
            "fraction",
            (0, 1),
            "the camera does not report them",
            _incomplete,
        ),
    ),
    Quantity(
        "frames_lost",
        "counter",
        "frames the camera sent that the stream never delivered (no free buffer, a frame missing)",
        "{:g} lost",
        "inspect_validate_camera_frames_lost_total",
        (
            "`n_underruns` + `n_missing_frames`",
            "the same",
            "`Statistic_Buffer_Underrun_Count`",
            "`STREAM_INFO_NUM_UNDERRUN`",
            "—",
        ),
        limit=Limit(
            "lost_frames",
            None,
            "Most frames the camera sent that the stream never delivered (no free buffer, "
            "a frame missing; default: reported, not limited, as a bench capture waits for "
            "the next frame): 0 on a line that triggers once per part, which lost those.",
            "camera: frames lost",
            "",
            "at_most",
            "count",
            (0, 10**12),
            "the stream does not count them",
            lambda t: (t["frames_lost"], "never delivered"),
        ),
    ),
    Quantity(
        "packets_lost",
        "counter",
        "packets still missing when their frame was closed",
        "{:g} packets lost",
        "inspect_validate_camera_packets_lost_total",
        (
            "`n_missing_packets`",
            "—",
            "GigE cameras: `Statistic_Failed_Packet_Count`",
            "—",
            "—",
        ),
        limit=Limit(
            "packets_lost",
            0,
            "Most packets still missing when their frame was closed (GigE Vision): any "
            "means the network drops data that resends did not recover.",
            "camera: packets lost",
            "",
            "at_most",
            "count",
            (0, 10**12),
            "the transport does not count packets (not GigE Vision)",
            _packets,
        ),
    ),
    Quantity(
        "resend_requests",
        "counter",
        "packets the host asked the camera to send again",
        "{:g} resends asked",
        "inspect_validate_camera_resend_requests_total",
        (
            "`n_resend_requests`",
            "—",
            "GigE cameras: `Statistic_Resend_Request_Count`",
            "—",
            "—",
        ),
        unlimited="recovered packets: shown beside the packets lost, which are limited",
    ),
    Quantity(
        "packets_resent",
        "counter",
        "packets the camera sent again",
        "{:g} resent",
        "inspect_validate_camera_packets_resent_total",
        (
            "`n_resent_packets`",
            "—",
            "GigE cameras: `Statistic_Resend_Packet_Count`",
            "—",
            "—",
        ),
        unlimited="recovered packets: shown beside the packets lost, which are limited",
    ),
    Quantity(
        "triggers_sent",
        "counter",
        "triggers the capture sent (software, or a pulse of the controller)",
        "{:g} triggers",
        "inspect_validate_camera_triggers_sent_total",
        (_STREAM,) * len(BACKENDS),
        unlimited="the denominator of the missed triggers",
    ),
    Quantity(
        "triggers_missed",
        "counter",
        "triggers that brought no frame within the timeout (each taken again once)",
        "{:g} missed",
        "inspect_validate_camera_triggers_missed_total",
        (_STREAM,) * len(BACKENDS),
        limit=Limit(
            "missed_triggers",
            0,
            "Most triggers that brought no frame (each was sent again once; the frames are "
            "whole, but a line that triggers once per part would have lost that part).",
            "camera: missed triggers",
            "",
            "at_most",
            "count",
            (0, 10**9),
            {
                "triggered": "the capture recorded no trigger count",
                "free-running": "the capture was free-running (no triggers)",
            },
            _triggers,
        ),
    ),
    Quantity(
        "temperature_c",
        "gauge",
        "the camera's temperature, °C (the hottest of its DeviceTemperatureSelector places)",
        "{:.1f} °C",
        "inspect_validate_camera_temperature_celsius",
        (
            *("`DeviceTemperature`, the hottest place of `DeviceTemperatureSelector`",)
            * (len(BACKENDS) - 1),
            "`world.temperature_c`",
        ),
        limit=Limit(
            "temperature_c",
            None,
            "Highest temperature the camera may report, °C: its datasheet's rated maximum "
            "for the place ``DeviceTemperature`` measures (default: reported, not limited).",
            "camera: temperature",
            "°C",
            "at_most",
            "number",
            (-60, 200),
            "the camera reports no DeviceTemperature",
            lambda t: (t["temperature_c"], "the hottest reading of the capture"),
        ),
        over_capture="max",
    ),
    Quantity(
        "link_speed_mbps",
        "gauge",
        "the link's speed, Mbit/s (GevLinkSpeed or DeviceLinkSpeed)",
        "link {:g} Mbit/s",
        "inspect_validate_camera_link_speed_mbps",
        (*("`GevLinkSpeed`, or `DeviceLinkSpeed`",) * (len(BACKENDS) - 1), "—"),
        limit=Limit(
            "link_speed_mbps",
            None,
            "Slowest link the camera may report, Mbit/s (1000 for a GigE camera that must "
            "not fall back to 100 Mbit/s on a bad cable; default: reported, not limited).",
            "camera: link speed",
            "Mbit/s",
            "at_least",
            "number",
            (0, 10**6),
            "the camera reports no link speed",
            lambda t: (t["link_speed_mbps"], "the slowest reading of the capture"),
        ),
        over_capture="min",
    ),
)
"""Every health quantity, in the order reports list them: the one table the limits
(``acceptance.health``), the checks, the text, the Prometheus metrics and the manual's
table are made from."""

COUNTERS: dict[str, str] = {q.name: q.meaning for q in QUANTITIES if q.kind == "counter"}
"""The counters a capture step records, where offered: they only grow while a camera is
open (the transport's, and the capture's own triggers)."""

GAUGES: dict[str, str] = {q.name: q.meaning for q in QUANTITIES if q.kind == "gauge"}
"""The gauges a capture step records, where offered: read at the step's end."""

HEALTH = tuple(q.name for q in QUANTITIES)
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
    kinds = {q.name: q.kind for q in QUANTITIES}
    for name, value in health.items():
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if name not in kinds:
            return f"its health record names {name!r}, not a health quantity"
        if not number or not math.isfinite(value) or not abs(value) <= _LARGEST:
            return f"its health record's {name} is {value!r}, not a finite number"
        if kinds[name] == "counter" and (value < 0 or value != int(value)):
            return f"its health record's {name} is {value!r}, not a count"
    return None


def step_health(before: Mapping[str, float], after: Mapping[str, float]) -> dict[str, float]:
    """One step's health from the camera's readings at its start and its end: each
    counter's increase (a counter read lower at the end was reset, and counts from 0),
    each gauge as read at the end. Quantities not offered at the end stay absent."""
    kinds = {q.name: q.kind for q in QUANTITIES}
    out: dict[str, float] = {}
    for name, value in after.items():
        if kinds.get(name) == "counter":
            start = before.get(name, 0)
            out[name] = value - start if value >= start else value
        elif kinds.get(name) == "gauge":
            out[name] = value
    return out


def capture_health(steps: Iterable[Mapping]) -> dict[str, float]:
    """A capture's health from its steps' records (manifest ``steps.<name>.health``,
    missing or malformed ones skipped): counters summed, each gauge as its quantity says
    (the temperature's highest reading, the link's slowest). Only quantities some step
    offered are present."""
    over = {q.name: q.over_capture for q in QUANTITIES}
    total: dict[str, float] = {}
    for record in steps:
        health = record.get("health") if isinstance(record, Mapping) else None
        if not isinstance(health, Mapping):
            continue
        for name, value in health.items():
            if (
                name not in over
                or isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not abs(value) <= _LARGEST  # NaN, inf, garbage from a 64-bit register
                or (value < 0 and over[name] == "sum")
            ):
                continue
            how = over[name]
            if how == "sum":
                total[name] = total.get(name, 0) + value
            else:
                total[name] = (max if how == "max" else min)(total.get(name, value), value)
    return total


def health_text(health: Mapping) -> str:
    """A step's or a capture's health in one line (``"40 delivered, 2 incomplete, 0
    packets lost, 3 resends asked, 0 resent, 41.5 °C"``); "not reported" for none."""
    parts = [_shown(q.text, health[q.name]) for q in QUANTITIES if q.name in health]
    return ", ".join(parts) or "not reported"


def _shown(text: str, value) -> str:
    """A health value in its text; one that is no number (an edited record, refused by
    the checks) shown as given rather than formatted."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return text.format(value)
    return text.replace(text[text.index("{") : text.index("}") + 1], f"{value!r} (not a number)")
