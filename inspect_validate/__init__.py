"""inspect-validate: spectral design and verification of machine-vision inspection stations.

``import inspect_validate as iv`` gives the verbs a user needs; each imports what it
uses when first called, so the command line starts fast:

* :func:`read_scene`, :func:`read_station`, :func:`read_rois` — the input files;
* :func:`predict`, :func:`sweep` — μ, σ², SNR_dB and ε of every combination of a scene;
* :func:`measure` — the same from frames and regions;
* :func:`capture`, :func:`verify`, :func:`train` — a station's frames, its verdict,
  its golden statistics;
* :func:`design` — the best mix of a controller's channels.

The modules are organised by concept: :mod:`inspect_validate.stats` (grey-value
statistics, class separation and classification error), :mod:`inspect_validate.roi`,
:mod:`inspect_validate.images`, :mod:`inspect_validate.measurement`,
:mod:`inspect_validate.model`, :mod:`inspect_validate.verification`,
:mod:`inspect_validate.report`, :mod:`inspect_validate.camera` (devices and capture).
"""

__version__ = "0.1.0"

# The verbs import what they use when called: this import stays cheap for the CLI.
from inspect_validate.api import *  # noqa: F403
from inspect_validate.api import __all__ as _verbs

__all__ = ["__version__", *_verbs]
