"""A station's capture folder measured in the station's regions: what ``verify``,
``train`` and ``watch`` measure, each through :func:`measure_capture`."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from concurrent.futures import Future

    from inspect_validate.comparisons import Comparisons
    from inspect_validate.components.sensors import SensorModel
    from inspect_validate.measurement import KdeMode, Limits, Measurement
    from inspect_validate.roi.roiset import RoiSet
    from inspect_validate.station.file import Station
    from inspect_validate.stats import Shading

__all__ = [
    "MeasuredCapture",
    "StepMeasurer",
    "measure_capture",
    "saturation_level",
    "station_regions",
    "station_shading",
]


@dataclass(frozen=True)
class MeasuredCapture:
    """A capture folder of a station, measured in the station's regions."""

    files: dict[str, list[Path]]  # illumination → frame files
    dark_files: list
    manifest: dict
    measurements: dict[str, Measurement]  # illumination → its measurement
    dark: Measurement | None  # of the dark stack
    saturation_level: float | None = None  # DN, :func:`saturation_level`
    sha256: dict = field(default_factory=dict)  # "step/frame_0001.tif" → hex, as audited
    sidecars: dict = field(default_factory=dict)  # frame path → its sidecar, as audited


def station_regions(station: Station) -> tuple[RoiSet, Comparisons]:
    """The station's ROI set and the :class:`~inspect_validate.comparisons.Comparisons` of
    its classes (the station's ``comparisons:``).

    Raises
    ------
    InputError
        No ``rois:``, an unreadable ROI file, weights naming unknown classes.
    """
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.roi import read_rois

    if station.rois is None:
        raise InputError(
            "the station has no 'rois:' (the regions of its classes)", source=str(station.path)
        )
    rois = read_rois(station.resolve(station.rois))
    comparisons = Comparisons.of(
        [c.name for c in rois.classes],
        station.comparisons.groups,
        station.comparisons.weights,
        source=f"{station.path}: comparisons",
    )
    return rois, comparisons


class StepMeasurer:
    """Measure each step of a capture as soon as its frames are written, on a thread of its
    own, while the camera takes the next step's (``capture(..., completed=measurer)``):
    ``verify`` in one pass over its frames. :func:`measure_capture` takes a step's result
    only where the audited capture holds the same frames and saturation level; anything
    else, or a step whose measurement failed, is measured again there (so an error is
    raised where and as it would be without).

    Use as a context manager (the thread ends with it); the arguments are
    :func:`measure_capture`'s.
    """

    def __init__(
        self,
        folder: Path,
        *,
        rois: RoiSet,
        comparisons: Comparisons,
        limits: Limits,
        kde: KdeMode,
        sensor: SensorModel | None = None,
    ) -> None:
        from concurrent.futures import ThreadPoolExecutor

        self.folder = Path(folder)
        self._options = {"rois": rois, "comparisons": comparisons, "limits": limits, "kde": kde}
        self._sensor = sensor
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="step-measurer")
        self._steps: dict[str, Future] = {}

    def __enter__(self) -> StepMeasurer:
        return self

    def __exit__(self, *exc: object) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)

    def __call__(self, step: str) -> None:
        """Start measuring ``step``, whose frames are all written."""
        self._steps[step] = self._pool.submit(self._measure, step)

    def _measure(self, step: str) -> tuple[list[Path], float | None, Measurement]:
        files = sorted((self.folder / step).glob("frame_*.tif"))
        level = saturation_level(files[0], self._sensor)
        return files, level, _measure_step(step, files, level, **self._options)

    def result(self, step: str, files: list[Path], level: float | None) -> Measurement | None:
        """``step``'s measurement where it was made of ``files`` at ``level``, else None."""
        future = self._steps.get(step)
        if future is None:
            return None
        try:
            measured, at, measurement = future.result()
        except Exception:  # measured again by the caller, which raises it as it would
            return None
        return measurement if measured == list(files) and at == level else None


def _measure_step(
    step: str, files: list[Path], level: float | None, *, rois, comparisons, limits, kde,
    shading=None, sidecars=None,
):  # fmt: skip
    """A step's frames measured as :func:`measure_capture` measures them (the darks
    without ε KDE and limits; ``sidecars`` as the audit read them)."""
    from inspect_validate.measurement import measure_files

    if step == "dark":
        return measure_files(
            files, rois, comparisons=comparisons, kde="never", saturation_level=level,
            sidecars=sidecars,
        )  # fmt: skip
    return measure_files(
        files, rois, comparisons=comparisons, limits=limits, kde=kde, saturation_level=level,
        shading=shading, sidecars=sidecars,
    )  # fmt: skip


def measure_capture(
    station: Station,
    folder: Path,
    *,
    rois: RoiSet,
    comparisons: Comparisons,
    limits: Limits,
    kde: KdeMode,
    sensor: SensorModel | None = None,
    measured: StepMeasurer | None = None,
) -> MeasuredCapture:
    """Measure every illumination (and the darks) of a capture folder of ``station``
    with :func:`~inspect_validate.measurement.measure_files`, the one measuring path;
    pixels count as saturated at :func:`saturation_level` (``sensor``: the station's
    sensor model, where the frames do not record their bit depth). ``measured``: the
    steps a :class:`StepMeasurer` measured while they were captured, taken where the
    audited frames are the ones it measured.

    Raises
    ------
    InputError
        Not a complete capture of the station; an unreadable frame; an ROI
        outside the frame.
    """
    from inspect_validate.camera.storage import read_capture

    files, dark_files, manifest, hashes, sidecars = read_capture(
        folder, [i.name for i in station.illuminations]
    )
    _settings_agree(station, folder, manifest, files, dark_files, sidecars)
    rig, camera = manifest.get("rig"), station.camera.name
    if camera is not None and isinstance(rig, dict) and rig.get("camera") not in (None, camera):
        raise InputError(
            f"these are camera {rig.get('camera')!r}'s frames, and this is camera {camera!r}: "
            f"give {Path(folder).parent / camera} (or --camera {rig.get('camera')})",
            source=str(folder),
        )
    first = next(iter(files.values()))[0]
    level = saturation_level(first, sensor, sidecar=sidecars.get(first))
    options = {"rois": rois, "comparisons": comparisons, "limits": limits, "kde": kde}

    def measure(step: str, paths: list[Path], shading: Shading | None = None) -> Measurement:
        early = measured.result(step, paths, level) if measured is not None else None
        if early is not None and shading is None:
            return early
        return _measure_step(step, paths, level, **options, shading=shading, sidecars=sidecars)

    dark = measure("dark", dark_files) if dark_files else None
    shadings = station_shading(station, dark, source=str(folder))
    measurements = {name: measure(name, paths, shadings.get(name)) for name, paths in files.items()}
    return MeasuredCapture(files, dark_files, manifest, measurements, dark, level, hashes, sidecars)


def station_shading(
    station: Station, dark: Measurement | None, *, source: str
) -> dict[str, Shading]:
    """Each illumination's shading correction where ``station``'s ``field`` is
    ``corrected`` (none otherwise): its field over the frame, above the dark level the
    capture's ``dark`` frames measured (their classes' mean).

    Raises
    ------
    InputError
        A corrected field and a capture without dark frames (naming ``source``).
    """
    if station.field is None or not station.field.corrected:
        return {}
    from inspect_validate.characterization.field_file import read_field
    from inspect_validate.stats import Shading

    if dark is None or not dark.classes:
        raise InputError(
            "field.corrected: correcting the shading needs the capture's dark frames (the "
            "signal above dark is divided by the field); capture with dark_frames ≥ 1",
            source=source,
        )
    dark_level = float(np.mean([c.mean for c in dark.classes]))
    fields = read_field(station.resolve(station.field.file)).fields()
    return {name: Shading(f.map(), dark_level) for name, f in fields.items()}


def _settings_agree(
    station: Station, folder: Path, manifest: dict, files, dark_files, sidecars=None
) -> None:
    """Refuse frames whose recorded settings contradict the station they are verified as:
    each step's channel levels (the manifest), exposure and pixel format (the frames'
    sidecars). The prediction is made at the station's settings, so a measurement at
    others would be compared with the wrong numbers (a manifest edited to the station's
    channels, or sidecars saying 4000 µs where the station says 8000 µs, were measured)."""
    from inspect_validate.camera.storage import step_record
    from inspect_validate.errors import listed

    problems = []
    t = station.camera.exposure_us
    exposed = t is not None and "exposure" not in (
        manifest.get("camera", {}).get("not_applied") or []
    )
    wanted = {
        i.name: {ch: float(pct) for ch, pct in i.channels.items() if pct > 0}
        for i in station.illuminations
    }
    for name, paths in [*files.items(), *([("dark", dark_files)] if dark_files else [])]:
        record = step_record(folder, manifest, name, sidecars)
        want = wanted.get(name, {})
        if set(record.channels) != set(want) or any(
            abs(record.channels[c] - want[c]) > 1e-6 for c in want
        ):
            problems.append(
                f"{name} was captured with channels {record.channels or 'off'}, the station "
                f"file says {want or 'off'}"
            )
        stored = _stored_as(paths[0], record.sidecar.get("pixel_format"))
        if stored:
            problems.append(stored)
        recorded = record.exposure_differs(t) if exposed and t is not None else None
        if recorded is not None:
            problems.append(
                f"{name}'s frames were exposed {recorded:g} µs, the station file says {t:g} µs"
            )
    if problems:
        raise InputError(
            f"these frames were taken with other settings than the station file's "
            f"({listed(problems, 3)}): they would be compared with a prediction of other "
            "settings; capture again with this station file, or verify with the station "
            "file they were taken with",
            source=str(folder),
        )


def _stored_as(frame: Path, pixel_format: object) -> str:
    """Why ``frame``'s pixels cannot be the ``pixel_format`` its sidecar records (a camera's
    integers stored as floats, or 16-bit where it sent 8), or ""."""
    import tifffile

    from inspect_validate.camera.pixelformats import BIT_DEPTH

    bits = BIT_DEPTH.get(pixel_format) if isinstance(pixel_format, str) else None
    if bits is None:
        return ""
    try:
        with tifffile.TiffFile(frame) as tif:
            dtype = tif.pages[0].dtype
    except (OSError, ValueError, tifffile.TiffFileError):
        return ""  # the measurement names an unreadable frame
    want = "uint8" if bits <= 8 else "uint16"
    if dtype is None or str(dtype) == want:
        return ""
    return (
        f"{frame.parent.name}/{frame.name} holds {dtype} pixels, where its sidecar records "
        f"{pixel_format} ({want}): not the camera's frames as captured"
    )


def saturation_level(
    frame: Path, sensor: SensorModel | None = None, *, sidecar: dict | None = None
) -> float | None:
    """The grey value of a saturated pixel, DN: 2^bits − 1 of the bit depth ``frame`` was
    recorded with (a Mono12 frame in uint16: 4095; ``sidecar``: its sidecar as already
    read), else of ``sensor`` (the scene's ``bit_depth``); None where neither tells (the
    storage type's maximum then)."""
    from inspect_validate.images import recorded_bit_depth

    bits = recorded_bit_depth(frame, sidecar_record=sidecar)
    if bits is None and sensor is not None:
        bits = sensor.bit_depth
    return None if bits is None else float(2**bits - 1)
