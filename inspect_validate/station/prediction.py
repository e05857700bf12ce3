"""The prediction of a station as built: one row per illumination.

A station is one optics and one camera, so the sweep's light × optics × camera axes
(:class:`~inspect_validate.model.Prediction`) fold into one axis of illuminations,
read by name. The statistics are those of :func:`~inspect_validate.model.predict`;
the separations can be taken again under other comparison weights (the regions'
pixel counts, known once frames are measured) without predicting the spectra again.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Mapping

    from inspect_validate.comparisons import Comparisons
    from inspect_validate.model import Prediction
    from inspect_validate.model.acquisition import Chain

__all__ = ["StationPrediction"]

_PER_CLASS = ("electrons", "mean", "variance", "spectral_variance", "saturated_fraction")
_PER_COMPARISON = ("snr_db", "cnr_db", "fisher_db", "error_gaussian", "log_error_gaussian")
_PER_SAMPLE = ("sample_electrons", "sample_mean", "sample_variance")


@dataclass(frozen=True, eq=False)
class StationPrediction:
    """Predicted statistics of a station's classes and comparisons, per illumination.

    Arrays are indexed ``[illumination, ...]`` (:meth:`index` of a name); the last axis
    is the class, the comparison or the reflectance sample.

    Attributes
    ----------
    illuminations : tuple of str
    classes : tuple of str
    comparison_set : Comparisons
    exposure_time : ndarray, (L,)
        s.
    electrons, mean, variance, spectral_variance, saturated_fraction : ndarray, (L, K)
        Mean photo-electrons μ_e (e⁻), μ (DN), σ² (DN²) and its part from the
        reflectance samples' spread, and the fraction of pixels at saturation.
    snr_db, cnr_db, fisher_db, error_gaussian, log_error_gaussian : ndarray, (L, P)
        SNR_dB (36), CNR, Fisher ratio and ε Gauss (37) with its natural log.
    sample_electrons, sample_mean, sample_variance : ndarray, (L, S)
        Per reflectance sample: μ_e before clipping, mean (DN), variance (DN²).
    sample_class : ndarray, (S,)
        The class of each reflectance sample.
    chain : Chain or None
        The components on the integration grid it was predicted from (one light per
        illumination, all of the station's): :meth:`calibrated` predicts from them again.
    """

    illuminations: tuple[str, ...]
    classes: tuple[str, ...]
    comparison_set: Comparisons
    exposure_time: np.ndarray
    electrons: np.ndarray
    mean: np.ndarray
    variance: np.ndarray
    spectral_variance: np.ndarray
    saturated_fraction: np.ndarray
    snr_db: np.ndarray
    cnr_db: np.ndarray
    fisher_db: np.ndarray
    error_gaussian: np.ndarray
    log_error_gaussian: np.ndarray
    sample_electrons: np.ndarray
    sample_mean: np.ndarray
    sample_variance: np.ndarray
    sample_class: np.ndarray
    chain: Chain | None = dataclasses.field(default=None, repr=False)

    @classmethod
    def of(cls, prediction: Prediction, *, chain: Chain | None = None) -> StationPrediction:
        """The rows of a :class:`~inspect_validate.model.Prediction` of one optics and one
        camera, one per light (an illumination); ``chain``, what it was predicted from."""
        if prediction.shape[1:] != (1, 1):
            raise ValueError(f"a station has one optics and one camera, not {prediction.shape[1:]}")
        arrays = {
            name: getattr(prediction, name)[:, 0, 0]
            for name in (*_PER_CLASS, *_PER_COMPARISON, *_PER_SAMPLE, "exposure_time")
        }
        return cls(
            illuminations=tuple(prediction.lights),
            classes=tuple(prediction.classes),
            comparison_set=prediction.comparison_set,
            sample_class=prediction.sample_class,
            chain=chain,
            **arrays,
        )

    @property
    def comparisons(self) -> tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]:
        """Each comparison as ``(first names, second names)``, the order of the last axis."""
        return self.comparison_set.named

    def index(self, illumination: str) -> int:
        """The row of ``illumination``."""
        try:
            return self.illuminations.index(illumination)
        except ValueError:
            raise InputError(
                f"no illumination {illumination!r} in the prediction "
                f"({', '.join(self.illuminations)})"
            ) from None

    def select(self, illuminations: Sequence[str]) -> StationPrediction:
        """The rows of ``illuminations``, in that order."""
        rows = [self.index(name) for name in illuminations]
        return dataclasses.replace(
            self,
            illuminations=tuple(illuminations),
            **{
                name: getattr(self, name)[rows]
                for name in (*_PER_CLASS, *_PER_COMPARISON, *_PER_SAMPLE, "exposure_time")
            },
        )

    def compared(self, comparisons: Comparisons) -> StationPrediction:
        """The same classes' statistics with the separations of ``comparisons``
        (:func:`~inspect_validate.separations.gaussian_separation`): other weights, such
        as the measured regions' pixel counts, need no new prediction of the spectra."""
        if comparisons == self.comparison_set:
            return self
        from inspect_validate.separations import gaussian_separation

        sep = gaussian_separation(self.mean, self.variance, comparisons)
        return dataclasses.replace(
            self,
            comparison_set=comparisons,
            **{name: getattr(sep, name) for name in _PER_COMPARISON},
        )

    def calibrated(self, scale: Mapping[str, float]) -> StationPrediction:
        """The prediction with each illumination's irradiance times ``scale[name]`` (a
        calibration; 1 where not given), its rows and comparisons as here.

        The signal is linear in the irradiance: the chain's light rows are scaled and the
        rest (exposure, grey values, noise, clipping, separations) follows from them, with
        no new spectral integration.
        """
        if self.chain is None:
            raise ValueError("this prediction keeps no chain to scale (StationModel.predict's do)")
        from inspect_validate.model.acquisition import predict_chain

        lights = self.chain.names[0]
        chain = dataclasses.replace(
            self.chain.scaled([scale.get(name, 1.0) for name in lights]),
            comparisons=self.comparison_set,
        )
        return StationPrediction.of(predict_chain(chain), chain=chain).select(self.illuminations)
