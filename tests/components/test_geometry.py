"""Reflection geometry (§2.2): closed forms, normalisation, reciprocity, and its use in scenes."""

import numpy as np
import pytest
from scipy import integrate

from inspect_validate.components.geometry import (
    beckmann,
    blinn_phong_specular,
    cook_torrance_specular,
    half_vector,
    lambert,
)
from inspect_validate.errors import InputError
from inspect_validate.scene import read_scene


def test_half_vector_is_the_corrected_13():
    h = half_vector([1, 0, 1], [-1, 0, 1])
    assert np.allclose(h, [0, 0, 1])
    assert np.allclose(half_vector([1, 0, 0], [0, 1, 0]), np.array([1, 1, 0]) / np.sqrt(2))


def test_lambert():
    assert lambert([0, 0, 1], [np.sin(np.pi / 3), 0, np.cos(np.pi / 3)]) == pytest.approx(0.5)
    assert lambert([0, 0, 1], [0, 0, -1]) == 0.0


def test_blinn_phong_peaks_in_the_mirror_direction():
    mirror = blinn_phong_specular([0, 0, 1], [1, 0, 1], [-1, 0, 1], ks=0.3, n=20)
    off = blinn_phong_specular([0, 0, 1], [1, 0, 1], [0, 0, 1], ks=0.3, n=20)
    assert mirror == pytest.approx(0.3) and off < mirror
    assert off == pytest.approx(0.3 * np.cos(np.pi / 8) ** 20)


def test_beckmann_is_normalised():
    for m in (0.1, 0.3, 0.7):
        total = integrate.quad(
            lambda t, m=m: beckmann(np.cos(t), m) * np.cos(t) * np.sin(t) * 2 * np.pi,
            0,
            np.pi / 2,
            epsabs=1e-13,
        )[0]
        assert total == pytest.approx(1.0, rel=1e-7)


def test_cook_torrance_reciprocity_and_normal_incidence():
    n = [0, 0, 1]
    light, view = [0.3, 0.1, 1.0], [-0.5, 0.2, 1.0]
    nl, nv = lambert(n, light), lambert(n, view)
    a = cook_torrance_specular(n, light, view, roughness=0.3, f0=0.04) / nl
    b = cook_torrance_specular(n, view, light, roughness=0.3, f0=0.04) / nv
    assert a == pytest.approx(b, rel=1e-12)  # the BRDF f_s is symmetric in L and V
    # L = V = N: D = 1/(π m²), F = f0, G = 1 → π·D·F/4 = f0 / (4 m²).
    assert cook_torrance_specular(n, n, n, roughness=0.3, f0=0.04) == pytest.approx(
        0.04 / (4 * 0.09)
    )
    assert cook_torrance_specular(n, [0, 0, -1], n, roughness=0.3, f0=0.04) == 0.0


def _scene(tmp_path, extra_class="", geometry=""):
    (tmp_path / "a.csv").write_text("400,0.5,0.52\n700,0.5,0.52\n")
    (tmp_path / "b.csv").write_text("400,0.3,0.31\n700,0.3,0.31\n")
    (tmp_path / "s.yaml").write_text(
        f"classes:\n  A: {{file: a.csv{extra_class}}}\n  B: {{file: b.csv}}\n"
        "lights: [{led: {peak: 550, fwhm: 30}}]\noptics: [ideal]\ncameras: [cmos-visible]\n"
        + geometry
    )
    return read_scene(tmp_path / "s.yaml")


def test_diffuse_scene_skips_geometry(tmp_path):
    sc = _scene(tmp_path)
    assert np.array_equal(sc.classes[0].reflectance.values, [[0.5, 0.5], [0.52, 0.52]])
    assert not sc.classes[0].reflectance.notes


def test_glossy_class_under_declared_geometry(tmp_path):
    geometry = "geometry: {light: [1, 0, 1], view: [-1, 0, 1]}\n"
    sc = _scene(tmp_path, ", gloss: {blinn_phong: {ks: 0.1, n: 10}}", geometry)
    a, b = (c.reflectance.values for c in sc.classes)
    cos = np.cos(np.pi / 4)
    assert np.allclose(a, np.array([[0.5, 0.5], [0.52, 0.52]]) * cos + 0.1)  # mirror: N·H = 1
    assert np.allclose(b, np.array([[0.3, 0.3], [0.31, 0.31]]) * cos)
    with pytest.raises(InputError, match=r"classes\.A: a glossy class needs the scene's geometry"):
        _scene(tmp_path, ", gloss: {cook_torrance: {roughness: 0.3}}")
    with pytest.raises(
        InputError, match=r"classes\.A\.gloss: gloss: give exactly one of blinn_phong"
    ):
        _scene(tmp_path, ", gloss: {phong: {}}", geometry)
