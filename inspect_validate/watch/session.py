"""What a ``watch`` holds while it runs: the station verified without its single-cycle
drift checks, the plan, the drift charts, the history, the folder's lock and the status
server — opened together, checked before the first cycle, and closed together whatever
ends the watch."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Iterator

    from inspect_validate.station.file import Station
    from inspect_validate.verification.plan import Plan
    from inspect_validate.watch.drift import DriftMonitor
    from inspect_validate.watch.history_writer import HistoryWriter
    from inspect_validate.watch.loop import LineWatch
    from inspect_validate.watch.rig import RigMonitor, RigWatch
    from inspect_validate.watch.serve import StatusServer

__all__ = ["Session", "watch_session"]


@dataclass(frozen=True)
class Session:
    """An open watch.

    Attributes
    ----------
    station : Station
        The station as each cycle verifies it (no single-cycle drift checks: the charts
        replace them).
    plan : Plan
        Its verification plan (made once).
    monitor : DriftMonitor
        The drift charts, centred on the golden file.
    history : HistoryWriter
        The history database, continued or new.
    folder : Path
        Where the cycles' frames go.
    status_path : Path
        The status file rewritten after every cycle.
    server : StatusServer or None
        ``/status`` and ``/metrics`` on 127.0.0.1, where asked for.
    line : LineWatch or None
        A watch of the running line (``plan`` then None): its golden parts and frames.
    rig : RigWatch or None
        A watch of several cameras (``plan`` then None): each camera's plan; ``monitor``
        is then a :class:`~.rig.RigMonitor`.
    """

    station: Station
    plan: Plan | None
    monitor: DriftMonitor | RigMonitor
    history: HistoryWriter
    folder: Path
    status_path: Path
    server: StatusServer | None
    line: LineWatch | None = None
    rig: RigWatch | None = None


@contextlib.contextmanager
def watch_session(
    station: Station,
    *,
    golden: Path | dict[str, Path] | None = None,
    db: Path | None = None,
    folder: Path | None = None,
    status: Path | None = None,
    http_port: int | None = None,
    production: bool = False,
    frames: Path | None = None,
) -> Iterator[Session]:
    """Open what a watch of ``station`` needs, and close it all when the block ends.

    Parameters
    ----------
    station : Station
    golden : Path or dict, keyword-only, optional
        The golden file the charts are centred on (default: ``acceptance.drift.golden``);
        of a station of several cameras, per camera name (default: ``cameras[].golden``).
    db : Path, keyword-only, optional
        The history database (default: ``watch-<station>/history.sqlite``).
    folder : Path, keyword-only, optional
        Where the cycles' frames go (default: the database's folder).
    status : Path, keyword-only, optional
        The status file (default: ``status.json`` in ``folder``).
    http_port : int, keyword-only, optional
        Serve the status on 127.0.0.1 (0: any free port).
    production : bool, keyword-only
        Watch the running line: batches of ``production.parts`` parts, charted against a
        golden file of good parts (``train --production``).
    frames : Path, keyword-only, optional
        With ``production``: the folder the line's program writes its frames into
        (default: the station's camera, under the production light).

    Raises
    ------
    InputError
        No golden file, one that does not fit the station or has too few repeats for the
        charts, an output path that cannot be written, a history of another station, a
        folder another watch writes into, a port in use (nothing is captured).
    """
    from inspect_validate.files import exclusive_lock, output_file, output_folder, release_lock
    from inspect_validate.watch.history_writer import HistoryWriter, history_path

    line = plan = rig = None
    monitor: DriftMonitor | RigMonitor
    if station.cameras:
        from inspect_validate.watch.rig import rig_watch

        if production or frames is not None:
            raise InputError(
                "--production watches the parts one camera sees: give --camera NAME",
                source=str(station.path),
            )
        rig, monitor, golden_meta = rig_watch(station, golden)
        watched = station
    else:
        monitor, plan, line, golden_meta = _one_camera(station, golden, production, frames)
        watched = station.model_copy(
            update={"acceptance": station.acceptance.model_copy(update={"drift": None})}
        )
    db = history_path(db or Path(f"watch-{station.file.stem}") / "history.sqlite")
    folder = Path(folder or db.parent)
    status = Path(status or folder / "status.json")
    for f in (db, status):
        output_file(f)
    output_folder(folder)
    with contextlib.ExitStack() as stack:
        # Two watches on one folder would set each other's cycles aside, even with two --db.
        lock = exclusive_lock(
            folder / ".watch.lock",
            holder="watch",
            what="cycles into this folder",
            remedy="another --out",
            source=folder,
        )
        stack.callback(release_lock, lock)
        history = HistoryWriter(db, station=str(station.file.resolve()), golden=golden_meta)
        stack.callback(history.close)
        server = None
        if http_port is not None:
            from inspect_validate.watch.serve import StatusServer

            try:
                server = StatusServer(http_port)
            except OSError as exc:
                raise InputError(
                    f"--http {http_port}: cannot serve the status on 127.0.0.1:{http_port} "
                    f"({exc.strerror or exc}); choose a free port, or 0 for any"
                ) from None
            stack.callback(server.close)
        yield Session(
            station=watched,
            # The golden file stays in the plan: without a drift section it sets no drift
            # check (the charts replace them), and each cycle's camera settings are held
            # to its snapshot.
            plan=plan,
            monitor=monitor,
            history=history,
            folder=folder,
            status_path=status,
            server=server,
            line=line,
            rig=rig,
        )


def _one_camera(
    station: Station, golden: Path | dict | None, production: bool, frames: Path | None
) -> tuple[DriftMonitor, Plan | None, LineWatch | None, str]:
    """The charts, plan or line of a watch of a station of one camera, and its golden file."""
    from inspect_validate.verification.plan import plan_verification
    from inspect_validate.watch.drift import DriftMonitor

    if isinstance(golden, dict):
        raise InputError(
            "golden files by camera: the station has one camera; give one golden file",
            source=str(station.path),
        )
    if golden is not None:
        station = station.with_golden(golden)
    drift = station.acceptance.drift
    if drift is None or drift.golden is None:
        raise InputError(
            "watch charts drift from a golden file: give --golden (made by 'train') or "
            "acceptance.drift.golden",
            source=str(station.path),
        )
    golden_file = station.resolve(drift.golden)
    line = plan = None
    if production:
        line = _line_watch(station, golden_file, frames)
    else:
        if frames is not None:
            raise InputError("--frames goes with --production (a folder of the line's frames)")
        # The plan reads the golden file and checks it fits the station; each cycle is
        # then verified without the single-cycle drift checks: the charts replace them,
        # with a false-alarm rate controlled over every chart together.
        plan = plan_verification(station, drift_checks=False)
    try:
        if line is not None:
            assert station.production is not None  # _line_watch refused a station without
            monitor = DriftMonitor(
                line.golden,
                dark_offset=line.dark_offset,
                snr_floor_db=drift.snr_floor_db,
                batch=station.production.parts,
                sensor=line.sensor,
            )
        else:
            from inspect_validate.verification.diagnosis import Sensor

            assert plan is not None and plan.golden is not None  # it read the golden file
            monitor = DriftMonitor(
                plan.golden,
                dark_offset=plan.model.sensor.dark_offset,
                snr_floor_db=drift.snr_floor_db,
                sensor=Sensor.of(plan.model.sensor),
            )
    except InputError as exc:
        raise InputError(str(exc), source=str(golden_file)) from None
    return monitor, plan, line, str(golden_file)


def _line_watch(station: Station, golden_file: Path, frames: Path | None) -> LineWatch:
    """The golden parts and the frames' source of ``watch --production``, checked before
    anything is opened."""
    from inspect_validate.station.production import part_locator
    from inspect_validate.verification.golden import read_golden
    from inspect_validate.verification.measured import station_regions
    from inspect_validate.verification.parts_golden import production_golden
    from inspect_validate.watch.feed import FolderFeed
    from inspect_validate.watch.loop import LineWatch

    locator = part_locator(station)  # no production block, a bad reference: said now
    _, comparisons = station_regions(station)
    assert station.production is not None
    golden = read_golden(golden_file)
    production_golden(golden, station, source=str(golden_file))
    if frames is None and station.camera.backend == "none":
        raise InputError(
            "watch --production without --frames takes the frames with the station's "
            "camera, and this station has none (a station of the line's frames alone): "
            "give --frames FOLDER, the folder the line's program writes its frames into",
            source=str(station.path),
        )
    feed = None
    if frames is not None:
        frames = Path(frames)
        if not frames.is_dir():
            raise InputError(
                "not a folder: give the folder the line's program writes its frames into",
                source=str(frames),
            )
        feed = FolderFeed(frames, station.production.parts)
    from inspect_validate.verification.diagnosis import station_sensor

    return LineWatch(golden, feed, locator, comparisons, station_sensor(station))
