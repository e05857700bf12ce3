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
from pathlib import Path

import numpy as np

from inspect_validate import __version__
from inspect_validate.model.acquisition import Prediction

__all__ = ["render_frame", "write_rendered"]

BAND_GAP = 8  # pixels of dark background between class bands


def render_frame(
    p: Prediction, index, *, cameras, height: int = 480, width: int = 640, seed: int = 0
):
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
    k = len(p.classes)
    band_h = (height - BAND_GAP * (k + 1)) // k
    frame = np.full((height, width), cam.dark_offset, dtype=float)
    frame += cam.gain * rng.normal(0.0, cam.dark_noise, frame.shape)
    bands = {}
    rate = (
        (p.sample_mean[index] - cam.dark_offset) / cam.gain / t
    )  # e⁻/s per sample, unclipped below max
    for c, name in enumerate(p.classes):
        samples = np.flatnonzero(p.sample_class == c)
        y0 = BAND_GAP + c * (band_h + BAND_GAP)
        # The model's spectral variance is the unbiased (39) spread of the S
        # samples: widen their deviations by sqrt(S/(S−1)) so the frame has it.
        r = rate[samples]
        if r.size > 1:
            r = r.mean() + (r - r.mean()) * np.sqrt(r.size / (r.size - 1))
        pick = rng.integers(0, r.size, size=(band_h, width))
        electrons = rng.poisson(np.maximum(r[pick] * t, 0.0))
        frame[y0 : y0 + band_h] = cam.dark_offset + cam.gain * (
            electrons + rng.normal(0.0, cam.dark_noise, electrons.shape)
        )
        bands[name] = (0, y0, width, band_h)
    frame = np.clip(np.floor(frame + 0.5), 0, cam.max_dn).astype(np.uint16)
    return frame, bands


def write_rendered(
    p: Prediction, index, folder: Path, *, cameras, stem: str, seed: int = 0
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
