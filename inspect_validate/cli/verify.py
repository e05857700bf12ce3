"""`inspect-validate verify`: a station captured, measured, predicted and checked."""

from __future__ import annotations

import sys

import click

from inspect_validate.cli.common import (
    PATH,
    camera_option,
    fresh_report,
    new_folder,
    retired_option,
    validate_outputs,
    verify_and_report,
    with_camera,
)
from inspect_validate.errors import EXIT_CHECK_FAILED


@click.command()
@click.argument("station", type=PATH)
@click.option(
    "--frames",
    "frames_dir",
    type=PATH,
    help="A capture folder made by 'capture' (default: capture now through the station's devices).",
)
@click.option(
    "--frames-out",
    "out",
    type=PATH,
    help="Where to save the frames captured now (default: REPORT/frames, else a new "
    "folder verify-<station>-<time>). An earlier REPORT holding frames is set aside as "
    "REPORT-<time>.",
)
@retired_option("--out", "old_out", type=PATH, instead="write --frames-out DIR")
@click.option(
    "--report",
    "report_dir",
    type=PATH,
    help="Write report.html, verification.json (with --production: production.json) and "
    "junit.xml to this folder.",
)
@click.option(
    "--history",
    "history_path",
    type=PATH,
    help="A history 'watch' keeps of this station: its trends go into report.html.",
)
@click.option(
    "--all-illuminations",
    is_flag=True,
    help="Capture every illumination, also those the prediction shows clearly worse than "
    "another where no check needs them (skipped by default, and listed).",
)
@click.option(
    "--production",
    is_flag=True,
    help="Verify the running line: --frames is a folder of production frames, each part "
    "located and measured against the golden parts (train --production).",
)
@click.option(
    "--golden",
    "golden_path",
    type=PATH,
    help="The golden file to check drift against (default: acceptance.drift.golden; with "
    "--production, the golden parts of train --production).",
)
@camera_option
def verify(
    station,
    frames_dir,
    out,
    old_out,
    report_dir,
    history_path,
    all_illuminations,
    production,
    golden_path,
    camera_name,
):
    """Verify STATION: measure its frames, predict it as built, calibrate, compare and check.

    Captures every illumination and the darks through the station's camera and
    controller (or reads --frames), measures the classes in the station's ROIs,
    predicts the same quantities from the spectra at the station's exposure and
    gain, estimates the system gain K by photon transfer, ties each
    illumination's irradiance to the measurement (calibration: fit, reference
    or absolute) and runs the checks of the station's acceptance section.
    Exits 0 when every check passes, 1 when one fails (reports still written),
    2 on bad input, 3 on a camera or controller failure (frames kept).
    """
    from inspect_validate.station.file import read_station

    out = out or old_out
    st = with_camera(read_station(station), camera_name)
    validate_outputs(folders=[report_dir])
    fresh_report(report_dir, reading=(frames_dir, out, history_path, golden_path))
    if production:
        _verify_production(
            st.one_camera("verify --production"), frames_dir, golden_path, report_dir
        )
        return
    if golden_path is not None:
        st = st.with_golden(golden_path)
    log = None
    if history_path is not None:
        st.one_camera("verify --history (a watch's history)")
        if report_dir is None:
            raise click.UsageError("--history adds trends to the report: give --report too")
        from inspect_validate.watch.history import read_station_history

        log = read_station_history(history_path, st)
        if camera_name is not None:  # a watch of every camera: this one's charts
            log = log.of_camera(camera_name)
    if frames_dir is None and out is None:
        out = report_dir / "frames" if report_dir else new_folder("verify", station)
    result = verify_and_report(
        st,
        frames_dir=frames_dir,
        out=out,
        report_dir=report_dir,
        history=log,
        skip_dominated=not all_illuminations,
    )
    if not result.passed:
        sys.exit(EXIT_CHECK_FAILED)


def _verify_production(st, frames_dir, golden_path, report_dir) -> None:
    """``verify --production``: one verdict over the parts in a folder of frames."""
    from inspect_validate.api import verify as run
    from inspect_validate.report import write_json
    from inspect_validate.report.production import format_production, production_document

    if frames_dir is None:
        raise click.UsageError("--production verifies a folder of production frames: give --frames")
    result = run(st, frames_dir, production=True, golden=golden_path)
    click.echo(format_production(result))
    if report_dir is not None:
        from inspect_validate.report.production import write_production_html
        from inspect_validate.report.verification import write_junit

        write_json(production_document(result), report_dir / "production.json")
        write_junit(result, report_dir / "junit.xml")
        write_production_html(result, report_dir / "report.html")  # last: the folder is whole
        click.echo(f"wrote {report_dir / 'report.html'}, production.json and junit.xml")
    if not result.passed:
        sys.exit(EXIT_CHECK_FAILED)
