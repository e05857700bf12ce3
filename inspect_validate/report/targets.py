"""The targets' datasheet (``characterize --field --sharpness``): ``targets.html``, each
illumination's field as a picture with its falloff and uniformity, and each edge's MTF
beside the lens's in-focus MTF, as charts the browser draws."""

from __future__ import annotations

import base64
import html
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate import __version__

if TYPE_CHECKING:
    from collections.abc import Mapping
    from pathlib import Path

    from inspect_validate.characterization.field import Field
    from inspect_validate.characterization.sharpness import EdgeMTF

__all__ = ["field_picture", "write_targets_page"]


def field_picture(field: Field) -> bytes:
    """The field F over the frame as a PNG: a false-colour map (OpenCV's viridis, F's
    least dark, 1 bright) with contours every 2 % of the light."""
    import cv2

    f = field.map()
    low = float(f.min())
    span = max(1.0 - low, 1e-6)
    grey = np.round(255 * (f - low) / span).astype(np.uint8)
    picture = cv2.applyColorMap(grey, cv2.COLORMAP_VIRIDIS)
    levels = np.floor(np.minimum(f, 1 - 1e-9) / 0.02)  # the brightest point no contour
    edges = (np.diff(levels, axis=0, prepend=levels[:1]) != 0) | (
        np.diff(levels, axis=1, prepend=levels[:, :1]) != 0
    )
    picture[edges] = (255, 255, 255)
    ok, png = cv2.imencode(".png", picture)
    assert ok  # an 8-bit 3-channel image always encodes
    return png.tobytes()


def write_targets_page(
    path: Path,
    *,
    field: Mapping[str, dict] | None,
    fields: Mapping[str, Field] | None,
    edges: Mapping[str, EdgeMTF] | None,
    focus: Mapping[str, np.ndarray] | None,
    frequencies: np.ndarray | None,
    inputs: dict,
) -> Path:
    """``targets.html`` at ``path``: ``field`` (the field document's illuminations) with
    each of ``fields`` as a picture, and ``edges`` with ``focus`` (the in-focus MTF at
    ``frequencies`` per illumination) as charts."""
    from inspect_validate.files import atomic_write
    from inspect_validate.report.charts import chart, mtf_chart
    from inspect_validate.report.html import page, table

    e = html.escape
    body = [
        "<h1>The station's field and sharpness</h1>",
        f'<p class="meta">station {e(str(inputs.get("station", "")))}, '
        f"inspect-validate {e(__version__)}</p>",
    ]
    if field and fields:
        rows = [
            [
                name,
                f"{100 * f['corner_falloff']:.1f} %",
                f"{f['uniformity']:.3f}",
                ", ".join(
                    f"{c} {100 * r['mean']:.1f} % ({r['uniformity']:.3f})"
                    for c, r in f["regions"].items()
                )
                or "—",
                f"{100 * f['residual']:.2f} %",
            ]
            for name, f in field.items()
        ]
        body += [
            "<h2>Light field (flat target)</h2>",
            table(
                [
                    "illumination",
                    "corners' falloff",
                    "uniformity (min/max)",
                    "regions: mean share (uniformity)",
                    "surface residual (rms)",
                ],
                rows,
            ),
        ]
        for name, f in fields.items():
            data = base64.b64encode(field_picture(f)).decode("ascii")
            body.append(
                f'<h3>{e(name)}</h3><img src="data:image/png;base64,{data}" alt="the '
                f"{e(name)} field over the frame, {100 * (1 - float(f.map().min())):.1f} % "
                'darkest, contours every 2 %">'
            )
    if edges:
        rows = []
        for name, edge in edges.items():
            limit = None
            if focus is not None and frequencies is not None and name in focus:
                from inspect_validate.model.mtf import falls_to

                limit = falls_to(frequencies, focus[name])
            rows.append(
                [
                    name,
                    f"{edge.mtf50:.4g}" if np.isfinite(edge.mtf50) else "above 1",
                    f"{edge.at(0.25):.3f}",
                    f"{limit:.4g}" if limit is not None else "—",
                    f"{edge.angle_deg:+.2f}°",
                ]
            )
        body += [
            "<h2>Sharpness (slanted edge, ISO 12233 e-SFR)</h2>",
            table(
                [
                    "illumination",
                    "MTF50 [cycles/px]",
                    "MTF at Nyquist/2",
                    "in focus at the f-number [cycles/px]",
                    "edge angle",
                ],
                rows,
            ),
        ]
        for name, edge in edges.items():
            spec = mtf_chart(name, edge, focus=(focus or {}).get(name), frequencies=frequencies)
            body.append(chart(spec, alt=f"the {name} edge's MTF against the in-focus MTF"))
    return atomic_write(path, page("The station's field and sharpness", body).encode())
