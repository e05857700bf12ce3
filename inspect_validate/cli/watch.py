"""`inspect-validate watch`: a running station verified cycle after cycle."""

from __future__ import annotations

import sys

import click

from inspect_validate.cli.common import PATH, Number, camera_option, with_camera
from inspect_validate.errors import EXIT_CHECK_FAILED


@click.command("watch")
@click.argument("station", type=PATH)
@click.option(
    "--golden",
    "golden_path",
    type=PATH,
    multiple=True,
    metavar="[NAME=]PATH",
    help="The golden file the drift charts are centred on (default: the station's "
    "acceptance.drift.golden). A station of several cameras: NAME=PATH for each camera "
    "(default: cameras[].golden).",
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
    type=Number(0, 86400),
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
    type=Number(0, 60),
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
@click.option(
    "--production",
    is_flag=True,
    help="Watch the running line: each cycle a batch of production.parts parts, located, "
    "measured and charted against a golden file of good parts (train --production).",
)
@click.option(
    "--frames",
    "frames_dir",
    type=PATH,
    help="With --production: the folder the line's program writes its frames into (new "
    "files taken as they land, whole; default: the station's camera, production light on).",
)
@camera_option
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
    production,
    frames_dir,
    camera_name,
) -> None:
    """Verify a running station cycle after cycle and chart its drift.

    Each cycle captures STATION's illuminations, verifies them (the acceptance
    checks; the charts replace the golden file's single-cycle drift checks),
    updates an EWMA chart per class μ, σ² and comparison SNR_dB, log ε against
    the golden spread, names the likely cause of a drift, and commits the cycle
    and what the camera reported of it (frames incomplete, packets lost, triggers
    missed, temperature) to the history. Ends after --cycles, on Ctrl-C or SIGTERM
    (at the next frame: the cycle under way is set aside uncommitted; exit 130),
    or with exit 3 after --max-failures failed cycles in a row; exits 1 when the
    last cycle failed a check or drifted.

    With --production each cycle is a batch of the running line's parts, charted by
    their means (μ, σ², focus, SNR_dB, log ε, position) against the golden parts.

    A station of several cameras (cameras:) is watched whole: each cycle triggers them all,
    verifies and charts each against its own golden file (cameras[].golden), and holds
    them to each other; --camera NAME watches one alone.
    """
    from inspect_validate.report import write_json
    from inspect_validate.watch.loop import WatchSettings, status_document
    from inspect_validate.watch.loop import watch as run_watch
    from inspect_validate.watch.session import watch_session

    if frames_dir is not None and not production:
        raise click.UsageError("--frames goes with --production (a folder of the line's frames)")
    settings = WatchSettings(
        interval=interval,
        cycles=cycles,
        max_failures=max_failures,
        retry_delay=retry_delay,
        keep_every=keep_every,
    )
    from inspect_validate.station.file import read_station

    whole = read_station(station)
    st = with_camera(whole, camera_name)
    golden = _goldens(golden_path, several=bool(st.cameras), camera=camera_name)
    if camera_name and golden is None:  # the camera's own golden file charts it alone
        golden = next(
            (whole.resolve(c.golden) for c in whole.cameras if c.name == camera_name and c.golden),
            None,
        )
    session = watch_session(
        st,
        golden=golden,
        db=db_path,
        folder=folder,
        status=status_path,
        http_port=http_port,
        production=production,
        frames=frames_dir,
    )
    with session as s:
        if s.line is not None and s.line.feed is not None:
            s.line.feed.notify = lambda message: click.echo(message, err=True)
        if s.server is not None:
            click.echo(f"status on http://127.0.0.1:{s.server.port}/status and /metrics")
        live = sys.stdout.isatty()
        click.echo(
            f"watching {s.station.name}: history {s.history.path} (from cycle "
            f"{s.history.next_cycle()}), {len(s.monitor.charts)} drift charts, "
            f"alarm beyond ±{s.monitor.limit:.2f} σ of each chart's smoothed value (EWMA "
            f"limit L, widened for the golden file's few repeats)"
        )

        def on_cycle(outcome) -> None:
            doc = status_document(outcome, s.station, interval=interval)
            write_json(doc, s.status_path)
            if s.server is not None:
                s.server.doc = doc
            show_cycle(outcome, live=live)

        last, stopped = run_watch(
            s.station,
            s.plan,
            s.history,
            s.monitor,
            folder=s.folder,
            settings=settings,
            on_cycle=on_cycle,
            line=s.line,
            rig=s.rig,
        )
    if s.server is not None:
        # The server ends with the watch: a scrape after this misses the last cycle,
        # which the status file and the history hold.
        click.echo(
            f"status server closed with the watch; the last cycle is in {s.status_path} and "
            f"{s.history.path}",
            err=True,
        )
    if stopped:
        click.echo(
            f"stopped after cycle {last.record.cycle if last else '—'}; history: {s.history.path}"
        )
        sys.exit(130)
    if last is not None and last.record.status in ("fail", "drift"):
        sys.exit(EXIT_CHECK_FAILED)


def _goldens(given, *, several: bool, camera: str | None = None):
    """``--golden``: one path, or for a station of several cameras ``NAME=PATH`` each;
    with ``--camera NAME``, its path or ``NAME=PATH`` as for the whole station."""
    from pathlib import Path

    if not given:
        return None
    if not several:
        if len(given) > 1:
            raise click.UsageError("--golden once: the station watched has one camera")
        name, eq, path = str(given[0]).partition("=")
        if camera is not None and eq and name == camera and path:
            return Path(path)
        return given[0]
    pairs = [str(g).partition("=") for g in given]
    for g, (name, eq, path) in zip(given, pairs, strict=True):
        if not (name and eq and path):
            raise click.UsageError(
                f"--golden {g}: a station of several cameras takes NAME=PATH, once per camera"
            )
    names = [name for name, _, _ in pairs]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise click.UsageError(f"--golden {twice[0]}=…: given twice")
    return {name: Path(path) for name, _, path in pairs}


def show_cycle(outcome, *, live: bool) -> None:
    """One cycle: a table redrawn in place on a terminal, a log line otherwise."""
    from inspect_validate.report.history import QUANTITY_LABELS, local_time
    from inspect_validate.text import render_table

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
        for key, (x, ewma, low, high) in outcome.state.points.items():
            ill, _, name, q, *camera = key  # the camera's name, of several
            rows.append(
                [
                    *camera,
                    ill,
                    name,
                    QUANTITY_LABELS.get(q, q),  # history's words and units
                    f"{x:.4g}",
                    f"{ewma:.4g}",
                    f"{low:.4g} … {high:.4g}",
                    "ALARM" if key in outcome.state.alarms else "",
                ]
            )
    click.echo("\x1b[H\x1b[2J", nl=False, color=True)  # redraw in place (kept: on a TTY)
    click.echo(line)
    if rows:
        header = ["illumination", "class / comparison", "quantity", "now", "EWMA", "band", ""]
        if len(rows[0]) > len(header):
            header.insert(0, "camera")
        click.echo(render_table(header, rows))
