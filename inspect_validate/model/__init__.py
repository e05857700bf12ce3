"""The spectral acquisition model: from component spectra to predicted grey-value statistics."""

from inspect_validate.model.acquisition import Exposure, ObjectClass, Prediction, predict

__all__ = ["Exposure", "ObjectClass", "Prediction", "predict"]
from inspect_validate.model.ranking import comparison_index, predicted_kde_error, rank

__all__ += ["comparison_index", "predicted_kde_error", "rank"]
