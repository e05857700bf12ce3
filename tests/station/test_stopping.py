"""Sequential stopping of an illumination's frames: the stopping rule against closed-form
standard errors, and on the simulated station against captures of the full count."""

import json

import numpy as np
import pytest
from conftest import ROOT, copy_station

from inspect_validate.roi import ClassRoi, RoiSet
from inspect_validate.roi.shapes import Rect
from inspect_validate.station.stopping import SequentialStop

STATION = ROOT / "sample_images" / "station"


def two_classes():
    rect = lambda x: ((Rect(x, 0, 50, 40), "test"),)  # noqa: E731
    return RoiSet((ClassRoi("A", rect(0)), ClassRoi("B", rect(50))), "test")


def frames(rng, *, count, temporal_sd):
    """Frames of two 2000 px classes with fixed texture and fresh temporal noise, and a
    frame-wide flicker of 0.1 %: μ_k varies by the flicker and the mean noise."""
    texture = np.concatenate([rng.normal(1000, 30, (40, 50)), rng.normal(3000, 60, (40, 50))], 1)
    for _ in range(count):
        yield texture * (1 + 0.001 * rng.normal()) + rng.normal(0, temporal_sd, texture.shape)


def test_standard_errors_match_the_closed_form():
    # Frame k of a class: x = t (1 + f_k) + e, texture t fixed (sd s), flicker f_k (sd φ),
    # noise e (sd σ_t), n pixels. Per frame, μ_k varies by φ μ and σ_t/√n; σ²_k by the
    # flicker 2 φ s², the texture×noise cross term 2 s σ_t/√n and the noise's own sample
    # variance σ_t² √(2/n). Over k frames each standard error is that sd / √k.
    rng = np.random.default_rng(3)
    stop = SequentialStop(two_classes(), mean=1e-9, variance=1e-9, min_frames=3)
    for f in frames(rng, count=400, temporal_sd=20.0):
        assert not stop.add(f)
    known = stop.known()
    n, k, phi, sd_t = 2000, 400, 0.001, 20.0
    mu, s = np.array([1000.0, 3000.0]), np.array([30.0, 60.0])
    se_mu = np.sqrt((phi * mu) ** 2 + sd_t**2 / n) / np.sqrt(k) / mu
    sd_var = np.sqrt((2 * phi * s**2) ** 2 + (2 * s * sd_t) ** 2 / n + 2 * sd_t**4 / n)
    se_var = sd_var / np.sqrt(k) / (s**2 + sd_t**2)
    # An sd from 400 frames scatters by 3.5 % (1σ), the texture's realised s by ~2 %.
    assert known.frames == 400 and not known.reached
    assert known.mean == pytest.approx(se_mu.max(), rel=0.15)
    assert known.variance == pytest.approx(se_var.max(), rel=0.15)


def test_stops_where_the_precision_is_first_reached_and_not_before_min_frames():
    rng = np.random.default_rng(4)
    target = 1e-4  # relative SE of μ; class A's k* = (√(1 + 20²/2000) / 1000 / target)² = 120
    stop = SequentialStop(two_classes(), mean=target, variance=0.5, min_frames=3)
    stream = frames(rng, count=1000, temporal_sd=20.0)
    k = next(k for k, f in enumerate(stream, start=1) if stop.add(f))
    known = stop.known()
    assert known.reached and known.frames == k and known.mean <= target
    assert 60 <= k <= 240  # the sd's own scatter moves the stop around k*

    # A precision any two frames reach still takes min_frames.
    stop = SequentialStop(two_classes(), mean=0.5, variance=0.5, min_frames=5)
    counts = [stop.add(f) for f in frames(rng, count=5, temporal_sd=20.0)]
    assert counts == [False] * 4 + [True]


def capture(cli, tmp_path, name, **top):
    (tmp_path / name).mkdir()
    station = copy_station(tmp_path / name, **top)
    out = tmp_path / name / "cap"
    code, stdout, err = cli(["capture", station, "--out", out])
    assert code == 0, err
    return out, stdout


def measured(cli, out, tmp_path):
    doc = tmp_path / f"{out.parent.name}.json"
    args = [
        "measure",
        out / "amber",
        "--rois",
        STATION / "rois.yaml",
        "--kde",
        "never",
        "--json",
        doc,
    ]
    assert cli([str(a) for a in args])[0] == 0
    return {c["name"]: c for c in json.loads(doc.read_text())["classes"]}


def test_a_capture_that_stops_early_agrees_with_the_full_count(cli, tmp_path):
    precision = {"mean": 0.001, "variance": 0.01}
    out, stdout = capture(cli, tmp_path, "seq", frames=16, precision=precision)
    manifest = json.loads((out / "manifest.json").read_text())
    known = manifest["steps"]["amber"]["precision"]
    saved = len(list((out / "amber").glob("frame_*.tif")))
    # The simulated camera's noise gives σ² ±0.3 % at 16 frames: a 1 % target is met early.
    assert known["reached"] and known["frames"] == saved and 3 <= saved < 16
    assert "stopped early" in stdout and len(list((out / "dark").glob("frame_*.tif"))) == 4
    full, _ = capture(cli, tmp_path, "full", frames=16)
    a, b = measured(cli, out, tmp_path), measured(cli, full, tmp_path)
    for name in a:
        # Two independent captures, each within its standard error: 4√2 of the target.
        assert a[name]["mean"] == pytest.approx(b[name]["mean"], rel=4 * 2**0.5 * 0.001)
        assert a[name]["variance"] == pytest.approx(b[name]["variance"], rel=4 * 2**0.5 * 0.01)


def test_an_unreachable_precision_takes_the_most_frames_and_says_so(cli, tmp_path):
    out, stdout = capture(
        cli, tmp_path, "tight", frames=4, precision={"mean": 1e-7, "variance": 1e-6}
    )
    assert len(list((out / "red").glob("frame_*.tif"))) == 4
    assert "precision not reached" in stdout
    assert (
        json.loads((out / "manifest.json").read_text())["steps"]["red"]["precision"]["reached"]
        is False
    )


@pytest.mark.parametrize(
    "top, message",
    [
        ({"precision": {"mean": 0.01, "variance": 0.1}, "rois": None}, "needs 'rois'"),
        (
            {"precision": {"mean": 0.01, "variance": 0.1, "min_frames": 5}, "frames": 4},
            "min_frames",
        ),
        ({"precision": {"mean": 0, "variance": 0.1}}, "precision.mean"),
        ({"precision": {"mean": 0.01}}, "precision.variance"),
    ],
)
def test_bad_precision_is_refused_naming_the_field(cli, tmp_path, top, message):
    station = copy_station(tmp_path, **top)
    code, _, err = cli(["capture", station, "--out", tmp_path / "cap"])
    assert code == 2 and message in err and "station.yaml" in err
    assert not (tmp_path / "cap").exists()
