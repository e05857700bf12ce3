"""`inspect-validate analyze-spectra`: ε per wavelength from the reflectances."""

from __future__ import annotations

import click

from inspect_validate.cli.common import (
    PATH,
    kde_mode,
    kde_option,
    plot_option,
    printer,
    validate_outputs,
)
from inspect_validate.text import labelled


@click.command("analyze-spectra")
@click.argument("scene", type=PATH)
@click.option(
    "--json",
    "json_path",
    type=PATH,
    help="Also write the per-wavelength errors as JSON ('-': to stdout only).",
)
@plot_option(
    help="Write the error curves (the chapter's Fig. 22) into this folder: "
    "spectral_error.html, or with --plot-format png spectral_error.png."
)
@click.option(
    "--best",
    type=click.IntRange(1),
    default=5,
    show_default=True,
    help="Bands to list per comparison.",
)
@kde_option(
    default="auto",
    help="The nonparametric (kernel density) error per wavelength: auto and always compute "
    "it (no fit test applies to reflectance samples, which are not pixels), never gives "
    "the parametric error only.",
)
def analyze_spectra(scene, json_path, plot_dir, plot_format, best, kde, no_kde) -> None:
    """Classification error per wavelength between the classes of SCENE, from reflectances alone.

    Shows which bands separate the classes before any hardware is chosen
    (chapter §4.2.1): parametric (Gaussian) and kernel-density ε_tot (37).
    """
    import numpy as np

    from inspect_validate.model import analyse_spectra
    from inspect_validate.report import write_json
    from inspect_validate.scene import read_scene
    from inspect_validate.text import format_error, render_table

    plot_path = None
    if plot_dir is not None and plot_dir.suffix.lower() == ".png":  # a file, as it was once
        click.echo(
            f"DeprecationWarning: --plot takes a folder now; {plot_dir} is written as the "
            f"file it names this once (write --plot {plot_dir.parent})",
            err=True,
        )
        plot_path = plot_dir
    elif plot_dir is not None:  # the names predict --plot gives it
        plot_path = plot_dir / f"spectral_error.{plot_format}"
    validate_outputs(files=[json_path, plot_path])
    sc = read_scene(scene)
    for note in sc.notes():
        click.echo(labelled("note", note), err=True)
    sep = analyse_spectra(
        list(sc.classes), kde=kde_mode(kde, no_kde) != "never", comparisons=sc.comparisons
    )
    rows = []
    for j, (a, b) in enumerate(sep.comparisons):
        eps = sep.error_gaussian[j]
        for i in np.argsort(np.where(np.isnan(eps), np.inf, eps))[:best]:
            kde_text = format_error(sep.error_kde[j][i]) if sep.error_kde is not None else "-"
            rows.append(
                [
                    f"{','.join(a)} vs {','.join(b)}",
                    f"{sep.wavelengths[i]:g}",
                    format_error(eps[i]),
                    kde_text,
                ]
            )
    echo = printer(json_path)
    echo(f"{sc.name}: best bands per comparison (ε_tot (37) from the reflectance samples)")
    echo(render_table(["comparison", "λ [nm]", "ε Gauss", "ε KDE"], rows))

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
        echo(f"\nwrote {json_path}")
    if plot_path and plot_path.suffix.lower() == ".png":
        from inspect_validate.report.plots import plot_spectral_errors

        click.echo(f"wrote {plot_spectral_errors(sep, plot_path)}")
    elif plot_path:
        from inspect_validate.report.charts import error_charts
        from inspect_validate.report.html import charts, write_charts_page

        body = [charts(error_charts(sep), what="ε per wavelength")]
        click.echo(f"wrote {write_charts_page(plot_path, f'ε per wavelength: {sc.name}', body)}")
