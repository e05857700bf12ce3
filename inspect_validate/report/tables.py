"""Plain-text tables in the layout of the chapter's Tables 4 (classes) and 3 (separation)."""

from __future__ import annotations

import math
import re
import sys

from inspect_validate.measurement import Measurement
from inspect_validate.text import labelled

__all__ = ["format_error", "format_measurement", "render_table"]


def format_error(value: float | None, log_value: float | None = None) -> str:
    """ε as a fraction (0 to ½), the unit of every output and every limit, to three
    significant digits; powers of ten for tiny values."""
    if value is None:
        return "-"
    if value == 0.0 and log_value is not None and math.isfinite(log_value):
        return f"1e{log_value / math.log(10):.0f}"
    if value >= 1e-4:
        return f"{value:#.3g}"
    return f"{value:.2e}"


_NUMBER = re.compile(r"^[-+−]?(\d|\.\d|inf|nan)|^[-—]$")


def render_table(header: list[str], rows: list[list[str]], *, left=None) -> str:
    """Columns padded to their widest cell: text flush left, numbers flush right. A
    column is text (``left``: its indices, default: found) unless most of its cells
    begin as a number does (a dash: none)."""
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    if left is None:
        left = set()
        for i in range(len(header)):
            cells = [r[i] for r in rows if r[i]]  # an empty cell is neither
            if 2 * sum(bool(_NUMBER.match(c)) for c in cells) < len(cells):
                left.add(i)

    def line(r):
        cells = (
            c.ljust(w) if i in left else c.rjust(w)
            for i, (c, w) in enumerate(zip(r, widths, strict=True))
        )
        return "  ".join(cells).rstrip()

    return "\n".join([line(header), line(["-" * w for w in widths]), *map(line, rows)])


def format_measurement(m: Measurement, *, saturation_limit: float | None = None) -> str:
    """The class table (μ, σ² (38)–(39)) and the separation table (SNR_dB (36), ε (37))."""
    stack = any(c.n_frames > 1 for c in m.classes)
    header = ["class", "mean [DN]", "var [DN²]", "pixels", "saturated"]
    if stack:
        header += ["temporal var", "spatial var"]
    kde = any(c.kde_bandwidth is not None for c in m.classes)
    if kde:
        header += ["KDE h [DN]"]
    rows = []
    for c in m.classes:
        flag = (
            " !" if saturation_limit is not None and c.saturated_fraction > saturation_limit else ""
        )
        row = [
            c.name,
            f"{c.mean:.2f}",
            f"{c.variance:.2f}",
            f"{c.n_pixels}",
            f"{100 * c.saturated_fraction:.2f} %{flag}",
        ]
        if stack:  # a one-pixel region has a temporal variance but no spatial one
            row += [
                "-" if v is None else f"{v:.2f}" for v in (c.temporal_variance, c.spatial_variance)
            ]
        if kde:
            h = c.kde_bandwidth
            row += ["-" if h is None else f"{h:.3g}{'*' if c.kde_bandwidth_at_floor else ''}"]
        rows.append(row)
    out = ["Classes (chapter Table 4: μ (38), σ² (39))", render_table(header, rows), ""]
    header = ["classes", "SNR_dB (36)", "CNR_dB", "Fisher_dB", "ε Gauss", "ε counted", "ε KDE"]
    rows = [
        [
            c.label,
            f"{c.snr_db:.2f}",
            f"{c.cnr_db:.2f}",
            f"{c.fisher_db:.2f}",
            format_error(c.error_gaussian, c.log_error_gaussian),
            format_error(None if math.isnan(c.error_counted) else c.error_counted),
            format_error(c.error_kde),
        ]
        for c in m.comparisons
    ]
    if not rows:
        out.append("Separation: one class, nothing to compare (give the ROIs of two or more)")
        return "\n".join(out)
    groups = {"equal": "equal weights", "pixels": "weighted by pixels", "priors": "class priors"}
    out += [
        labelled(
            "Separation",
            "chapter Table 3; ε_tot (37), a fraction, with equal priors between the sides; "
            f"a group of classes is their mixture, {groups[m.weighting]}",
            stream=sys.stdout,
        ),
        render_table(header, rows),
    ]
    if any(c.kde_bandwidth_at_floor for c in m.classes):
        out.append(
            "* KDE bandwidth at its floor of one quantisation step: LSCV wants a narrower "
            "kernel than the grey levels resolve."
        )
    return "\n".join(out)
