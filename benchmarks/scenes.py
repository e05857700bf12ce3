"""Scenes the benchmarks share beyond the shipped ones."""

from __future__ import annotations

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "sample_images" / "scenes"


def twelve_bit_scene(folder: Path) -> Path:
    """The paperboard scene on a 12-bit monochrome camera (K 0.1 DN/e⁻, 30,000 e⁻ full
    well, dark offset 20 DN), written into ``folder``; a station on it sets
    ``pixel_format: Mono12``."""
    scene = yaml.safe_load((SCENES / "paperboard" / "scene.yaml").read_text())
    for c in scene["classes"].values():
        c["file"] = str(SCENES / "paperboard" / c["file"])
    scene["cameras"][0].update(
        file=str(SCENES / "chapter_table2" / "camera1_qe.csv"),
        name="mono 12-bit",
        gain=0.1,
        saturation=30000,
        bit_depth=12,
        dark_offset=20,
    )
    path = folder / "scene12.yaml"
    path.write_text(yaml.safe_dump(scene))
    return path
