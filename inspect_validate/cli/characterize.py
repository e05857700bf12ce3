"""`inspect-validate characterize`: EMVA 1288 of the station's own camera."""

from __future__ import annotations

import click

from inspect_validate.cli.common import (
    PATH,
    REGION,
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
@click.option(
    "--field",
    "flat",
    type=PATH,
    help="A flat target's capture (capture --target flat): each illumination's light field "
    "over the frame, written to OUT/field.json (name it in the station as field:).",
)
@click.option(
    "--sharpness",
    "edge",
    type=PATH,
    help="A slanted edge's capture (capture --target edge): each illumination's MTF, "
    "written to OUT/sharpness.json (name it in the station as sharpness:).",
)
@click.option(
    "--edge",
    "edge_region",
    type=REGION,
    help="With --sharpness: the region X,Y,W,H (px) holding the edge [100 px about the "
    "frame's centre].",
)
@camera_option
def characterize(station, out, report_dir, resume, flat, edge, edge_region, camera_name):
    """Measure STATION's own camera as EMVA 1288 prescribes, through its camera and controller.

    Captures an exposure series from dark to past saturation (lit and dark pairs;
    a series of LED levels where the exposure cannot be set) and stacks in the dark
    and at about 50 % for DSNU and PRNU, in front of a uniform target (place a white
    diffuser; the simulated camera renders one). Prints K, dark noise, saturation
    capacity, linearity, dark current, DSNU, PRNU and dynamic range with standard
    errors, and writes the measured camera file: name it in the station as
    camera.measured and every prediction uses it.

    With --field and/or --sharpness, measures the station's targets instead: a flat
    card's capture as each illumination's light field (corner falloff, uniformity over
    the frame and each class's region), a slanted edge's as the lens's MTF (ISO 12233
    e-SFR: MTF50, MTF at Nyquist/2), into OUT/field.json and OUT/sharpness.json.
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
    if edge_region is not None and edge is None:
        raise click.UsageError("--edge is the region of --sharpness's edge")
    if flat is not None or edge is not None:
        if resume:
            raise click.UsageError("--resume continues a camera series, not --field/--sharpness")
        _targets(st, flat, edge, edge_region, out or new_folder("characterize", station))
        return
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
            "station_sha256": station_hash(st),
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


def _targets(st, flat, edge, region, out) -> None:
    """``characterize --field/--sharpness``: the targets' captures measured, printed and
    written to ``out``."""
    import math

    from inspect_validate.files import write_json
    from inspect_validate.station.file import station_hash

    out.mkdir(parents=True, exist_ok=True)
    inputs = {"station": str(st.path), "station_sha256": station_hash(st)}
    fields = field_doc = edges = None
    if flat is not None:
        from inspect_validate.characterization.field_file import field_document
        from inspect_validate.characterization.targets import measure_field

        fields = measure_field(st, flat)
        document = field_doc = field_document(
            fields,
            masks=_class_masks(st, next(iter(fields.values()))),
            inputs={**inputs, "capture": str(flat)},
        )
        for name, f in document["illuminations"].items():
            regions = ", ".join(
                f"{c} {100 * r['mean']:.1f} % (uniformity {r['uniformity']:.3f})"
                for c, r in f["regions"].items()
            )
            click.echo(
                f"{name}: corners lose {100 * f['corner_falloff']:.1f} % of the brightest "
                f"point's light, uniformity (min/max) {f['uniformity']:.3f} over the frame"
                + (f"; regions: {regions}" if regions else "")
                + f"; the surface leaves {100 * f['residual']:.2f} % rms"
            )
        click.echo(
            f"field: {write_json(document, out / 'field.json')} (name it in the station as field:)"
        )
    if edge is not None:
        from inspect_validate.characterization.sharpness_file import (
            HALF_NYQUIST,
            sharpness_document,
        )
        from inspect_validate.characterization.targets import measure_sharpness

        readings = measure_sharpness(st, edge, region=region)
        # what the station measured when it was set up, read before this one is written
        # (an --out of the station's own calibration folder replaces it)
        reference = _reference_sharpness(st)
        used = next(iter(readings.values())).region
        document = sharpness_document(
            readings, region=used, inputs={**inputs, "capture": str(edge)}
        )
        edges = {name: r.edge for name, r in readings.items()}
        for name, r in readings.items():
            e = r.edge
            mtf50 = f"{e.mtf50:.4g}" if math.isfinite(e.mtf50) else "above 1"
            se = f" ± {r.mtf50_se:.2g}" if math.isfinite(r.mtf50_se) else ""
            click.echo(
                f"{name}: MTF50 {mtf50}{se} cycles/px, MTF at Nyquist/2 ({HALF_NYQUIST} "
                f"cycles/px) {e.at(HALF_NYQUIST):.3f}; edge turned {e.angle_deg:+.2f}°, "
                f"contrast {e.contrast:.4g} DN"
            )
        click.echo(
            f"sharpness: {write_json(document, out / 'sharpness.json')} (name it in the "
            "station as sharpness:)"
        )
    _datasheet(st, out, field_doc, fields, edges, inputs)
    if edge is not None and reference is not None:
        _focus_since(st, readings, reference)


def _reference_sharpness(st):
    """The station's ``sharpness:`` file, read (None where it names none, or names the
    file this first measurement writes)."""
    if st.sharpness is None or not st.resolve(st.sharpness).exists():
        return None
    from inspect_validate.characterization.sharpness_file import read_sharpness

    return read_sharpness(st.resolve(st.sharpness))


def _focus_since(st, readings, reference) -> None:
    """The edge's MTF50 against the station's ``sharpness:`` file (what it measured when
    it was set up): each illumination's loss checked at the station's false-alarm rate,
    one-sided, in both measurements' standard errors; exit 1 where the lens lost focus."""
    import math
    import sys

    from inspect_validate.errors import EXIT_CHECK_FAILED
    from inspect_validate.report.verification import check_rows, count_failed, verdict_table
    from inspect_validate.text import terminal_width
    from inspect_validate.verification.checks import at_least, decide, not_run

    path = st.resolve(st.sharpness)
    checks = []
    for name, r in readings.items():
        then = reference.illuminations.get(name)
        label = f"{name}: MTF50 since {path.name}"
        lens = {"illumination": name, "subject": "lens", "quantity": "mtf50"}
        if then is None or then.mtf50 is None or not math.isfinite(r.edge.mtf50):
            why = "no MTF50 of this illumination in both"
            checks.append(not_run(label, "sharpness", 0.0, "%", "≥", why, **lens))
            continue
        spread = math.hypot(then.mtf50_se or math.nan, r.mtf50_se)
        if not math.isfinite(spread):
            which = (
                f"{path.name} records no standard error of its MTF50 (measure the station's "
                "edge again with characterize --sharpness, and name that file)"
                if then.mtf50_se is None
                else "this edge is of one frame: its MTF50 has no standard error (capture "
                "more frames)"
            )
            checks.append(not_run(label, "sharpness", 0.0, "%", "≥", which, **lens))
            continue
        frames = min(then.frames or 2, r.frames)
        checks.append(
            at_least(
                label,
                "sharpness",
                100 * (r.edge.mtf50 / then.mtf50 - 1),
                0.0,
                "%",
                f"{then.mtf50:.4g} then, {r.edge.mtf50:.4g} cycles/px now; below, the lens "
                "lost focus (or a haze on it)",
                basis="statistical",
                standard_error=100 * spread / then.mtf50,
                df=frames - 1,
                sided=1,
                **lens,
            )
        )
    decided = decide(checks, st.acceptance.false_alarm_rate)
    rows = [cells for _, cells in check_rows(decided)]
    click.echo(verdict_table(rows, terminal_width(sys.stdout)))
    if any(not c.passed and math.isfinite(c.value) for c in decided):
        click.echo("likely cause: the lens lost focus since the station's sharpness was measured")
    click.echo(f"{'PASS' if all(c.passed for c in decided) else 'FAIL'}: {count_failed(decided)}")
    if not all(c.passed for c in decided):
        sys.exit(EXIT_CHECK_FAILED)


def _datasheet(st, out, field_doc, fields, edges, inputs) -> None:
    """``targets.html``: the fields as pictures, the edges beside the lens in focus (where
    the station has a scene to predict it from)."""
    import numpy as np

    from inspect_validate.report.targets import write_targets_page

    focus = frequencies = None
    if edges and st.scene is not None:
        from inspect_validate.station.model import station_model

        frequencies = np.linspace(0.0, 1.0, 201)
        focus = station_model(st).focus_mtf(st, frequencies)
    page = write_targets_page(
        out / "targets.html",
        field=field_doc["illuminations"] if field_doc else None,
        fields=fields,
        edges=edges,
        focus=focus,
        frequencies=frequencies,
        inputs=inputs,
    )
    click.echo(f"datasheet: {page}")


def _class_masks(st, field) -> dict:
    """The station's class regions as masks of the field's frame size (none without an
    ROI file)."""
    if st.rois is None:
        return {}
    from inspect_validate.roi.roiset import class_masks
    from inspect_validate.verification.measured import station_regions

    rois, _ = station_regions(st)
    return class_masks(rois, (field.height, field.width))
