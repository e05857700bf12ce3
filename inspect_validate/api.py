"""The verbs of ``import inspect_validate as iv``: each a few lines over the library
functions the commands use, importing them only when called (``import
inspect_validate`` stays cheap for the command line)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Literal, overload

if TYPE_CHECKING:
    from collections.abc import Iterable

    from inspect_validate.camera.capture import CaptureResult
    from inspect_validate.comparisons import Comparisons, RankBy
    from inspect_validate.images import FramePaths
    from inspect_validate.measurement import KdeMode, Limits, Measurement
    from inspect_validate.mix_design.solve import Design
    from inspect_validate.model import Prediction, Ranking
    from inspect_validate.roi.roiset import RoiSet
    from inspect_validate.scene import Scene
    from inspect_validate.scene_file import ComparisonsSpec
    from inspect_validate.station.file import Station
    from inspect_validate.verification.golden import Golden
    from inspect_validate.verification.production import ProductionVerification
    from inspect_validate.verification.results import Verification

__all__ = [
    "capture",
    "design",
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

    Parameters
    ----------
    path : str or Path
        The scene file (YAML); the files it names are relative to it.

    Returns
    -------
    Scene
        Its components ready to predict: ``classes`` (reflectance samples),
        ``lights``, ``optics``, ``cameras``, the wavelength ``grid`` (nm), the
        ``comparisons`` and how it ranks (``rank_by``, ``rank_comparison``).

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

    Parameters
    ----------
    path : str or Path
        The station file (YAML); the scene, ROI and camera files it names are relative
        to it.

    Returns
    -------
    Station
        The validated, frozen model (the manual's "Station files" lists every key).

    Raises
    ------
    InputError
        Naming the file and the field.

    Examples
    --------
    >>> import inspect_validate as iv
    >>> station = iv.read_station("sample_images/station/station.yaml")
    >>> [i.name for i in station.illuminations]
    ['amber', 'red']
    """
    from inspect_validate.station.file import read_station as read

    return read(path)


def read_rois(path: str | Path) -> RoiSet:
    """An ROI file (YAML, ImageJ ``.roi`` or RoiSet ``.zip``): the classes' shapes.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    RoiSet
        Each class's name and shapes (pixels, origin at the top-left corner).

    Examples
    --------
    >>> import inspect_validate as iv
    >>> [c.name for c in iv.read_rois("sample_images/paperboard/rois.yaml").classes]
    ['A', 'B', 'C']
    """
    from inspect_validate.roi import read_rois as read

    return read(path)


def _scene(scene) -> Scene:
    return scene if hasattr(scene, "lights") else read_scene(scene)


def _station(station) -> Station:
    return station if hasattr(station, "illuminations") else read_station(station)


def predict(scene: Scene | str | Path) -> Prediction:
    """Every light × optics × camera combination of a scene: each class's μ (DN) and
    σ² (DN²), and per comparison SNR_dB (36), CNR, Fisher ratio and ε Gauss (37).

    Parameters
    ----------
    scene : Scene, str or Path
        A scene, or its file.

    Returns
    -------
    Prediction
        Arrays indexed (light, optics, camera, …): ``mean`` (DN) and ``variance``
        (DN²) of shape (L, O, C, K) for K classes; ``snr_db``, ``cnr_db``,
        ``error_gaussian`` (a fraction) of shape (L, O, C, P) for the P comparisons
        of ``comparison_set``; ``exposure_time`` (s) of shape (L, O, C).

    Raises
    ------
    InputError
        A scene too large to hold every combination's arrays (above 2 GB): :func:`sweep`
        ranks it in blocks.

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
    by: RankBy | None = None,
    comparison: str | None = None,
    top: int = 10,
) -> Ranking:
    """The ``top`` combinations of a scene of any size, best first, as ``predict`` the
    command ranks them: ``by`` ``"error"`` (ε Gauss, lowest first), ``"snr_db"`` or
    ``"cnr_db"`` (highest first; default: the scene's ``rank.by``), of ``comparison``
    (``"A vs B,C"``; default: the scene's ``rank.comparison``, else the worst comparison
    of each combination).
    :func:`~inspect_validate.report.prediction.format_prediction` prints it as a table.

    Parameters
    ----------
    scene : Scene, str or Path
    by : {"error", "snr_db", "cnr_db"}, keyword-only, optional
    comparison : str, keyword-only, optional
    top : int, keyword-only
        Rows kept.

    Returns
    -------
    Ranking
        ``index`` (top, 3): each row's (light, optics, camera); the rows' ``mean``,
        ``variance``, ``snr_db``, ``error_gaussian``…; ``key`` the ranked value.

    Examples
    --------
    >>> import inspect_validate as iv
    >>> ranking = iv.sweep("sample_images/scenes/mix/scene.yaml", top=2)
    >>> ranking.index.shape  # (rows, (light, optics, camera))
    (2, 3)
    """
    return _scene(scene).sweep(by=by, comparison=comparison, top=top)


def measure(
    frames: FramePaths,
    rois: str | Path | RoiSet,
    *,
    dark: FramePaths = (),
    comparisons: Comparisons | ComparisonsSpec | None = None,
    saturation_level: float | None = None,
    limits: Limits | None = None,
    kde: KdeMode = "auto",
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
        ε KDE for every comparison, none, or (``auto``) where the Gaussians do not fit.

    Returns
    -------
    Measurement
        ``classes`` (μ in DN, σ² in DN², their temporal and spatial parts, pixel counts,
        saturated and zero fractions), ``comparisons`` (SNR_dB, CNR, Fisher, ε Gauss,
        ε counted, ε KDE where computed), ``skipped``, ``warnings``, ``violations``.

    Raises
    ------
    InputError
        An unreadable frame or ROI file, an ROI outside the frame, frames of different
        sizes or settings (each message names the file).

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


def capture(
    station: Station | str | Path,
    out: str | Path,
    *,
    resume: bool = False,
    production: bool = False,
    parts: int | None = None,
) -> CaptureResult:
    """Capture a station's illuminations and darks into ``out`` (TIFF frames, sidecars,
    a manifest): what ``inspect-validate capture`` does, without a progress bar.

    Parameters
    ----------
    station : Station, str or Path
    out : str or Path
        The capture folder (the manual's "Capture folders").
    resume : bool, keyword-only
        Continue an interrupted capture in ``out``: complete steps are kept.
    production : bool, keyword-only
        The running line instead: ``parts`` frames (default ``production.parts``), each
        of another part, under the production illumination (``capture --production``).
    parts : int, keyword-only, optional

    Returns
    -------
    CaptureResult
        ``folder``, ``steps`` (frames saved per step), ``skipped`` (steps already
        complete), ``not_applied`` (settings the camera lacks), ``warnings``.

    Raises
    ------
    DeviceError
        The camera or the controller failed; the frames saved so far are kept.

    Examples
    --------
    >>> import inspect_validate as iv, tempfile
    >>> result = iv.capture("sample_images/station/station.yaml", tempfile.mkdtemp() + "/c")
    >>> sorted(result.steps)
    ['amber', 'dark', 'red']
    >>> result.steps["amber"]
    4
    """
    from inspect_validate.station.capture import capture as run
    from inspect_validate.station.capture import production_steps

    st = _station(station)
    steps = production_steps(st, parts=parts) if production else None
    return run(st, Path(out), resume=resume, steps=steps)


@overload
def verify(
    station: Station | str | Path,
    frames: str | Path | None = None,
    *,
    out: str | Path | None = None,
    all_illuminations: bool = False,
    production: Literal[False] = False,
    golden: Golden | str | Path | None = None,
) -> Verification: ...


@overload
def verify(
    station: Station | str | Path,
    frames: str | Path | None = None,
    *,
    out: str | Path | None = None,
    all_illuminations: bool = False,
    production: Literal[True],
    golden: Golden | str | Path | None = None,
) -> ProductionVerification: ...


def verify(
    station: Station | str | Path,
    frames: str | Path | None = None,
    *,
    out: str | Path | None = None,
    all_illuminations: bool = False,
    production: bool = False,
    golden: Golden | str | Path | None = None,
) -> Verification | ProductionVerification:
    """Verify a station: capture it into ``out`` (unless ``frames``, an earlier capture
    folder, is given), measure it and check the measurement against the prediction
    and the acceptance section. :attr:`Verification.passed <inspect_validate.verification.results.Verification.passed>` is the verdict. As
    ``inspect-validate verify``: illuminations no check needs and the prediction shows
    clearly worse are not captured unless the measurement contradicts it.

    With ``production=True``, the running line instead (``verify --production``): the
    parts in ``frames``, a folder of production frames, each located and measured, and
    their means checked against ``golden``'s good parts.

    Parameters
    ----------
    station : Station, str or Path
    frames : str or Path, optional
        An earlier capture folder of this station to verify instead of capturing (with
        ``production``: the folder of production frames, required).
    out : str or Path, keyword-only, optional
        Where to capture (default: a new folder in the working directory).
    all_illuminations : bool, keyword-only
        Capture every illumination (``verify --all-illuminations``).
    production : bool, keyword-only
    golden : Golden, str or Path, keyword-only, optional
        With ``production``: the golden parts (:func:`train` with ``production=True``,
        or its file; default the station's ``acceptance.drift.golden``).

    Returns
    -------
    Verification or ProductionVerification
        ``checks`` (each with value, limit, unit, verdict, detail), ``passed``, the
        ``measurements``, the calibrated ``prediction``, the predicted-against-measured
        ``classes`` and ``comparisons``, the ``ranking``, ``skipped`` and ``notes``;
        on the line the ``checks``, ``passed``, the ``parts`` and the likely ``cause``.

    Examples
    --------
    >>> import inspect_validate as iv, tempfile
    >>> result = iv.verify("sample_images/station/station.yaml",
    ...                    out=tempfile.mkdtemp() + "/frames")
    >>> result.passed
    True
    """
    from inspect_validate.verification.verify import verify_station

    if production:
        return _verify_line(_station(station), frames, golden)
    return verify_station(
        _station(station),
        frames=None if frames is None else Path(frames),
        out=None if out is None else Path(out),
        skip_dominated=not all_illuminations,
    )


def train(
    station: Station | str | Path,
    captures: Iterable[str | Path] | str | Path,
    *,
    production: bool = False,
) -> Golden:
    """The golden statistics of a known-good station from its capture folders (two or
    more independent captures give each value's spread), or with ``production=True``
    of the good parts in one folder of production frames (``train --production``: the
    parts' spread is the one a production verdict allows).

    Parameters
    ----------
    station : Station, str or Path
    captures : sequence of str or Path, or (with ``production``) str or Path
        Capture folders of the station in its known-good state; on the line, the
        folder of frames of good parts.
    production : bool, keyword-only

    Returns
    -------
    Golden
        Per illumination, each class's μ and σ² and each comparison's SNR_dB and ε, as
        spreads over the captures; ``document()`` is the golden file's JSON.

    Examples
    --------
    >>> import inspect_validate as iv, tempfile
    >>> station = "sample_images/station/station.yaml"
    >>> folders = [iv.capture(station, tempfile.mkdtemp() + "/c").folder for _ in range(2)]
    >>> golden = iv.train(station, folders)
    >>> golden.repeats, sorted(golden.illuminations)
    (2, ['amber', 'red'])
    """
    from inspect_validate.verification.golden import train as run

    if production:
        from inspect_validate.verification.parts_golden import train_production

        if not isinstance(captures, str | Path):
            raise TypeError("train(..., production=True) takes one folder of frames")
        return train_production(_station(station), Path(captures))
    if isinstance(captures, str | Path):
        raise TypeError("train takes a sequence of capture folders (two or more)")
    return run(_station(station), [Path(c) for c in captures])


def _verify_line(st: Station, frames, golden) -> ProductionVerification:
    """:func:`verify` of the running line."""
    from inspect_validate.errors import InputError
    from inspect_validate.verification.golden import Golden, read_golden
    from inspect_validate.verification.production import verify_production

    if frames is None:
        raise InputError("the running line is verified from a folder of its frames: give frames")
    if golden is None:
        if st.acceptance.drift is None or st.acceptance.drift.golden is None:
            raise InputError(
                "no golden file: give golden=, or acceptance.drift.golden in the station file",
                source=str(st.path),
            )
        golden = st.resolve(st.acceptance.drift.golden)
    if isinstance(golden, Golden):
        return verify_production(st, Path(frames), golden)
    return verify_production(st, Path(frames), read_golden(golden), source=str(golden))


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
    of them. What ``inspect-validate design`` prints
    (:func:`~inspect_validate.report.design.format_design`).

    Parameters
    ----------
    source : str or Path
        A station file (its channels, exposure and camera) or a scene file (its lights
        as channels 1, 2, …).
    objective : {"error", "cnr"}, keyword-only
    choose : int, keyword-only, optional
        Choose the best K of the channels (a catalogue), with their mix.
    auto_exposure : bool, keyword-only
        Design the exposure time too.

    Returns
    -------
    Design
        ``percent`` (channel → drive level, %), ``mix`` and ``single_prediction`` (the
        mix's and the best single channel's predictions), ``flatness`` (the worst value
        with a level ±10 %), ``exposure_time`` (s), ``choice``.

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
