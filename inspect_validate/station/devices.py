"""Opening the camera and light controller a station file describes, each by its
backend (:mod:`inspect_validate.camera.registry`: the shipped ones and any installed
plugin's)."""

from __future__ import annotations

import contextlib
from typing import TYPE_CHECKING, Literal

from inspect_validate.camera.registry import Opening, backend

if TYPE_CHECKING:
    from collections.abc import Iterator

    from inspect_validate.station.file import Station

__all__ = ["open_devices"]


@contextlib.contextmanager
def open_devices(station: Station, *, target: str = "scene") -> Iterator[tuple]:
    """Yield (controller, camera) for the station, closing both afterwards. ``target``:
    what a camera that renders the scene shows (``"uniform"``: a white target filling
    the frame, as for ``characterize``; real cameras see what is there).

    A camera section with ``simulate: true`` is opened by its backend's simulator (the
    ``inspect_validate.simulators`` group), which renders the station's scene into that
    backend's own emulator.

    Raises
    ------
    InputError
        A backend that is not installed or does not load (naming the station file).
    DeviceError
        A device that does not open or answer.
    """
    source = str(station.path)
    opening = Opening(source=source, base=station.folder, station=station, target=target)
    camera_kind: Literal["cameras", "simulators"] = (
        "simulators" if getattr(station.camera, "simulate", False) else "cameras"
    )
    controller_backend = backend("controllers", station.controller.backend, source=source)
    camera_backend = backend(camera_kind, station.camera.backend, source=source)
    with contextlib.ExitStack() as stack:
        controller = stack.enter_context(controller_backend.open(station.controller, opening))
        opened = Opening(
            source=source,
            base=station.folder,
            station=station,
            target=target,
            controller=controller,
            state=getattr(controller, "state_path", None),
        )
        camera = stack.enter_context(camera_backend.open(station.camera, opened))
        yield controller, camera
