"""Camera and controller backends, found by entry points: the shipped ones and any
installed package's, registered the same way.

A backend is an entry point of a package's metadata in one of three groups:

``inspect_validate.cameras``
    name → a :class:`Backend` whose ``open`` yields a
    :class:`~inspect_validate.camera.grabbers.base.Grabber`;
``inspect_validate.controllers``
    name → a :class:`Backend` whose ``open`` yields a
    :class:`~inspect_validate.camera.controllers.base.LedController`;
``inspect_validate.simulators``
    a camera backend's name → a :class:`Backend` that renders a station's simulated
    scene into that backend's own emulator (``camera.simulate: true``).

The name is what a station file's ``camera.backend`` or ``controller.backend`` says. A
vendor's backend is a package of its own that declares, in its ``pyproject.toml``::

    [project.entry-points."inspect_validate.cameras"]
    acme = "acme_iv:BACKEND"

with ``BACKEND = Backend("acme", AcmeSettings, open_acme)``: ``AcmeSettings`` the
pydantic model of its ``camera:`` keys (derived from
:class:`~inspect_validate.camera.settings.CameraSettings`, with
``backend: Literal["acme"]``), ``open_acme(settings, opening)`` a context manager
yielding the grabber. The manual's "Station files" page shows a whole one.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from pydantic import BaseModel

__all__ = ["GROUPS", "Backend", "Opening", "Search", "backend", "backends", "broken"]

Kind = Literal["cameras", "controllers", "simulators"]
GROUPS: dict[Kind, str] = {
    "cameras": "inspect_validate.cameras",
    "controllers": "inspect_validate.controllers",
    "simulators": "inspect_validate.simulators",
}


@dataclass(frozen=True)
class Opening:
    """What a backend is opened with besides its settings.

    Attributes
    ----------
    source : str
        The file its settings come from (for messages).
    base : Path
        The folder paths in that file are relative to.
    controller : object, optional
        The light controller, opened first (a camera that replays frames per light
        setting reads what it applied).
    target : {"scene", "flat", "edge"}
        What a camera that renders a scene shows: the scene's objects, a white target
        filling the frame (``characterize``'s series, ``capture --target flat``), or a dark
        square on white whose edge crosses the frame's centre turned by a few degrees
        (``capture --target edge``). A real camera sees what is in front of it.
    station : object, optional
        The whole station (simulators render its scene; device backends need not look).
    state : Path, optional
        The simulated controller's state file (which lights are on), for a simulator.
    """

    source: str
    base: Path
    controller: Any = None
    target: str = "scene"
    station: Any = None
    state: Path | None = None

    def resolve(self, path: str | Path) -> Path:
        """``path`` as given in the settings' file, on disk."""
        return self.base / path


@dataclass(frozen=True)
class Search:
    """Where a backend looks for devices (``inspect-validate devices``).

    Attributes
    ----------
    cti : str, optional
        A GenTL producer to load (default: every one in ``GENICAM_GENTL64_PATH``).
    """

    cti: str | None = None


@dataclass(frozen=True)
class Backend:
    """One backend: its name, the model of its settings and how to open it.

    Attributes
    ----------
    name : str
        What ``backend:`` says in a station file.
    settings : type
        The pydantic model of its section's keys (with ``backend: Literal[name]``).
    open : callable
        ``open(settings, opening)`` → a context manager yielding the device.
    discover : callable, optional
        ``discover(search)`` → the devices it can see now, as
        :class:`~inspect_validate.camera.grabbers.base.DeviceInfo`; a
        :class:`~inspect_validate.errors.DeviceError` saying what to install where its
        library is missing. None: a backend with nothing to discover (replay, simulated).
    device_keys : callable
        ``device_keys(info)`` → the keys of its settings that choose that found device
        (default: ``{"serial": info.serial}``).
    """

    name: str
    settings: type[BaseModel]
    open: Callable[[Any, Opening], AbstractContextManager]
    discover: Callable[[Search], list] | None = None
    device_keys: Callable[[Any], dict[str, Any]] = lambda info: {"serial": info.serial}


@cache
def _load(kind: Kind) -> tuple[dict[str, Backend], dict[str, str]]:
    """The installed backends of ``kind`` by name, and the broken entry points' reasons
    (read once per process)."""
    from importlib.metadata import entry_points

    found: dict[str, Backend] = {}
    broken: dict[str, str] = {}
    for point in sorted(entry_points(group=GROUPS[kind]), key=lambda p: p.name):
        try:
            loaded = point.load()
        except Exception as exc:  # a broken plugin must not take the shipped ones down
            broken[point.name] = f"{point.value} does not load ({exc})"
            continue
        if not isinstance(loaded, Backend) or loaded.name != point.name:
            broken[point.name] = f"{point.value} is not a Backend named {point.name!r}"
            continue
        found[point.name] = loaded
    return found, broken


def backends(kind: Kind) -> dict[str, Backend]:
    """Every installed backend of ``kind`` that loads, by name."""
    return _load(kind)[0]


def broken(kind: Kind) -> dict[str, str]:
    """Installed entry points of ``kind`` that do not load: name → why."""
    return _load(kind)[1]


def backend(kind: Kind, name: str, *, source: str | None = None) -> Backend:
    """The backend ``name`` of ``kind``.

    Raises
    ------
    InputError
        None of that name is installed (the message lists those that are), or its
        package's entry point is broken.
    """
    found, broken = _load(kind)
    if name in broken:
        raise InputError(f"{kind[:-1]} backend {name!r}: {broken[name]}", source=source)
    if name not in found:
        raise InputError(
            f"no {kind[:-1]} backend {name!r} is installed (there are: "
            f"{', '.join(found) or 'none'}); a vendor's backend is a package registering an "
            f"entry point in {GROUPS[kind]!r}",
            source=source,
        )
    return found[name]
