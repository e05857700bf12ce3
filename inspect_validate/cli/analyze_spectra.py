"""`inspect-validate analyze-spectra`: ε per wavelength from the reflectances."""

from __future__ import annotations

import click

from inspect_validate.cli.common import (
    PATH,
    check_outputs,
    printer,
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
@click.option(
    "--plot",
    "plot_path",
    type=PATH,
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
def analyze_spectra(scene, json_path, plot_path, best, no_kde) -> None:
    """Classification error per wavelength between the classes of SCENE, from reflectances alone.

    Shows which bands separate the classes before any hardware is chosen
    (chapter §4.2.1): parametric (Gaussian) and kernel-density ε_tot (37).
    """
    import numpy as np

    from inspect_validate.model import analyse_spectra
    from inspect_validate.report import write_json
    from inspect_validate.scene import read_scene
    from inspect_validate.text import format_error, render_table

    check_outputs(files=[json_path, plot_path])
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
    if plot_path:
        from inspect_validate.report.plots import plot_spectral_errors

        click.echo(f"wrote {plot_spectral_errors(sep, plot_path)}")
