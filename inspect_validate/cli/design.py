"""`inspect-validate design`: the best mix of a controller's channels."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from inspect_validate.cli.common import (
    PATH,
    new_folder,
    printer,
    validate_outputs,
    verify_and_report,
)
from inspect_validate.errors import EXIT_CHECK_FAILED
from inspect_validate.text import labelled


@click.command()
@click.argument("source", type=PATH)
@click.option(
    "--json", "json_path", type=PATH, help="Write the design as JSON ('-': to stdout only)."
)
@click.option(
    "--verify",
    "check",
    is_flag=True,
    help="Capture the mix and the best single channel on the station (a station file) and "
    "verify them: measured against predicted, the station's acceptance checks on the mix.",
)
@click.option(
    "--out",
    "out_dir",
    type=PATH,
    help="Folder for design.json, the plots (design-spectrum.png, design-path.png) and, with "
    "--verify, the station it verified, the frames and the verification reports (default "
    "with --verify: design-<source>-<time>).",
)
@click.option(
    "--choose",
    type=click.IntRange(1, 64),
    help="Choose the best K of the channels (a scene's lights: a catalogue of LEDs) for a "
    "K-channel controller, with their mix.",
)
@click.option(
    "--objective",
    type=click.Choice(["error", "cnr"]),
    help="Minimise the worst comparison's ε Gauss (error) or maximise its contrast-to-noise "
    "ratio (cnr). Default: cnr for a scene that ranks by cnr_db, else error.",
)
@click.option(
    "--auto-exposure",
    is_flag=True,
    help="Design the exposure time too (up to 100 s, or the scene's exposure.max_time): the "
    "shortest at which no level needs more than 100 %. A scene with 'exposure: auto' is "
    "designed so anyway.",
)
def design(source, json_path, check, out_dir, choose, objective, auto_exposure):
    """Design the mix of a controller's channels that separates the classes best.

    SOURCE is a station file (its channels, exposure, camera and the
    comparisons its acceptance section names) or a scene file (its lights as
    channels 1, 2, … at its exposure). Finds the drive levels that minimise
    the worst comparison's ε Gauss (or maximise its CNR) with no class
    saturating, and prints them next to the best single channel, how the worst
    value moves when a level is off by ±10 %, and an illumination entry for the
    station file. With --verify, exits 1 when a check on the captured mix fails
    or the mix does not measure better than the best single channel.
    """
    from inspect_validate.errors import InputError
    from inspect_validate.mix_design.problem import design_problem
    from inspect_validate.mix_design.solve import solve
    from inspect_validate.report import write_json
    from inspect_validate.report.design import design_document, format_design

    if check and out_dir is None:
        out_dir = new_folder("design", source)
    validate_outputs(files=[json_path], folders=[out_dir])
    problem = design_problem(source, auto_exposure=auto_exposure)
    for work in problem.skipped:
        click.echo(labelled("not computed", work), err=True)
    objective = objective or ("cnr" if problem.rank_by == "cnr_db" else "error")
    if check and problem.station is None:
        raise InputError(
            "--verify captures on a station: give a station file (it has 'controller:'), "
            "not a scene file",
            source=str(source),
        )
    if choose is None:

        def note(message) -> None:
            click.echo(f"design: {message}", err=True)

        result = solve(problem, objective=objective, note=note)
    else:
        with click.progressbar(
            length=1, label=f"choosing {choose} of {len(problem.channels)}", file=sys.stderr
        ) as bar:

            def progress(done, total) -> None:
                bar.length = total
                bar.update(done - bar.pos)

            result = solve(problem, objective=objective, choose=choose, progress=progress)
    echo = printer(json_path)
    echo(format_design(result, source=Path(source).name))
    document = design_document(result)
    for path in (json_path, out_dir and out_dir / "design.json"):
        if path:
            write_json(document, path)
            echo(f"wrote {path}")
    if out_dir:
        from inspect_validate.report.plots import plot_design_path, plot_design_spectrum

        for plot, file in (
            (plot_design_spectrum, "design-spectrum.png"),
            (plot_design_path, "design-path.png"),
        ):
            click.echo(f"wrote {plot(result, out_dir / file)}")
    if check:
        verify_design(problem, result, out_dir)


def verify_design(problem, result, out_dir) -> None:
    """Capture ``result``'s mix and best single channel on ``problem``'s station, verify them
    and print measured against predicted ε; exit 1 when the design does not hold."""
    from inspect_validate.mix_design.station import design_station
    from inspect_validate.report.design import design_verification
    from inspect_validate.station.file import write_station
    from inspect_validate.text import render_table

    st = write_station(
        design_station(problem.station, result),
        out_dir / "station.yaml",
        comment=f"{problem.station.name} lit by the mix 'design' found for it "
        f"(inspect-validate design --verify {problem.source})",
    )
    click.echo(f"\nverifying the design on {st.path}")
    # Every illumination: the mix is judged against the single lights.
    verification = verify_and_report(
        st, frames_dir=None, out=out_dir / "frames", report_dir=out_dir, skip_dominated=False
    )
    summary = design_verification(verification, problem.objective.labels, kind=result.objective)
    click.echo(render_table(summary.header, summary.rows))
    click.echo(summary.verdict)
    if not (verification.passed and summary.holds):
        sys.exit(EXIT_CHECK_FAILED)
