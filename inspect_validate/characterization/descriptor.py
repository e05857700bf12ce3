"""The series as an EMVA 1288 descriptor file, which the ``emva1288`` package reads.

Lines (the package's parser; ``#`` starts a comment): ``v 3.0``; ``n BITS WIDTH
HEIGHT``; ``b EXPOSURE PHOTONS`` followed by its ``i FILE`` lines (two: a temporal
pair; more: a spatial stack); ``d EXPOSURE`` and its files likewise. Exposures are
in ns. The photons per pixel are not known here (the irradiance at the sensor is
not measured): they are written as the electrons the series' linear fit gives, i.e.
at a quantum efficiency of 100 %, so the package's QE and responsivity are relative
while its K, dark noise, saturation, DSNU and PRNU are the camera's.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from inspect_validate.characterization.analysis import Characterization
    from inspect_validate.characterization.series import Plan

__all__ = ["DESCRIPTOR_FILE", "write_descriptor"]

DESCRIPTOR_FILE = "emva1288_descriptor.txt"


def write_descriptor(
    out: Path, plan: Plan, result: Characterization, *, width: int, height: int
) -> Path:
    """Write ``out/emva1288_descriptor.txt`` for the series captured in ``out``."""
    from inspect_validate.files import atomic_write

    def files(step):
        return [
            f"i {p.relative_to(out).as_posix()}" for p in sorted((out / step).glob("frame_*.tif"))
        ]

    def photons(exposure, level):
        return result.responsivity * (exposure if plan.varies == "exposure" else 100 * level)

    lines = [
        "# inspect-validate characterize: photons written at a QE of 100 % (relative)",
        "v 3.0",
        f"n {plan.bits} {width} {height}",
    ]
    for i, (t, level) in enumerate(zip(plan.exposure_us, plan.level, strict=True)):
        lines += [f"b {t * 1e3:.1f} {photons(t, level):.6g}", *files(f"b_{i:03d}")]
    spatial = photons(plan.spatial_exposure_us, plan.spatial_level)
    lines += [f"b {plan.spatial_exposure_us * 1e3:.1f} {spatial:.6g}", *files("b_spatial")]
    seen = set()
    for i, t in enumerate(plan.exposure_us):
        if t in seen:  # one dark pair per exposure in the format
            continue
        seen.add(t)
        lines += [f"d {t * 1e3:.1f}", *files(f"d_{i:03d}")]
    lines += [f"d {plan.spatial_exposure_us * 1e3:.1f}", *files("d_spatial")]
    return atomic_write(out / DESCRIPTOR_FILE, ("\n".join(lines) + "\n").encode())
