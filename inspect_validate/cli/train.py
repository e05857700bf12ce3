"""`inspect-validate train`: the golden statistics of a known-good station."""

from __future__ import annotations

import click

from inspect_validate.cli.common import (
    PATH,
    camera_option,
    capture_with_progress,
    validate_outputs,
    with_camera,
)


@click.command()
@click.argument("station", type=PATH)
@click.option(
    "--out",
    "golden_path",
    type=PATH,
    required=True,
    help="The golden file to write (JSON); acceptance.drift.golden names it.",
)
@click.option(
    "--repeats",
    type=click.IntRange(1, 1000),
    default=5,
    show_default=True,
    help="Captures of the known-good setup (re-place the parts between them).",
)
@click.option(
    "--frames",
    "frames_dirs",
    type=PATH,
    multiple=True,
    help="Train on these capture folders instead of capturing (repeatable; --repeats is ignored).",
)
@click.option(
    "--frames-out",
    type=PATH,
    help="Where to keep the captures (default: <golden file's stem>-frames next to it).",
)
@click.option(
    "--production",
    is_flag=True,
    help="Train on the parts of the running line: --frames is a folder of frames of good "
    "parts under the production light (the station's production: block), one repeat a part.",
)
@camera_option
def train(station, golden_path, repeats, frames_dirs, frames_out, production, camera_name) -> None:
    """Store the golden statistics of STATION in a known-good state.

    Captures the station --repeats times (or reads --frames folders), measures
    every illumination in the station's ROIs and writes per class μ and σ² and
    per comparison SNR_dB and ε with their spread across the repeats.
    'verify' then checks drift from it (acceptance.drift). Exits 2 on bad input,
    3 on a camera or controller failure (the captures so far are kept).
    """
    from inspect_validate.report import write_json
    from inspect_validate.report.golden import format_golden
    from inspect_validate.station.file import read_station
    from inspect_validate.verification.golden import train as run_train
    from inspect_validate.verification.measured import station_regions

    whole = read_station(station)
    st = with_camera(whole, camera_name)  # --camera refused for a station of one camera
    if camera_name is None:
        st = st.one_camera("train")
    else:
        from inspect_validate.verification.rig import camera_view

        # The catches printed are those of the station's verify, which decides each
        # camera at its share of the station's rate.
        st = camera_view(whole, camera_name)
    validate_outputs(files=[golden_path], folders=[frames_out])
    if production:
        _train_production(st, frames_dirs, golden_path)
        return
    regions = station_regions(st)  # a station without ROIs fails before the captures
    captures = list(frames_dirs)
    if not captures:
        base = frames_out or golden_path.with_name(f"{golden_path.stem}-frames")
        for i in range(repeats):
            folder = base / f"repeat_{i + 1:02d}"
            if repeats > 1:
                click.echo(f"repeat {i + 1} of {repeats}", err=True)
            capture_with_progress(st, folder)
            captures.append(folder)
        click.echo(f"frames: {base}")
    golden = run_train(st, captures, regions=regions)
    from dataclasses import replace

    from inspect_validate.verification.dominance import dominated_illuminations
    from inspect_validate.verification.plan import plan_verification, planned_tests

    rate = st.acceptance.false_alarm_rate
    # The checks verify will share the rate among, as it plans them (the illuminations it
    # leaves out as dominated, the comparisons the prediction puts below the floors).
    plain = st.model_copy(update={"acceptance": st.acceptance.model_copy(update={"drift": None})})
    plan = plan_verification(plain)
    plan = replace(plan, dominated=dominated_illuminations(st, plan.prediction))
    tests = planned_tests(st, plan, golden, drift=True)
    click.echo(format_golden(golden, share=rate / tests, rate=rate, drift=st.acceptance.drift))
    write_json(golden.document(), golden_path)
    click.echo(f"golden: {golden_path} ({golden.repeats} repeats)")


def _train_production(st, frames_dirs, golden_path) -> None:
    """``train --production``: the golden parts of one folder of production frames."""
    from inspect_validate.report import write_json
    from inspect_validate.verification.parts import measure_parts
    from inspect_validate.verification.parts_golden import golden_parts

    if len(frames_dirs) != 1:
        raise click.UsageError("--production trains on one folder of frames: give --frames DIR")
    parts = measure_parts(st, frames_dirs[0])
    golden = golden_parts(st, parts, source=str(frames_dirs[0]))
    ((name, ill),) = golden.illuminations.items()
    click.echo(f"{golden.repeats} good parts under {name!r}")
    for c, g in ill.classes.items():
        focus = f", focus {g.focus.summary(3)} DN²" if g.focus is not None else ""
        click.echo(f"  {c}: μ {g.mean.summary()} DN, σ² {g.variance.summary()} DN²{focus}")
    for label, comparison in ill.comparisons.items():
        click.echo(f"  {label}: SNR_dB {comparison.snr_db.summary(3)} dB")
    if parts.not_measured:
        # A golden spread is only as good as its parts: say which frames were left out.
        total = len(parts.measured) + len(parts.not_measured)
        click.echo(f"{len(parts.not_measured)} of {total} frames not measured:")
        for frame, why in list(parts.not_measured.items())[:10]:
            click.echo(f"  {frame}: {why}")
        if len(parts.not_measured) > 10:
            click.echo(f"  and {len(parts.not_measured) - 10} more")
    write_json(golden.document(), golden_path)
    click.echo(f"wrote {golden_path}")
