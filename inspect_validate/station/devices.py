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

__all__ = ["open_devices", "open_rig"]


@contextlib.contextmanager
def open_devices(station: Station, *, target: str = "scene") -> Iterator[tuple]:
    """Yield (controller, camera) for the station, closing both afterwards. ``target``:
    what a camera that renders the scene shows (``"flat"``: a white target filling
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
    with open_rig(station, target=target, views=[station]) as (controller, cameras):
        yield controller, cameras[station.camera.name]


@contextlib.contextmanager
def open_rig(
    station: Station, *, target: str = "scene", views: list[Station] | None = None
) -> Iterator[tuple]:
    """Yield (controller, {name: camera}) for a station of several cameras (``cameras:``),
    each opened as its :meth:`~inspect_validate.station.file.Station.view` sees it, on the
    one controller; all closed afterwards, also when one fails to open. ``views``: the
    one-camera stations to open instead (:func:`open_devices`)."""
    source = str(station.path)
    cameras_ = [view.camera for view in views] if views is not None else station.cameras
    missing = [
        what
        for what, none in (
            ("camera", any(c.backend == "none" for c in cameras_ or [station.camera])),
            ("light controller", station.controller.backend == "none"),
        )
        if none
    ]
    if missing:
        from inspect_validate.errors import InputError

        raise InputError(
            f"this station has no {' and no '.join(missing)} (backend none, or no "
            "section): its frames come from the line's own program. Give --production --frames FOLDER "
            "of them to train, verify or watch; to capture, describe the "
            f"{' and the '.join(missing)} in the station file (camera:, controller:)",
            source=source,
        )
    opening = Opening(source=source, base=station.folder, station=station, target=target)
    controller_backend = backend("controllers", station.controller.backend, source=source)
    if views is None:
        views = [station.view(name) for name in station.camera_names]
    with contextlib.ExitStack() as stack:
        controller = stack.enter_context(controller_backend.open(station.controller, opening))
        cameras = {}
        for view in views:
            kind: Literal["cameras", "simulators"] = (
                "simulators" if getattr(view.camera, "simulate", False) else "cameras"
            )
            opened = Opening(
                source=source,
                base=station.folder,
                station=view,
                target=target,
                controller=controller,
                state=getattr(controller, "state_path", None),
            )
            camera_backend = backend(kind, view.camera.backend, source=source)
            cameras[view.camera.name] = stack.enter_context(
                camera_backend.open(view.camera, opened)
            )
        yield controller, cameras
