"""Errors that reach the user, and the process exit codes they map to.

Every error the CLI reports names the thing at fault (a file, a field, a class, a
shape or a device) and says what to do about it. The exit codes are part of the
documented interface (the manual, "Exit codes").
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

EXIT_OK = 0
"""Success."""
EXIT_CHECK_FAILED = 1
"""The job ran, but a limit or an acceptance criterion was not met."""
EXIT_INPUT = 2
"""Bad input: usage, a malformed file, an ROI outside the frame, an unreadable image."""
EXIT_DEVICE = 3
"""A camera or light controller failed (timeout, error reply, port vanished)."""
EXIT_INTERNAL = 70
"""A bug in inspect-validate (EX_SOFTWARE); the traceback is printed."""


class InspectValidateError(Exception):
    """Base class of the errors reported to the user without a traceback."""

    exit_code = EXIT_INTERNAL


class InputError(InspectValidateError, ValueError):
    """Invalid input data: a file, a field, an ROI or an image.

    Parameters
    ----------
    message : str
        What is wrong and what to do about it.
    source : str, optional
        The file (and, where known, the field or line) the problem is in; it is
        prefixed to the message.
    """

    exit_code = EXIT_INPUT

    def __init__(self, message: str, *, source: str | None = None) -> None:
        self.source = source
        super().__init__(f"{source}: {message}" if source else message)


@contextlib.contextmanager
def sourced(source: str) -> Iterator[None]:
    """Name ``source`` in an :class:`InputError` raised inside that names no file (the
    model's "no combination can be predicted", a NaN pixel in a region): the file is
    what the user changes. One that names its own file is left as it is."""
    try:
        yield
    except InputError as exc:
        if exc.source:
            raise
        raise InputError(str(exc), source=source) from None


def listed(problems: list[str], most: int) -> str:
    """The first ``most`` of ``problems`` joined with "; ", and how many more there are:
    one message that names each disagreement a check found without running to pages."""
    more = len(problems) - most
    return "; ".join(problems[:most]) + (f"; and {more} more" if more > 0 else "")


class DeviceError(InspectValidateError, RuntimeError):
    """A camera or light controller did not do what it was asked."""

    exit_code = EXIT_DEVICE


class FrameTimeout(DeviceError):
    """No frame arrived within the timeout.

    Free-running, the camera has stopped: an error. Triggered, the trigger may have been
    missed (a camera still reading out): the capture counts it and triggers once more;
    only a second timeout in a row is an error.
    """


class IncompleteFrame(DeviceError):
    """A frame arrived with data missing (packets lost on the way, a buffer underrun).

    The capture sequence discards it, counts it with the step's discarded frames and takes
    the next one; only when more are discarded than a step allows is it an error.
    """
