"""`inspect-validate measure`: classes and comparisons measured in frames."""

from __future__ import annotations

import sys

import click

from inspect_validate.cli.common import (
    PATH,
    REGION,
    Number,
    Share,
    kde_mode,
    kde_option,
    printer,
    validate_outputs,
)
from inspect_validate.errors import EXIT_CHECK_FAILED
from inspect_validate.text import labelled


@click.command()
@click.argument("frames", nargs=-1, required=True, type=PATH)
@click.option("--rois", type=PATH, help="ROI file: YAML, ImageJ .roi or RoiSet.zip.")
@click.option(
    "--edge",
    type=REGION,
    help="A region X,Y,W,H (px) of the frames holding a slanted edge, dark against light and "
    "turned 1–30° (about 5° is best): its MTF, MTF50 and MTF at Nyquist/2 (ISO 12233 e-SFR), "
    "of the frames' mean less the darks'.",
)
@click.option(
    "--dark",
    multiple=True,
    type=PATH,
    help="Dark frame(s) at the same exposure and gain; repeat for several.",
)
@click.option(
    "--json",
    "json_path",
    type=PATH,
    help="Also write the results as JSON to this file ('-': to stdout only).",
)
@click.option(
    "--saturation-level",
    type=Number(min=0, min_open=True),
    help="Raw value counted as saturated [DN]; default 2^bits − 1 of the bit depth a "
    "captured frame records (Mono12 in uint16: 4095), else the data type's maximum.",
)
@click.option(
    "--max-saturated",
    type=Share(),
    default=0.001,
    show_default=True,
    help="Largest acceptable fraction of saturated pixels per class (0.001, or 0.1%).",
)
@click.option(
    "--max-zero",
    type=Share(),
    default=0.001,
    show_default=True,
    help="Largest acceptable fraction of zero (underexposed) pixels per class (0.001, or 0.1%).",
)
@kde_option(
    default="auto",
    help="The nonparametric (kernel density) error: auto computes it only where the classes' "
    "Gaussians do not fit the pixels (their rule's counted error differs from ε Gauss).",
)
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
    edge,
    dark,
    json_path,
    saturation_level,
    max_saturated,
    max_zero,
    kde,
    no_kde,
    comparison_texts,
    weights,
) -> None:
    """Measure object classes in FRAMES (one setting; several files, a folder or a quoted glob make a stack).

    Prints per-class μ and σ² (chapter Table 4) and, for every pair of classes
    and every class against the rest, SNR_dB (36), CNR, Fisher ratio and the
    classification error ε_tot (37), parametric and kernel-density (Table 3).
    Exits 1 when a class has more saturated or zero pixels than allowed. With --edge,
    the sharpness of a slanted edge's region too (or alone, without --rois).
    """
    if rois is None and edge is None:
        raise click.UsageError(
            "give --rois FILE (the classes to measure), --edge X,Y,W,H (a slanted edge's "
            "region, for the sharpness), or both"
        )
    validate_outputs(files=[json_path])
    document: dict = {}
    if rois is not None:
        document, failed = _measure_classes(
            frames, rois, dark, json_path, saturation_level, max_saturated, max_zero,
            kde_mode(kde, no_kde), comparison_texts, weights,
        )  # fmt: skip
    else:
        failed = False
    if edge is not None:
        document["edge"] = _measure_edge(frames, dark, edge, printer(json_path))
    if json_path:
        from inspect_validate.report import write_json

        write_json(document, json_path)
        printer(json_path)(f"\nwrote {json_path}")
    if failed:
        sys.exit(EXIT_CHECK_FAILED)


def _measure_edge(frames, dark, region, echo) -> dict:
    """The MTF of the slanted edge in ``region`` of the frames' mean (less the darks'),
    printed; its JSON document."""
    import numpy as np

    from inspect_validate.characterization.sharpness import edge_mtf
    from inspect_validate.errors import InputError
    from inspect_validate.images import read_frames

    mean = read_frames(frames).astype(np.float64).mean(axis=0)
    if dark:
        darks = read_frames(dark)
        if darks.shape[1:] != mean.shape:
            raise InputError(
                f"the darks are {darks.shape[2]}×{darks.shape[1]}, the frames "
                f"{mean.shape[1]}×{mean.shape[0]}",
                source="--dark",
            )
        mean -= darks.astype(np.float64).mean(axis=0)
    x, y, w, h = region
    height, width = mean.shape
    if x + w > width or y + h > height:
        raise InputError(
            f"[{x}, {y}, {w}, {h}] reaches outside the {width}×{height} frame; give a region "
            "inside it",
            source="--edge",
        )
    try:
        found = edge_mtf(mean[y : y + h, x : x + w])
    except InputError as exc:
        raise InputError(str(exc), source=f"--edge {x},{y},{w},{h}") from None
    half = found.at(0.25)
    along = "columns" if found.vertical else "rows"
    mtf50 = (
        f"{found.mtf50:.4g} cycles/px"
        if np.isfinite(found.mtf50)
        # Not NaN: what it means (a step drawn sharper than the pixels sample it).
        else "above 1 cycle/px (the modulation stays above ½ that far: an edge sharper than "
        "the pixels sample, or aliased)"
    )
    echo(
        f"edge [{x}, {y}, {w}, {h}]: turned {found.angle_deg:+.2f}° from the {along}, "
        f"contrast {found.contrast:.4g} DN\n"
        f"  MTF50 {mtf50}, MTF at Nyquist/2 (0.25 cycles/px) {half:.3f}"
    )
    return {
        "region": [x, y, w, h],
        "angle_deg": found.angle_deg,
        "vertical": found.vertical,
        "contrast_dn": found.contrast,
        "mtf50_cycles_per_px": None if np.isnan(found.mtf50) else found.mtf50,
        "mtf_at_half_nyquist": half,
        "frequencies_cycles_per_px": found.frequencies.tolist(),
        "mtf": found.mtf.tolist(),
    }


def _measure_classes(
    frames, rois, dark, json_path, saturation_level, max_saturated, max_zero, kde,
    comparison_texts, weights,
) -> tuple[dict, bool]:  # fmt: skip
    """The classes of ``rois`` measured and printed: the JSON document, and whether a
    limit was exceeded."""
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import Limits, measure_files
    from inspect_validate.report import measurement_document
    from inspect_validate.roi import read_rois

    roi_set = read_rois(rois)
    # Checked against the ROI file's classes here, so that a mistake names the option.
    comparisons = Comparisons.of(
        [c.name for c in roi_set.classes],
        list(comparison_texts) or "default",
        weights,
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
        kde=kde,
    )
    echo = printer(json_path)
    echo(result.table(saturation_limit=max_saturated))
    for reason in result.skipped:
        click.echo(labelled("skipped", reason), err=True)
    for warning in result.warnings:
        click.echo(labelled("warning", warning), err=True)
    for v in result.violations:
        click.echo(f"limit exceeded: {v}", err=True)
    return measurement_document(result, limits=limits), bool(result.violations)
