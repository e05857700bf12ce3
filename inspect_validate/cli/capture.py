"""`inspect-validate capture`: a station's illuminations and darks, verified frame by frame."""

from __future__ import annotations

import click

from inspect_validate.cli.common import (
    PATH,
    camera_option,
    capture_with_progress,
    with_camera,
)
from inspect_validate.text import labelled


@click.command()
@click.argument("station", type=PATH)
@click.option(
    "--out",
    "out",
    type=PATH,
    required=True,
    help="Folder for the frames (TIFF + JSON sidecars) and the manifest.",
)
@click.option(
    "--resume",
    is_flag=True,
    help="Continue an interrupted capture in --out, skipping finished steps.",
)
@click.option(
    "--production",
    is_flag=True,
    help="The running line: the production illumination on, one frame a part, nothing "
    "switched after (the station's production: block); the frames in OUT/<illumination>.",
)
@click.option(
    "--parts",
    type=click.IntRange(2, 100_000),
    help="With --production: frames to take, each of another part [production.parts].",
)
@click.option(
    "--target",
    type=click.Choice(["flat", "edge"]),
    help="A characterization target in front of the camera instead of the objects: flat "
    "(a uniform white card filling the frame, for the light's field) or edge (a dark "
    "square turned 2–10°, for the lens's sharpness); every illumination and dark, for "
    "characterize --field / --sharpness. A simulated camera renders it.",
)
@camera_option
def capture(station, out, resume, production, parts, target, camera_name) -> None:
    """Capture every illumination of STATION (and dark frames), verified and saved as they come.

    Switches each illumination, waits for the controller, discards frames
    exposed before the switch, checks brightness is stable, and writes 16-bit
    TIFFs with JSON sidecars atomically. Exits 3 on a camera or controller
    failure, keeping every frame saved; rerun with --resume to continue.
    A station of several cameras (cameras:) triggers them together for every frame,
    keeps only rounds whose every camera's frame holds, and writes each camera's
    frames to OUT/<camera>/.
    With --production, frames of the running line's parts under its one light
    (their brightness differs part to part), for train and verify --production.
    With --target, frames of a flat card or a slanted edge for characterize.
    """
    from inspect_validate.station.file import read_station

    if parts is not None and not production:
        raise click.UsageError("--parts is for --production")
    if target and production:
        raise click.UsageError("--target captures a target, not the running line's parts")
    st = with_camera(read_station(station), camera_name)
    if target:
        st = st.one_camera(f"capture --target {target}")
    steps = None
    if production:
        from inspect_validate.station.capture import production_steps

        steps = production_steps(st.one_camera("capture --production"), parts=parts)
    result = capture_with_progress(st, out, resume=resume, steps=steps, target=target or "scene")
    if result.not_applied:
        click.echo(
            f"warning: the camera has no {', '.join(result.not_applied)} setting; the station's value "
            "was not applied (recorded in the manifest)",
            err=True,
        )
    for warning in result.warnings:
        click.echo(labelled("warning", warning), err=True)
    names = st.camera_names
    for step, n in result.steps.items():
        if names:  # several cameras: each its own folder, frames matched by round
            where = ", ".join(str(out / name / step) for name in names)
            click.echo(f"{step}: {n} frames from each camera, matched by trigger, in {where}")
        else:
            click.echo(f"{step}: {n} frames in {out / step}{precision_note(result, step, st)}")
    for step in result.skipped:
        click.echo(f"{step}: already complete, skipped")
    manifests = [out / name / "manifest.json" for name in names] or [out / "manifest.json"]
    click.echo(f"manifest: {', '.join(map(str, manifests))}")


def precision_note(result, step, station) -> str:
    """What sequential stopping did in ``step``: the frames it saved, or that the
    precision was not reached within the station's ``frames``."""
    known = result.known.get(step)
    if known is None:
        return ""
    if not known.reached:
        return f" (the most; precision not reached: {known.describe()})"
    if known.frames == station.frames:
        return f" ({known.describe()})"
    return f" (stopped early, {known.describe()}; the most is {station.frames})"
