"""What every verdict gives its readers, on the bench, on a station of several cameras
and on the running line: the one shape the report writers (the terminal's table, JUnit,
the HTML pages' checks, the watch) read, whichever made it.

A verdict is :attr:`~Verdict.passed` where every one of its :attr:`~Verdict.checks`
passed (a station of several cameras: every camera's checks, named by the camera, and
the checks across them), decided at its :attr:`~Verdict.false_alarm` rate; what was not
checked is in :attr:`~Verdict.skipped`, what a reader should know of its inputs in
:attr:`~Verdict.notes`, and the likely cause of what failed in :attr:`~Verdict.cause`.
:class:`~.results.Verification`, :class:`~.rig.RigVerification` and
:class:`~.production.ProductionVerification` are verdicts (the type checker
holds each to it, below).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    from inspect_validate.station.file import Station
    from inspect_validate.verification.checks import Check
    from inspect_validate.verification.production import ProductionVerification
    from inspect_validate.verification.results import Verification
    from inspect_validate.verification.rig import RigVerification

__all__ = ["Verdict"]


@runtime_checkable
class Verdict(Protocol):
    """A verdict of any kind (module text)."""

    @property
    def station(self) -> Station: ...
    @property
    def checks(self) -> tuple[Check, ...]: ...
    @property
    def skipped(self) -> tuple[str, ...]: ...
    @property
    def notes(self) -> tuple[str, ...]: ...
    @property
    def false_alarm(self) -> float: ...
    @property
    def passed(self) -> bool: ...
    @property
    def cause(self) -> str | None: ...


if TYPE_CHECKING:  # each verdict is one, or the type check fails here

    def _bench(v: Verification) -> Verdict:
        return v

    def _rig(v: RigVerification) -> Verdict:
        return v

    def _line(v: ProductionVerification) -> Verdict:
        return v
