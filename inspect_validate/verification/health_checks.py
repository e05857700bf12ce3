"""Checks on what the camera and its transport reported while the frames were taken
(``acceptance.health``: :class:`~inspect_validate.acceptance.Health`): incomplete frames,
packets lost, triggers missed, the camera's temperature.

Each is fixed: a count over its limit fails whatever the frames show, because the frames
kept can be right while the acquisition around them fails (frames arriving incomplete
are discarded; a trigger that brought no frame is sent again). The quantities come from
each step's ``health`` record in the capture's manifest
(:func:`~inspect_validate.camera.health.capture_health`); a quantity the camera does not
offer is never taken as 0.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from inspect_validate.errors import listed
from inspect_validate.verification.checks import Check, at_most, not_run

if TYPE_CHECKING:
    from inspect_validate.acceptance import Health

__all__ = ["health_checks", "health_text"]


def health_checks(health: Health, manifest: dict) -> tuple[list[Check], list[str]]:
    """The checks ``health`` asks for on the capture ``manifest`` describes, and what was
    not checked and why (for the skipped list).

    A limit the station file gives for a quantity the camera did not report fails
    (:func:`~.checks.not_run`); a default limit is then skipped, saying so. A capture with
    no health record at all (taken before health was recorded, or frames from elsewhere)
    is skipped as a whole.
    """
    from inspect_validate.camera.health import capture_health, health_problem

    records = manifest.get("steps")
    if not isinstance(records, dict):
        records = {}
    steps = {n: s for n, s in records.items() if isinstance(s, dict) and s.get("complete")}
    held = [n for n, s in steps.items() if "health" in s or "health_sha256" in s]
    if not held:
        return [], [
            "camera health: the capture holds no health record (taken before health was "
            "recorded, or frames from elsewhere)"
        ]
    # A record that cannot be read, or a step without one beside steps with one, leaves
    # every limit unchecked: a share over fewer frames, or a value dropped, is no pass.
    unread = [f"step {n!r}: {why}" for n, s in steps.items() if (why := health_problem(s))]
    unread += [f"step {n!r} holds no health record while others do" for n in steps if n not in held]
    # With a record that cannot be read, every quantity is "absent", for that reason.
    total = {} if unread else capture_health(steps.values())
    asked = health.model_fields_set
    checks: list[Check] = []
    skipped: list[str] = []

    def absent(field: str, name: str, limit: float, unit: str, why: str) -> None:
        if unread:
            checks.append(not_run(name, "health", limit, unit, "≤", listed(unread, 2)))
        elif field in asked:
            checks.append(not_run(name, "health", limit, unit, "≤", why))
        else:
            skipped.append(f"{name}: {why}")

    if health.incomplete_frames is not None:
        name = "camera: frames arriving incomplete"
        limit = 100 * health.incomplete_frames
        if "frames_incomplete" not in total:
            absent("incomplete_frames", name, limit, "%", "the camera does not report them")
        else:
            bad = total["frames_incomplete"]
            seen = bad + total.get("frames_delivered", 0)
            share = 100 * bad / seen if seen else 0.0
            checks.append(
                at_most(
                    name,
                    "health",
                    share,
                    limit,
                    "%",
                    f"{bad:g} of {seen:g} frames arrived incomplete",
                )
            )
    if health.packets_lost is not None:
        name = "camera: packets lost"
        if "packets_lost" not in total:
            absent(
                "packets_lost",
                name,
                health.packets_lost,
                "",
                "the transport does not count packets (not GigE Vision)",
            )
        else:
            resent = ", ".join(
                f"{what} {total[key]:g}"
                for key, what in (
                    ("resend_requests", "resends asked"),
                    ("packets_resent", "resent"),
                )
                if key in total
            )
            checks.append(
                at_most(
                    name,
                    "health",
                    total["packets_lost"],
                    health.packets_lost,
                    "",
                    "never recovered" + (f"; {resent}" if resent else ""),
                )
            )
    if health.missed_triggers is not None:
        name = "camera: missed triggers"
        if "triggers_sent" not in total:
            absent(
                "missed_triggers",
                name,
                health.missed_triggers,
                "",
                "the capture recorded no trigger count"
                if any(s.get("acquisition", "free-run") != "free-run" for s in steps.values())
                else "the capture was free-running (no triggers)",
            )
        else:
            missed, sent = total.get("triggers_missed", 0), total["triggers_sent"]
            checks.append(
                at_most(
                    name,
                    "health",
                    missed,
                    health.missed_triggers,
                    "",
                    f"{missed:g} of {sent:g} triggers brought no frame (each sent again once)",
                )
            )
    if health.temperature_c is not None:
        name = "camera: temperature"
        if "temperature_c" not in total:
            absent(
                "temperature_c",
                name,
                health.temperature_c,
                "°C",
                "the camera reports no DeviceTemperature",
            )
        else:
            checks.append(
                at_most(
                    name,
                    "health",
                    total["temperature_c"],
                    health.temperature_c,
                    "°C",
                    "the hottest reading of the capture",
                )
            )
    return checks, skipped


def health_text(health: dict) -> str:
    """A step's or a capture's health in one line (``"40 delivered, 2 incomplete, 0
    packets lost (3 resends asked, 0 resent), 41.5 °C"``); "not reported" for none."""
    parts = []
    for key, label in (
        ("frames_delivered", "delivered"),
        ("frames_incomplete", "incomplete"),
        ("frames_lost", "lost"),
        ("packets_lost", "packets lost"),
        ("resend_requests", "resends asked"),
        ("packets_resent", "resent"),
        ("triggers_sent", "triggers"),
        ("triggers_missed", "missed"),
    ):
        if key in health:
            parts.append(f"{_number(health[key], 'g')} {label}")
    if "temperature_c" in health:
        parts.append(f"{_number(health['temperature_c'], '.1f')} °C")
    if "link_speed_mbps" in health:
        parts.append(f"link {_number(health['link_speed_mbps'], 'g')} Mbit/s")
    return ", ".join(parts) or "not reported"


def _number(value, spec: str) -> str:
    """A health value as text; one that is no number (an edited record, refused by the
    checks) shown as given rather than formatted."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return format(value, spec)
    return f"{value!r} (not a number)"
