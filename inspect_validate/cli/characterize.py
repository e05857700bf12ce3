"""`inspect-validate characterize`: EMVA 1288 of the station's own camera."""

from __future__ import annotations

import click

from inspect_validate.cli.common import (
    PATH,
    FrameProgress,
    camera_option,
    new_folder,
    one_station,
    validate_outputs,
)


@click.command()
@click.argument("station", type=PATH)
@click.option(
    "--out",
    type=PATH,
    help="Folder for the series' frames, the plan, the measured camera file and the "
    "emva1288 descriptor (default: a new folder characterize-<station>-<time>).",
)
@click.option(
    "--report",
    "report_dir",
    type=PATH,
    help="Write characterization.json and the EMVA 1288 plots to this folder.",
)
@click.option("--resume", is_flag=True, help="Continue an interrupted series in --out.")
@camera_option
def characterize(station, out, report_dir, resume, camera_name):
    """Measure STATION's own camera as EMVA 1288 prescribes, through its camera and controller.

    Captures an exposure series from dark to past saturation (lit and dark pairs;
    a series of LED levels where the exposure cannot be set) and stacks in the dark
    and at about 50 % for DSNU and PRNU, in front of a uniform target (place a white
    diffuser; the simulated camera renders one). Prints K, dark noise, saturation
    capacity, linearity, dark current, DSNU, PRNU and dynamic range with standard
    errors, and writes the measured camera file: name it in the station as
    camera.measured and every prediction uses it.
    """
    from dataclasses import replace

    from inspect_validate.characterization.descriptor import write_descriptor
    from inspect_validate.characterization.series import (
        capture_series,
        expected_rate,
        read_series,
    )
    from inspect_validate.components.camera_file import write_camera_file
    from inspect_validate.images import read_frames
    from inspect_validate.report.characterization import (
        format_characterization,
        write_characterization_report,
    )
    from inspect_validate.station.file import station_hash

    st = one_station(station, camera_name, "characterize")
    if resume and out is None:
        raise click.UsageError("--resume needs the --out folder of the interrupted series")
    out = out or new_folder("characterize", station)
    validate_outputs(folders=(report_dir,))
    series = st.characterize
    total = 2 * 2 * (series.points + 10) + 2 * series.frames_spatial  # 10 near saturation
    with FrameProgress(total, label="characterizing") as advance:
        plan = capture_series(
            st, out, resume=resume, progress=lambda step, _done, _total: advance.step(step)
        )
    plan, result = read_series(st, out)
    expected = expected_rate(st, plan) if st.scene else None
    if expected:
        result = replace(
            result,
            qe_scale=result.responsivity / expected,
            qe_scale_se=result.responsivity_se / expected,
        )
    click.echo(format_characterization(result, plan))
    h, w = read_frames([out / "b_000"]).shape[1:]
    descriptor = write_descriptor(out, plan, result, width=w, height=h)
    camera_file = write_camera_file(
        out / "camera.yaml",
        result,
        name=f"{st.name} camera (characterized)",
        gain_db=st.camera.gain_db or 0.0,
        provenance={
            "station": str(st.path),
            "station_sha256": station_hash(st.path),
            "capture": str(out),
        },
    )
    if report_dir is not None:
        inputs = {"station": str(st.path), "capture": str(out), "camera_file": str(camera_file)}
        for path in write_characterization_report(report_dir, result, plan, inputs=inputs):
            click.echo(f"report: {path}")
    click.echo(f"emva1288 descriptor: {descriptor}")
    click.echo(
        f"camera file: {camera_file} (name it in the station as camera.measured to predict "
        "with the measured camera)"
    )
