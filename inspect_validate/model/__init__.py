"""The spectral acquisition model: from component spectra to predicted grey-value statistics."""

from inspect_validate.model.acquisition import Exposure, ObjectClass, Prediction, predict
from inspect_validate.model.ranking import comparison_index, predicted_kde_error, rank
from inspect_validate.model.spectral_analysis import SpectralSeparation, analyse_spectra
from inspect_validate.model.sweep import Ranking, sweep

__all__ = [
    "Exposure",
    "ObjectClass",
    "Prediction",
    "Ranking",
    "SpectralSeparation",
    "analyse_spectra",
    "comparison_index",
    "predict",
    "predicted_kde_error",
    "rank",
    "sweep",
]
