"""What a verification found: per class and comparison the prediction (calibrated and as
stated) against the measurement, the ranking of the illuminations, the checks and the
verdict (:class:`Verification`)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from inspect_validate.measurement import Limits, Measurement
    from inspect_validate.roi import RoiSet
    from inspect_validate.station.file import Station
    from inspect_validate.station.model import StationModel
    from inspect_validate.station.prediction import StationPrediction
    from inspect_validate.verification.calibration import Gain, IrradianceScale
    from inspect_validate.verification.checks import Check
    from inspect_validate.verification.diagnosis import Diagnosis
    from inspect_validate.verification.golden import Golden

__all__ = [
    "ClassAgreement",
    "ComparisonAgreement",
    "ComparisonValues",
    "MeasuredClass",
    "NominalClass",
    "PredictedClass",
    "RankingAgreement",
    "Verification",
]


@dataclass(frozen=True)
class PredictedClass:
    """A class as the calibrated prediction has it: μ (DN), σ² and its temporal and spatial
    (reflectance) parts (DN²), the saturated fraction."""

    mean: float
    variance: float
    temporal_variance: float
    spatial_variance: float
    saturated_fraction: float


@dataclass(frozen=True)
class NominalClass:
    """A class as predicted at the station's stated irradiances: μ (DN), σ² (DN²)."""

    mean: float
    variance: float


@dataclass(frozen=True)
class MeasuredClass:
    """A class as measured: μ (DN), σ² and its EMVA 1288 parts (DN², None where the frames
    cannot tell), saturated and zero fractions, and the dark level subtracted (DN)."""

    mean: float
    variance: float
    temporal_variance: float | None
    spatial_variance: float | None
    saturated_fraction: float
    zero_fraction: float
    dark_mean: float


@dataclass(frozen=True)
class ClassAgreement:
    """One class under one illumination, predicted against measured. ``mean_relative`` is
    (μ measured − μ predicted) over the predicted signal above the dark level,
    ``variance_relative`` (σ² measured − σ² predicted) over σ² predicted."""

    illumination: str
    class_name: str
    predicted: PredictedClass
    nominal: NominalClass
    measured: MeasuredClass
    mean_relative: float
    variance_relative: float


@dataclass(frozen=True)
class ComparisonValues:
    """A comparison's separation: SNR_dB (36), CNR_dB, ε Gauss and ε KDE (37), fractions
    (ε KDE None where not computed)."""

    snr_db: float
    cnr_db: float
    error_gaussian: float
    error_kde: float | None = None


@dataclass(frozen=True)
class ComparisonAgreement:
    """One comparison under one illumination, predicted (calibrated), nominal and measured;
    ``snr_db_difference`` is measured − predicted SNR_dB, dB."""

    illumination: str
    comparison: str
    predicted: ComparisonValues
    nominal: ComparisonValues
    measured: ComparisonValues
    snr_db_difference: float


@dataclass(frozen=True)
class RankingAgreement:
    """The illuminations ranked by the key ``comparison``, predicted against measured:
    each illumination's value ``by`` (``log_error_gaussian``, lowest best; ``snr_db`` or
    ``cnr_db``, highest best), the best of each, whether they agree, Kendall's τ."""

    comparison: str
    by: str
    predicted: dict[str, float]
    measured: dict[str, float]
    predicted_best: str
    measured_best: str
    agree: bool
    kendall_tau: float

    @property
    def tau_text(self) -> str:
        """Kendall's τ as reports say it (undefined where a ranking is tied throughout)."""
        if math.isfinite(self.kendall_tau):
            return f"Kendall τ {self.kendall_tau:.2f}"
        return "Kendall τ undefined (a ranking tied throughout)"


@dataclass(frozen=True)
class Verification:
    """Everything ``verify`` found; :attr:`~inspect_validate.verification.results.Verification.passed` is the verdict."""

    station: Station
    model: StationModel  # what the prediction used (its scene holds the ROI classes only)
    rois: RoiSet  # measured
    limits: Limits  # the saturated and zero fractions the measurements were held to
    inputs: dict
    measurements: dict[str, Measurement]  # illumination → its measurement
    dark: Measurement | None  # of the dark stack
    nominal: StationPrediction  # at the stated irradiances
    prediction: StationPrediction  # after calibration
    scales: dict[str, IrradianceScale]  # illumination → its scale
    gain: Gain | None
    classes: list[ClassAgreement]  # per illumination and class
    comparisons: list[ComparisonAgreement]  # per illumination and comparison
    ranking: RankingAgreement | None
    checks: tuple[Check, ...]
    skipped: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default=())
    acquisition: tuple[
        dict, ...
    ] = ()  # per step: how its frames were taken (camera.storage.acquisition_record)
    false_alarm: float = 0.0027  # the family-wise rate the checks share (acceptance)
    golden: Golden | None = None  # the golden file the drift checks were held to

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @functools.cached_property
    def diagnosis(self) -> Diagnosis | None:
        """What the capture changed against the golden file and the causes that explain
        it, best first (the module ``inspect_validate.verification.diagnosis``); None
        without a golden file."""
        from inspect_validate.verification.diagnosis import Sensor, capture_diagnosis

        if self.golden is None:
            return None
        return capture_diagnosis(
            self.measurements, self.golden, sensor=Sensor.of(self.model.sensor)
        )

    @property
    def cause(self) -> str | None:
        """The likely cause of failed drift checks (the :attr:`diagnosis`) and of a lens
        less sharp than its in-focus limit; None where neither failed (or nothing
        explains the drift beyond its noise)."""
        failed = [c for c in self.checks if not c.passed]
        causes = []
        if any(c.kind == "drift" for c in failed) and self.diagnosis is not None:
            causes.append(self.diagnosis.text)
        lenses = [str(c.illumination) for c in failed if c.kind == "sharpness"]
        if lenses:
            causes.append(
                f"the lens is out of focus or soiled ({', '.join(lenses)}: MTF50 below "
                "acceptance.sharpness of its in-focus limit): focus it, clean it"
            )
        return "; ".join(c for c in causes if c) or None

    def __repr__(self) -> str:
        failed = sum(not c.passed for c in self.checks)
        verdict = "PASS" if self.passed else "FAIL"
        return (
            f"<Verification of {self.station.name!r}: {verdict}, {len(self.checks)} checks, "
            f"{failed} failed; .table() for the checks>"
        )

    def table(self) -> str:
        """The checks as text, failures first, and the verdict (``verify`` prints them
        with the calibration and what was skipped)."""
        from inspect_validate.text import render_table

        rows = [
            [c.verdict, c.name, f"{c.value:.4g}", f"{c.relation} {c.limit:.4g}", c.unit, c.basis]
            for c in sorted(self.checks, key=lambda c: (c.passed, not c.undecided))
        ]
        failed = sum(not c.passed for c in self.checks)
        verdict = (
            f"{'PASS' if self.passed else 'FAIL'}: {failed} of {len(self.checks)} checks failed"
        )
        header = ["verdict", "check", "value", "limit", "unit", "basis"]
        return render_table(header, rows, left={0, 1, 4, 5}) + "\n" + verdict

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.table())}</pre>"
