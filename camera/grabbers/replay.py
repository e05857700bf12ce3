"""Replay: frames from a folder of images, to re-run a recorded session without hardware.

Two kinds of folder:

* **a capture** written by ``inspect-validate capture`` (it has ``manifest.json``):
  every frame's sidecar records the light setting it was exposed under, so the
  camera serves, on each grab, the next recorded frame taken under the setting
  the controller has applied *now* — a replayed capture goes through the same
  switching and verification as the original, and a station that asks for a
  light, exposure or more frames than were recorded fails with a clear message;
* **any folder of images** (TIFF, PNG, PGM, BMP, NPY; stacks page by page):
  served in file-name order whatever the lights, with the arrival clock, so a
  capture flushes ``flush_frames`` after each switch as for a live camera.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Literal

import numpy as np

from inspect_validate.camera.controllers.base import describe_setting
from inspect_validate.camera.frame import Frame
from inspect_validate.camera.grabbers.base import Grabber
from inspect_validate.camera.registry import Backend, Opening
from inspect_validate.camera.settings import CameraSettings
from inspect_validate.errors import DeviceError, InputError
from inspect_validate.files import regular_text

__all__ = ["BACKEND", "ReplayGrabber", "ReplaySettings"]

Setting = tuple[tuple[int, float], ...]


def _setting(channels: dict) -> Setting:
    """A light setting as a hashable key: the channels that are on, sorted."""
    return tuple(sorted((int(c), float(v)) for c, v in channels.items() if float(v)))


class ReplayGrabber(Grabber):
    """Serve the frames of ``folder``.

    Parameters
    ----------
    folder : path
        A capture folder (with ``manifest.json``) or a folder of images.
    lights : callable, optional
        Returns the controller's current setting (channel → %); required to
        replay a capture, where it selects the recorded frames to serve.
    """

    def __init__(
        self, folder: str | Path, *, lights: Callable[[], dict[int, float] | None] | None = None
    ) -> None:
        from inspect_validate.images import expand_paths

        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise InputError(
                "replay folder not found (camera.folder in the station file)",
                source=str(self.folder),
            )
        self.name = f"replay of {self.folder}"
        self.lights = lights
        self.frame_id = 0
        self._current: tuple[Setting | None, Iterator] | None = None
        self.recorded: dict[Setting, list[tuple[Path, dict]]] | None = None
        if (self.folder / "manifest.json").is_file():
            if lights is None:
                raise InputError(
                    "replaying a capture needs a controller to select the frames of each light",
                    source=str(self.folder),
                )
            self.recorded = self._index_capture()
            self.missing: set[str] = set()
        else:
            self.paths = expand_paths([self.folder])
            self.missing = {"exposure", "gain"}

    def _index_capture(self) -> dict[Setting, list[tuple[Path, dict]]]:
        recorded: dict[Setting, list[tuple[Path, dict]]] = {}
        # Top-level frames only: partial-* folders hold interrupted attempts.
        for sidecar in sorted(self.folder.glob("*/frame_*.json")):
            try:
                meta = json.loads(regular_text(sidecar))
                setting = _setting(meta["light_setting"])
            except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
                raise InputError(
                    f"not a capture sidecar ({exc!r}); was the file edited?", source=str(sidecar)
                ) from None
            recorded.setdefault(setting, []).append((sidecar.with_suffix(".tif"), meta))
        if not recorded:
            raise InputError("the capture holds no saved frames", source=str(self.folder))
        return recorded

    def configure(
        self,
        *,
        exposure_us: float | None = None,
        gain_db: float | None = None,
        pixel_format: str | None = None,
        region: tuple[int, int, int, int] | None = None,
    ) -> None:
        if region is not None:
            raise DeviceError(f"{self.name}: a replay cannot change the region")
        if self.recorded is None:
            return  # a plain folder knows no settings: exposure and gain are reported missing
        metas = [m for frames in self.recorded.values() for _, m in frames]
        for key, want in (
            ("exposure_us", exposure_us),
            ("gain_db", gain_db),
            ("pixel_format", pixel_format),
        ):
            had = {m.get(key) for m in metas}
            if want is not None and had not in ({want}, {None}):  # None: camera had no such node
                shown = ", ".join(str(v) for v in sorted(had, key=str))
                raise DeviceError(
                    f"{self.name}: the station asks {key} = {want}, the recording was taken at {shown}; "
                    "replay with the station file of the recording"
                )
        self._current = None

    def _frames(self, setting: Setting | None) -> Iterator[tuple[np.ndarray, dict, Path]]:
        from inspect_validate.images import read_image

        if setting is None:
            for path in self.paths:
                image = read_image(path)
                for page in image if image.ndim == 3 else (image,):
                    yield page, {}, path
            return
        for path, meta in (self.recorded or {}).get(setting, ()):
            yield read_image(path), meta, path

    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        frames = []
        for _ in range(n):
            setting = None
            if self.recorded is not None and self.lights is not None:
                setting = _setting(self.lights() or {})
                if setting not in self.recorded:
                    have = "; ".join(describe_setting(dict(s)) for s in self.recorded)
                    raise DeviceError(
                        f"{self.name}: nothing was recorded under {describe_setting(dict(setting))} (recorded: {have}); "
                        "replay with the station file of the recording"
                    )
            if self._current is None or self._current[0] != setting:
                self._current = (setting, self._frames(setting))
            try:
                data, meta, path = next(self._current[1])
            except StopIteration:
                count = len(self.paths) if setting is None else len((self.recorded or {})[setting])
                what = "" if setting is None else f" under {describe_setting(dict(setting))}"
                raise DeviceError(
                    f"{self.name}: the recording has no more frames{what} ({count} in all); "
                    "ask for fewer frames in the station file or record more"
                ) from None
            self.frame_id += 1
            recorded = {k: meta[k] for k in ("frame_id", "timestamp_ns", "device") if k in meta}
            frames.append(
                Frame(
                    data=data,
                    frame_id=self.frame_id,
                    timestamp_ns=time.monotonic_ns(),
                    exposure_us=meta.get("exposure_us"),
                    gain_db=meta.get("gain_db"),
                    pixel_format=meta.get(
                        "pixel_format", "Mono8" if data.dtype == np.uint8 else "Mono16"
                    ),
                    bit_depth=int(meta.get("bit_depth", data.dtype.itemsize * 8)),
                    device=self.name,
                    # A recorded frame is chosen by the light that is on now, so it
                    # counts as exposed now; a plain sequence knows nothing of lights.
                    clock="exposure" if setting is not None else "arrival",
                    extra={"replayed_from": str(path), "recorded": recorded},
                )
            )
        return frames


class ReplaySettings(CameraSettings):
    """Frames recorded earlier, served per light setting (a capture folder)."""

    backend: Literal["replay"]
    """Frames recorded earlier, replayed from a folder as a camera would deliver them."""
    folder: str
    """The folder of recorded frames (a relative path is from the station file's folder)."""


def open_replay(settings: ReplaySettings, opening: Opening) -> ReplayGrabber:
    controller = opening.controller
    return ReplayGrabber(
        opening.resolve(settings.folder), lights=lambda: getattr(controller, "applied", None)
    )


BACKEND = Backend("replay", ReplaySettings, open_replay)
