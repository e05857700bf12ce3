"""The ``calibration:`` and ``acceptance:`` sections of a station file.

Example::

    calibration:
      method: fit                  # fit | reference | absolute
      reference: white             # the class of known reflectance (method: reference)
    acceptance:
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
        k: 3                       # tolerance k × the trained spread, unless given:
        mean_dn: 2                 # |μ − μ_golden| per class, DN
        snr_db: 0.5                # |SNR_dB − SNR_dB golden| per comparison
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from inspect_validate.config import StrictModel

__all__ = ["Acceptance", "Agreement", "Calibration", "Drift", "Separation"]

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
    reference: str | None = None

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
    min_snr_db: Decibel | None = None
    min_cnr_db: Decibel | None = None
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
    """... where either is above this floor: below it the classes overlap almost entirely
    and SNR_dB is set by a mean difference within the model's accuracy (−49 against −58 dB
    says nothing), so a comparison below the floor in both agrees."""


class Drift(StrictModel):
    """Largest drift from the golden statistics ``inspect-validate train`` stored
    (:mod:`.golden`); a tolerance not given is ``k`` × the trained spread."""

    golden: Annotated[str, Field(min_length=1)]
    k: Annotated[float, Field(gt=0, le=100, allow_inf_nan=False)] = 3.0
    mean_dn: Annotated[float, Field(gt=0, le=1e9, allow_inf_nan=False)] | None = None
    snr_db: Annotated[float, Field(gt=0, le=200, allow_inf_nan=False)] | None = None
    snr_floor_db: Decibel = -20.0
    """As in :class:`Agreement`: comparisons below it, trained and now, are not checked."""


class Acceptance(StrictModel):
    illumination: str | None = None
    separation: list[Separation] = []
    max_saturated: Fraction | None = 0.001
    max_zero: Fraction | None = 0.001
    agreement: Agreement | None = Agreement()
    ranking: bool = False
    gain_relative: Relative | None = None
    drift: Drift | None = None

    @property
    def needs_kde(self) -> bool:
        """Whether a check asks for ε KDE (the kernel densities are computed only then)."""
        return any(s.max_error_kde is not None for s in self.separation)

    def limits(self):
        """The saturated and zero fractions as measurement :class:`~inspect_validate.measurement.Limits`
        (no limit given: any fraction passes)."""
        from inspect_validate.measurement import Limits

        return Limits(
            max_saturated=1.0 if self.max_saturated is None else self.max_saturated,
            max_zero=1.0 if self.max_zero is None else self.max_zero,
        )
