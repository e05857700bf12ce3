"""Capture storage: 16-bit TIFF frames with JSON sidecars, written atomically, resumable.

Layout of ``--out DIR``::

    manifest.json               station, its hash, tool version, steps done
    <step>/frame_0001.tif       the frame (uint8/uint16, as grabbed)
    <step>/frame_0001.json      its metadata: camera settings, light state, times
    <step>/partial-<time>/      frames of an interrupted step, kept, never deleted

Each file is written to a temporary name and renamed, so a file that exists is
complete; a frame counts once its sidecar exists. The manifest records each step's
frame count and every frame file's SHA-256, so that :func:`audit_capture` can tell
a capture as written from one changed since (a frame deleted, added, duplicated,
replaced by another step's, or edited).

Frames are encoded and written on one background thread, in order, while the
next frames are grabbed (:meth:`CaptureStore.save_later`); at most
:data:`QUEUED_FRAMES` wait, so a disk that cannot keep up slows the capture
instead of filling memory. A step is marked complete only after its every frame
is on disk (:meth:`CaptureStore.flush`), and a failure or an interruption still
writes every frame grabbed before it.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import threading
import time
from collections import Counter
from collections.abc import Iterable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple, TextIO

from inspect_validate import __version__
from inspect_validate.camera.frame import Frame
from inspect_validate.camera.health import health_problem, health_sha256
from inspect_validate.errors import InputError, listed
from inspect_validate.files import (
    atomic_write,
    exclusive_lock,
    output_folder,
    regular_text,
    release_lock,
    unused_path,
)

__all__ = [
    "QUEUED_FRAMES",
    "Audited",
    "CaptureFiles",
    "CaptureStore",
    "StepRecord",
    "audit_capture",
    "audit_rig",
    "changed_settings",
    "read_capture",
    "read_manifest",
    "settings_sha256",
    "step_record",
]

LOCK_FILE = ".capture.lock"
"""Held in the capture folder while a capture writes into it (removed when it ends)."""
QUEUED_FRAMES = 8
"""Grabbed frames that may wait for the writer thread."""


def settings_sha256(values: dict[str, str]) -> str:
    """The SHA-256 of a settings snapshot (node → value), independent of the nodes' order."""
    text = json.dumps(sorted(values.items()), ensure_ascii=False)
    return hashlib.sha256(text.encode()).hexdigest()


def changed_settings(before: dict[str, str], now: dict[str, str]) -> list[str]:
    """Each node whose value differs between two settings snapshots, as
    ``"Gamma 1.0 → 0.7"`` (``absent`` where one snapshot lacks the node), in node order."""
    return [
        f"{name} {before.get(name, 'absent')} → {now.get(name, 'absent')}"
        for name in sorted({*before, *now})
        if before.get(name) != now.get(name)
    ]


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict:
    """A JSON object whose keys are each given once: a key given twice is an edit (JSON
    would keep the last silently)."""
    out = dict(pairs)
    if len(out) != len(pairs):
        (twice, _), *_ = Counter(k for k, _ in pairs).most_common(1)
        raise ValueError(f"the key {twice!r} is given twice")
    return out


def read_manifest(path: Path) -> dict:
    """A capture's manifest, checked enough to resume or measure from (a damaged one is
    refused naming the file: the frames beside it stay as they are)."""
    try:
        manifest = json.loads(regular_text(path), object_pairs_hook=_unique_keys)
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        manifest = exc
    steps = manifest.get("steps") if isinstance(manifest, dict) else None
    if not isinstance(steps, dict) or not all(isinstance(v, dict) for v in steps.values()):
        why = manifest if isinstance(manifest, Exception) else "no steps mapping of step records"
        raise InputError(
            f"the capture's manifest is damaged ({why}); its frames are kept — capture again "
            "into a new --out folder ('measure' still reads the frames themselves)",
            source=str(path),
        )
    return manifest


class CaptureStore:
    """The output folder of one capture of one station file."""

    def __init__(
        self, folder: Path, *, station_path: Path, station_sha256: str, resume: bool
    ) -> None:
        self.folder = Path(folder)
        self._writer: ThreadPoolExecutor | None = None  # started with the first queued frame
        self._slots = threading.BoundedSemaphore(QUEUED_FRAMES)
        self._lock = threading.Lock()  # the writer thread adds frames while steps are saved
        self._pending: list[Future] = []
        self.manifest_path = self.folder / "manifest.json"
        output_folder(self.folder)
        # Two captures into one folder would overwrite each other's frames and manifest.
        self._held: TextIO | None = exclusive_lock(
            self.folder / LOCK_FILE,
            holder="capture",
            what="this capture folder",
            remedy="another --out folder",
            source=self.folder,
        )
        try:
            self._start(station_path, station_sha256, resume)
        except BaseException:
            self.release()
            raise

    def _start(self, station_path: Path, station_sha256: str, resume: bool) -> None:
        if self.manifest_path.exists():
            manifest = read_manifest(self.manifest_path)
            if manifest.get("station_sha256") != station_sha256:
                raise InputError(
                    "this folder holds a capture of a different station file; use a new --out folder or the original station file",
                    source=str(self.folder),
                )
            if not resume:
                raise InputError(
                    "a capture is already here: choose a new --out folder, verify what it holds with "
                    "--frames, or continue it with 'capture --resume'",
                    source=str(self.folder),
                )
            self.manifest = manifest
        else:
            self.manifest = {
                "schema": "inspect-validate/capture",
                # 2: every step records its frames' hashes; 3: and its health record's
                "schema_version": 3,
                "station": str(station_path),
                "station_sha256": station_sha256,
                "tool_version": __version__,
                "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "steps": {},
            }

    def _save_manifest(self) -> None:
        with self._lock:
            text = json.dumps(self.manifest, indent=2)
        atomic_write(self.manifest_path, text.encode())

    def record(self, key: str, value: Any) -> None:
        """Add ``key`` to the manifest (e.g. the camera and the settings it lacks).

        Resuming with another camera than the one that took the saved frames is
        refused: a stack must come from one camera.
        """
        if key == "camera" and "camera" in self.manifest:
            before, now = self.manifest["camera"].get("name"), value.get("name")
            if before != now:
                raise InputError(
                    f"the frames here were taken with {before!r}, the station now opens {now!r}; "
                    "resume with the same camera or capture into a new --out folder",
                    source=str(self.folder),
                )
        if key == "settings" and isinstance(self.manifest.get("settings"), dict):
            changed = changed_settings(
                self.manifest["settings"].get("values", {}), value.get("values", {})
            )
            if changed:
                raise InputError(
                    f"the camera's settings changed since the frames here were taken "
                    f"({'; '.join(changed)}): a stack must come from one setting; restore "
                    "them, or capture into a new --out folder",
                    source=str(self.folder),
                )
        self.manifest[key] = value
        self._save_manifest()

    def note(self, step: str, key: str, value: Any) -> None:
        """Record ``key`` for ``step`` (e.g. the light state the controller reports); a
        health record with its hash (:func:`~inspect_validate.camera.health.health_sha256`)."""
        self.manifest["steps"][step][key] = value
        if key == "health":
            self.manifest["steps"][step]["health_sha256"] = health_sha256(value)

    def is_complete(self, step: str) -> bool:
        return bool(self.manifest["steps"].get(step, {}).get("complete"))

    def begin(self, step: str, info: dict) -> Path:
        """Start (or restart) a step; frames of an earlier, unfinished attempt are moved aside."""
        folder = self.folder / step
        if folder.exists() and not folder.is_dir():
            raise InputError(
                f"{folder.name} is a file where the capture keeps that step's frames; move it "
                "away, or capture into a new --out folder",
                source=str(folder),
            )
        old = sorted(folder.glob("frame_*")) if folder.exists() else []
        if old:
            aside = unused_path(folder / f"partial-{time.strftime('%Y%m%dT%H%M%S')}")
            aside.mkdir()
            for p in old:
                p.rename(aside / p.name)
        folder.mkdir(parents=True, exist_ok=True)
        self.manifest["steps"][step] = {"complete": False, "frames": 0, "sha256": {}, **info}
        self._save_manifest()
        return folder

    def save(self, step: str, index: int, frame: Frame, info: dict) -> Path:
        import tifffile

        folder = self.folder / step
        tif = folder / f"frame_{index:04d}.tif"
        meta = {
            **frame.metadata(),
            **info,
            "file": tif.name,
            "station_sha256": self.manifest["station_sha256"],
            "tool_version": __version__,
            "saved": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        }
        encoded = io.BytesIO()  # tifffile needs a named file or a buffer, not a raw fd
        tifffile.imwrite(
            encoded, frame.data, photometric="minisblack", description=json.dumps(meta)
        )
        data = encoded.getvalue()
        atomic_write(tif, data)
        atomic_write(tif.with_suffix(".json"), json.dumps(meta, indent=2).encode())
        # The sidecar is the record of a saved frame; the manifest's count and hashes
        # are written with the step's end, not rewritten (and fsynced) per frame.
        with self._lock:
            record = self.manifest["steps"][step]
            record["frames"] = index
            record["sha256"][tif.name] = hashlib.sha256(data).hexdigest()
        return tif

    def save_later(self, step: str, index: int, frame: Frame, info: dict) -> None:
        """:meth:`save` on the writer thread, after the frames queued before it; waits
        while :data:`QUEUED_FRAMES` are queued. A failure is raised by :meth:`flush`."""
        if self._writer is None:
            self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="frame-writer")
        self._slots.acquire()

        def write() -> None:
            try:
                self.save(step, index, frame, info)
            finally:
                self._slots.release()

        self._pending.append(self._writer.submit(write))

    def flush(self) -> None:
        """Wait until every queued frame is on disk; then raise the first failure, if any
        (every frame is attempted: one unwritable file does not drop the others)."""
        pending, self._pending = self._pending, []
        errors = [f.exception() for f in pending]
        first = next((e for e in errors if e is not None), None)
        if first is not None:
            raise first

    def release(self) -> None:
        """Let another capture into the folder (its lock file removed); once the capture
        ends, whatever the end."""
        if self._held is not None:
            release_lock(self._held)
            self._held = None

    def close(self) -> BaseException | None:
        """Write every queued frame and stop the writer thread; the first failure is
        returned, not raised (an error already on its way matters more)."""
        try:
            self.flush()
        except Exception as exc:  # returned: the caller decides whether it matters most
            return exc
        finally:
            if self._writer is not None:
                self._writer.shutdown(wait=True)
                self._writer = None
        return None

    def finish(self, step: str) -> None:
        self.manifest["steps"][step]["complete"] = True
        self._save_manifest()

    def fail(self, step: str, message: str) -> None:
        self.manifest["steps"].setdefault(step, {})["error"] = message
        self._save_manifest()


class Audited(NamedTuple):
    """What :func:`audit_capture` read of a capture's frames, for its readers to use
    rather than read again: each frame file's SHA-256 (``"step/frame_0001.tif"`` → hex,
    for comparing captures with each other) and each frame's sidecar (its path → the
    record)."""

    hashes: dict[str, str]
    sidecars: dict[Path, dict]


def audit_capture(folder: Path, manifest: dict, steps: Iterable[str]) -> Audited:
    """Check that the frames of ``steps`` in a capture ``folder`` are the ones written.

    Each step's frame files must be those its manifest record counts and hashes, each
    with its sidecar, both naming the step and the file, the TIFF's own description
    agreeing with the sidecar (frame id, time, step, light), and no frame twice (by
    its bytes, or by its camera frame id and timestamp). A step without its hashes is
    refused: nothing else tells a rewritten frame from the one captured.

    Returns
    -------
    Audited
        Each frame file's SHA-256 and its sidecar as read.

    Raises
    ------
    InputError
        Naming the capture folder and every disagreement found, and what to do.
    """
    import tifffile

    problems: list[str] = []
    hashes: dict[str, str] = {}
    sidecars: dict[Path, dict] = {}
    seen: dict[str, str] = {}
    stamps: dict[tuple, str] = {}
    snapshot = manifest.get("settings")
    if snapshot is not None and (
        not isinstance(snapshot, dict)
        or not isinstance(snapshot.get("values"), dict)
        or settings_sha256(snapshot["values"]) != snapshot.get("sha256")
    ):
        problems.append("the camera settings snapshot is not the one recorded (edited)")
    # Without its hashes a manifest cannot tell rewritten frames from those captured, so
    # none is read without them, whatever version it claims (an unreleased build wrote
    # version 1 without hashes for two days; a version number is as easily edited).
    for step in steps:
        record = manifest.get("steps", {}).get(step, {})
        recorded = record.get("sha256")
        files = sorted((folder / step).glob("frame_*.tif"))
        names = [p.name for p in files]
        count = record.get("frames")
        if count is not None and (not isinstance(count, int) or isinstance(count, bool)):
            problems.append(f"{step}: the manifest's frame count {count!r} is not a whole number")
        elif isinstance(count, int) and count != len(files):
            problems.append(
                f"{step}: the manifest records {count} frames, the folder holds {len(files)}"
            )
        if not (isinstance(recorded, dict) and all(isinstance(v, str) for v in recorded.values())):
            problems.append(
                f"{step}: the manifest's frame hashes (sha256) are missing or damaged, so the "
                "frames cannot be checked"
            )
        if (why := health_problem(record)) is not None:
            problems.append(f"{step}: {why}")
        if isinstance(recorded, dict):
            missing = sorted(set(recorded) - set(names))
            extra = sorted(set(names) - set(recorded))
            if missing:
                problems.append(f"{step}: {', '.join(missing)} recorded but missing")
            if extra:
                problems.append(f"{step}: {', '.join(extra)} not written by this capture")
        for path in files:
            where = f"{step}/{path.name}"
            if not path.is_file():  # a pipe would block the read, a device never end it
                problems.append(f"{where} is not a regular file")
                continue
            data = path.read_bytes()  # read once: hashed, and its description parsed
            digest = hashlib.sha256(data).hexdigest()
            hashes[where] = digest
            if isinstance(recorded, dict) and recorded.get(path.name) not in (None, digest):
                # None: the file is already named above as not written by this capture
                problems.append(f"{where} changed since it was written (SHA-256 differs)")
            if digest in seen:
                problems.append(f"{where} is the same frame as {seen[digest]} (identical bytes)")
            seen.setdefault(digest, where)
            sidecar = path.with_suffix(".json")
            if sidecar.exists() and not sidecar.is_file():
                problems.append(f"{where}: its sidecar {sidecar.name} is not a regular file")
                continue
            try:
                meta = json.loads(sidecar.read_text())
            except (OSError, UnicodeDecodeError, ValueError, RecursionError):
                problems.append(f"{where}: its sidecar {sidecar.name} is missing or not JSON")
                continue
            if not isinstance(meta, dict):
                problems.append(f"{where}: its sidecar is not a JSON object")
                continue
            sidecars[path] = meta
            if meta.get("step", step) != step or meta.get("file", path.name) != path.name:
                problems.append(f"{where}: its sidecar is of {meta.get('step')}/{meta.get('file')}")
            try:
                with tifffile.TiffFile(io.BytesIO(data)) as tif:
                    text = getattr(tif.pages[0], "description", "")
                described = json.loads(text) if text.startswith("{") else None
            except Exception:  # tifffile raises many kinds on a damaged file
                problems.append(f"{where} is not a readable TIFF")
                continue
            if isinstance(described, dict):
                differ = [
                    k
                    for k in ("step", "frame_id", "timestamp_ns", "light_setting", "round")
                    if k in described and described.get(k) != meta.get(k)
                ]
                if differ:
                    problems.append(
                        f"{where}: the TIFF's description and the sidecar disagree on "
                        f"{', '.join(differ)} (the TIFF says step {described.get('step')!r})"
                    )
            stamp = (meta.get("device"), meta.get("frame_id"), meta.get("timestamp_ns"))
            if stamp[1] is not None and stamp[2] and stamp in stamps:
                problems.append(
                    f"{where} is the same camera frame as {stamps[stamp]} (frame id {stamp[1]}, "
                    f"timestamp {stamp[2]})"
                )
            stamps.setdefault(stamp, where)
    if problems:
        raise InputError(
            f"the capture is not as it was written: {listed(problems, 8)}. Measure only what the camera "
            "wrote: capture again (or restore the folder from its copy)",
            source=str(folder),
        )
    return Audited(hashes, sidecars)


class CaptureFiles(NamedTuple):
    """A capture folder as :func:`read_capture` read it: each step's frame files, the
    darks', its manifest, and what the audit read (each frame's SHA-256 and sidecar)."""

    frames: dict[str, list[Path]]
    dark: list[Path]
    manifest: dict
    hashes: dict[str, str]
    sidecars: dict[Path, dict]


def read_capture(folder: Path, steps: Iterable[str], *, target: str = "scene") -> CaptureFiles:
    """Frame files of each of ``steps`` (the illuminations' names) and of the darks in a
    capture folder of ``target`` (what was in front of the camera: the objects, or a
    ``flat`` or ``edge`` target), its manifest, each frame file's SHA-256 and sidecar —
    after checking that the frames are those the capture wrote (:func:`audit_capture`).

    Raises
    ------
    InputError
        No manifest, a capture of another target, one of ``steps`` missing or incomplete,
        or frames changed since they were written (each disagreement named).
    """
    folder = Path(folder)
    wanted = list(steps)
    manifest_path = folder / "manifest.json"
    if not manifest_path.exists():
        raise InputError(
            "not a capture folder (no manifest.json); make one with 'inspect-validate capture' "
            "or leave out --frames to capture now",
            source=str(folder),
        )
    manifest = read_manifest(manifest_path)
    held = manifest.get("target", "scene")
    if held != target:
        what = {"scene": "the objects", "flat": "a flat target", "edge": "an edge target"}
        use = {
            "scene": "verify, measure or train it",
            "flat": "give it to characterize --field",
            "edge": "give it to characterize --sharpness",
        }
        raise InputError(
            f"a capture of {what.get(held, repr(held))}, not of {what[target]}: "
            f"{use.get(held, 'capture again')}",
            source=str(folder),
        )
    records = manifest["steps"]
    frames = {}
    for name in wanted:
        files = sorted((folder / name).glob("frame_*.tif"))
        if not records.get(name, {}).get("complete") or not files:
            raise InputError(
                f"illumination {name!r} was not captured completely here; "
                "rerun the capture with --resume",
                source=str(folder),
            )
        frames[name] = files
    dark = (
        sorted((folder / "dark").glob("frame_*.tif"))
        if records.get("dark", {}).get("complete")
        else []
    )
    audited = audit_capture(folder, manifest, [*frames, *(["dark"] if dark else [])])
    return CaptureFiles(frames, dark, manifest, audited.hashes, audited.sidecars)


def audit_rig(folder: Path, names: Sequence[str]) -> None:
    """Check that the folders ``folder/<name>/`` of a capture of several cameras are one
    capture's: each its own folder (no link to another's), each the camera it is named
    for, all of one capture (the ``rig.id`` every camera's manifest records), and every
    step of the same rounds in each (the frames of round k of one trigger).

    Raises
    ------
    InputError
        Naming the folder and each disagreement, and what to do.
    """
    folder = Path(folder)
    problems: list[str] = []
    records: dict[str, dict] = {}
    places: dict[Path, str] = {}
    for name in names:
        path = folder / name
        if path.is_symlink():
            problems.append(f"cameras {name!r}: its folder is a link (to {os.readlink(path)})")
        real = path.resolve()
        if real in places:
            problems.append(f"cameras {name!r} and {places[real]!r} are one folder")
        places.setdefault(real, name)
        manifest = read_manifest(path / "manifest.json")
        rig = manifest.get("rig")
        if not isinstance(rig, dict) or not isinstance(rig.get("id"), str):
            problems.append(
                f"cameras {name!r}: its manifest records no capture of several cameras (rig.id)"
            )
            continue
        if rig.get("camera") != name:
            problems.append(
                f"cameras {name!r}: its folder holds camera {rig.get('camera')!r}'s frames"
            )
        records[name] = manifest
    ids = {m["rig"]["id"] for m in records.values()}
    if len(ids) > 1:
        which = ", ".join(f"{n} {m['rig']['id'][:8]}" for n, m in records.items())
        problems.append(f"the cameras' folders are of different captures ({which})")
    elif records:
        first, *others = records
        for step, record in records[first]["steps"].items():
            for other in others:
                theirs = records[other]["steps"].get(step)
                if not record.get("complete") and not (theirs or {}).get("complete"):
                    continue
                if not isinstance(theirs, dict) or theirs.get("rounds") != record.get("rounds"):
                    problems.append(
                        f"{step}: cameras {first!r} and {other!r} hold different rounds "
                        "(frames of other triggers)"
                    )
    if problems:
        raise InputError(
            f"not one capture of the station's cameras: {listed(problems, 6)}. Capture the "
            "station again (or restore the folder from its copy)",
            source=str(folder),
        )


def acquisition_record(
    manifest: dict, files: dict[str, list[Path]], sidecars: dict[Path, dict] | None = None
) -> tuple[dict, ...]:
    """How each step's frames were taken, from the manifest and the frames' sidecars
    (``sidecars`` as the audit read them; read here where not given):
    the acquisition mode, the exposure the frames verifiably had (their chunk values
    where the camera sent chunks, else the setting read back), and the frames discarded
    before them, by reason. Steps captured before modes were recorded say ``free-run``."""
    rows = []
    for step, paths in files.items():
        if not paths:
            continue
        entry = manifest.get("steps", {}).get(step, {})
        exposures, source = set(), "read back"
        for path in paths:
            meta = (sidecars or {}).get(path)
            try:
                meta = (
                    meta if meta is not None else json.loads(path.with_suffix(".json").read_text())
                )
            except (OSError, ValueError):
                continue  # a frame without its sidecar: the exposure is not known for it
            chunk = (meta.get("extra") or {}).get("chunk") or {}
            if "ExposureTime" in chunk:
                exposures.add(float(chunk["ExposureTime"]))
                source = "chunk"
            elif meta.get("exposure_us") is not None:
                exposures.add(float(meta["exposure_us"]))
        rows.append(
            {
                "step": step,
                "mode": entry.get("acquisition", "free-run"),
                "frames": len(paths),
                "exposure_us": sorted(exposures),
                "exposure_source": source if exposures else None,
                "discarded": dict(entry.get("discarded") or {}),
                # what the camera reported (health.COUNTERS, GAUGES); None: not recorded
                "health": dict(entry["health"]) if isinstance(entry.get("health"), dict) else None,
            }
        )
    return tuple(rows)


@dataclass(frozen=True)
class StepRecord:
    """What a capture recorded of one step's settings: the channels lit (manifest:
    channel → %, those above 0) and its first frame's sidecar (empty where it has none
    or it is not JSON: the audit names that)."""

    channels: dict[int, float]
    sidecar: dict

    def exposure_differs(self, wanted_us: float) -> float | None:
        """The recorded exposure, µs, where it differs from ``wanted_us`` by more than a
        camera's rounding of it (2 % and 1 µs); else None."""
        recorded = self.sidecar.get("exposure_us")
        if isinstance(recorded, (int, float)) and abs(recorded - wanted_us) > (
            0.02 * wanted_us + 1.0
        ):
            return float(recorded)
        return None


def step_record(
    folder: Path, manifest: dict, step: str, sidecars: dict[Path, dict] | None = None
) -> StepRecord:
    """The settings ``folder``'s capture recorded for ``step`` (:class:`StepRecord`):
    what a reader compares with the settings the frames are used as (its first frame's
    sidecar from ``sidecars``, as the audit read them, where given)."""
    record = manifest.get("steps", {}).get(step, {})
    channels = {}
    for ch, pct in (record.get("channels") or {}).items():
        with contextlib.suppress(TypeError, ValueError):
            if float(pct) > 0:
                channels[int(ch)] = float(pct)
    first = Path(folder) / step / "frame_0001.tif"
    meta = (sidecars or {}).get(first)
    sidecar = first.with_suffix(".json")
    try:
        if meta is None:
            meta = json.loads(sidecar.read_text()) if sidecar.is_file() else {}
    except (OSError, ValueError, RecursionError):
        meta = {}
    return StepRecord(channels, meta if isinstance(meta, dict) else {})
