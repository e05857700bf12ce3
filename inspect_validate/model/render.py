"""Simulated frames of a scene (chapter §4.1.2, Fig. 19).

The classes fill horizontal bands of the frame. Each pixel takes one of its
class's reflectance samples at random (the spectral spread) and is exposed with
the EMVA 1288 noise model: Poisson photo-electrons, Gaussian dark noise, gain,
offset, rounding to DN and clipping at the largest grey value. The samples'
deviations from the class mean are widened by sqrt(S/(S−1)), so that the frame's
spectral spread is the unbiased (39) one the model predicts. Measuring the
frame with the ROI file written next to it gives back the predicted μ and σ².
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate import __version__
from inspect_validate.components.sensors import grey_value
from inspect_validate.model.acquisition import Prediction

if TYPE_CHECKING:
    from inspect_validate.components.sensors import SensorModel

__all__ = [
    "class_bands",
    "expected_grey",
    "expose",
    "render_frame",
    "sensor_pattern",
    "write_rendered",
]

BAND_GAP = 8  # pixels of dark background between class bands


def class_bands(classes: Sequence[str], *, height: int, width: int, gap: int = BAND_GAP) -> dict:
    """Class name → (x, y, width, height) of its horizontal band, ``gap`` pixels apart.

    Raises
    ------
    InputError
        A frame too low for a band of at least 4 rows per class (the simulated camera's
        ``camera.height``, named in the message).
    """
    from inspect_validate.errors import InputError

    k = len(classes)
    band_h = (height - gap * (k + 1)) // k if k else 0
    if band_h < 4:
        need = gap * (k + 1) + 4 * k
        raise InputError(
            f"a frame of {height} rows has no room for the bands of {k} classes "
            f"({', '.join(classes)}: each at least 4 rows, {gap} rows apart); give "
            f"camera.height {need} or more"
        )
    return {name: (0, gap + c * (band_h + gap), width, band_h) for c, name in enumerate(classes)}


def sensor_pattern(
    sensor: SensorModel, shape: tuple[int, ...], *, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray] | None:
    """The camera's fixed pattern over a frame of ``shape``: each pixel's gain factor
    1 + PRNU·N(0, 1) and dark signal DSNU·N(0, 1), e⁻ (EMVA 1288 release 4.0, §8); the
    same in every frame of one sensor. None for a sensor without non-uniformities."""
    if not (sensor.prnu or sensor.dsnu):
        return None
    return (
        1.0 + sensor.prnu * rng.standard_normal(shape),
        sensor.dsnu * rng.standard_normal(shape),
    )


def expose(
    electrons: np.ndarray,
    sensor: SensorModel,
    *,
    rng: np.random.Generator,
    gain: float | None = None,
    exposure_s: float = 0.0,
    pattern: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Grey values of pixels with mean photo-electrons ``electrons``, EMVA 1288 noise model.

    DN = offset + K (Poisson(μ_e·g + I_d·t) + d + N(0, σ_d)), rounded and clipped to
    [0, max DN] (uint16): g and d are the pixels' fixed gain factor and dark signal
    (``pattern``, :func:`sensor_pattern`), I_d the camera's dark current over the
    exposure ``exposure_s``; K is ``gain`` (DN/e⁻), by default the camera's.
    """
    k = sensor.gain if gain is None else gain
    photo = electrons if pattern is None else electrons * pattern[0]
    e = rng.poisson(np.maximum(photo + sensor.dark_current * exposure_s, 0.0)) + rng.normal(
        0.0, sensor.dark_noise, electrons.shape
    )
    if pattern is not None:
        e = e + pattern[1]
    top = min(sensor.max_dn, 2**16 - 1)
    return np.clip(np.floor(sensor.dark_offset + k * e + 0.5), 0, top).astype(np.uint16)


def expected_grey(
    electrons: np.ndarray,
    sensor: SensorModel,
    *,
    gain: float | None = None,
    exposure_s: float = 0.0,
    pattern: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Expected grey value and temporal variance of each pixel that :func:`expose` renders.

    μ = offset + K (μ_e·g + I_d·t + d) and σ² = K² (μ_e·g + I_d·t + σ_d²) + 1/12 DN²,
    the last term the rounding to DN (Sheppard's correction): the prediction's own
    grey-value model. It holds where the dark noise smooths the distribution over a
    DN: its error is of order exp(−2π² (K σ_d)²), 3e-9 at K σ_d = 1 DN, 7e-3 at 0.5 DN
    (below, the Poisson lattice shows through). Clipping is not modelled: valid where
    a pixel stays many σ inside [0, max DN].

    Parameters
    ----------
    electrons : ndarray
        Mean photo-electrons μ_e per pixel, e⁻.
    sensor : SensorModel
        Dark offset (DN), dark noise σ_d (e⁻), dark current (e⁻/s) and gain K (DN/e⁻).
    gain : float, keyword-only, optional
        K in DN/e⁻, by default the camera's.
    exposure_s : float, keyword-only
        The exposure time the dark current runs for, s.
    pattern : tuple of ndarray, keyword-only, optional
        The pixels' gain factors and dark signals (:func:`sensor_pattern`).

    Returns
    -------
    mean, variance : ndarray
        DN and DN², the shape of ``electrons``.
    """
    k = sensor.gain if gain is None else gain
    photo = np.maximum(electrons, 0.0)
    if pattern is not None:
        photo = photo * pattern[0]
    mean, variance = grey_value(
        photo + sensor.dark_current * exposure_s, k, sensor.dark_noise, sensor.dark_offset
    )
    if pattern is not None:
        mean = mean + k * pattern[1]
    return mean, variance


def render_frame(
    p: Prediction,
    index: tuple[int, int, int],
    *,
    cameras: Sequence[SensorModel],
    height: int = 480,
    width: int = 640,
    seed: int = 0,
) -> tuple[np.ndarray, dict[str, tuple[int, int, int, int]]]:
    """A frame (uint16 DN) and the band of each class for combination ``index`` = (light, optics, camera).

    Returns
    -------
    frame : ndarray of uint16, shape (height, width)
    bands : dict
        Class name → (x, y, width, height) of its band, pixels.
    """
    rng = np.random.default_rng(seed)
    _, _, ci = index
    cam = cameras[ci]
    t = p.exposure_time[index]
    bands = class_bands(p.classes, height=height, width=width)
    electrons = np.zeros((height, width))
    assert p.sample_electrons is not None  # a full prediction keeps its samples
    rate = p.sample_electrons[index] / t  # photo-e⁻/s per sample, unclipped
    for c, (x, y, w, h) in enumerate(bands.values()):
        # The model's spectral variance is the unbiased (39) spread of the S
        # samples: widen their deviations by sqrt(S/(S−1)) so the frame has it.
        r = rate[p.sample_class == c]
        if r.size > 1:
            r = r.mean() + (r - r.mean()) * np.sqrt(r.size / (r.size - 1))
        electrons[y : y + h, x : x + w] = r[rng.integers(0, r.size, size=(h, w))] * t
    frame = expose(
        electrons,
        cam,
        rng=rng,
        exposure_s=t,
        pattern=sensor_pattern(cam, electrons.shape, rng=rng),
    )
    return frame, bands


def write_rendered(
    p: Prediction,
    index: tuple[int, int, int],
    folder: Path,
    *,
    cameras: Sequence[SensorModel],
    stem: str,
    seed: int = 0,
) -> tuple[Path, Path]:
    """Write ``stem.tif`` (16-bit, description = JSON metadata) and ``stem_rois.yaml``."""
    import tifffile

    frame, bands = render_frame(p, index, cameras=cameras, seed=seed)
    folder.mkdir(parents=True, exist_ok=True)
    li, oi, ci = (int(i) for i in index)
    meta = {
        "tool_version": __version__,
        "light": p.lights[li],
        "optics": p.optics[oi],
        "camera": p.cameras[ci],
        "exposure_time_s": float(p.exposure_time[li, oi, ci]),
        "predicted": {
            n: {"mean": float(p.mean[li, oi, ci, k]), "variance": float(p.variance[li, oi, ci, k])}
            for k, n in enumerate(p.classes)
        },
        "seed": seed,
    }
    tif = folder / f"{stem}.tif"
    tifffile.imwrite(tif, frame, photometric="minisblack", description=json.dumps(meta))
    rois = folder / f"{stem}_rois.yaml"
    lines = ["# ROIs of the simulated frame: one band per class", "classes:"]
    for name, (x, y, w, h) in bands.items():
        lines += [f"  {json.dumps(name)}:", f"    - rect: [{x}, {y}, {w}, {h}]"]
    rois.write_text("\n".join(lines) + "\n")
    return tif, rois
