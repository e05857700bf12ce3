"""`inspect-validate predict`: every combination of a scene ranked from spectra."""

from __future__ import annotations

import contextlib

import click

from inspect_validate.cli.common import (
    PATH,
    kde_mode,
    kde_option,
    plot_option,
    printer,
    retired_option,
    validate_outputs,
)
from inspect_validate.text import labelled


def scheduler_address(_ctx, _param, value):
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


@click.command()
@click.argument("scene", type=PATH)
@click.option(
    "--json",
    "json_path",
    type=PATH,
    help="Also write the ranking as JSON to this file ('-': to stdout only).",
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
    "--rank-comparison",
    "comparison",
    help='Rank by one comparison, e.g. "A vs B,C" (default: the scene\'s rank.comparison, '
    "else the worst pair).",
)
@retired_option("--comparison", "old_comparison", instead='write --rank-comparison "A vs B"')
@kde_option(
    default="auto",
    help="The nonparametric (kernel density) error of the listed rows, from the reflectance "
    "samples: auto and always compute it (no fit test applies to samples, which are not "
    "pixels), never leaves it out.",
)
@plot_option(
    help="Write the charts (component spectra, ε per wavelength, ranking) into this folder: "
    "prediction.html, or with --plot-format png spectra.png, spectral_error.png, ranking.png."
)
@click.option(
    "--render",
    "render_dir",
    type=PATH,
    help="Write simulated 16-bit frames of the best and worst combination (Fig. 19) with ROI files.",
)
@click.option(
    "--dask",
    "dask_address",
    is_flag=False,
    flag_value="local",
    metavar="[ADDRESS]",
    callback=scheduler_address,
    help="Predict the blocks of combinations on Dask: a LocalCluster, or the scheduler "
    "at ADDRESS (tcp://host:8786).",
)
def predict(
    scene,
    json_path,
    top,
    rank_by,
    comparison,
    old_comparison,
    kde,
    no_kde,
    plot_dir,
    plot_format,
    render_dir,
    dask_address,
):
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
    comparison = comparison or old_comparison
    named = comparison or sc.rank_comparison
    if named is not None:
        from inspect_validate.errors import InputError

        try:  # an unknown comparison fails before the sweep, naming where it came from
            sc.comparisons.index(named)
        except InputError as exc:
            where = "--rank-comparison" if comparison else f"{scene}: rank.comparison"
            raise InputError(str(exc), source=where) from None
    validate_outputs(files=[json_path], folders=[plot_dir, render_dir])
    if dask_address:
        from inspect_validate.model.sweep import dask_client

        cluster = dask_client(dask_address)
    else:
        cluster = contextlib.nullcontext()
    with cluster as client:
        # None ranks as the scene's rank: says
        result = sc.sweep(by=rank_by, comparison=comparison, top=top, client=client)
    for reason in result.skipped:
        click.echo(labelled("skipped", reason), err=True)
    for work in result.skipped_work:
        click.echo(labelled("not computed", work), err=True)
    with_kde = kde_mode(kde, no_kde) != "never"
    rows = prediction_rows(result, kde=with_kde)
    n = result.combinations
    n_skipped = n - result.predicted
    echo = printer(json_path)
    echo(
        f"{sc.name}: {n} combinations{f' ({n_skipped} skipped)' if n_skipped else ''}, "
        f"{sc.grid[0]:g}–{sc.grid[-1]:g} nm in {sc.grid[1] - sc.grid[0]:g} nm steps"
    )
    echo(format_prediction(result, rows))
    if json_path:
        write_json(
            prediction_document(result, rows, scene=str(scene)),
            json_path,
        )
        echo(f"\nwrote {json_path}")
    if plot_dir:
        from inspect_validate.model import analyse_spectra

        separation = analyse_spectra(list(sc.classes), kde=with_kde, comparisons=sc.comparisons)
        if plot_format == "png":
            from inspect_validate.report.plots import (
                plot_component_spectra,
                plot_ranked_separation,
                plot_spectral_errors,
            )

            written = [
                plot_component_spectra(sc, plot_dir / "spectra.png"),
                plot_spectral_errors(separation, plot_dir / "spectral_error.png"),
                plot_ranked_separation(rows, plot_dir / "ranking.png", by=result.by),
            ]
        else:
            from inspect_validate.report.html import prediction_html, write_charts_page

            body = prediction_html(sc, separation, rows, by=result.by)
            written = [write_charts_page(plot_dir / "prediction.html", f"predict {sc.name}", body)]
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
