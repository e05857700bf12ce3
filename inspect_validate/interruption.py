"""A stop asked for by a signal: SIGTERM (a service manager, ``kill``) or SIGINT (Ctrl-C).

The command line's handler records the signal and raises :class:`Interrupted`
where the program is, so that every open device, lock and child process is released
by the ``with`` and ``finally`` blocks it passes on its way out. An exception can be
swallowed: a library that imports with a bare ``except:``, a finalizer whose exceptions
Python ignores. The record cannot: the loops that run for long (a capture's frames, a
watch's cycles, its pause) call :func:`stop_if_requested` and stop at their next step. A
:func:`deferred` block — a history's commit — runs to its end first.

This module imports nothing of the tool, so the device layer may use it.
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NoReturn

__all__ = ["Interrupted", "deferred", "install", "requested", "reset", "stop_if_requested"]


class Interrupted(KeyboardInterrupt):
    """A stop a signal asked for. A subclass, so that what catches Ctrl-C catches it, and
    not KeyboardInterrupt itself: CPython marks an exact KeyboardInterrupt that passes
    through code a library runs with ``PyRun_String`` as unhandled, and then ends the
    process by SIGINT after the tool has exited with 130."""


_received: list[int] = []  # the signals received, in order
_deferring: list[bool] = []  # one entry per deferred() block entered
_raised: list[bool] = []  # [True] once the stop was raised


# The import system's own code: a module lock is taken and given back there in plain
# Python, with no ``finally`` around every step, so an exception raised in it can leave a
# module locked for good. The importing thread goes on (the lock is its own), but the
# next thread to import that module waits forever, and with it the run's end (a train
# stopped while its frame writer imported tifffile hung in one CI run of hundreds).
_IMPORT_SYSTEM = ("<frozen importlib._bootstrap>", "<frozen importlib._bootstrap_external>")
_RETRY_S = 0.01  # how often a stop that came during an import looks again


def _importing(frame) -> bool:
    """Whether the main thread, stopped at ``frame``, is inside an import."""
    while frame is not None:
        if frame.f_code.co_filename in _IMPORT_SYSTEM:
            return True
        frame = frame.f_back
    return False


def _raise_unless_importing(frame) -> None:
    if _deferring:
        return  # deferred() raises at its end
    if _importing(frame):
        _arm(_RETRY_S)  # raised once the import is over
        return
    _stop()


def _stop() -> NoReturn:
    # A retry still to come must not raise a second time in the cleanup this one starts.
    _arm(0)
    _raised[:] = [True]
    raise Interrupted(signal.Signals(_received[0]).name)


def _arm(seconds: float) -> None:
    """Call :func:`_on_retry` in ``seconds`` (0: not at all). Windows has no timer
    signal: there a stop that came during an import is raised by the next
    :func:`stop_if_requested`."""
    if hasattr(signal, "setitimer"):
        signal.setitimer(signal.ITIMER_REAL, seconds)


def _on_signal(signum, frame) -> None:
    _received.append(signum)
    _raise_unless_importing(frame)


def _on_retry(signum, frame) -> None:
    if _received and not _raised:
        _raise_unless_importing(frame)


def install() -> None:
    """Handle SIGTERM and SIGINT as a stop (:func:`stop_if_requested`); SIGINT too where it was
    inherited as ignored (a job started with ``&`` from a script). Does nothing outside
    the main thread, where an embedding program keeps its own handling.

    A signal that lands inside an import is raised once the import is over (looked at
    every 10 ms, by SIGALRM): raised inside the import system, it could leave the module
    locked, and the next thread to import it waiting forever.

    A signal that lands while Python runs code whose exceptions it cannot pass on (a
    finalizer, a callback of C code, a dict lookup's ``__eq__``) has its
    :class:`Interrupted` written off as "Exception ignored", with a traceback, on stderr.
    Such an Interrupted is dropped silently instead: its signal is recorded, and the stop
    comes at the next :func:`stop_if_requested`."""
    import sys

    try:
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, _on_signal)
        if hasattr(signal, "SIGALRM"):
            signal.signal(signal.SIGALRM, _on_retry)
    except ValueError:  # not the main thread
        return
    if getattr(sys.unraisablehook, "_drops_interrupted", False):
        return
    previous = sys.unraisablehook

    def hook(unraisable) -> None:
        if not isinstance(unraisable.exc_value, Interrupted):
            previous(unraisable)

    hook._drops_interrupted = True  # type: ignore[attr-defined]
    sys.unraisablehook = hook


def requested() -> int | None:
    """The first signal that asked for a stop, None if none did."""
    return _received[0] if _received else None


def stop_if_requested() -> None:
    """Raise :class:`KeyboardInterrupt` if a stop was asked for (also one whose exception
    was swallowed on the way)."""
    if _received and not _deferring:
        _stop()


def reset() -> None:
    """Forget the signals received (a program that handled a stop and goes on)."""
    _received.clear()
    _raised.clear()


@contextmanager
def deferred() -> Iterator[None]:
    """A block a signal does not interrupt: the stop it asks for is raised at its end."""
    _deferring.append(True)
    try:
        yield
    finally:
        _deferring.pop()
    stop_if_requested()
