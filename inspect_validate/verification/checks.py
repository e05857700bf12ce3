"""One acceptance check: what was measured, its limit and unit, and the verdict."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Check", "at_least", "at_most", "not_run"]


@dataclass(frozen=True)
class Check:
    """A check of the ``acceptance:`` section.

    Attributes
    ----------
    name : str
        What is checked, e.g. ``"amber: A vs B,C SNR_dB"``.
    kind : str
        ``separation``, ``saturation``, ``agreement``, ``ranking``, ``gain`` or ``drift``.
    value, limit : float
        The measured value and its limit (1.0/0.0 for yes/no checks).
    unit : str
        ``dB``, ``%``, ``DN``, ``DN/e⁻`` or ``""``.
    relation : str
        ``"≥"`` or ``"≤"``: how ``value`` must stand to ``limit``.
    passed : bool
    detail : str
        Context for a reader (predicted value, spread, why a value is missing).
    """

    name: str
    kind: str
    value: float
    limit: float
    unit: str
    relation: str
    passed: bool
    detail: str = ""

    @property
    def ran(self) -> bool:
        """False for a check that could not be evaluated (no value): not a pass."""
        return math.isfinite(self.value)

    @property
    def verdict(self) -> str:
        return "pass" if self.passed else ("FAIL" if self.ran else "NOT RUN")


def _check(name, kind, value, limit, unit, relation, detail):
    value = float(value)
    ok = math.isfinite(value) and (value >= limit if relation == "≥" else value <= limit)
    if not math.isfinite(value) and not detail:
        detail = "no value: the quantity could not be computed from these frames"
    return Check(name, kind, value, float(limit), unit, relation, bool(ok), detail)


def not_run(name: str, kind: str, limit, unit: str, relation: str, why: str) -> Check:
    """A check the acceptance section asks for that these frames cannot evaluate: it
    fails, saying why (a check asked for is never passed by not being done)."""
    return Check(name, kind, math.nan, float(limit), unit, relation, False, f"could not run: {why}")


def at_least(name: str, kind: str, value, limit, unit: str = "", detail: str = "") -> Check:
    """Passes when ``value ≥ limit`` (a NaN value fails)."""
    return _check(name, kind, value, limit, unit, "≥", detail)


def at_most(name: str, kind: str, value, limit, unit: str = "", detail: str = "") -> Check:
    """Passes when ``value ≤ limit`` (a NaN value fails)."""
    return _check(name, kind, value, limit, unit, "≤", detail)
