"""inspect-validate: spectral design and verification of machine-vision inspection stations.

The package is organised by concept: :mod:`inspect_validate.stats` (grey-value
statistics, class separation and classification error), :mod:`inspect_validate.roi`
(regions of interest), :mod:`inspect_validate.images` (frame input),
:mod:`inspect_validate.measure` (per-class measurement of frames) and
:mod:`inspect_validate.report` (tables and JSON).
"""

__version__ = "0.1.0"
