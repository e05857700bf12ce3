"""The ``calibration:`` and ``acceptance:`` sections of a station file.

Example::

    calibration:
      method: fit                  # fit | reference | absolute
      reference: white             # the class of known reflectance (method: reference)
    acceptance:
      false_alarm: 0.0027          # how often an unchanged station may fail (default: 3σ)
      illumination: amber          # separation checks apply to this one (default: every one)
      separation:
        - {comparison: "A vs B,C", min_snr_db: -10, max_error: 0.1}
      max_saturated: 0.001         # fraction of a class's pixels, per illumination
      max_zero: 0.001
      agreement:                   # measured against predicted, after calibration
        mean_relative: 0.05
        snr_db: 1.5
      ranking: true                # the measured best illumination is the predicted best
      gain_relative: 0.1           # photon-transfer K against the camera's declared gain
      drift:                       # against the golden statistics of 'inspect-validate train'
        golden: golden.json        # relative to the station file
        mean_dn: 2                 # a fixed tolerance |μ − μ_golden| per class, DN
        snr_db: 0.5                # |SNR_dB − SNR_dB golden| per comparison; without
                                   # them, prediction intervals from the trained repeats
      health:                      # what the camera reports of the capture (fixed)
        incomplete_frames: 0.01    # share of frames arriving incomplete, at most
        packets_lost: 0            # packets never recovered (GigE Vision)
        missed_triggers: 0         # triggers that brought no frame
        temperature_c: 55          # the camera's rated maximum (default: not limited)
        settings: true             # the camera's nodes as the golden file's

Every check that estimates (drift without a fixed tolerance, the ranking) or holds an
estimate to a given limit (agreement, separation, gain) shares ``false_alarm``
(:mod:`inspect_validate.verification.checks`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import Field, model_validator

from inspect_validate.config import StrictModel

if TYPE_CHECKING:
    from inspect_validate.measurement import Limits

__all__ = ["Acceptance", "Agreement", "Calibration", "Drift", "Health", "Separation"]

FALSE_ALARM_DEFAULT = 0.0027  # checks.DEFAULT_FALSE_ALARM (not imported: scipy-free module)
CONFIDENCE_DEFAULT = 0.95
"""The confidence of the drift limits' tolerance intervals unless ``drift.confidence``
sets one (:class:`Drift`)."""

Fraction = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]
Decibel = Annotated[float, Field(ge=-200, le=200, allow_inf_nan=False)]
Relative = Annotated[float, Field(gt=0, le=100, allow_inf_nan=False)]


class Calibration(StrictModel):
    """How the prediction's absolute scale is tied to the measurement.

    ``fit``: one irradiance scale per illumination, least squares over the
    classes' mean signals; ``reference``: the scale that makes the class named
    by ``reference`` (known reflectance, e.g. a white tile) match; ``absolute``:
    the irradiances as the station gives them (radiometrically calibrated lights).
    """

    method: Literal["fit", "reference", "absolute"] = "fit"
    """``fit``, ``reference`` or ``absolute`` (above)."""
    reference: str | None = None
    """The class of known reflectance that ``reference`` calibrates with."""

    @model_validator(mode="after")
    def _reference_class(self):
        if self.method == "reference" and not self.reference:
            raise ValueError(
                "method 'reference' needs 'reference: <class name>' (e.g. a white tile)"
            )
        return self


class Separation(StrictModel):
    """Limits on one comparison's measured separation."""

    comparison: Annotated[str, Field(min_length=1)]
    """The comparison, as ``comparisons:`` names it (``"A vs B,C"``)."""
    min_snr_db: Decibel | None = None
    """Least SNR_dB (36), dB."""
    min_cnr_db: Decibel | None = None
    """Least CNR_dB, dB."""
    max_error: Fraction | None = None
    """ε Gauss (37), a fraction."""
    max_error_kde: Fraction | None = None
    """ε KDE (37); asking for it is what makes ``verify`` compute the kernel densities."""


class Agreement(StrictModel):
    """Largest deviations of the measurement from the calibrated prediction."""

    mean_relative: Relative | None = 0.1
    """|μ_meas − μ_pred| / (μ_pred − dark level), per class and illumination."""
    variance_relative: Relative | None = None
    """|σ²_meas − σ²_pred| / σ²_pred."""
    snr_db: Annotated[float, Field(gt=0, le=200)] | None = 3.0
    """|SNR_meas − SNR_pred| in dB, per comparison and illumination ..."""
    snr_floor_db: Decibel = -20.0
    """... where the prediction puts it above this floor by more than the false-alarm
    rate's k of its own standard errors: below it the classes overlap almost entirely and
    SNR_dB is set by a mean difference within the model's accuracy (−49 against −58 dB
    says nothing), and just above it other draws of the classes fall either side."""
    parts: Literal["other", "measured"] = "other"
    """``other``: the parts in front of the camera are other draws of their classes than
    the reflectance samples the scene holds (as on a line), so the prediction is uncertain
    by its samples (σ_spectral/√S for μ; the delta method for SNR_dB) and each agreement
    check's standard error holds that beside the measurement's. ``measured``: they are the
    very parts whose spectra were measured (a reference target); only the measurement's
    own uncertainty widens the limits."""


class Drift(StrictModel):
    """Largest drift from the golden statistics ``inspect-validate train`` stored
    (:mod:`inspect_validate.verification.golden`). Where no fixed tolerance is given, the
    limit is statistical: the wider of a prediction interval (the trained repeats' spread,
    Student's t with n − 1 degrees of freedom, and the new measurement's own standard
    error, at the verification's false-alarm rate) and a tolerance interval that holds
    that rate for this golden file with probability ``confidence``."""

    golden: Annotated[str, Field(min_length=1)] | None = None
    """The golden file ``train`` wrote (a relative path is from the station file's folder);
    required with one camera. With several (``cameras:``), each camera's own ``golden``."""
    k: Annotated[float, Field(gt=0, le=30, allow_inf_nan=False)] | None = None
    """The false-alarm rate as a normal-equivalent two-sided level: k = 3 is
    ``acceptance.false_alarm: 0.0027`` (give one of the two)."""
    mean_dn: Annotated[float, Field(gt=0, le=1e9, allow_inf_nan=False)] | None = None
    """A fixed tolerance on |μ − μ_golden| per class, DN (instead of the interval)."""
    snr_db: Annotated[float, Field(gt=0, le=200, allow_inf_nan=False)] | None = None
    """A fixed tolerance on |SNR_dB − SNR_dB golden| per comparison, dB."""
    snr_floor_db: Decibel = -20.0
    """As in :class:`Agreement`: comparisons below it, trained and now, are not checked."""
    confidence: Annotated[float, Field(ge=0.5, lt=1, allow_inf_nan=False)] | None = (
        CONFIDENCE_DEFAULT
    )
    """The probability over the training that *this* golden file's statistical limits
    fail an unchanged station at most their share of the false-alarm rate: each limit
    is the wider of the prediction interval (which promises the rate only on average
    over trainings) and a tolerance interval at this confidence. ``null``: the
    prediction interval alone."""


class _HealthBase(StrictModel):
    settings: bool = True
    """The camera's settings (its snapshot in the capture) must be those the golden file
    was trained at, node by node (with ``drift.golden``)."""


def _health_model() -> type[_HealthBase]:
    """``acceptance.health``: a limit for each health quantity that has one, made from
    the quantities' table (:data:`~inspect_validate.camera.health.QUANTITIES`)."""
    from pydantic import create_model

    from inspect_validate.camera.health import QUANTITIES

    fields: dict[str, Any] = {}
    for q in QUANTITIES:
        if q.limit is None:
            continue
        lo, hi = q.limit.bounds
        kind = int if q.limit.kind == "count" else float
        bounded = Field(ge=lo, le=hi) if kind is int else Field(ge=lo, le=hi, allow_inf_nan=False)
        fields[q.limit.key] = (
            Annotated[kind, bounded] | None,
            Field(default=q.limit.default, description=q.limit.doc),
        )
    return create_model(
        "Health",
        __base__=_HealthBase,
        __doc__=HEALTH_DOC,
        __module__=__name__,
        **fields,
    )


HEALTH_DOC = """Limits on what the camera and its transport report of the verification's capture
(each step's ``health`` in the capture's manifest: :mod:`inspect_validate.camera.health`).
Fixed checks: a value beyond its limit fails, whatever the frames show. A limit left at
its default is checked where the camera offers the quantity and said to be not offered
where it does not; a limit given in the station file and not offered fails, as a check
asked for that could not run."""

if TYPE_CHECKING:
    Health = _HealthBase
else:
    Health = _health_model()


class Acceptance(StrictModel):
    """The checks ``verify`` runs, their limits, and how often an unchanged station may
    fail them."""

    false_alarm: Annotated[float, Field(gt=0, le=0.5, allow_inf_nan=False)] | None = None
    """The family-wise false-alarm rate: how often a verification of a station that has
    not changed fails, at most (default 0.0027, the 3σ convention; or ``drift.k``)."""
    illumination: str | None = None
    """The illumination the separation checks apply to (default: every one)."""
    separation: list[Separation] = []
    """Requirements on the measured separation of comparisons (tolerance checks)."""
    max_saturated: Fraction | None = 0.001
    """Largest fraction of a class's pixels at saturation, per illumination (fixed)."""
    max_zero: Fraction | None = 0.001
    """Largest fraction of a class's pixels at 0 DN, per illumination (fixed)."""
    agreement: Agreement | None = Agreement()
    """How far the measurement may lie from the calibrated prediction (tolerance checks)."""
    ranking: bool = False
    """The measured best illumination must be the predicted best, unless these frames
    cannot tell them apart (statistical)."""
    gain_relative: Relative | None = None
    """Largest relative deviation of the photon-transfer K from the camera's (tolerance)."""
    sharpness: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] | None = 0.7
    """Least MTF50 of the station's ``sharpness:`` file, as a fraction of its lens's
    in-focus MTF50 at its f-number and pixels (fixed; checked where the station names a
    sharpness file; null: not checked)."""
    drift: Drift | None = None
    """Drift from the golden statistics of ``inspect-validate train``."""
    health: Health = Health()
    """What the camera and its transport report: incomplete frames, lost packets, missed
    triggers, its temperature, and its settings against the golden file's."""

    @model_validator(mode="after")
    def _one_level(self):
        k = self.drift.k if self.drift else None
        if k is not None and self.false_alarm is not None:
            import math

            implied = math.erfc(k / math.sqrt(2.0))
            if not math.isclose(implied, self.false_alarm, rel_tol=1e-3):
                raise ValueError(
                    f"drift.k {k:g} means a false-alarm rate of {implied:.3g}, and "
                    f"false_alarm says {self.false_alarm:g}: give one of the two"
                )
        return self

    @property
    def false_alarm_rate(self) -> float:
        """The family-wise false-alarm rate: ``false_alarm``, else that of ``drift.k``
        (2 (1 − Φ(k))), else 0.0027."""
        if self.false_alarm is not None:
            return self.false_alarm
        if self.drift is not None and self.drift.k is not None:
            import math

            return math.erfc(self.drift.k / math.sqrt(2.0))
        return FALSE_ALARM_DEFAULT

    @property
    def confidence(self) -> float | None:
        """The confidence of the statistical drift limits (:attr:`Drift.confidence`; the
        default where the section has no ``drift``, as ``verify --production``)."""
        return self.drift.confidence if self.drift is not None else CONFIDENCE_DEFAULT

    @property
    def needs_kde(self) -> bool:
        """Whether a check asks for ε KDE (the kernel densities are computed only then)."""
        return any(s.max_error_kde is not None for s in self.separation)

    def limits(self) -> Limits:
        """The saturated and zero fractions as measurement :class:`~inspect_validate.measurement.Limits`
        (no limit given: any fraction passes)."""
        from inspect_validate.measurement import Limits

        return Limits(
            max_saturated=1.0 if self.max_saturated is None else self.max_saturated,
            max_zero=1.0 if self.max_zero is None else self.max_zero,
        )
