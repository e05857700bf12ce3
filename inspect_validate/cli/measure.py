"""`inspect-validate measure`: classes and comparisons measured in frames."""

from __future__ import annotations

import sys

import click

from inspect_validate.cli.common import (
    PATH,
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
@click.option("--rois", required=True, type=PATH, help="ROI file: YAML, ImageJ .roi or RoiSet.zip.")
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
    Exits 1 when a class has more saturated or zero pixels than allowed.
    """
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import Limits, measure_files
    from inspect_validate.report import measurement_document, write_json
    from inspect_validate.roi import read_rois

    validate_outputs(files=[json_path])
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
        kde=kde_mode(kde, no_kde),
    )
    echo = printer(json_path)
    echo(result.table(saturation_limit=max_saturated))
    for reason in result.skipped:
        click.echo(labelled("skipped", reason), err=True)
    for warning in result.warnings:
        click.echo(labelled("warning", warning), err=True)
    if json_path:
        write_json(measurement_document(result, limits=limits), json_path)
        echo(f"\nwrote {json_path}")
    for v in result.violations:
        click.echo(f"limit exceeded: {v}", err=True)
    if result.violations:
        sys.exit(EXIT_CHECK_FAILED)
