"""
Verify the simulated station
============================

The shipped station: a simulated Gardasoft controller on a pseudo-terminal and a
simulated camera rendering the paperboards under the amber and red LEDs, with the
acquisition and EMVA 1288 noise models. ``iv.verify`` captures each illumination
and the darks, measures the classes, predicts the same numbers from the spectra and
checks them: ``result.passed`` is the verdict.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import inspect_validate as iv
from inspect_validate.images import read_image
from inspect_validate.roi import class_masks

station_file = Path(iv.__file__).resolve().parents[1] / "sample_images" / "station" / "station.yaml"
out = Path(tempfile.mkdtemp()) / "frames"
result = iv.verify(station_file, out=out)

# %%
# The checks: each a measured value against its limit, and a verdict.
for check in result.checks:
    limit = f"{check.relation} {check.limit:g} {check.unit}".rstrip()
    print(f"{check.verdict:5s} {check.name}: {check.value:.4g} (must be {limit}) {check.detail}")
print("passed:", result.passed)

# %%
# One captured amber frame, with the station's regions.
frame = read_image(sorted((out / "amber").glob("frame_*.tif"))[0])
masks = class_masks(result.rois, frame.shape)
fig, ax = plt.subplots(figsize=(5, 4))
ax.imshow(frame, cmap="gray")
for name, mask in masks.items():
    ax.contour(mask, levels=[0.5], colors="yellow", linewidths=1)
    ys, xs = mask.nonzero()
    ax.text(xs.mean(), ys.mean(), name, color="yellow", ha="center", va="center")
ax.set_axis_off()
fig.tight_layout()
