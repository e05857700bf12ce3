"""What several commands share: the path, frame size and controller address types, output checks, the progress bar of a
capture, and verify's reports (verify, design --verify)."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO, cast

import click

if TYPE_CHECKING:
    from inspect_validate.measurement import KdeMode

PATH = click.Path(path_type=Path)


class Retired(click.Option):
    """A retired spelling of an option, kept a release: hidden from the help, and saying
    when used what to write instead (``deprecated=``), naming itself by its spelling
    (click names the parameter, an identifier of the code)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs["hidden"] = True
        super().__init__(*args, **kwargs)

    @property
    def human_readable_name(self) -> str:
        return max(self.opts, key=len)


def retired_option(spelling: str, dest: str, *, instead: str, **options: Any) -> Callable:
    """``spelling`` as a :class:`Retired` option into ``dest``; ``instead`` says what to
    write (``"write --size WxH"``)."""
    return click.option(spelling, dest, cls=Retired, deprecated=instead, **options)


class _FrameSize(click.ParamType):
    """``WIDTHxHEIGHT`` in pixels, as (width, height)."""

    name = "WxH"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        width, sep, height = str(value).lower().partition("x")
        digits = [w.isascii() and w.isdigit() and len(w) <= 6 for w in (width, height)]
        if not (sep and all(digits) and int(width) and int(height)):
            self.fail(
                f"{value!r}: write WIDTHxHEIGHT in pixels, each at least 1 and at most 999999, e.g. 640x480",
                param,
                ctx,
            )
        return int(width), int(height)


SIZE = _FrameSize()


class _Region(click.ParamType):
    """``X,Y,W,H`` in pixels: a rectangle's top-left corner, width and height."""

    name = "X,Y,W,H"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        parts = str(value).replace(" ", "").split(",")
        whole = [p.isascii() and p.isdigit() and len(p) <= 6 for p in parts]
        if len(parts) != 4 or not all(whole) or not (int(parts[2]) and int(parts[3])):
            self.fail(
                f"{value!r}: write X,Y,W,H in pixels (the top-left corner, then a width and a "
                "height of 1 or more), e.g. 300,200,64,100",
                param,
                ctx,
            )
        x, y, w, h = (int(p) for p in parts)
        return x, y, w, h


REGION = _Region()


class _Address(click.ParamType):
    """A controller's serial port or ``socket://host:port``
    (:func:`~inspect_validate.camera.settings.controller_address`, as the station file's
    ``controller.port``)."""

    name = "PORT"

    def convert(self, value, param, ctx):
        from inspect_validate.camera.settings import controller_address

        try:
            return controller_address(str(value))
        except ValueError as exc:
            self.fail(str(exc), param, ctx)


ADDRESS = _Address()


class Number(click.FloatRange):
    """A finite number, within ``min``/``max`` where given: click's float and float range
    let NaN (which every comparison passes) and infinities through."""

    name = "number"

    def _describe_range(self) -> str:
        # click writes '[x<=None]' for a range without bounds
        return super()._describe_range() if (self.min, self.max) != (None, None) else ""

    def convert(self, value, param, ctx):
        import math

        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{number} is not a finite number", param, ctx)
        return number


class Share(Number):
    """A fraction 0–1 (``0.001``), or the same in per cent (``0.1%``), as reports show it."""

    name = "fraction"

    def __init__(self) -> None:
        super().__init__(0, 1)

    def convert(self, value, param, ctx):
        if isinstance(value, str) and value.strip().endswith("%"):
            try:
                value = float(value.strip()[:-1]) / 100
            except ValueError:
                self.fail(f"{value!r} is not a number of per cent", param, ctx)
        return super().convert(value, param, ctx)


def verify_and_report(
    st, *, frames_dir, out, report_dir, history=None, skip_dominated: bool = True
):
    """:func:`~inspect_validate.verification.verify.verify_station` with a progress bar,
    the verdict printed and the reports written into ``report_dir`` (with ``history``'s
    trends); the :class:`Verification`."""
    from inspect_validate.report import write_json
    from inspect_validate.report.html import write_verification_html
    from inspect_validate.report.verification import (
        format_verdict,
        verification_document,
        write_junit,
    )
    from inspect_validate.verification.verify import verify_station

    if frames_dir is None:
        simulated_light_notes(st)
    if st.cameras:
        return _verify_rig_and_report(st, frames_dir=frames_dir, out=out, report_dir=report_dir)
    with FrameProgress(label="capturing") as advance:
        result = verify_station(
            st,
            frames=frames_dir,
            out=out,
            skip_dominated=skip_dominated,
            progress=lambda step, done, total: advance(done, step, total),
            notify=lambda message: click.echo(message, err=True),
        )
    if frames_dir is None:
        click.echo(f"frames: {out}")
    st = result.station
    click.echo(
        f"{st.name}: {len(st.illuminations)} illumination(s), calibration {st.calibration.method}"
    )
    click.echo(format_verdict(result))
    if report_dir:
        write_json(verification_document(result), report_dir / "verification.json")
        write_junit(result, report_dir / "junit.xml")
        write_verification_html(result, report_dir / "report.html", history=history)
        click.echo(f"report: {report_dir / 'report.html'} (verification.json, junit.xml)")
    return result


def _verify_rig_and_report(st, *, frames_dir, out, report_dir):
    """:func:`verify_and_report` of a station of several cameras: each camera's verdict
    and reports (``report_dir/<camera>/``), the checks across cameras, and the one
    verdict (``report_dir/verification.json``); the
    :class:`~inspect_validate.verification.rig.RigVerification`."""
    from inspect_validate.report import write_json
    from inspect_validate.report.html import write_rig_html, write_verification_html
    from inspect_validate.report.verification import (
        format_rig_verdict,
        rig_document,
        verification_document,
        write_junit,
    )
    from inspect_validate.verification.rig import verify_rig

    with FrameProgress(label="capturing") as advance:
        result = verify_rig(
            st,
            frames=frames_dir,
            out=out,
            progress=lambda step, done, total: advance(done, step, total),
        )
    if frames_dir is None:
        click.echo(f"frames: {out}")
    click.echo(format_rig_verdict(result))
    if report_dir:
        for name, v in result.cameras.items():
            folder = report_dir / name
            write_json(verification_document(v), folder / "verification.json")
            write_junit(v, folder / "junit.xml")
            write_verification_html(v, folder / "report.html")
        write_json(rig_document(result), report_dir / "verification.json")
        write_junit(result, report_dir / "junit.xml")
        write_rig_html(result, report_dir / "report.html")
        click.echo(
            f"report: {report_dir / 'report.html'} (verification.json, junit.xml; each "
            f"camera's in {report_dir}/<camera>/)"
        )
    return result


class FrameProgress:
    """A click progress bar of frames on standard error, started at the first frame.

    click times a bar from its creation, so the seconds a camera takes to open and
    settle would be charged to the first frames (an 11 s capture on Aravis showed an
    ETA of 00:20:02), and a resumed run's frames already on disk would count as instant
    steps. The bar is therefore made when the first frame arrives, for the frames still
    to come; only click's documented interface is used (the step being captured is the
    bar's current item, shown beside it on a terminal).

    Use as a context manager; call it with the frames done so far, the step and the
    frames of the whole capture (a capture of another total, such as one resumed after
    the first, starts a bar of its own).
    """

    def __init__(self, total: int | None = None, *, label: str, file: TextIO | None = None) -> None:
        self.total, self.label = total, label
        self.file = file if file is not None else sys.stderr
        self.bar: Any = None  # click's ProgressBar, from the first frame
        self.done = 0

    def __enter__(self) -> FrameProgress:
        if self.file.isatty():  # the devices open before any frame: say so until then
            self.file.write(f"{self.label} (opening the devices)\r")
            self.file.flush()
        return self

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.__exit__(*exc)

    def __call__(self, done: int, item: str | None = None, total: int | None = None) -> None:
        if total is not None and total != self.total:
            if self.bar is not None:
                self.bar.__exit__(None, None, None)
                self.bar = None
            self.total = total
        if self.bar is None:
            self.bar = click.progressbar(
                length=max((self.total or done) - done, 1),
                label=self.label,
                file=self.file,
                item_show_func=lambda step: step,
            ).__enter__()
            self.bar.update(0, current_item=item)
        else:
            self.bar.update(done - self.done, current_item=item)
        self.done = done

    def step(self, item: str | None = None) -> None:
        """One frame more, for a caller whose steps come from captures that each count
        from 0 (characterize's series)."""
        self(self.done + 1, item)


def simulated_light_notes(station) -> None:
    """Say on stderr which channels a simulated camera lights at a nominal irradiance (the
    station file and the scene give it none)."""
    if station.camera.backend == "simulated" or getattr(station.camera, "simulate", False):
        from inspect_validate.station.model import NOMINAL_IRRADIANCE, station_model

        model = station_model(station)
        for ch in sorted(model.nominal):  # rendered at some power: say which
            click.echo(
                f"note: channel {ch} ({model.channels[ch].name}) has no irradiance in the station "
                f"file (channels.{ch}.irradiance) or the scene; the simulated camera lights it at "
                f"the nominal {NOMINAL_IRRADIANCE:g} W/m²",
                err=True,
            )


def capture_with_progress(station, out, *, resume: bool = False, steps=None, target="scene"):
    """Capture ``station`` into ``out`` with a progress bar on stderr (``steps``: other
    steps than the station's illuminations and darks; ``target``, what is in front of the
    camera)."""
    from inspect_validate.station.capture import capture

    simulated_light_notes(station)
    with FrameProgress(label="capturing") as advance:
        return capture(
            station,
            out,
            resume=resume,
            progress=lambda step, done, total: advance(done, step, total),
            steps=steps,
            target=target,
        )


def new_folder(command: str, source) -> Path:
    """A default output folder in the working directory: <command>-<source's stem>-<time>."""

    return Path(f"{command}-{Path(source).stem}-{time.strftime('%Y%m%dT%H%M%S')}")


PLOT_FORMATS = ("html", "png")


def plot_option(*, help: str) -> Callable:
    """``--plot DIR`` and ``--plot-format html|png``: the charts of a command as one HTML
    page drawn by the browser (the reports' charts, milliseconds to write), or as PNG
    figures drawn by matplotlib (imported only then: 0.4 s, and 0.1–0.2 s a figure)."""

    def decorate(command: Callable) -> Callable:
        command = click.option(
            "--plot-format",
            type=click.Choice(PLOT_FORMATS),
            default="html",
            show_default=True,
            help="What --plot writes: one HTML page of charts, or PNG figures.",
        )(command)
        return click.option("--plot", "plot_dir", type=PATH, help=help)(command)

    return decorate


def camera_option(command: Callable) -> Callable:
    """``--camera NAME``: of a station of several cameras, the one a command of one camera
    takes (:func:`one_station`)."""
    return click.option(
        "--camera",
        "camera_name",
        metavar="NAME",
        help="Of a station of several cameras (cameras:), the one to take alone, as a "
        "station of that camera (its rois, its scene camera, its golden file).",
    )(command)


def with_camera(station, camera_name: str | None):
    """``station`` (read from its file), or its camera ``camera_name`` (``--camera``) alone
    as a station of that camera; refused, saying so, for a name it does not have or a
    station of one camera."""
    from inspect_validate.errors import InputError

    if camera_name is None:
        return station
    if not station.cameras:
        raise InputError(
            f"--camera {camera_name}: the station has one camera (camera:); leave --camera out",
            source=str(station.path),
        )
    return station.view(camera_name)


def one_station(path, camera_name: str | None, what: str):
    """The station file at ``path`` as a station of one camera (:func:`with_camera`);
    refused, naming ``what`` (a command), for a station of several cameras without
    ``--camera``."""
    from inspect_validate.station.file import read_station

    return with_camera(read_station(path), camera_name).one_camera(what)


#: How a command computes ε KDE, the nonparametric error (37): one option, ``--kde``, in
#: every command that computes it (measurement.KdeMode, which is not imported at start-up).
KDE_MODES = ("auto", "always", "never")


def kde_option(*, default: str, help: str) -> Callable:
    """``--kde auto|always|never`` and its retired spelling ``--no-kde`` (kept a release,
    hidden, saying what to write); the command reads :func:`kde_mode` of the two."""

    def decorate(command: Callable) -> Callable:
        command = retired_option("--no-kde", "no_kde", instead="write --kde never", is_flag=True)(
            command
        )
        return click.option(
            "--kde", type=click.Choice(KDE_MODES), default=default, show_default=True, help=help
        )(command)

    return decorate


def kde_mode(kde: str, no_kde: bool) -> KdeMode:
    """The ``--kde`` mode, ``never`` where the retired ``--no-kde`` was given."""
    mode = "never" if no_kde else kde
    assert mode in KDE_MODES  # click.Choice(KDE_MODES) took it
    return cast("KdeMode", mode)


def printer(json_path) -> Callable[..., None]:
    """What prints a command's tables: ``click.echo``, or nothing where ``--json -`` puts
    the JSON document on standard output in its place (every command's ``--json`` takes
    ``-`` so; messages stay on standard error)."""
    if json_path is not None and str(json_path) == "-":
        return lambda *args, **kwargs: None
    return click.echo


# What verify writes into its --report folder, and makes anew each run (each camera's
# in a folder of its name).
REPORT_FILES = frozenset({"report.html", "verification.json", "production.json", "junit.xml"})


def fresh_report(report_dir, *, reading=()) -> None:
    """Make ``report_dir`` ready for this run's report (:func:`~inspect_validate.files.fresh_folder`):
    an earlier report's files removed, an earlier report that holds frames set aside and
    said so; the folders this run reads (``reading``) are left in place."""
    from inspect_validate.files import fresh_folder

    if report_dir is None:
        return
    aside = fresh_folder(report_dir, derived=REPORT_FILES, keep=reading)
    if aside is not None:
        click.echo(
            f"note: the earlier report in {report_dir} (and its frames) is now {aside}", err=True
        )


def validate_outputs(*, files=(), folders=()) -> None:
    """Check output paths before the work starts, so a typo does not cost a sweep or a capture."""
    from inspect_validate.files import output_file, output_folder

    for f in files:
        if f is not None and str(f) != "-":
            output_file(f)
    for d in folders:
        if d is not None:
            output_folder(d)
