"""The report of ``characterize``: the JSON datasheet, the EMVA 1288 plots (PNG) and a
page with both (``characterization.html``)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate import __version__

if TYPE_CHECKING:
    from inspect_validate.characterization.analysis import Characterization
    from inspect_validate.characterization.series import Plan

__all__ = [
    "CHARACTERIZATION_SCHEMA_VERSION",
    "format_characterization",
    "write_characterization_report",
]

CHARACTERIZATION_SCHEMA_VERSION = 1


def format_characterization(result: Characterization, plan: Plan) -> str:
    """The datasheet as terminal lines: value ± standard error, unit."""
    r = result

    def pm(value, se, unit, fmt: str = ".4g"):
        if not np.isfinite(value):
            return "not measured"
        return f"{value:{fmt}} ± {se:.2g} {unit}" if np.isfinite(se) else f"{value:{fmt}} {unit}"

    sat = pm(r.saturation, r.saturation_se, "e⁻", ".5g")
    if not r.saturation_reached:
        sat += " (the series did not reach saturation: a lower bound)"
    varies = "exposure" if plan.varies == "exposure" else "LED level (the exposure is fixed)"
    lines = [
        f"EMVA 1288 series: {len(plan.exposure_us)} points over the {varies}, "
        f"illumination {plan.illumination}, {plan.bits}-bit",
        f"system gain K        {pm(r.gain, r.gain_se, 'DN/e⁻')} ({r.fit_points} points below 70 % of saturation)",
        f"dark noise σ_d       {pm(r.dark_noise, r.dark_noise_se, 'e⁻', '.3g')}",
        f"saturation capacity  {sat}",
        f"dark offset          {r.dark_offset:.4g} DN",
        f"dark current         {pm(r.dark_current, r.dark_current_se, 'e⁻/s', '.3g')}",
        f"linearity error      {100 * r.linearity_error:.2g} %"
        if np.isfinite(r.linearity_error)
        else "linearity error      not measured",
        f"DSNU                 {pm(r.dsnu, r.dsnu_se, 'e⁻', '.3g')}",
        f"PRNU                 {pm(100 * r.prnu, 100 * r.prnu_se, '%', '.3g')}",
        f"dynamic range        {r.dynamic_range:.4g} ({r.dynamic_range_db:.1f} dB)",
        (
            f"quantum efficiency   {pm(r.qe_scale, r.qe_scale_se, '×', '.3g')} the scene camera's "
            "curve (through the lens: their product), from the illumination's stated irradiance"
            if np.isfinite(r.qe_scale)
            else "quantum efficiency   relative only (the illumination's irradiance is not "
            f"stated): {r.responsivity:.4g} e⁻ per {'µs' if plan.varies == 'exposure' else '% level'}"
        ),
    ]
    return "\n".join(lines)


def write_characterization_report(
    folder: Path, result: Characterization, plan: Plan, *, inputs: dict
) -> list[Path]:
    """``characterization.json``, the 1288 plots (PNG) and ``characterization.html`` in
    ``folder``; their paths."""
    from inspect_validate.files import output_folder
    from inspect_validate.report.jsonfile import write_json
    from inspect_validate.report.plots import save_figure, subplots

    folder = output_folder(folder)
    doc = {
        "schema": "inspect-validate/characterization",
        "schema_version": CHARACTERIZATION_SCHEMA_VERSION,
        "tool_version": __version__,
        "inputs": inputs,
        "series": {
            "varies": plan.varies,
            "illumination": plan.illumination,
            "abscissa": result.exposure_us.tolist(),
            "mean": result.mean.tolist(),
            "variance": result.variance.tolist(),
            "dark_mean": result.dark_mean.tolist(),
            "dark_variance": result.dark_variance.tolist(),
        },
        "datasheet": result.datasheet(),
    }
    written = [write_json(doc, folder / "characterization.json")]
    r = result
    signal, noise = r.mean - r.dark_mean, r.variance - r.dark_variance
    x = r.exposure_us
    label = "exposure [µs]" if plan.varies == "exposure" else "LED level [%]"

    fig, ax = subplots(figsize=(6, 4))
    ax.plot(signal, noise, "o", ms=3, label="measured")
    fit = np.linspace(0, signal[r.saturation_index], 50)
    ax.plot(fit, r.gain * fit, "-", label=f"K = {r.gain:.4g} DN/e⁻")
    ax.axvline(0.7 * signal[r.saturation_index], ls=":", c="grey", label="70 % of saturation")
    ax.set(xlabel="μ_y − μ_y.dark [DN]", ylabel="σ²_y − σ²_y.dark [DN²]", title="Photon transfer")
    ax.legend()
    written.append(save_figure(fig, folder / "photon_transfer.png"))

    fig, ax = subplots(figsize=(6, 4))
    electrons = np.maximum(signal / r.gain, 1e-3)
    ax.loglog(electrons, np.maximum(r.snr, 1e-3), "o", ms=3, label="measured")
    from inspect_validate.components.sensors import grey_value

    _, temporal = grey_value(electrons, r.gain, r.dark_noise, 0.0)
    model = r.gain * electrons / np.sqrt(temporal)  # the EMVA 1288 SNR of μ_e
    ax.loglog(electrons, model, "-", label="EMVA 1288 linear model")
    ax.set(xlabel="μ_e [e⁻]", ylabel="SNR", title="Signal-to-noise ratio")
    ax.legend()
    written.append(save_figure(fig, folder / "snr.png"))

    fig, (a1, a2) = subplots(2, 1, figsize=(6, 5), sharex=True)
    a1.plot(x, signal, "o", ms=3)
    a1.set(ylabel="μ_y − μ_y.dark [DN]", title=f"Linearity (error {100 * r.linearity_error:.2g} %)")
    ok = (signal >= 0.05 * signal[r.saturation_index]) & (
        signal <= 0.95 * signal[r.saturation_index]
    )
    if ok.sum() >= 3:
        a, b = np.polyfit(x[ok], signal[ok], 1)
        a2.plot(x[ok], 100 * (signal[ok] - (a * x[ok] + b)) / (a * x[ok] + b), "o", ms=3)
    a2.set(xlabel=label, ylabel="deviation [%]")
    written.append(save_figure(fig, folder / "linearity.png"))

    fig, (a1, a2) = subplots(1, 2, figsize=(8, 3.5))
    a1.plot(x, r.dark_mean, "o", ms=3)
    a1.set(xlabel=label, ylabel="μ_y.dark [DN]", title="Dark signal")
    a2.plot(x, r.dark_variance, "o", ms=3)
    a2.set(xlabel=label, ylabel="σ²_y.dark [DN²]", title="Dark noise")
    written.append(save_figure(fig, folder / "dark_signal.png"))

    if r.dark_image is not None and r.bright_image is not None:
        fig, axes = subplots(2, 2, figsize=(8, 6))
        for row, (image, name) in enumerate(((r.dark_image, "DSNU"), (r.bright_image, "PRNU"))):
            centred = image - image.mean()
            im = axes[row, 0].imshow(centred, cmap="coolwarm")
            axes[row, 0].set(title=f"{name}: mean image − its mean [DN]")
            fig.colorbar(im, ax=axes[row, 0])
            axes[row, 1].hist(centred.ravel(), bins=100, log=True)
            axes[row, 1].set(xlabel="DN", ylabel="pixels", title=f"{name} histogram")
        written.append(save_figure(fig, folder / "nonuniformity.png"))
    written.append(_write_page(folder / "characterization.html", result, plan, inputs, written))
    return written


def _write_page(path: Path, result, plan, inputs: dict, pictures: list[Path]) -> Path:
    """``characterization.html``: the datasheet and the 1288 plots as charts the browser
    draws (the nonuniformity maps as the picture written beside it), one file."""
    import base64
    import html

    from inspect_validate.files import atomic_write
    from inspect_validate.report.charts import characterization_charts, chart
    from inspect_validate.report.html import page, table

    heading, *lines = format_characterization(result, plan).splitlines()
    rows = []
    for line in lines:
        name, _, value = line.partition("  ")
        rows.append([name.strip(), value.strip()])
    body = [
        "<h1>EMVA 1288 characterization</h1>",
        f'<p class="meta">{html.escape(heading)}; '
        f"station {html.escape(str(inputs.get('station', '')))}, "
        f"inspect-validate {html.escape(__version__)}</p>",
        "<h2>Datasheet</h2>",
        table(["quantity", "value"], rows),
        "<h2>Measurements</h2>",
        '<div class="charts">',
        *(chart(spec, alt=spec["title"]) for spec in characterization_charts(result, plan)),
        "</div>",
    ]
    maps = [p for p in pictures if p.name == "nonuniformity.png"]
    if maps:
        data = base64.b64encode(maps[0].read_bytes()).decode("ascii")
        body += [
            "<h2>Nonuniformity</h2>",
            f'<img src="data:image/png;base64,{data}" alt="DSNU and PRNU maps and histograms">',
        ]
    return atomic_write(path, page("EMVA 1288 characterization", body).encode())
