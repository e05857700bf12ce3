"""The verbs of ``import inspect_validate as iv``: each a few lines over the library
functions the commands use, importing them only when called (``import
inspect_validate`` stays cheap for the command line)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from inspect_validate.camera.station import Station
    from inspect_validate.measurement import Limits, Measurement
    from inspect_validate.mix_design.solve import Design
    from inspect_validate.model import Prediction, Ranking
    from inspect_validate.scene import Scene
    from inspect_validate.verification.golden import Golden
    from inspect_validate.verification.verify import Verification

__all__ = [
    "capture",
    "design",
    "design_mix",
    "measure",
    "predict",
    "read_rois",
    "read_scene",
    "read_station",
    "sweep",
    "train",
    "verify",
]


def read_scene(path: str | Path) -> Scene:
    """A scene file (lights, optics, cameras, object classes), validated.

    Raises
    ------
    InputError
        Naming the file and the field.

    Examples
    --------
    >>> import inspect_validate as iv
    >>> scene = iv.read_scene("sample_images/scenes/mix/scene.yaml")
    >>> [c.name for c in scene.classes]
    ['A', 'B', 'C']
    """
    from inspect_validate.scene import read_scene as read

    return read(path)


def read_station(path: str | Path) -> Station:
    """A station file (camera, controller, illuminations, acceptance), validated.

    Examples
    --------
    >>> import inspect_validate as iv
    >>> station = iv.read_station("sample_images/station/station.yaml")
    >>> [i.name for i in station.illuminations]
    ['amber', 'red']
    """
    from inspect_validate.camera.station import read_station as read

    return read(path)


def read_rois(path: str | Path):
    """An ROI file (YAML, ImageJ ``.roi`` or RoiSet ``.zip``): the classes' shapes."""
    from inspect_validate.roi import read_rois as read

    return read(path)


def _scene(scene) -> Scene:
    return scene if hasattr(scene, "lights") else read_scene(scene)


def _station(station) -> Station:
    return station if hasattr(station, "illuminations") else read_station(station)


def predict(scene: Scene | str | Path) -> Prediction:
    """Every light × optics × camera combination of a scene: each class's μ (DN) and
    σ² (DN²), and per comparison SNR_dB (36), CNR, Fisher ratio and ε Gauss (37).

    Arrays are indexed (light, optics, camera, …). A scene too large to hold every
    combination's arrays (above 2 GB) is refused: :func:`sweep` ranks it in blocks.

    Examples
    --------
    >>> import inspect_validate as iv
    >>> p = iv.predict("sample_images/scenes/mix/scene.yaml")
    >>> p.mean.shape  # 3 lights, 1 optics, 1 camera, 3 classes
    (3, 1, 1, 3)
    """
    return _scene(scene).predict()


def sweep(
    scene: Scene | str | Path,
    *,
    by: str | None = None,
    comparison: str | None = None,
    top: int = 10,
) -> Ranking:
    """The ``top`` combinations of a scene of any size, best first, as ``predict`` the
    command ranks them: ``by`` ``"error"`` (ε Gauss, lowest first), ``"snr_db"`` or
    ``"cnr_db"`` (highest first; default: the scene's ``rank.by``), of ``comparison``
    (``"A vs B,C"``; default: the scene's ``rank.comparison``, else the worst comparison
    of each combination).
    :func:`~inspect_validate.report.prediction.format_prediction` prints it as a table.

    Examples
    --------
    >>> import inspect_validate as iv
    >>> ranking = iv.sweep("sample_images/scenes/mix/scene.yaml", top=2)
    >>> ranking.index.shape  # (rows, (light, optics, camera))
    (2, 3)
    """
    return _scene(scene).sweep(by=by, comparison=comparison, top=top)


def measure(
    frames,
    rois,
    *,
    dark=(),
    comparisons=None,
    saturation_level: float | None = None,
    limits: Limits | None = None,
    kde: str = "auto",
) -> Measurement:
    """Each class's μ (DN) and σ² (DN²) in a stack of frames, and every comparison's
    SNR_dB (36), CNR, Fisher ratio and ε (37): what ``inspect-validate measure`` prints.

    Parameters
    ----------
    frames : path, sequence of paths, folder or glob
        Frames of one camera setting (TIFF, PNG, NPY; a capture step's folder).
    rois : path or RoiSet
    dark : sequence of paths, keyword-only
        Dark frames at the same exposure and gain.
    comparisons : ComparisonsSpec or Comparisons, keyword-only
        Default: every pair and each class against the rest, equal weights.
    saturation_level : float, keyword-only
        Raw value counted as saturated, DN (default: from the recorded bit depth).
    limits : Limits, keyword-only
        Saturated and zero fractions allowed.
    kde : {"auto", "always", "never"}, keyword-only

    Examples
    --------
    >>> import inspect_validate as iv
    >>> m = iv.measure("sample_images/paperboard/optimized.png",
    ...                "sample_images/paperboard/rois.yaml")
    >>> [round(c.mean, 2) for c in m.classes]
    [126.99, 111.41, 119.3]
    >>> round(m.comparison("A vs B").snr_db, 2)
    -14.56
    """
    from inspect_validate.measurement import Limits, measure_files

    return measure_files(
        frames,
        rois,
        dark=dark,
        comparisons=comparisons,
        saturation_level=saturation_level,
        limits=limits or Limits(),
        kde=kde,
    )


def capture(station: Station | str | Path, out: str | Path, *, resume: bool = False):
    """Capture a station's illuminations and darks into ``out`` (TIFF frames, sidecars,
    a manifest): what ``inspect-validate capture`` does, without a progress bar."""
    from inspect_validate.camera.capture import capture as run

    return run(_station(station), Path(out), resume=resume)


def verify(
    station: Station | str | Path,
    frames: str | Path | None = None,
    *,
    out: str | Path | None = None,
) -> Verification:
    """Verify a station: capture it into ``out`` (unless ``frames``, an earlier capture
    folder, is given), measure it and check the measurement against the prediction
    and the acceptance section. :attr:`Verification.passed` is the verdict.

    Examples
    --------
    >>> import inspect_validate as iv, tempfile
    >>> result = iv.verify("sample_images/station/station.yaml",
    ...                    out=tempfile.mkdtemp() + "/frames")
    >>> result.passed
    True
    """
    from inspect_validate.verification.verify import verify_station

    return verify_station(_station(station), frames=frames, out=out)


def train(station: Station | str | Path, captures) -> Golden:
    """The golden statistics of a known-good station from its capture folders (two or
    more independent captures give each value's spread)."""
    from inspect_validate.verification.golden import train as run

    return run(_station(station), [Path(c) for c in captures])


def design(
    source: str | Path,
    *,
    objective: str = "error",
    choose: int | None = None,
    auto_exposure: bool = False,
) -> Design:
    """The drive levels of a controller's channels (a station file's, or a scene's
    lights) that minimise the worst comparison's ε Gauss (``objective="cnr"``:
    maximise its CNR), no class saturating; with ``choose``, of the best ``choose``
    of them. What ``inspect-validate design`` prints.

    Examples
    --------
    >>> import inspect_validate as iv
    >>> d = iv.design("sample_images/scenes/mix/scene.yaml")
    >>> sorted(d.percent)  # channels in the mix: blue and red
    [1, 3]
    """
    from inspect_validate.mix_design.problem import design_problem
    from inspect_validate.mix_design.solve import solve

    problem = design_problem(source, auto_exposure=auto_exposure)
    return solve(problem, objective=objective, choose=choose)


design_mix = design
"""The same as :func:`design` (its name before the API was flat)."""
