"""`inspect-validate init`: a first station file from a camera, a controller and a scene."""

from __future__ import annotations

import sys

import click

from inspect_validate.cli.common import ADDRESS, PATH, SIZE, Number, retired_option


def _pairs(values, option: str, convert):
    """``N=VALUE`` options as {N: convert(VALUE)}."""
    out = {}
    for text in values:
        channel, sep, value = text.partition("=")
        number = channel.strip()
        if not sep or not (number.isascii() and number.isdigit() and len(number) <= 2):
            raise click.BadParameter(
                f"{text!r}: write CHANNEL=VALUE, the channel a number 1–64, e.g. 1=amber LED",
                param_hint=option,
            )
        if not value.strip():
            raise click.BadParameter(f"{text!r}: nothing after '='", param_hint=option)
        try:
            out[int(number)] = convert(value.strip())
        except ValueError:
            raise click.BadParameter(
                f"{text!r}: {value!r} is not a number", param_hint=option
            ) from None
    return out


@click.command()
@click.argument("out", type=PATH)
@click.option(
    "--scene", type=PATH, help="The scene file: spectra of the classes, lights, lens and camera."
)
@click.option(
    "--camera-backend",
    "camera_backend",
    help="Camera backend (genicam, pylon, aravis, v4l2, simulated…; `devices` lists what is found).",
)
@retired_option("--camera", "old_camera_backend", instead="write --camera-backend NAME")
@click.option(
    "--serial", help="The camera's serial number or device id (default: the only one found)."
)
@click.option("--cti", type=PATH, help="GenTL producer (.cti), for --camera-backend genicam.")
@click.option(
    "--simulate",
    is_flag=True,
    help="pylon or aravis: render the scene into the backend's emulator instead of a camera.",
)
@click.option("--size", type=SIZE, help="Frame size of a rendered camera (simulated, --simulate).")
@click.option(
    "--controller",
    "controller_backend",
    help="Light controller backend (gardasoft, generic, manual, simulated).",
)
@click.option("--port", type=ADDRESS, help="The controller's serial port or socket://host:port.")
@click.option(
    "--protocol",
    type=PATH,
    help="YAML of a generic controller's protocol (a station file's controller.protocol keys).",
)
@click.option(
    "--channel",
    "channels",
    multiple=True,
    metavar="N=LIGHT",
    help="Controller channel N drives the scene light LIGHT (repeatable; default: the scene's "
    "lights on channels 1, 2, … in order).",
)
@click.option(
    "--irradiance",
    "irradiances",
    multiple=True,
    metavar="N=W/m²",
    help="Channel N's irradiance at the object at 100 % (repeatable; default: the scene's).",
)
@click.option(
    "--exposure-us",
    type=Number(min=0, min_open=True, max=1e8),
    help="Exposure time, µs (default: from the scene's prediction).",
)
@click.option("--pixel-format", help="Monochrome pixel format (default: the camera's deepest).")
@click.option("--rois", type=PATH, help="The ROI file of the classes in the frames.")
@click.option("--name", help="The station's name (reports, metrics, history).")
@click.option("--force", is_flag=True, help="Overwrite OUT if it exists.")
@click.option(
    "--interactive/--no-interactive",
    default=None,
    help="Ask for what is not given (default: when standard input is a terminal).",
)
def init(
    out,
    scene,
    camera_backend,
    old_camera_backend,
    serial,
    cti,
    simulate,
    size,
    controller_backend,
    port,
    protocol,
    channels,
    irradiances,
    exposure_us,
    pixel_format,
    rois,
    name,
    force,
    interactive,
):
    """Write a station file OUT for a camera, a light controller and a scene.

    Every scene light goes on a channel of its own and is captured at full drive.
    The camera is opened to read what it offers: the pixel format and the exposure
    are checked against its ranges (the exposure, where not given, is the one at which
    the scene predicts the brightest class at half of saturation). Each key is
    written with a comment saying what it means, and the file is read back as
    `capture` reads it. On a terminal, what is not given is asked for.
    """
    from inspect_validate.camera.inventory import probe_port, read_features, take_inventory
    from inspect_validate.camera.registry import Search, backend, backends
    from inspect_validate.camera.settings import AsciiProtocol
    from inspect_validate.config import load_yaml
    from inspect_validate.errors import DeviceError, InputError
    from inspect_validate.files import output_file
    from inspect_validate.scene import read_scene
    from inspect_validate.station.draft import draft_station, fitting_exposure_us, pixel_format_for
    from inspect_validate.station.file import write_station

    if interactive is None:  # standard input may be closed (0<&-): then nobody to ask
        interactive = sys.stdin is not None and sys.stdin.isatty()

    def ask(option: str, question: str, *, why: str | None = None, **kwargs):
        if not interactive:
            because = f": {why}" if why else ""
            raise InputError(f"give {option} ({question.lower()}){because}", source="init")
        if why:
            click.echo(why, err=True)
        try:
            return click.prompt(question, **kwargs)
        except click.exceptions.Abort:
            from inspect_validate import interruption

            if interruption.requested() is not None:
                raise  # Ctrl-C: interrupted
            raise InputError(  # the end of the input (a script's here-document ran out)
                f"the input ended before {option} ({question.lower()}) was answered; give "
                f"{option} on the command line",
                source="init",
            ) from None

    if out.is_dir():
        raise InputError("is a folder; give the station file's name", source=str(out))
    if out.exists() and not force:
        raise InputError(f"{out} exists; give --force to overwrite it", source="init")
    scene = scene or PATH.convert(ask("--scene", "Scene file"), None, None)
    channel_lights = _pairs(channels, "--channel", str)
    irradiance = _pairs(irradiances, "--irradiance", float)

    # -- the camera -----------------------------------------------------------------------
    features = None
    camera: dict = {}
    camera_backend = camera_backend or old_camera_backend
    if camera_backend is None:
        found = take_inventory(Search(cti=str(cti) if cti else None)).cameras
        for i, c in enumerate(found, start=1):
            click.echo(f"  {i}: {c.describe()} [{c.backend}] {c.interface}", err=True)
        pick = ask("--camera-backend", "Camera (its number, or a backend name such as 'simulated')")
        if str(pick).isdigit() and 1 <= int(pick) <= len(found):
            info = found[int(pick) - 1]
            camera_backend, serial = info.backend, info.serial or info.device_id
        else:
            camera_backend = str(pick)
    if camera_backend == "none":
        raise InputError(
            "init drafts a station that captures (a camera, a controller, illuminations); "
            "a station of the line's frames alone needs no draft: write rois: and "
            'production: {reference: FRAME} (the manual\'s "On the running line")',
            source="--camera-backend",
        )
    chosen = backend("cameras", camera_backend, source="--camera-backend")
    renders = camera_backend == "simulated" or simulate
    if simulate:
        if camera_backend not in backends("simulators"):
            raise InputError(
                f"--simulate: the {camera_backend} backend has no emulator to render into "
                f"(these have: {', '.join(backends('simulators'))})",
                source="init",
            )
        camera["simulate"] = True
        if camera_backend == "aravis":
            _warn_other_fake_cameras(chosen)
    if not renders and chosen.discover is not None:
        found = [
            c
            for c in chosen.discover(Search(cti=str(cti) if cti else None))
            if serial is None or serial in (c.serial, c.device_id)
        ]
        if not found:
            raise DeviceError(
                f"no {camera_backend} camera"
                + (f" with serial or id {serial!r}" if serial else "")
                + " found; `inspect-validate devices` lists the cameras each backend sees"
            )
        if len(found) > 1 and serial is None:
            for i, c in enumerate(found, start=1):
                click.echo(f"  {i}: {c.describe()} {c.interface}", err=True)
            pick = ask(
                "--serial",
                f"{len(found)} cameras found: which (its number)",
                type=click.IntRange(1, len(found)),
            )
            found = [found[pick - 1]]
        info = found[0]
        camera.update(chosen.device_keys(info))
        features = read_features(info)
    elif cti is not None:
        camera["cti"] = str(cti.resolve())
    if size is not None:
        if not renders:
            raise InputError(
                "--size is for a rendered camera (simulated, --simulate)", source="init"
            )
        camera.update(width=size[0], height=size[1])
    if features is not None:
        offered = features.monochrome
        if pixel_format is None:
            pixel_format = pixel_format_for(features)
        elif offered and pixel_format not in offered:
            raise InputError(
                f"--pixel-format {pixel_format}: the camera offers {', '.join(offered) or 'no monochrome format'}",
                source="init",
            )
    if simulate and pixel_format is None:
        pixel_format = "Mono16"  # the deepest pylon's emulator and Aravis' fake camera offer
    if pixel_format is not None:
        camera["pixel_format"] = pixel_format

    # -- the controller -------------------------------------------------------------------
    if controller_backend is None:
        if renders:
            controller_backend = "simulated"
        else:
            controller_backend = ask(
                "--controller",
                "Light controller",
                type=click.Choice(sorted(backends("controllers"))),
            )
    backend("controllers", controller_backend, source="--controller")
    controller: dict = {"backend": controller_backend}
    if controller_backend in ("gardasoft", "generic"):
        controller["port"] = port or ask(
            "--port",
            "Controller port (e.g. /dev/ttyUSB0, socket://192.168.1.20:30313)",
            type=ADDRESS,
        )
    asked_protocol = None
    if controller_backend == "generic":
        if protocol is None:
            raise InputError(
                "a generic controller needs --protocol (its command templates)", source="init"
            )
        asked_protocol = load_yaml(protocol, AsciiProtocol, what="controller protocol")
        controller["protocol"] = asked_protocol.model_dump(exclude_unset=True)

    # -- the station ----------------------------------------------------------------------
    camera = {"backend": camera_backend, **camera}

    parsed = read_scene(scene)

    def drafted():
        return draft_station(
            scene,
            camera=camera,
            controller=controller,
            channels=channel_lights or None,
            irradiance=irradiance,
            rois=rois,
            name=name,
            path=out.resolve(),
            parsed=parsed,
        )

    draft = drafted()
    limits = features.exposure_us if features is not None else None
    if exposure_us is None:
        exposure_us = fitting_exposure_us(draft, limits=limits, scene=parsed)
        if exposure_us is None:
            exposure_us = ask(
                "--exposure-us",
                "Exposure time, µs",
                why="the scene's lights have no irradiance, so the exposure cannot be predicted "
                "(or give each channel's with --irradiance N=W/m²)",
                type=Number(min=0, min_open=True),
            )
        else:
            click.echo(
                f"exposure {exposure_us:g} µs: the brightest class predicted at half of saturation",
                err=True,
            )
    elif limits is not None and not limits[0] <= exposure_us <= limits[1]:
        raise InputError(
            f"--exposure-us {exposure_us:g}: the camera takes {limits[0]:g}–{limits[1]:g} µs",
            source="init",
        )
    camera["exposure_us"] = exposure_us
    station = drafted()
    output_file(out)  # its folder made, or what is in the way named
    write_station(
        station,
        out,
        comment="Written by inspect-validate init; each key's meaning is above it.\n"
        "Every key: the manual's 'Station files' format page.",
        explained=True,
    )
    click.echo(f"station file: {out}")
    if "port" in controller:
        answer = probe_port(controller["port"], protocol=asked_protocol)
        if not answer:
            click.echo(
                f"warning: nothing answered on {controller['port']} as a {controller_backend} "
                "controller; check the port and that the controller is powered",
                err=True,
            )
    click.echo(f"next: inspect-validate capture {out} --out first_capture")
    if rois is None or not rois.exists():
        classes = ",".join(c.name for c in parsed.classes)
        click.echo(
            "then: inspect-validate rois propose "
            f"first_capture/{station.illuminations[0].name} --dark first_capture/dark "
            f"--out {rois or 'rois.yaml'}, look at its overlay, and name the numbered regions "
            f"with --names (the scene's classes: {classes})"
            + ("" if rois else f"; then add 'rois: rois.yaml' to {out}")
        )


def _warn_other_fake_cameras(chosen) -> None:
    """Aravis' fake cameras all answer on the loopback interface: one already running
    answers for the one a simulated station starts, and its capture then stops ("asked
    for serial …, but Aravis Fake … answered"). Said now, while the station is made."""
    from inspect_validate.camera.registry import Search
    from inspect_validate.errors import DeviceError

    try:
        found = [c for c in chosen.discover(Search()) if "fake" in (c.model or "").lower()]
    except DeviceError:  # Aravis not installed: the capture says so
        return
    for c in found:
        click.echo(
            f"warning: Aravis' fake camera {c.serial or c.device_id} already runs on this "
            "machine; the simulated station starts a fake camera of its own, which the running "
            "one answers for: stop it before capturing",
            err=True,
        )
