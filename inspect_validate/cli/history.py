"""`inspect-validate history`: the history a watch keeps, printed, plotted, exported."""

from __future__ import annotations

import click

from inspect_validate.cli.common import (
    PATH,
    plot_option,
    retired_option,
    validate_outputs,
)


@click.command("history")
@click.argument("db", type=PATH)
@click.option(
    "--last",
    type=click.IntRange(1),
    help="Read only the last N cycles: the trends, charts, plots and CSV are of those.",
)
@click.option(
    "--list",
    "recent",
    type=click.IntRange(0),
    default=10,
    show_default=True,
    help="How many of the cycles read to list one by one, the newest last.",
)
@retired_option("--recent", "old_recent", type=click.IntRange(0), instead="write --list N")
@plot_option(
    help="Write the charts into this folder: history.html, or with --plot-format png "
    "history-overview.png and one history-<illumination>.png per illumination."
)
@click.option(
    "--csv", "csv_path", type=PATH, help="Export one row per cycle and chart (UTF-8 CSV)."
)
def history(db, last, recent, old_recent, plot_dir, plot_format, csv_path) -> None:
    """Print, plot and export the history DB that 'watch' keeps.

    Prints the cycles' statuses, the last cycles, and per drift chart its golden
    target, its smoothed value at the start and now, its band now and how far
    off target it is (in half-widths of the band: beyond ±1 is an alarm),
    furthest first. Reads a history while 'watch' is still writing it.
    """
    import re

    from inspect_validate.report.history import format_history, write_history_csv
    from inspect_validate.watch.history import read_history

    if old_recent is not None:
        recent = old_recent
    validate_outputs(files=[csv_path], folders=[plot_dir])
    log = read_history(db, last=last)
    click.echo(format_history(log, recent=recent))
    if csv_path:
        write_history_csv(log, csv_path)
        click.echo(f"csv: {csv_path}")
    if plot_dir and log.charts and plot_format == "png":
        from inspect_validate.report.plots import plot_history_charts, plot_history_overview

        written = [plot_history_overview(log, plot_dir / "history-overview.png")]
        for ill in log.illuminations:
            slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", ill)
            written.append(plot_history_charts(log, ill, plot_dir / f"history-{slug}.png"))
        click.echo(f"plots: {', '.join(str(w) for w in written)}")
    elif plot_dir and log.charts:
        from pathlib import Path

        from inspect_validate.report.html import history_html, write_charts_page

        title = f"history of {Path(log.station).name}"
        page = write_charts_page(plot_dir / "history.html", title, history_html(log))
        click.echo(f"plots: {page}")
    elif plot_dir:
        click.echo("plots: none (no measured cycle yet)")
