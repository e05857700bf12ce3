"""
Two stations that fail, and why
===============================

Two variants of the shipped simulated station. ``red_only.yaml`` lights the
paperboards with the red LED only: the classes' reflectances differ around
550–600 nm, where red emits nothing, so the separation check fails however well the
station agrees with its model. ``amber_drift.yaml`` simulates an amber LED emitting
6 nm longer than its datasheet says: the classes still separate, but not as the
spectra predict, and the agreement checks fail. A simulator rendered from the model
could only agree with it; this one renders a world that differs from the scene.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import inspect_validate as iv

stations = Path(iv.__file__).resolve().parents[1] / "sample_images" / "station"
results = {}
for name in ("red_only", "amber_drift"):
    out = Path(tempfile.mkdtemp()) / "frames"
    results[name] = iv.verify(stations / f"{name}.yaml", out=out)

# %%
# The verdicts and the checks that failed.
for name, result in results.items():
    failed = [c for c in result.checks if not c.passed]
    print(
        f"{name}: {'PASS' if result.passed else 'FAIL'}, {len(failed)} of {len(result.checks)} failed"
    )
    for check in failed[:6]:
        limit = f"{check.relation} {check.limit:g} {check.unit}".rstrip()
        print(f"  {check.name}: {check.value:.4g} (must be {limit})")

# %%
# The drifted amber LED: each comparison's SNR_dB (36), predicted from the datasheet's
# spectrum (calibrated) and measured. The calibration absorbs a common brightness; a
# shifted spectrum changes the classes' contrasts, which it cannot absorb.
rows = [r for r in results["amber_drift"].comparisons if r.illumination == "amber"]
x = np.arange(len(rows))
fig, ax = plt.subplots(figsize=(7, 3))
ax.bar(x - 0.2, [r.predicted.snr_db for r in rows], width=0.4, label="predicted")
ax.bar(x + 0.2, [r.measured.snr_db for r in rows], width=0.4, label="measured")
ax.set_xticks(x, [r.comparison for r in rows])
ax.set_ylabel("SNR_dB [dB]")
ax.axhline(0, color="0.4", lw=1)
ax.legend()
fig.tight_layout()
