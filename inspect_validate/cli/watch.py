"""`inspect-validate watch`: a running station verified cycle after cycle."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from inspect_validate.cli.common import (
    PATH,
    check_outputs,
)
from inspect_validate.errors import EXIT_CHECK_FAILED


@click.command("watch")
@click.argument("station", type=PATH)
@click.option(
    "--golden",
    "golden_path",
    type=PATH,
    help="The golden file the drift charts are centred on (default: the station's "
    "acceptance.drift.golden).",
)
@click.option(
    "--db",
    "db_path",
    type=PATH,
    help="History database (SQLite); an existing one is continued (default: "
    "watch-<station>/history.sqlite).",
)
@click.option(
    "--out",
    "folder",
    type=PATH,
    help="Folder for the kept frames and status.json (default: the database's folder).",
)
@click.option(
    "--interval",
    type=click.FloatRange(0, 86400),
    default=60.0,
    show_default=True,
    help="Seconds from the start of one cycle to the next.",
)
@click.option("--cycles", type=click.IntRange(1), help="Stop after this many cycles.")
@click.option(
    "--max-failures",
    type=click.IntRange(1),
    default=5,
    show_default=True,
    help="Failed cycles in a row (camera, controller) that end the watch with exit 3.",
)
@click.option(
    "--retry-delay",
    type=click.FloatRange(0, 60),
    default=1.0,
    show_default=True,
    help="Seconds before the first reconnect after a failed cycle; doubles, at most 60.",
)
@click.option(
    "--keep-every",
    type=click.IntRange(1),
    default=10,
    show_default=True,
    help="Keep the frames of every K-th passing cycle (failing and drifting ones always).",
)
@click.option(
    "--status",
    "status_path",
    type=PATH,
    help="Status file rewritten atomically each cycle (default: OUT/status.json).",
)
@click.option(
    "--http",
    "http_port",
    type=click.IntRange(0, 65535),
    help="Serve the latest status on 127.0.0.1:PORT (/status JSON, /metrics Prometheus).",
)
def watch(
    station,
    golden_path,
    db_path,
    folder,
    interval,
    cycles,
    max_failures,
    retry_delay,
    keep_every,
    status_path,
    http_port,
):
    """Verify a running station cycle after cycle and chart its drift.

    Each cycle captures STATION's illuminations, verifies them (the acceptance
    checks; the charts replace the golden file's single-cycle drift checks),
    updates an EWMA chart per class μ, σ² and comparison SNR_dB, log ε against
    the golden spread, names
    the likely cause of a drift, and commits the cycle to the history. Ends
    after --cycles, on Ctrl-C (after committing the current cycle: exit 130),
    or with exit 3 after --max-failures failed cycles in a row; exits 1 when
    the last cycle failed a check or drifted.
    """
    from dataclasses import replace

    from inspect_validate.acceptance import Drift
    from inspect_validate.errors import InputError
    from inspect_validate.report import write_json
    from inspect_validate.station.file import read_station
    from inspect_validate.verification.verify import plan_verification
    from inspect_validate.watch.drift import DriftMonitor
    from inspect_validate.watch.history import History
    from inspect_validate.watch.loop import WatchSettings, status_document
    from inspect_validate.watch.loop import watch as run_watch

    st = read_station(station)
    drift = st.acceptance.drift
    if golden_path is not None:
        golden_path = Path(golden_path).resolve()
        drift = (drift or Drift(golden=str(golden_path))).model_copy(
            update={"golden": str(golden_path)}
        )
    if drift is None:
        raise InputError(
            "watch charts drift from a golden file: give --golden (made by 'train') or "
            "acceptance.drift.golden",
            source=str(station),
        )
    # The plan reads the golden file and checks it fits the station; each cycle is then
    # verified without the single-cycle drift checks: the charts replace them, with a
    # false-alarm rate controlled over every chart together.
    plan = plan_verification(
        st.model_copy(update={"acceptance": st.acceptance.model_copy(update={"drift": drift})}),
        drift_checks=False,
    )
    st = st.model_copy(update={"acceptance": st.acceptance.model_copy(update={"drift": None})})
    db_path = Path(db_path or Path(f"watch-{Path(station).stem}") / "history.sqlite")
    folder = Path(folder or db_path.parent)
    status_path = Path(status_path or folder / "status.json")
    check_outputs(files=[db_path, status_path], folders=[folder])
    golden_file = st.resolve(drift.golden)
    try:
        monitor = DriftMonitor(
            plan.golden,
            dark_offset=plan.model.camera.dark_offset,
            snr_floor_db=drift.snr_floor_db,
        )
    except InputError as exc:
        raise InputError(str(exc), source=str(st.resolve(drift.golden))) from None
    from inspect_validate.files import exclusive_lock

    # Two watches on one folder would set each other's cycles aside, even with two --db.
    folder_lock = exclusive_lock(
        folder / ".watch.lock",
        holder="watch",
        what="cycles into this folder",
        remedy="another --out",
        source=folder,
    )
    try:
        history = History(db_path, station=str(st.path.resolve()), golden=str(golden_file))
    except BaseException:
        folder_lock.close()
        raise
    server = None
    if http_port is not None:
        from inspect_validate.watch.serve import StatusServer

        try:
            server = StatusServer(http_port)
        except OSError as exc:
            history.close()
            folder_lock.close()
            raise InputError(
                f"--http {http_port}: cannot serve the status on 127.0.0.1:{http_port} "
                f"({exc.strerror or exc}); choose a free port, or 0 for any"
            ) from None
        click.echo(f"status on http://127.0.0.1:{server.port}/status and /metrics")
    live = sys.stdout.isatty()
    click.echo(
        f"watching {st.name}: history {db_path} (from cycle {history.next_cycle()}), "
        f"{len(monitor.charts)} drift charts, limit {monitor.limit:.2f} σ"
    )

    def on_cycle(outcome):
        doc = status_document(outcome, st, interval=interval)
        write_json(doc, status_path)
        if server is not None:
            server.doc = doc
        show_cycle(outcome, live=live)

    settings = WatchSettings(
        interval=interval,
        cycles=cycles,
        max_failures=max_failures,
        retry_delay=retry_delay,
        keep_every=keep_every,
    )
    try:
        last, stopped = run_watch(
            st,
            replace(plan, golden=None),
            history,
            monitor,
            folder=folder,
            settings=settings,
            on_cycle=on_cycle,
        )
    finally:
        history.close()
        folder_lock.close()
        if server is not None:
            server.close()
    if stopped:
        click.echo(f"stopped after cycle {last.record.cycle if last else '—'}; history: {db_path}")
        sys.exit(130)
    if last is not None and last.record.status in ("fail", "drift"):
        sys.exit(EXIT_CHECK_FAILED)


def show_cycle(outcome, *, live: bool) -> None:
    """One cycle: a table redrawn in place on a terminal, a log line otherwise."""
    from inspect_validate.report import render_table
    from inspect_validate.report.history import local_time

    r = outcome.record
    line = f"{local_time(r.started)} cycle {r.cycle}: {r.status.upper()}"
    if r.cause:
        line += f" — {r.cause}"
    if r.reason and r.status != "pass":
        line += f" ({r.reason})"
    if not live:
        click.echo(line)
        return
    rows = []
    if outcome.state is not None:
        for (ill, kind, name, q), (x, ewma, low, high) in outcome.state.points.items():
            alarm = (ill, kind, name, q) in outcome.state.alarms
            rows.append(
                [
                    ill,
                    name,
                    q,
                    f"{x:.4g}",
                    f"{ewma:.4g}",
                    f"{low:.4g} … {high:.4g}",
                    "ALARM" if alarm else "",
                ]
            )
    click.echo("\x1b[H\x1b[2J", nl=False, color=True)  # redraw in place (kept: on a TTY)
    click.echo(line)
    if rows:
        click.echo(
            render_table(
                ["illumination", "class / comparison", "quantity", "now", "EWMA", "band", ""], rows
            )
        )
