"""Generate the example scenes for ``inspect-validate predict`` (deterministic).

``chapter_table2/``: the chapter's simulated study (§4.1, Table 2): daylight and an
LED, two optics, two cameras whose efficiency peaks at 500 and 670 nm, two
objects of three spectra each. Object 1 reflects more in the red, object 2 more
in the blue: under broadband daylight the two cancel to a degree that depends on
how optics and camera weight the spectrum (errors from a few % to ~40 %), while
a blue LED sees the difference directly (small, nearly constant error) — the
pattern of Table 2. The chapter's own spectra are not published.

``paperboard/``: three paperboards with 20 reflectance spectra each, A differing
from B and C around 575 nm but not at 630 nm (chapter §4.2, Fig. 21), under an
amber and a red LED: the prediction ranks amber above red.

``mix/``: three printed inks, A brighter than B around 465 nm, C brighter than B
around 635 nm, under a blue, a green and a red LED on one controller. Blue
alone cannot tell B from C, red alone cannot tell A from B, and an equal mix of
the two makes A look like C: only an unequal mix separates all three (the
example of ``inspect-validate design``).

Run ``python sample_images/scenes/generate.py`` to rewrite the files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
GRID = np.arange(380.0, 781.0, 5.0)


def sigmoid(x):
    return 1.0 / (1.0 + np.exp(-x))


def write_csv(path: Path, grid, columns, names):
    rows = ["wavelength_nm," + ",".join(names)]
    rows += [
        f"{w:g}," + ",".join(f"{v:.6f}" for v in vals)
        for w, vals in zip(grid, np.asarray(columns).T, strict=True)
    ]
    path.write_text("\n".join(rows) + "\n")


def write_samples(out: Path, curves: dict, rng, *, gain: float, noise: float) -> None:
    """20 spectrometer readings per class: its curve × a random gain (sd ``gain``) plus
    white noise (sd ``noise``), each class to ``<name>.csv``."""
    for name, curve in curves.items():
        samples = [
            curve * (1 + rng.normal(0, gain)) + rng.normal(0, noise, GRID.size) for _ in range(20)
        ]
        write_csv(out / f"{name}.csv", GRID, samples, [f"r{i + 1}" for i in range(20)])


def chapter_table2(rng):
    out = HERE / "chapter_table2"
    out.mkdir(exist_ok=True)
    g = GRID
    step = sigmoid((g - 560.0) / 30.0)
    obj1 = 0.42 + 0.22 * step
    obj2 = 0.66 - 0.22 * step
    # Three spectra per object, ±4.5 % in brightness: the class's spectral spread.
    for name, base in (("object1", obj1), ("object2", obj2)):
        samples = [base * (1 + a) + rng.normal(0, 0.002, g.size) for a in (-0.045, 0.0, 0.045)]
        write_csv(out / f"{name}.csv", g, samples, ["s1", "s2", "s3"])
    # Optics 1 favours the blue end, optics 2 the red end; the "mixed" pairings
    # with the cameras balance the two objects under daylight.
    write_csv(out / "optics1.csv", g, [0.95 - 0.7 * sigmoid((g - 600) / 40)], ["t"])
    write_csv(out / "optics2.csv", g, [0.25 + 0.7 * sigmoid((g - 520) / 40)], ["t"])
    for name, peak in (("camera1", 500.0), ("camera2", 670.0)):
        write_csv(
            out / f"{name}_qe.csv", g, [0.6 * np.exp(-0.5 * ((g - peak) / 120.0) ** 2)], ["qe"]
        )
    (out / "scene.yaml").write_text(
        "# The chapter's simulated study (Table 2): 2 lights x 2 optics x 2 cameras.\n"
        "name: chapter Table 2\n"
        "wavelength: {start: 380, stop: 780, step: 1}\n"
        "classes:\n  object1: {file: object1.csv}\n  object2: {file: object2.csv}\n"
        "lights:\n  - {cie: D65, name: daylight}\n  - {led: {peak: 450, fwhm: 20}, name: LED}\n"
        "optics:\n  - {file: optics1.csv, name: optics 1}\n  - {file: optics2.csv, name: optics 2}\n"
        "cameras:\n"
        "  - {file: camera1_qe.csv, name: camera 1, gain: 0.06, dark_noise: 10, saturation: 4000, bit_depth: 8}\n"
        "  - {file: camera2_qe.csv, name: camera 2, gain: 0.06, dark_noise: 10, saturation: 4000, bit_depth: 8}\n"
        "exposure: {mode: auto, target: 0.7}\n"
    )


def paperboard(rng):
    out = HERE / "paperboard"
    out.mkdir(exist_ok=True)
    g = GRID
    base = 0.55 + 0.15 * sigmoid((g - 450) / 30) - 0.05 * sigmoid((g - 650) / 40)
    bumps = {"A": 0.07, "B": -0.02, "C": 0.015}
    curves = {name: base + b * np.exp(-0.5 * ((g - 575) / 18) ** 2) for name, b in bumps.items()}
    write_samples(out, curves, rng, gain=0.008, noise=0.003)
    (out / "scene.yaml").write_text(
        "# Paperboards A, B, C (chapter 4.2): which LED separates A from B and C?\n"
        "name: paperboard\n"
        "wavelength: {start: 380, stop: 780, step: 1}\n"
        "classes:\n  A: {file: A.csv}\n  B: {file: B.csv}\n  C: {file: C.csv}\n"
        "lights:\n  - {led: {peak: 590, fwhm: 15}, name: amber LED}\n  - {led: {peak: 630, fwhm: 18}, name: red LED}\n"
        "optics:\n  - {lens: visible}\n"
        "cameras:\n  - {file: ../chapter_table2/camera1_qe.csv, name: mono 8-bit, gain: 0.0255, dark_noise: 12, saturation: 10000, bit_depth: 8, dark_offset: 4}\n"
        "exposure: {mode: auto, target: 0.5}\n"
        'rank: {by: error, comparison: "A vs B,C"}\n'
    )


def mix(rng):
    out = HERE / "mix"
    out.mkdir(exist_ok=True)
    g = GRID
    base = 0.40 + 0.10 * sigmoid((g - 520) / 40)
    bumps = {"A": (465.0, 0.08), "B": (550.0, 0.0), "C": (635.0, 0.08)}
    curves = {
        name: base + height * np.exp(-0.5 * ((g - centre) / 22) ** 2)
        for name, (centre, height) in bumps.items()
    }
    write_samples(out, curves, rng, gain=0.004, noise=0.002)
    (out / "scene.yaml").write_text(
        "# Three inks under a blue, a green and a red LED: no single LED separates all three.\n"
        "name: inks\n"
        "wavelength: {start: 380, stop: 780, step: 1}\n"
        "classes:\n  A: {file: A.csv}\n  B: {file: B.csv}\n  C: {file: C.csv}\n"
        "lights:\n"
        "  - {led: {peak: 465, fwhm: 20}, name: blue LED, irradiance: 2.0}\n"
        "  - {led: {peak: 530, fwhm: 30}, name: green LED, irradiance: 2.0}\n"
        "  - {led: {peak: 635, fwhm: 18}, name: red LED, irradiance: 2.0}\n"
        "optics:\n  - {lens: visible}\n"
        "cameras:\n  - {file: ../chapter_table2/camera1_qe.csv, name: mono 12-bit, gain: 0.1, "
        "dark_noise: 12, saturation: 30000, bit_depth: 12, dark_offset: 20}\n"
        "exposure: {mode: fixed, time: 0.04}\n"
        "rank: {by: error}\n"
    )


def main():
    rng = np.random.default_rng(2012)
    chapter_table2(rng)
    paperboard(rng)
    mix(np.random.default_rng(465))


if __name__ == "__main__":
    main()
