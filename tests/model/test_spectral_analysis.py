"""Per-wavelength errors, plots, and the render → measure loop against the prediction."""

import json

import numpy as np
import pytest
from conftest import ROOT, run_cli

from inspect_validate.errors import InputError
from inspect_validate.model import ObjectClass, analyse_spectra
from inspect_validate.scene import read_scene
from inspect_validate.spectra import Spectrum
from inspect_validate.stats import gaussian_error


def test_per_wavelength_gaussian_error_is_the_closed_form():
    g = np.array([500.0, 550.0, 600.0])
    a = np.array([[0.50, 0.60, 0.4], [0.52, 0.62, 0.41], [0.51, 0.58, 0.42]])
    b = np.array([[0.50, 0.40, 0.4], [0.49, 0.43, 0.45], [0.52, 0.41, 0.43]])
    sep = analyse_spectra(
        [
            ObjectClass("A", Spectrum(g, a, "reflectance", "A", "a")),
            ObjectClass("B", Spectrum(g, b, "reflectance", "B", "b")),
        ],
        kde=False,
    )
    expected = gaussian_error(a.mean(0), a.var(0, ddof=1), b.mean(0), b.var(0, ddof=1))
    assert np.allclose(sep.error_gaussian[0], expected, rtol=1e-14)
    assert np.argmin(sep.error_gaussian[0]) == 1
    with pytest.raises(InputError, match="one spectrum"):
        analyse_spectra(
            [
                ObjectClass("A", Spectrum(g, a[0], "reflectance", "A", "a")),
                ObjectClass("B", Spectrum(g, b, "reflectance", "B", "b")),
            ]
        )


@pytest.mark.parametrize("scale", [1e-300, 1e-5])
def test_spreads_below_the_resolution_agree_between_gauss_and_kde(scale):
    """Reflectances far below the measurement's resolution (1e-3): the Gaussian ε takes
    the resolution as its spread floor, as the KDE's bandwidth does, so both say the
    classes cannot be told apart (it was ε Gauss 0 beside ε KDE ½)."""
    g = np.array([500.0, 550.0])
    a = np.array([[1.0, 1.1], [1.1, 1.2], [0.9, 1.0]]) * scale
    b = np.array([[1.2, 1.3], [1.25, 1.35], [1.3, 1.2]]) * scale
    sep = analyse_spectra(
        [
            ObjectClass("A", Spectrum(g, a, "reflectance", "A", "a")),
            ObjectClass("B", Spectrum(g, b, "reflectance", "B", "b")),
        ],
    )
    assert np.allclose(sep.error_gaussian, 0.5, atol=1e-3)
    assert np.allclose(sep.error_kde, 0.5, atol=1e-3)


def test_analyze_spectra_cli_finds_the_amber_band(tmp_path, capsys):
    from conftest import ROOT

    out, png = tmp_path / "s.json", tmp_path / "plots" / "spectral_error.png"
    assert (
        run_cli(
            [
                "analyze-spectra",
                ROOT / "sample_images/scenes/paperboard/scene.yaml",
                "--json",
                out,
                "--plot",
                png.parent,
                "--plot-format",
                "png",
            ]
        )
        == 0
    )
    doc = json.loads(out.read_text())
    comp = next(c for c in doc["comparisons"] if c["first"] == ["A"] and c["second"] == ["B", "C"])
    eps = np.array(comp["error_gaussian"], dtype=float)
    best = doc["wavelength_nm"][int(np.nanargmin(eps))]
    assert 560 <= best <= 590  # the amber band, not the red one
    assert eps[doc["wavelength_nm"].index(630)] > 0.3
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "A vs B,C" in capsys.readouterr().out


def test_predict_plots_and_render_round_trip(tmp_path):
    """Frames rendered from a prediction, measured with `measure`, give back the predicted μ and σ²."""
    from conftest import ROOT

    scene = ROOT / "sample_images/scenes/chapter_table2/scene.yaml"
    pred = tmp_path / "p.json"
    assert (
        run_cli(
            [
                "predict",
                scene,
                "--kde",
                "never",
                "--plot",
                tmp_path / "plots",
                "--plot-format",
                "png",
                "--render",
                tmp_path / "frames",
                "--json",
                pred,
            ]
        )
        == 0
    )
    for name in ("spectra.png", "spectral_error.png", "ranking.png"):
        assert (tmp_path / "plots" / name).stat().st_size > 10_000
    import tifffile

    for stem in ("best", "worst"):
        tif = tmp_path / "frames" / f"{stem}.tif"
        predicted = json.loads(tifffile.TiffFile(tif).pages[0].description)["predicted"]
        assert tifffile.imread(tif).dtype == np.uint16
        out = tmp_path / f"{stem}.json"
        assert (
            run_cli(
                [
                    "measure",
                    tif,
                    "--rois",
                    tmp_path / "frames" / f"{stem}_rois.yaml",
                    "--kde",
                    "never",
                    "--json",
                    out,
                ]
            )
            == 0
        )
        for c in json.loads(out.read_text())["classes"]:
            p = predicted[c["name"]]
            n = c["n_pixels"]
            # 5 standard errors of a sample mean and variance of n pixels (plus
            # the spread of which reflectance sample each pixel drew).
            assert c["mean"] == pytest.approx(p["mean"], abs=5 * np.sqrt(p["variance"] / n) + 0.05)
            assert c["variance"] == pytest.approx(p["variance"], rel=0.03)


@pytest.mark.parametrize("by", ["error", "snr_db"])
def test_ranking_plot_shows_what_the_table_ranks_by(monkeypatch, by):
    """ranking.png's bars are each row's key comparison's value — the number the table
    ranks by — not the worst listed comparison's, each written at its bar."""
    from inspect_validate.report import plots

    rows = [
        {
            "rank": i + 1,
            "light": f"L{i}",
            "optics": "o",
            "camera": "c",
            "key_comparison": 1,
            "comparisons": [
                {"first": ["A"], "second": ["B"], "error_gaussian": 0.4, "snr_db": -30.0},
                {"first": ["A"], "second": ["B", "C"], "error_gaussian": e, "snr_db": s},
            ],
        }
        for i, (e, s) in enumerate([(0.01, -3.0), (0.02, -5.0), (0.05, -9.0)])
    ]
    shown = {}
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: shown.setdefault("fig", fig))
    plots.plot_ranked_separation(rows, "unused.png", by=by)
    ax = shown["fig"].axes[0]
    widths = [bar.get_width() for bar in ax.patches]
    key = "error_gaussian" if by == "error" else "snr_db"
    assert widths == [r["comparisons"][1][key] for r in rows]
    assert "A vs B,C" in ax.get_xlabel() and len(ax.texts) == 3


def test_spectral_error_plot_says_where_it_is_floored(monkeypatch):
    """ε below the log axis's 1e-16 floor is drawn on it with a word saying so, and the
    lights' labels sit above the plot, not over the curves."""
    from inspect_validate.model import analyse_spectra
    from inspect_validate.report import plots
    from inspect_validate.scene import read_scene

    scene = read_scene(ROOT / "sample_images" / "scenes" / "mix" / "scene.yaml")
    sep = analyse_spectra(list(scene.classes), kde=False, comparisons=scene.comparisons)
    assert np.nanmin(sep.error_gaussian) < 1e-16  # the inks separate completely somewhere
    shown = {}
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: shown.setdefault("fig", fig))
    plots.plot_spectral_errors(sep, "unused.png", marked={"blue LED": 465})
    texts = {t.get_text(): t for t in shown["fig"].axes[0].texts}
    assert any("complete separation" in t for t in texts)
    assert texts["blue LED"].get_verticalalignment() == "bottom"  # above the axes' top


def _charts(page: str) -> list[dict]:
    """The chart specs a page carries (each ``<div class="chart">``'s JSON)."""
    import re

    return [
        json.loads(m) for m in re.findall(r'<script type="application/json">(.*?)</script>', page)
    ]


def test_plot_writes_one_page_of_charts_without_matplotlib(tmp_path):
    """predict --plot and analyze-spectra --plot write one HTML page of the reports'
    browser-drawn charts by default; matplotlib is not imported (its PNGs cost 89 % of
    predict --plot's run, benchmarks/bench_report.py)."""
    import subprocess
    import sys

    from conftest import ROOT

    scene = ROOT / "sample_images/scenes/paperboard/scene.yaml"
    code = (
        "import sys; from inspect_validate.cli import main\n"
        "try:\n    main(sys.argv[1:])\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
        "print('matplotlib' in sys.modules)"
    )
    for command, page in (
        ("predict", "prediction.html"),
        ("analyze-spectra", "spectral_error.html"),
    ):
        folder = tmp_path / command
        done = subprocess.run(
            [sys.executable, "-c", code, command, str(scene), "--plot", str(folder)],
            capture_output=True,
            text=True,
        )
        assert done.returncode == 0, done.stderr
        assert done.stdout.strip().splitlines()[-1] == "False"
        assert sorted(p.name for p in folder.iterdir()) == [page]
        titles = [c["title"] for c in _charts((folder / page).read_text())]
        assert any(t.startswith("ε_tot per wavelength, parametric") for t in titles), titles
        if command == "predict":
            assert {"lights", "object reflectance", "optics transmission", "camera QE"} <= set(
                titles
            )
            assert "Ranking by ε Gauss" in (folder / page).read_text()


def test_every_wavelength_at_once_is_each_wavelength_alone():
    """The batched ε KDE (LSCV bandwidths of all columns at once, one grid a wavelength
    for every comparison) against the one-wavelength path (lscv_bandwidth and
    kde_separation at each wavelength), to 1e-12 relative, on the paperboards' 81
    wavelengths and six comparisons (ε from 2.5e-81 to 0.48)."""
    from inspect_validate.separations import kde_separation

    scene = read_scene(ROOT / "sample_images/scenes/paperboard/scene.yaml")
    classes = list(scene.classes)
    sep = analyse_spectra(classes, kde=True, comparisons=scene.comparisons)
    values = [c.reflectance.resample(sep.wavelengths) for c in classes]
    want = np.array(
        [
            kde_separation([v[:, j] for v in values], scene.comparisons, quantum=1e-3).error
            for j in range(sep.wavelengths.size)
        ]
    ).T
    assert want.min() < 1e-60  # the far reach's rows are among them
    np.testing.assert_allclose(sep.error_kde, want, rtol=1e-12, atol=0)
