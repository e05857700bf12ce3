"""Compiled ε_tot (37) of two Gaussians: the functions of
:mod:`~inspect_validate.stats._gaussian_error_scalar` compiled by numba as they stand,
in one parallel pass instead of the numpy implementation's thirty array passes.

Loaded only for large arrays (a sweep's blocks): numba's import and cache load
cost about 0.3 s, what numpy spends on some 500,000 pairs.
"""

import types

import numba as nb

from inspect_validate.stats import _gaussian_error_scalar as _scalar


def _compiled(module) -> dict:
    """``module``'s namespace with each of its functions compiled. Each function is
    rebuilt on that namespace, so a compiled function calls the compiled versions of
    the others (numba resolves globals when it compiles)."""
    namespace = dict(vars(module))
    for name, fn in vars(module).items():
        if isinstance(fn, types.FunctionType) and fn.__module__ == module.__name__:
            rebuilt = types.FunctionType(fn.__code__, namespace, name, fn.__defaults__)
            namespace[name] = nb.njit(rebuilt, cache=True, error_model="numpy")
    return namespace


_one = _compiled(_scalar)["_one"]
_GL_NODES, _GL_WEIGHTS = _scalar._GL_NODES, _scalar._GL_WEIGHTS


@nb.njit(cache=True, error_model="numpy", parallel=True)
def error_and_log(m1, v1, m2, v2, eps, log_eps) -> None:
    """ε_tot and log ε_tot of every pair (1-d float64 arrays, finite, variances ≥ 0)."""
    for i in nb.prange(m1.size):
        eps[i], log_eps[i] = _one(m1[i], v1[i], m2[i], v2[i], _GL_NODES, _GL_WEIGHTS)
