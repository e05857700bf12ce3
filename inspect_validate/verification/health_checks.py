"""Checks on what the camera and its transport reported while the frames were taken
(``acceptance.health``: :class:`~inspect_validate.acceptance.Health`): one check for each
quantity of :data:`~inspect_validate.camera.health.QUANTITIES` that has a limit, made
from its row (incomplete frames, frames lost, packets lost, triggers missed, the camera's
temperature, the link's speed).

Each is fixed: a value beyond its limit fails whatever the frames show, because the frames
kept can be right while the acquisition around them fails (frames arriving incomplete
are discarded; a trigger that brought no frame is sent again). The quantities come from
each step's ``health`` record in the capture's manifest
(:func:`~inspect_validate.camera.health.capture_health`); a quantity the camera does not
offer is never taken as 0.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from inspect_validate.errors import listed
from inspect_validate.verification.checks import Check, at_least, at_most, not_run

if TYPE_CHECKING:
    from inspect_validate.acceptance import Health

__all__ = ["health_checks"]


def health_checks(health: Health, manifest: dict) -> tuple[list[Check], list[str]]:
    """The checks ``health`` asks for on the capture ``manifest`` describes, and what was
    not checked and why (for the skipped list).

    A limit the station file gives for a quantity the camera did not report fails
    (:func:`~.checks.not_run`); a default limit is then skipped, saying so. A capture with
    no health record at all (taken before health was recorded, or frames from elsewhere)
    is skipped as a whole.
    """
    from inspect_validate.camera.health import QUANTITIES, capture_health, health_problem

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
    triggered = any(s.get("acquisition", "free-run") != "free-run" for s in steps.values())
    for q in QUANTITIES:
        rule = q.limit
        limit = getattr(health, rule.key) if rule is not None else None
        if rule is None or limit is None:
            continue
        shown = 100 * limit if rule.kind == "fraction" else limit
        relation = "≤" if rule.bound == "at_most" else "≥"
        who = {"subject": "camera", "quantity": q.name}
        if q.name not in total:
            absent = rule.absent
            said = (
                absent
                if isinstance(absent, str)
                else absent["triggered" if triggered else "free-running"]
            )
            if unread or rule.key in asked:
                why = listed(unread, 2) if unread else said
                checks.append(not_run(rule.check, "health", shown, rule.unit, relation, why, **who))
            else:
                skipped.append(f"{rule.check}: {said}")
            continue
        value, detail = rule.value(total)
        bound = at_most if rule.bound == "at_most" else at_least
        checks.append(bound(rule.check, "health", value, shown, rule.unit, detail, **who))
    return checks, skipped
