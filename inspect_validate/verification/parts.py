"""The parts of a running line's frames (a station's ``production:`` block): each frame's
part located against the reference frame, its regions moved with it, and measured
(:mod:`inspect_validate.station.production`): per class μ (38), σ² (39) and the focus
measure, per comparison SNR_dB (36) and ε Gauss (37), and where it lay. A frame without a
part, or one that cannot be this station's frame, is counted with why, never measured.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Iterable, Sequence

    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import Measurement
    from inspect_validate.roi.pose import Pose
    from inspect_validate.station.file import Station
    from inspect_validate.station.production import PartLocator
    from inspect_validate.verification.golden import GoldenIllumination

__all__ = [
    "Part",
    "Parts",
    "capture_of",
    "golden_field",
    "measure_frames",
    "measure_parts",
    "parts_field",
    "production_folder",
]


@dataclass(frozen=True)
class Part:
    """One measured part: its frame file, pose, classes and comparisons, each class's
    focus measure (DN², :func:`~inspect_validate.station.production.focus_measure`), and
    where it lies: the template's centre in the frame, px (x, y), and its rotation, °."""

    frame: str
    pose: Pose
    measurement: Measurement
    focus: dict[str, float]
    position: tuple[float, float, float]


@dataclass(frozen=True)
class Parts:
    """The parts of a folder of frames: those measured, the frames that held none
    (file → why), and the manifest of the capture that took them (None for frames from
    elsewhere: the line's own program)."""

    measured: tuple[Part, ...]
    not_measured: dict[str, str]
    comparisons: Comparisons
    manifest: dict | None = None

    @property
    def unusable(self) -> dict[str, str]:
        """The frames not measured because they cannot be used as this station's frames
        (unreadable, of another size or pixel type, a copy of another), not because no
        part lay whole in them: file → why."""
        return {
            f: why
            for f, why in self.not_measured.items()
            if not why.startswith("no part found") and " keeps " not in why
        }

    @property
    def found(self) -> float:
        """The fraction of the frames with a measured part."""
        total = len(self.measured) + len(self.not_measured)
        return len(self.measured) / total if total else 0.0


def measure_parts(station: Station, frames: Path | Sequence[Path]) -> Parts:
    """Every part in ``frames`` (a folder, or files) of ``station``'s running line.

    Raises
    ------
    InputError
        No ``production:`` block, no frames, a frame that cannot be read, is in colour or
        of another size than the reference (naming the file).
    """
    from inspect_validate.images import expand_paths, read_image

    manifest = None
    if isinstance(frames, Path | str):
        frames = production_folder(station, Path(frames))
        manifest = capture_of(frames)  # audited: a capture's frames are those it wrote
    files = expand_paths([frames] if isinstance(frames, Path | str) else list(frames))
    if not files:
        raise InputError("no frames: give a folder of production frames", source=str(frames))
    parts = measure_frames(station, ((str(path), read_image(path)) for path in files))
    return replace(parts, manifest=manifest)


def production_folder(station: Station, frames: Path) -> Path:
    """The folder of a batch's frames: a ``capture --production`` folder stands for its
    production illumination's step folder; any other folder is itself."""
    name = station.production.illumination if station.production is not None else None
    if name and (frames / "manifest.json").is_file() and (frames / name).is_dir():
        return frames / name
    return frames


def measure_frames(
    station: Station,
    frames: Iterable[tuple[str, np.ndarray]],
    *,
    refuse: bool = True,
    locator: PartLocator | None = None,
    comparisons: Comparisons | None = None,
) -> Parts:
    """:func:`measure_parts` of frames already read: ``(name, frame)`` pairs (a
    simulation's, a camera's). ``refuse=False`` counts a frame of another size or in
    colour as not measured, with why, instead of raising (a watch goes on); a part that
    cannot be measured (a class left with too few pixels to have a spread) is a part not
    measured, named by its frame, either way. ``locator`` and ``comparisons``: the
    station's, built once by a caller that measures batch after batch (a watch)."""
    from inspect_validate.measurement import compare_many
    from inspect_validate.station.production import part_classes, part_focus, part_locator
    from inspect_validate.verification.measured import station_regions

    locator = locator or part_locator(station)
    if comparisons is None:
        _, comparisons = station_regions(station)
    x, y, w, h = locator.template
    centre = np.array([[x + w / 2, y + h / 2]])
    measured, missing = [], {}
    seen: dict[bytes, str] = {}
    for name, frame in frames:
        # The same frame twice (a copy, a link) is one part counted twice: a batch of
        # copies would pass, and train a golden spread of nothing.
        digest = hashlib.blake2b(np.ascontiguousarray(frame).data, digest_size=16)
        digest.update(f"{frame.dtype}{frame.shape}".encode())
        first = seen.setdefault(digest.digest(), name)
        if first != name:
            why = f"the same frame as {first} (a copy or a link): a part is one frame"
            if refuse:
                raise InputError(why, source=name)
            missing[name] = why
            continue
        try:
            placement = locator.place(frame)
        except InputError as exc:
            if refuse:
                raise InputError(str(exc), source=name) from None
            missing[name] = str(exc)
            continue
        if placement.regions is None:
            missing[name] = str(placement.reason)
            continue
        px, py = (float(v) for v in placement.pose.apply(centre)[0])
        try:
            classes = part_classes(frame, placement)
        except (InputError, ValueError) as exc:
            missing[name] = f"the part cannot be measured: {exc}"
            continue
        focus = part_focus(frame, placement.regions)
        measured.append((name, placement.pose, classes, focus, (px, py, placement.pose.angle_deg)))
    # The batch's comparisons at once: a group's ε is one root search for every part.
    measurements = compare_many([m[2] for m in measured], comparisons)
    parts = tuple(
        Part(frame=name, pose=pose, measurement=measurement, focus=focus, position=position)
        for (name, pose, _, focus, position), measurement in zip(
            measured, measurements, strict=True
        )
    )
    return Parts(parts, missing, comparisons)


def capture_of(frames: Path, *, audit: bool = True) -> dict | None:
    """The manifest of the capture ``frames`` were taken by (``capture --production``: the
    folder itself, or the step folder in it), holding that step alone; None for frames
    from elsewhere (the line's program). ``audit``: check the frames are those the
    capture wrote (:func:`~inspect_validate.camera.storage.audit_capture`), where they
    come from outside this run."""
    from inspect_validate.camera.storage import audit_capture, read_manifest

    frames = Path(frames)
    for folder, step in ((frames, None), (frames.parent, frames.name)):
        path = folder / "manifest.json"
        if frames.is_dir() and path.is_file():
            manifest = read_manifest(path)
            steps = [step] if step is not None else list(manifest["steps"])
            if step is not None and step not in manifest["steps"]:
                continue
            # Frames replaced, added or edited since, or an edited health record: refused
            # as the bench refuses them (a capture is measured only as it was written).
            if audit:
                audit_capture(folder, manifest, steps)
            if step is None:
                return manifest
            return {**manifest, "steps": {step: manifest["steps"][step]}}
    return None


Slopes = dict[str, tuple[np.ndarray, np.ndarray]]
"""Per class, the field's slopes (x, y) relative to μ per 100 px and their standard
errors (:func:`~inspect_validate.characterization.field.part_slopes`)."""


def parts_field(parts: Sequence[Part], *, dark_offset: float = 0.0) -> Slopes:
    """The light's field as the ``parts`` show it: each class's μ (above
    ``dark_offset``) against where the part lies."""
    from inspect_validate.characterization.field import part_slopes

    if not parts:
        return {}
    x = [p.position[0] for p in parts]
    y = [p.position[1] for p in parts]
    return {
        c.name: part_slopes([p.measurement.classes[k].mean - dark_offset for p in parts], x, y)
        for k, c in enumerate(parts[0].measurement.classes)
    }


def golden_field(golden: GoldenIllumination, *, dark_offset: float = 0.0) -> Slopes:
    """:func:`parts_field` of the golden parts, from their recorded μ and positions (none
    without positions, or where a class's values do not pair with them)."""
    from inspect_validate.characterization.field import part_slopes

    if golden.pose is None:
        return {}

    def values(spread, offset=0.0):
        return [math.nan if v is None else v - offset for v in spread.values]

    x, y = values(golden.pose.x), values(golden.pose.y)
    out = {}
    for name, cls in golden.classes.items():
        mu = values(cls.mean, dark_offset)
        if len(mu) == len(x) == len(y):
            out[name] = part_slopes(mu, x, y)
    return out
