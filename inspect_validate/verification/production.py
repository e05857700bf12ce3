"""Verification of a station on its running line (its ``production:`` block): the parts in
a folder of production frames, each located and measured
(:mod:`inspect_validate.station.production`), against golden statistics trained the same
way on good parts.

**The golden parts.** ``train --production`` measures every part in a folder of frames
of good parts: per class μ (38), σ² (39) and the focus measure, per comparison SNR_dB
(36) and ε Gauss (37), one value per part; their spread over the parts (n of them) is
the part-to-part variation a production verdict allows.

**The verdict.** A batch of m parts is compared by the mean of each quantity over its
parts: if nothing changed, the batch mean x̄ₘ differs from the golden mean x̄ₙ by

    |x̄ₘ − x̄ₙ| ≤ t_{n−1}(1 − α/2) · s · √(1/m + 1/n)

with probability 1 − α, s the golden parts' standard deviation (a part's own pixel
noise is inside it). α is the check's share of the station's false-alarm rate
(:mod:`.checks`). A folder where fewer than half the frames hold a part fails its own
check, naming the reasons (a wrong reference, a moved camera, no parts passing).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError, listed

if TYPE_CHECKING:
    from collections.abc import Iterable, Sequence

    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import Measurement
    from inspect_validate.roi.pose import Pose
    from inspect_validate.station.file import Station
    from inspect_validate.station.production import PartLocator
    from inspect_validate.verification.checks import Check
    from inspect_validate.verification.diagnosis import Diagnosis, Sensor
    from inspect_validate.verification.golden import Golden, Spread

__all__ = [
    "MIN_FOUND",
    "Part",
    "Parts",
    "ProductionVerification",
    "golden_parts",
    "measure_frames",
    "measure_parts",
    "production_golden",
    "train_production",
    "verify_parts",
    "verify_production",
]

MIN_FOUND = 0.5
"""The fraction of a folder's frames that must hold a measured part."""


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
    from inspect_validate.station.production import measure_part, part_focus, part_locator
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
            measurement = measure_part(frame, placement, comparisons)
        except (InputError, ValueError) as exc:
            missing[name] = f"the part cannot be measured: {exc}"
            continue
        measured.append(
            Part(
                frame=name,
                pose=placement.pose,
                measurement=measurement,
                focus=part_focus(frame, placement.regions),
                position=(px, py, placement.pose.angle_deg),
            )
        )
    return Parts(tuple(measured), missing, comparisons)


def train_production(station: Station, frames: Path) -> Golden:
    """The golden statistics of good parts: every part in ``frames`` measured, each
    quantity's values over the parts (module description).

    Raises
    ------
    InputError
        As :func:`measure_parts`; fewer than two parts measured (no spread).
    """
    return golden_parts(station, measure_parts(station, frames), source=str(frames))


def golden_parts(station: Station, parts: Parts, *, source: str = "the frames") -> Golden:
    """The golden statistics of measured good ``parts`` (:func:`train_production`)."""
    from inspect_validate import __version__
    from inspect_validate.station.file import station_hash
    from inspect_validate.verification.golden import golden_of

    if len(parts.measured) < 2:
        reasons = "; ".join(sorted(set(parts.not_measured.values()))[:2])
        raise InputError(
            f"{len(parts.measured)} part measured: golden statistics need the spread of two "
            f"or more good parts{f' ({reasons})' if reasons else ''}",
            source=source,
        )
    assert station.production is not None  # measure_parts refused a station without
    name = station.production.illumination
    only = station.model_copy(
        update={"illuminations": [i for i in station.illuminations if i.name == name]}
    )
    return golden_of(
        only,
        [{name: p.measurement} for p in parts.measured],
        parts.comparisons,
        captures=[p.frame for p in parts.measured],
        tool_version=__version__,
        station_sha256=station_hash(station.file),
        focus=[p.focus for p in parts.measured],
        poses=[p.position for p in parts.measured],
    )


@dataclass(frozen=True)
class ProductionVerification:
    """A verdict on a batch of production frames: the checks (decided at
    ``false_alarm``), the parts, and whether every check passed."""

    station: Station
    golden: Golden
    parts: Parts
    checks: tuple[Check, ...]
    false_alarm: float
    skipped: tuple[str, ...] = ()  # what was not checked, and why
    notes: tuple[str, ...] = ()  # what a reader of the verdict should know of its inputs

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def cause(self) -> str | None:
        """The likely cause of the failed checks, from their pattern (None where every
        check passed): a light level moves every class's μ by one factor (a gain too,
        told apart by σ² against the EMVA model); its spectrum
        or the parts move them by different ones; a lens out of focus lowers the focus
        measure at steady μ; parts that differ move σ² with μ and focus steady; a shade
        fixed in the frame (dust on the lens) makes a class's μ depend on where the part
        lies."""
        return _cause(self)

    @property
    def diagnosis(self) -> Diagnosis:
        """What the batch's parts changed against the golden parts, and the causes that
        explain it best first (:mod:`~inspect_validate.verification.diagnosis`)."""
        return diagnosis_of(self.station, self.parts.measured, self.golden)


def verify_production(
    station: Station, frames: Path, golden: Golden, *, source: str = "the golden file"
) -> ProductionVerification:
    """Verify ``station`` on the parts in ``frames`` against ``golden`` (trained by
    :func:`train_production`; ``source``, its file, for messages).

    Raises
    ------
    InputError
        A golden file trained on the bench (or of another illumination), and as
        :func:`measure_parts`.
    """
    from inspect_validate.station.file import station_hash

    production_golden(golden, station, source=source)
    parts = measure_parts(station, frames)
    verified = verify_parts(station, parts, golden, manifest=parts.manifest)
    if station.path is not None and golden.station_sha256 != station_hash(station.path):
        note = (
            "the golden file was trained with another version of the station file (its "
            "station_sha256 differs): its parts are the reference as they are; train it "
            "again if the station changed"
        )
        verified = replace(verified, notes=(note,))
    return verified


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


def verify_parts(
    station: Station,
    parts: Parts,
    golden: Golden,
    *,
    drift: bool = True,
    manifest: dict | None = None,
) -> ProductionVerification:
    """:func:`verify_production` of parts already measured, against a ``golden`` file
    :func:`production_golden` accepted for ``station`` (once, before the first batch: a
    watch verifies one a cycle); ``drift=False`` leaves out the golden statistics'
    checks (``watch --production``, whose charts replace them); ``manifest``, the capture
    that took them: what the camera reported is held to ``acceptance.health``
    (:func:`~.health_checks.health_checks`)."""
    from inspect_validate.verification.checks import at_least, decide
    from inspect_validate.verification.health_checks import health_checks

    assert station.production is not None
    name = station.production.illumination
    found = at_least(
        "parts found",
        "production",
        100 * parts.found,
        100 * MIN_FOUND,
        "%",
        f"{len(parts.measured)} of {len(parts.measured) + len(parts.not_measured)} frames "
        "hold a part" + (f"; {_reasons(parts.not_measured)}" if parts.not_measured else ""),
    )
    confidence = station.acceptance.confidence
    checks = [
        found,
        *(_drift_checks(parts, golden.illuminations[name], confidence) if drift else []),
    ]
    unhealthy, skipped = health_checks(station.acceptance.health, manifest or {})
    checks += unhealthy
    rate = station.acceptance.false_alarm_rate
    return ProductionVerification(
        station, golden, parts, decide(checks, rate), rate, tuple(skipped)
    )


def production_golden(golden: Golden, station: Station, *, source: str) -> None:
    """Refuse a golden file trained on the bench, or on another production illumination
    than ``station``'s (before any frame is read; ``source``, the file, for messages).

    Raises
    ------
    InputError
        Naming the file and what to give instead.
    """
    if station.production is None:
        raise InputError(
            "no 'production:' block: give one to verify the running line", source=str(station.path)
        )
    from inspect_validate.verification.golden_checks import validate_camera

    validate_camera(golden, station, source=source)
    if golden.mode != "production":
        raise InputError(
            "this golden file was trained on the bench (captures, every illumination); "
            "train one from good parts: inspect-validate train STATION --production "
            "--frames DIR --out FILE",
            source=source,
        )
    name = station.production.illumination
    if name not in golden.illuminations:
        raise InputError(
            f"the golden file holds {', '.join(golden.illuminations)}, not the production "
            f"illumination {name!r}; train it again from this station's parts",
            source=source,
        )
    from inspect_validate.verification.measured import station_regions

    g = golden.illuminations[name]
    rois, comparisons = station_regions(station)
    lacks = [f"class {c.name!r}" for c in rois.classes if c.name not in g.classes]
    lacks += [f"class {n!r}'s focus" for n, c in g.classes.items() if c.focus is None]
    lacks += [f"comparison {label!r}" for label in comparisons.labels if label not in g.comparisons]
    if g.pose is None:
        lacks.append("the parts' pose (x, y, rotation)")
    if lacks:
        raise InputError(
            f"the golden file lacks {listed(lacks, 3)} that a verdict on this station's "
            "parts checks (edited, or trained on another ROI file): train it again from "
            "this station's parts",
            source=source,
        )


def _cause(v: ProductionVerification) -> str | None:
    camera = [
        c.name.removeprefix("camera: ") for c in v.checks if c.kind == "health" and not c.passed
    ]
    failed = [c.name for c in v.checks if not c.passed and c.kind != "health"]
    if not failed:
        # the parts' own statistics held; what failed is how the frames arrived
        return f"the camera or its link: {', '.join(camera)}" if camera else None
    if "parts found" in failed:
        missing = v.parts.not_measured
        unusable = v.parts.unusable
        if unusable and 2 * len(unusable) >= len(missing):
            total = len(missing) + len(v.parts.measured)
            return (
                f"{len(unusable)} of {total} frames cannot be used as this station's frames "
                f"({_reasons(unusable)}): the line's program writes frames unlike the "
                "reference (size, colour, pixel type) or cuts them short"
            )
        return (
            "most frames hold no part to measure: a wrong reference, a moved camera or "
            "fixture, or no parts passing"
        )
    return v.diagnosis.text or (f"{listed(failed, 3)} failed, and no one cause explains what moved")


def diagnosis_of(station: Station, parts: Sequence[Part], golden: Golden) -> Diagnosis:
    """The :func:`~inspect_validate.verification.diagnosis.diagnose` of ``parts`` against
    ``golden``'s production illumination, with :func:`station_sensor`."""
    from inspect_validate.verification.diagnosis import diagnose, shaded_classes

    g = next(iter(golden.illuminations.values()))
    return diagnose(parts, g, sensor=station_sensor(station), shaded=shaded_classes(parts, g))


def station_sensor(station: Station) -> Sensor | None:
    """The station camera's EMVA values (a
    :class:`~inspect_validate.verification.diagnosis.Sensor`) where the station has a
    scene to take them from; None for a station of frames alone (its dark level taken as
    0 DN, and a light and a gain one cause)."""
    if station.scene is None:
        return None
    from inspect_validate.station.model import station_model
    from inspect_validate.verification.diagnosis import Sensor

    s = station_model(station).sensor
    return Sensor(s.gain, s.dark_noise, s.dark_offset)


def _reasons(missing: dict[str, str]) -> str:
    """The commonest reasons frames held no measured part, counted."""
    counts: dict[str, int] = {}
    for why in missing.values():
        key = why.split(" keeps")[0] if " keeps " in why else why.split(":")[0]
        if key.startswith("the same frame as"):
            key = "the same frame as another"
        counts[key] = counts.get(key, 0) + 1
    return "; ".join(f"{why} ({n})" for why, n in sorted(counts.items(), key=lambda x: -x[1]))


def _drift_checks(parts: Parts, golden, confidence: float | None) -> list[Check]:
    """Each class's μ, σ² and focus, each comparison's SNR_dB: the batch mean against the
    golden parts' (module description), with tolerance intervals at ``confidence``."""
    if not parts.measured:
        return []
    checks = []
    ms = [p.measurement for p in parts.measured]
    for k, c in enumerate(ms[0].classes):
        g = golden.classes[c.name]
        quantities = [("μ", g.mean, [m.classes[k].mean for m in ms], "DN"),
                      ("σ²", g.variance, [m.classes[k].variance for m in ms], "DN²")]  # fmt: skip
        if g.focus is not None:
            quantities.append(("focus", g.focus, [p.focus[c.name] for p in parts.measured], "DN²"))
        for what, ref, values, unit in quantities:
            checks.append(_batch_check(f"{c.name} {what} drift", values, ref, unit, confidence))
    for j, comp in enumerate(ms[0].comparisons):
        ref = golden.comparisons[comp.label].snr_db
        values = [m.comparisons[j].snr_db for m in ms]
        checks.append(_batch_check(f"{comp.label} SNR_dB drift", values, ref, "dB", confidence))
    if golden.pose is not None:
        poses = [p.position for p in parts.measured]
        for i, (what, ref, unit) in enumerate(
            (
                ("x", golden.pose.x, "px"),
                ("y", golden.pose.y, "px"),
                ("rotation", golden.pose.angle, "°"),
            )
        ):
            name = f"pose {what} drift"
            checks.append(_batch_check(name, [p[i] for p in poses], ref, unit, confidence))
    return checks


def _batch_check(
    name: str, values: list[float], ref: Spread, unit: str, confidence: float | None
) -> Check:
    """|batch mean − golden mean| against t_{n−1} · s · √(1/m + 1/n), or the tolerance
    interval of a mean of m around the mean of n (its spread s/√m, its centre n/m such
    means) at ``confidence`` where that is wider."""
    from inspect_validate.verification.checks import Coverage, at_most, not_run

    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    m, n, s = v.size, ref.n, ref.std
    if m == 0 or n < 2 or not math.isfinite(s):
        return not_run(name, "drift", 0.0, unit, "<=", "no spread of good parts to set its limit")
    mean = float(v.mean())
    sd = s * math.sqrt(1.0 / m + 1.0 / n)
    return at_most(
        name,
        "drift",
        abs(mean - ref.mean),
        0.0,
        unit,
        f"golden {ref.summary()} {unit} over {n} parts, now {mean:.4g} over {m}; "
        f"prediction interval of a batch mean, sd {sd:.2g} {unit}, t with {n - 1} df",
        basis="statistical",
        standard_error=sd,
        df=n - 1,
        sided=2,
        coverage=None
        if confidence is None or s <= 0
        else Coverage(s / math.sqrt(m), n / m, confidence),
    )
