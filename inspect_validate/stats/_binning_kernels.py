"""Compiled linear binning for :func:`inspect_validate.stats.bandwidth.pair_counts`.

One pass over the sample instead of numpy's five (scale, floor, fraction and two
weighted bincounts); loaded only when continuous data are binned.
"""

import numba as nb
import numpy as np


@nb.njit(cache=True)
def linear_bin(x, lo, step, size):
    """Linear-binning weights on the grid lo + k·step, k < size.

    Returns the weights and the two self-pair terms each point leaves in the
    weights' autocorrelation: Σ((1−f)² + f²) at lag 0 and Σ f(1−f) at lag 1.
    """
    w = np.zeros(size)
    self0 = 0.0
    self1 = 0.0
    for v in x:
        pos = (v - lo) / step
        k = min(int(pos), size - 2)
        f = pos - k
        w[k] += 1.0 - f
        w[k + 1] += f
        self0 += (1.0 - f) * (1.0 - f) + f * f
        self1 += f * (1.0 - f)
    return w, self0, self1
