"""The ``inspect-validate`` command line.

Only click and the error types are imported at start-up; numpy, numba, OpenCV
and the rest load inside the command that needs them, so ``--help`` is instant.
Exit codes: see :mod:`inspect_validate.errors` and the manual, "Exit codes".
"""

from __future__ import annotations

import contextlib
import sys
import traceback
from pathlib import Path

import click

from inspect_validate import __version__
from inspect_validate.errors import (
    EXIT_CHECK_FAILED,
    EXIT_INPUT,
    EXIT_INTERNAL,
    InspectValidateError,
)
from inspect_validate.text import labelled

_PATH = click.Path(path_type=Path)


def _finite(value, param):
    """Refuse NaN and infinities, which click's float type lets through."""
    import math

    if value is not None and not math.isfinite(value):
        raise click.BadParameter(f"{value} is not a finite number", param=param)
    return value


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="inspect-validate")
def cli():
    """Design and verify machine-vision inspection stations from spectra and images."""


@cli.command()
@click.argument("frames", nargs=-1, required=True, type=_PATH)
@click.option(
    "--rois", required=True, type=_PATH, help="ROI file: YAML, ImageJ .roi or RoiSet.zip."
)
@click.option(
    "--dark",
    multiple=True,
    type=_PATH,
    help="Dark frame(s) at the same exposure and gain; repeat for several.",
)
@click.option(
    "--json", "json_path", type=_PATH, help="Also write the results as JSON to this file."
)
@click.option(
    "--saturation-level",
    type=float,
    callback=lambda ctx, param, v: _finite(v, param),
    help="Raw value counted as saturated [DN]; default the data type's maximum.",
)
@click.option(
    "--max-saturated",
    type=click.FloatRange(0, 1),
    default=0.001,
    show_default=True,
    help="Largest acceptable fraction of saturated pixels per class.",
)
@click.option(
    "--max-zero",
    type=click.FloatRange(0, 1),
    default=0.001,
    show_default=True,
    help="Largest acceptable fraction of zero (underexposed) pixels per class.",
)
@click.option(
    "--kde",
    type=click.Choice(["auto", "always", "never"]),
    default="auto",
    show_default=True,
    help="The nonparametric (kernel density) error: auto computes it only where the classes' "
    "Gaussians do not fit the pixels (their rule's counted error differs from ε Gauss).",
)
@click.option("--no-kde", is_flag=True, help="Same as --kde never.")
@click.option(
    "--comparison",
    "comparison_texts",
    multiple=True,
    help='Compare only these, e.g. "A vs B,C" (repeat; default every pair and each class vs the rest).',
)
@click.option(
    "--weights",
    type=click.Choice(["equal", "pixels"]),
    default="equal",
    show_default=True,
    help="How a group of several classes is weighted: equally, or by pixel count (the "
    "mixture with weights n_i/N, as the chapter's Table 3; the manual: 'Comparisons and groups of classes').",
)
def measure(
    frames,
    rois,
    dark,
    json_path,
    saturation_level,
    max_saturated,
    max_zero,
    kde,
    no_kde,
    comparison_texts,
    weights,
):
    """Measure object classes in FRAMES (one setting; several files, a folder or a quoted glob make a stack).

    Prints per-class μ and σ² (chapter Table 4) and, for every pair of classes
    and every class against the rest, SNR_dB (36), CNR, Fisher ratio and the
    classification error ε_tot (37), parametric and kernel-density (Table 3).
    Exits 1 when a class has more saturated or zero pixels than allowed.
    """
    from inspect_validate.comparisons import Comparisons, ComparisonsSpec
    from inspect_validate.measurement import Limits, measure_files
    from inspect_validate.report import format_measurement, measurement_document, write_json
    from inspect_validate.roi import read_rois

    _outputs(files=[json_path])
    spec = ComparisonsSpec(groups=list(comparison_texts) or "default", weights=weights)
    roi_set = read_rois(rois)
    # Checked against the ROI file's classes here, so that a mistake names the option.
    comparisons = Comparisons.of(
        [c.name for c in roi_set.classes],
        spec,
        source="--comparison" if comparison_texts else "--weights",
    )
    limits = Limits(max_saturated=max_saturated, max_zero=max_zero)
    result = measure_files(
        frames,
        roi_set,
        dark=dark,
        comparisons=comparisons,
        saturation_level=saturation_level,
        limits=limits,
        kde="never" if no_kde else kde,
    )
    click.echo(format_measurement(result, saturation_limit=max_saturated))
    for reason in result.skipped:
        click.echo(labelled("skipped", reason), err=True)
    for warning in result.warnings:
        click.echo(labelled("warning", warning), err=True)
    if json_path:
        write_json(measurement_document(result, limits=limits), json_path)
        click.echo(f"\nwrote {json_path}")
    for v in result.violations:
        click.echo(f"limit exceeded: {v}", err=True)
    if result.violations:
        sys.exit(EXIT_CHECK_FAILED)


def _scheduler_address(_ctx, _param, value):
    """``--dask``'s value (a click callback): "local", or a scheduler address
    (``tcp://host:8786``, ``host:8786``). Anything else is the SCENE, taken as the
    address when ``--dask`` comes first."""
    import re

    if value is None or value == "local" or re.match(r"^(\w+://.+|[\w.\-\[\]:]+:\d+)$", value):
        return value
    raise click.BadParameter(
        f"{value!r} is not a scheduler address (tcp://host:8786); for a LocalCluster put "
        "--dask after SCENE, or write --dask=local",
        param_hint="--dask",
    )


@cli.command()
@click.argument("scene", type=_PATH)
@click.option(
    "--json", "json_path", type=_PATH, help="Also write the ranking as JSON to this file."
)
@click.option(
    "--top",
    type=click.IntRange(1),
    default=10,
    show_default=True,
    help="Rows to print and to write.",
)
@click.option(
    "--rank-by",
    type=click.Choice(["error", "snr_db", "cnr_db"]),
    help="Ranking measure (default: the scene's, else error).",
)
@click.option(
    "--comparison", help='Rank by one comparison, e.g. "A vs B,C" (default: the worst pair).'
)
@click.option("--no-kde", is_flag=True, help="Skip the nonparametric error of the listed rows.")
@click.option(
    "--plot",
    "plot_dir",
    type=_PATH,
    help="Write PNG plots (spectra, per-wavelength error, ranking) to this folder.",
)
@click.option(
    "--render",
    "render_dir",
    type=_PATH,
    help="Write simulated 16-bit frames of the best and worst combination (Fig. 19) with ROI files.",
)
@click.option(
    "--dask",
    "dask_address",
    is_flag=False,
    flag_value="local",
    metavar="[ADDRESS]",
    callback=_scheduler_address,
    help="Predict the blocks of combinations on Dask: a LocalCluster, or the scheduler "
    "at ADDRESS (tcp://host:8786).",
)
def predict(scene, json_path, top, rank_by, comparison, no_kde, plot_dir, render_dir, dask_address):
    """Predict class separation for every light × optics × camera of SCENE and rank them.

    Per combination: μ and σ² of every class in DN (reflectance spread plus
    shot, dark and quantisation noise, clipped at saturation), SNR_dB (36),
    CNR, ε Gauss and ε KDE (37).
    """
    from inspect_validate.report import write_json
    from inspect_validate.report.prediction import (
        format_prediction,
        prediction_document,
        prediction_rows,
    )
    from inspect_validate.scene import read_scene

    sc = read_scene(scene)
    for note in sc.notes():
        click.echo(labelled("note", note), err=True)
    by = rank_by or sc.rank_by
    rank_comparison, comparison = comparison, comparison or sc.rank_comparison
    if comparison is not None:
        from inspect_validate.errors import InputError

        try:  # an unknown comparison fails before the sweep, naming where it came from
            sc.comparisons.index(comparison)
        except InputError as exc:
            where = "--comparison" if rank_comparison else f"{scene}: rank.comparison"
            raise InputError(str(exc), source=where) from None
    _outputs(files=[json_path], folders=[plot_dir, render_dir])
    if dask_address:
        from inspect_validate.model.sweep import dask_client

        cluster = dask_client(dask_address)
    else:
        cluster = contextlib.nullcontext()
    with cluster as client:
        result = sc.sweep(by=by, comparison=comparison, top=top, client=client)
    for reason in result.skipped:
        click.echo(labelled("skipped", reason), err=True)
    for work in result.skipped_work:
        click.echo(labelled("not computed", work), err=True)
    rows = prediction_rows(result, kde=not no_kde)
    n = result.combinations
    n_skipped = n - result.predicted
    click.echo(
        f"{sc.name}: {n} combinations{f' ({n_skipped} skipped)' if n_skipped else ''}, "
        f"{sc.grid[0]:g}–{sc.grid[-1]:g} nm in {sc.grid[1] - sc.grid[0]:g} nm steps"
    )
    click.echo(format_prediction(result, rows))
    if json_path:
        write_json(
            prediction_document(result, rows, scene=str(scene)),
            json_path,
        )
        click.echo(f"\nwrote {json_path}")
    if plot_dir:
        from inspect_validate.model import analyse_spectra
        from inspect_validate.report.plots import (
            plot_component_spectra,
            plot_ranked_separation,
            plot_spectral_errors,
        )

        written = [
            plot_component_spectra(sc, plot_dir / "spectra.png"),
            plot_spectral_errors(
                analyse_spectra(list(sc.classes), kde=not no_kde, comparisons=sc.comparisons),
                plot_dir / "spectral_error.png",
            ),
            plot_ranked_separation(rows, plot_dir / "ranking.png", by=by),
        ]
        click.echo("wrote " + ", ".join(str(p) for p in written))
    if render_dir:
        import dataclasses

        from inspect_validate.model.render import write_rendered

        for stem, (li, oi, ci) in (("best", result.index[0]), ("worst", result.worst)):
            # The one combination again, on its own: a sweep keeps no per-pixel model.
            one = dataclasses.replace(
                sc, lights=(sc.lights[li],), optics=(sc.optics[oi],), cameras=(sc.cameras[ci],)
            ).predict()
            tif, rois = write_rendered(
                one, (0, 0, 0), render_dir, cameras=[sc.cameras[ci]], stem=stem
            )
            click.echo(f"wrote {tif} and {rois}")


@cli.command("analyze-spectra")
@click.argument("scene", type=_PATH)
@click.option(
    "--json", "json_path", type=_PATH, help="Also write the per-wavelength errors as JSON."
)
@click.option(
    "--plot",
    "plot_path",
    type=_PATH,
    help="Write the error curves as a PNG (the chapter's Fig. 22).",
)
@click.option(
    "--best",
    type=click.IntRange(1),
    default=5,
    show_default=True,
    help="Bands to list per comparison.",
)
@click.option("--no-kde", is_flag=True, help="Parametric error only.")
def analyze_spectra(scene, json_path, plot_path, best, no_kde):
    """Classification error per wavelength between the classes of SCENE, from reflectances alone.

    Shows which bands separate the classes before any hardware is chosen
    (chapter §4.2.1): parametric (Gaussian) and kernel-density ε_tot (37).
    """
    import numpy as np

    from inspect_validate.model import analyse_spectra
    from inspect_validate.report import render_table, write_json
    from inspect_validate.report.tables import format_error
    from inspect_validate.scene import read_scene

    _outputs(files=[json_path, plot_path])
    sc = read_scene(scene)
    for note in sc.notes():
        click.echo(labelled("note", note), err=True)
    sep = analyse_spectra(list(sc.classes), kde=not no_kde, comparisons=sc.comparisons)
    rows = []
    for j, (a, b) in enumerate(sep.comparisons):
        eps = sep.error_gaussian[j]
        for i in np.argsort(np.where(np.isnan(eps), np.inf, eps))[:best]:
            kde = format_error(sep.error_kde[j][i]) if sep.error_kde is not None else "-"
            rows.append(
                [
                    f"{','.join(a)} vs {','.join(b)}",
                    f"{sep.wavelengths[i]:g}",
                    format_error(eps[i]),
                    kde,
                ]
            )
    click.echo(f"{sc.name}: best bands per comparison (ε_tot (37) from the reflectance samples)")
    click.echo(render_table(["comparison", "λ [nm]", "ε Gauss", "ε KDE"], rows))

    if json_path:
        doc = {
            "schema": "inspect-validate/spectral-analysis",
            "schema_version": 1,
            "scene": str(scene),
            "wavelength_nm": sep.wavelengths.tolist(),
            "comparisons": [
                {
                    "first": list(a),
                    "second": list(b),
                    "error_gaussian": sep.error_gaussian[j].tolist(),
                    "error_kde": None if sep.error_kde is None else sep.error_kde[j].tolist(),
                }
                for j, (a, b) in enumerate(sep.comparisons)
            ],
        }
        write_json(doc, json_path)
        click.echo(f"\nwrote {json_path}")
    if plot_path:
        from inspect_validate.report.plots import plot_spectral_errors

        click.echo(f"wrote {plot_spectral_errors(sep, plot_path)}")


@cli.command()
@click.argument("station", type=_PATH)
@click.option(
    "--out",
    "out",
    type=_PATH,
    required=True,
    help="Folder for the frames (TIFF + JSON sidecars) and the manifest.",
)
@click.option(
    "--resume",
    is_flag=True,
    help="Continue an interrupted capture in --out, skipping finished steps.",
)
def capture(station, out, resume):
    """Capture every illumination of STATION (and dark frames), verified and saved as they come.

    Switches each illumination, waits for the controller, discards frames
    exposed before the switch, checks brightness is stable, and writes 16-bit
    TIFFs with JSON sidecars atomically. Exits 3 on a camera or controller
    failure, keeping every frame saved; rerun with --resume to continue.
    """
    from inspect_validate.camera.station import read_station

    st = read_station(station)
    result = _capture(st, out, resume=resume)
    if result.not_applied:
        click.echo(
            f"warning: the camera has no {', '.join(result.not_applied)} setting; the station's value "
            "was not applied (recorded in the manifest)",
            err=True,
        )
    for warning in result.warnings:
        click.echo(labelled("warning", warning), err=True)
    for step, n in result.steps.items():
        click.echo(f"{step}: {n} frames in {out / step}{_precision_note(result, step, st)}")
    for step in result.skipped:
        click.echo(f"{step}: already complete, skipped")
    click.echo(f"manifest: {out / 'manifest.json'}")


@cli.command()
@click.argument("station", type=_PATH)
@click.option(
    "--out",
    type=_PATH,
    help="Folder for the series' frames, the plan, the measured camera file and the "
    "emva1288 descriptor (default: a new folder characterize-<station>-<time>).",
)
@click.option(
    "--report",
    "report_dir",
    type=_PATH,
    help="Write characterization.json and the EMVA 1288 plots to this folder.",
)
@click.option("--resume", is_flag=True, help="Continue an interrupted series in --out.")
def characterize(station, out, report_dir, resume):
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

    from inspect_validate.camera.station import read_station, station_hash
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

    st = read_station(station)
    if resume and out is None:
        raise click.UsageError("--resume needs the --out folder of the interrupted series")
    out = out or _new_folder("characterize", station)
    _outputs(folders=(report_dir,))
    series = st.characterize
    total = 2 * 2 * (series.points + 10) + 2 * series.frames_spatial  # 10 near saturation
    with click.progressbar(length=total, label="characterizing", file=sys.stderr) as bar:

        def progress(step, _done, _total):
            bar.label = f"characterizing {step}"
            bar.update(1)

        plan = capture_series(st, out, resume=resume, progress=progress)
    plan, result = read_series(st, out)
    expected = expected_rate(st, plan) if st.scene else None
    if expected:
        result = replace(result, qe_scale=result.responsivity / expected)
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


@cli.command()
@click.argument("station", type=_PATH)
@click.option(
    "--frames",
    "frames_dir",
    type=_PATH,
    help="A capture folder made by 'capture' (default: capture now through the station's devices).",
)
@click.option(
    "--out",
    type=_PATH,
    help="Where to save the frames captured now (default: REPORT/frames, else a new "
    "folder verify-<station>-<time>).",
)
@click.option(
    "--report",
    "report_dir",
    type=_PATH,
    help="Write report.html, verification.json and junit.xml to this folder.",
)
@click.option(
    "--history",
    "history_path",
    type=_PATH,
    help="A history 'watch' keeps of this station: its trends go into report.html.",
)
@click.option(
    "--all-illuminations",
    is_flag=True,
    help="Capture every illumination, also those the prediction shows clearly worse than "
    "another where no check needs them (skipped by default, and listed).",
)
def verify(station, frames_dir, out, report_dir, history_path, all_illuminations):
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
    from inspect_validate.camera.station import read_station

    st = read_station(station)
    _outputs(folders=[report_dir])
    log = None
    if history_path is not None:
        if report_dir is None:
            raise click.UsageError("--history adds trends to the report: give --report too")
        log = _station_history(history_path, st)
    if frames_dir is None and out is None:
        out = report_dir / "frames" if report_dir else _new_folder("verify", station)
    result = _verify_station(
        st,
        frames_dir=frames_dir,
        out=out,
        report_dir=report_dir,
        history=log,
        skip_dominated=not all_illuminations,
    )
    if not result.passed:
        sys.exit(EXIT_CHECK_FAILED)


def _station_history(path, st):
    """The watch history at ``path``, refused unless it was kept of station ``st``."""
    from inspect_validate.errors import InputError
    from inspect_validate.watch.history import read_history

    log = read_history(path)
    if Path(log.station) != st.path.resolve():
        raise InputError(
            f"this history was kept of station {log.station}, not {st.path.resolve()}; "
            "give the history of this station",
            source=str(path),
        )
    return log


def _verify_station(st, *, frames_dir, out, report_dir, history=None, skip_dominated=False):
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

    def capture(station, folder, *, resume=False):
        _capture(station, folder, resume=resume)
        if not resume:
            click.echo(f"frames: {folder}")

    result = verify_station(
        st,
        frames=frames_dir,
        out=out,
        skip_dominated=skip_dominated,
        capture=capture,
        notify=lambda message: click.echo(message, err=True),
    )
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


@cli.command()
@click.argument("station", type=_PATH)
@click.option(
    "--out",
    "golden_path",
    type=_PATH,
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
    type=_PATH,
    multiple=True,
    help="Train on these capture folders instead of capturing (repeatable; --repeats is ignored).",
)
@click.option(
    "--frames-out",
    type=_PATH,
    help="Where to keep the captures (default: <golden file's stem>-frames next to it).",
)
def train(station, golden_path, repeats, frames_dirs, frames_out):
    """Store the golden statistics of STATION in a known-good state.

    Captures the station --repeats times (or reads --frames folders), measures
    every illumination in the station's ROIs and writes per class μ and σ² and
    per comparison SNR_dB and ε with their spread across the repeats.
    'verify' then checks drift from it (acceptance.drift). Exits 2 on bad input,
    3 on a camera or controller failure (the captures so far are kept).
    """
    from inspect_validate.camera.station import read_station
    from inspect_validate.report import render_table, write_json
    from inspect_validate.verification.golden import train as run_train
    from inspect_validate.verification.measured import station_regions

    st = read_station(station)
    _outputs(files=[golden_path], folders=[frames_out])
    regions = station_regions(st)  # a station without ROIs fails before the captures
    captures = list(frames_dirs)
    if not captures:
        base = frames_out or golden_path.with_name(f"{golden_path.stem}-frames")
        for i in range(repeats):
            folder = base / f"repeat_{i + 1:02d}"
            if repeats > 1:
                click.echo(f"repeat {i + 1} of {repeats}", err=True)
            _capture(st, folder)
            captures.append(folder)
        click.echo(f"frames: {base}")
    golden = run_train(st, captures, regions=regions)
    rows = [
        [
            ill,
            name,
            c.mean.summary(),
            c.variance.summary(),
        ]
        for ill, g in golden.illuminations.items()
        for name, c in g.classes.items()
    ]
    click.echo(render_table(["illumination", "class", "μ [DN]", "σ² [DN²]"], rows))
    rows = [
        [
            ill,
            label,
            c.snr_db.summary(3),
            c.error_gaussian.summary(3),
        ]
        for ill, g in golden.illuminations.items()
        for label, c in g.comparisons.items()
    ]
    click.echo(render_table(["illumination", "comparison", "SNR_dB", "ε Gauss"], rows))
    write_json(golden.document(), golden_path)
    click.echo(f"golden: {golden_path} ({golden.repeats} repeats)")


@cli.command()
@click.argument("source", type=_PATH)
@click.option("--json", "json_path", type=_PATH, help="Write the design as JSON.")
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
    type=_PATH,
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
    from inspect_validate.mix_design.solve import decibel, drive_percent, solve
    from inspect_validate.report import render_table, write_json
    from inspect_validate.report.design import design_document

    if check and out_dir is None:
        out_dir = _new_folder("design", source)
    _outputs(files=[json_path], folders=[out_dir])
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

        def note(message):
            click.echo(f"design: {message}", err=True)

        result = solve(problem, objective=objective, note=note)
    else:
        with click.progressbar(
            length=1, label=f"choosing {choose} of {len(problem.channels)}", file=sys.stderr
        ) as bar:

            def progress(done, total):
                bar.length = total
                bar.update(done - bar.pos)

            result = solve(problem, objective=objective, choose=choose, progress=progress)
    names = {c: light.name for c, light in problem.channels.items()}
    goal = "minimising the worst ε Gauss" if objective == "error" else "maximising the worst CNR"
    exposure = f"{1e3 * result.exposure_time:.4g} ms" + (
        " (designed)" if problem.auto_exposure else ""
    )
    click.echo(
        f"{Path(source).name}: {len(names)} channels, exposure {exposure}, {goal} of "
        f"{', '.join(problem.objective.labels)} ({result.starts} starts)"
    )
    click.echo(
        "designed mix: "
        + ", ".join(f"channel {c} ({names[c]}) {p:g} %" for c, p in result.percent.items())
    )
    if result.choice is not None:
        c = result.choice
        bound = f"ε {c.bound:.3g}" if objective == "error" else f"CNR {decibel(c.bound):.2f} dB"
        how = (
            "every subset optimised"
            if c.exhaustive
            else f"local search; no choice can beat all {len(names)} mixed, worst {bound}"
        )
        click.echo(
            f"chose {len(c.channels)} of {len(names)} channels ({c.evaluated} subsets, {how})"
        )
    ch, level = result.single
    click.echo(f"best single channel: {ch} ({names[ch]}) at {drive_percent(level):g} %")
    mix, single = result.mix, result.single_prediction
    ratio = "snr_db" if objective == "error" else "cnr_db"  # the chapter's SNR, or the objective
    rows = [
        [
            text,
            f"{mix.error_gaussian[0, 0, 0, j]:.3g}",
            f"{single.error_gaussian[0, 0, 0, j]:.3g}",
            f"{getattr(mix, ratio)[0, 0, 0, j]:.2f}",
            f"{getattr(single, ratio)[0, 0, 0, j]:.2f}",
        ]
        for j, text in enumerate(problem.comparisons.labels)
    ]
    name = "SNR_dB" if objective == "error" else "CNR_dB"
    click.echo(
        render_table(["comparison", "ε mix", "ε single", f"{name} mix", f"{name} single"], rows)
    )
    if objective == "error":
        worst = max(result.flatness, key=lambda f: f["worst_error"])
        value = f"the worst ε is at most {worst['worst_error']:.3g}"
    else:
        worst = min(result.flatness, key=lambda f: f["worst_cnr_db"])
        value = f"the worst CNR is at least {worst['worst_cnr_db']:.2f} dB"
    click.echo(
        f"drive tolerance: with one level off by ±10 % {value} "
        f"(channel {worst['channel']} {100 * worst['change']:+.0f} %)"
        + ("; +10 % on a level saturates" if any(f["saturates"] for f in result.flatness) else "")
    )
    entry = ", ".join(f"{c}: {p:g}" for c, p in result.percent.items())
    click.echo(f"station entry:\n  - {{name: design, channels: {{{entry}}}}}")
    if problem.auto_exposure:
        click.echo(f"  with camera.exposure_us: {1e6 * result.exposure_time:.6g}")
        top = max(result.levels.values())
        if top < 1.0:  # the single channel set the exposure; the mix alone needs less
            alone = ", ".join(
                f"{c}: {drive_percent(w / top):g}"
                for c, w in result.levels.items()
                if c in result.percent
            )
            click.echo(
                f"  (the mix alone, faster: channels {{{alone}}} at camera.exposure_us "
                f"{1e6 * result.exposure_time * top:.6g})"
            )
    document = design_document(result)
    for path in (json_path, out_dir and out_dir / "design.json"):
        if path:
            write_json(document, path)
            click.echo(f"wrote {path}")
    if out_dir:
        from inspect_validate.report.plots import plot_design_path, plot_design_spectrum

        for plot, file in (
            (plot_design_spectrum, "design-spectrum.png"),
            (plot_design_path, "design-path.png"),
        ):
            click.echo(f"wrote {plot(result, out_dir / file)}")
    if check:
        _verify_design(problem, result, out_dir)


def _verify_design(problem, result, out_dir):
    """Capture ``result``'s mix and best single channel on ``problem``'s station, verify them
    and print measured against predicted ε; exit 1 when the design does not hold."""
    from inspect_validate.camera.station import write_station
    from inspect_validate.mix_design.station import design_station
    from inspect_validate.report import render_table
    from inspect_validate.report.design import design_verification

    st = write_station(
        design_station(problem.station, result),
        out_dir / "station.yaml",
        comment=f"{problem.station.name} lit by the mix 'design' found for it "
        f"(inspect-validate design --verify {problem.source})",
    )
    click.echo(f"\nverifying the design on {st.path}")
    verification = _verify_station(st, frames_dir=None, out=out_dir / "frames", report_dir=out_dir)
    summary = design_verification(verification, problem.objective.labels, kind=result.objective)
    click.echo(render_table(summary.header, summary.rows))
    click.echo(summary.verdict)
    if not (verification.passed and summary.holds):
        sys.exit(EXIT_CHECK_FAILED)


@cli.command("watch")
@click.argument("station", type=_PATH)
@click.option(
    "--golden",
    "golden_path",
    type=_PATH,
    help="The golden file the drift charts are centred on (default: the station's "
    "acceptance.drift.golden).",
)
@click.option(
    "--db",
    "db_path",
    type=_PATH,
    help="History database (SQLite); an existing one is continued (default: "
    "watch-<station>/history.sqlite).",
)
@click.option(
    "--out",
    "folder",
    type=_PATH,
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
    type=_PATH,
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
    from inspect_validate.camera.station import read_station
    from inspect_validate.errors import InputError
    from inspect_validate.report import write_json
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
        st.model_copy(update={"acceptance": st.acceptance.model_copy(update={"drift": drift})})
    )
    st = st.model_copy(update={"acceptance": st.acceptance.model_copy(update={"drift": None})})
    db_path = Path(db_path or Path(f"watch-{Path(station).stem}") / "history.sqlite")
    folder = Path(folder or db_path.parent)
    status_path = Path(status_path or folder / "status.json")
    _outputs(files=[db_path, status_path], folders=[folder])
    golden_file = st.resolve(drift.golden)
    monitor = DriftMonitor(
        plan.golden, dark_offset=plan.model.camera.dark_offset, snr_floor_db=drift.snr_floor_db
    )
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
        doc = status_document(outcome, st)
        write_json(doc, status_path)
        if server is not None:
            server.doc = doc
        _show_cycle(outcome, live=live)

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


@cli.command("history")
@click.argument("db", type=_PATH)
@click.option("--last", type=click.IntRange(1), help="Only the last N cycles.")
@click.option(
    "--recent",
    type=click.IntRange(0),
    default=10,
    show_default=True,
    help="Cycles listed one by one (the trends cover all that are read).",
)
@click.option(
    "--plot",
    "plot_dir",
    type=_PATH,
    help="Write history-overview.png and one history-<illumination>.png per illumination.",
)
@click.option(
    "--csv", "csv_path", type=_PATH, help="Export one row per cycle and chart (UTF-8 CSV)."
)
def history(db, last, recent, plot_dir, csv_path):
    """Print, plot and export the history DB that 'watch' keeps.

    Prints the cycles' statuses, the last cycles, and per drift chart its golden
    target, its smoothed value at the start and now, its band now and how far
    off target it is (in half-widths of the band: beyond ±1 is an alarm),
    furthest first. Reads a history while 'watch' is still writing it.
    """
    import re

    from inspect_validate.report.history import format_history, write_history_csv
    from inspect_validate.watch.history import read_history

    _outputs(files=[csv_path], folders=[plot_dir])
    log = read_history(db, last=last)
    click.echo(format_history(log, recent=recent))
    if csv_path:
        write_history_csv(log, csv_path)
        click.echo(f"csv: {csv_path}")
    if plot_dir and log.charts:
        from inspect_validate.report.plots import plot_history_charts, plot_history_overview

        written = [plot_history_overview(log, plot_dir / "history-overview.png")]
        for ill in log.illuminations:
            slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", ill)
            written.append(plot_history_charts(log, ill, plot_dir / f"history-{slug}.png"))
        click.echo(f"plots: {', '.join(str(w) for w in written)}")
    elif plot_dir:
        click.echo("plots: none (no measured cycle yet)")


def _show_cycle(outcome, *, live: bool) -> None:
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


def _capture(station, out, *, resume=False):
    """Capture ``station`` into ``out`` with a progress bar on stderr."""
    from inspect_validate.camera.capture import capture

    total = sum(station.frames for _ in station.illuminations) + station.dark_frames
    with click.progressbar(length=total, label="capturing", file=sys.stderr) as bar:
        last = [0]

        def progress(step, done, _total):
            bar.label = f"capturing {step}"
            bar.update(done - last[0])
            last[0] = done

        return capture(station, out, resume=resume, progress=progress)


def _precision_note(result, step, station) -> str:
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


def _new_folder(command: str, source) -> Path:
    """A default output folder in the working directory: <command>-<source's stem>-<time>."""
    import time

    return Path(f"{command}-{Path(source).stem}-{time.strftime('%Y%m%dT%H%M%S')}")


def _outputs(*, files=(), folders=()):
    """Check output paths before the work starts, so a typo does not cost a sweep or a capture."""
    from inspect_validate.files import output_file, output_folder

    for f in files:
        if f is not None:
            output_file(f)
    for d in folders:
        if d is not None:
            output_folder(d)


def _terminated(signum, frame):
    """SIGTERM (a service manager, ``kill``) ends the tool as Ctrl-C does: saved frames
    kept, exit 130 with a message — not the bare 143 of the default action."""
    raise KeyboardInterrupt


def main(argv=None):
    """Console entry point: run the CLI and map errors to documented exit codes."""
    import signal

    try:
        signal.signal(signal.SIGTERM, _terminated)
        # Ctrl-C too, even where it was inherited as ignored (a job started with '&' from
        # a script): an interrupted capture writes every grabbed frame and its manifest.
        signal.signal(signal.SIGINT, signal.default_int_handler)
    except ValueError:  # not the main thread (an embedding program): its own handling
        pass
    try:
        cli.main(args=argv, prog_name="inspect-validate", standalone_mode=False)
    except (click.exceptions.Abort, KeyboardInterrupt):
        click.echo(
            "interrupted; frames saved so far are kept (capture: rerun with --resume)", err=True
        )
        sys.exit(130)
    except click.ClickException as exc:
        exc.show()
        sys.exit(EXIT_INPUT)
    except InspectValidateError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(exc.exit_code)
    except MemoryError:
        click.echo("error: out of memory; measure fewer or smaller frames at a time", err=True)
        sys.exit(EXIT_INTERNAL)
    except Exception:
        traceback.print_exc()
        click.echo(
            "internal error in inspect-validate: please report it with the traceback above",
            err=True,
        )
        sys.exit(EXIT_INTERNAL)
    sys.exit(0)
