"""Compiled ε_tot (37) of two Gaussians: the functions of
:mod:`~inspect_validate.stats._gaussian_error_scalar` compiled by numba as they stand,
its loop over the pairs in parallel, in one pass instead of the numpy implementation's
thirty array passes.

Loaded only for large arrays (a sweep's blocks): numba's import and cache load
cost about 0.3 s, what numpy spends on some 500,000 pairs.
"""

import types

import numba as nb

from inspect_validate.stats import _gaussian_error_scalar as _scalar

_PARALLEL = ("error_and_log",)


def _compiled(module) -> dict:
    """``module``'s namespace with each of its functions compiled (its loops over pairs
    in parallel). Each function is rebuilt on that namespace, so a compiled function
    calls the compiled versions of the others (numba resolves globals when it compiles);
    the code stays the module's, and so does numba's cache of it."""
    namespace = dict(vars(module), prange=nb.prange)
    for name, fn in vars(module).items():
        if isinstance(fn, types.FunctionType) and fn.__module__ == module.__name__:
            rebuilt = types.FunctionType(fn.__code__, namespace, name, fn.__defaults__)
            namespace[name] = nb.njit(
                rebuilt, cache=True, error_model="numpy", parallel=name in _PARALLEL
            )
    return namespace


error_and_log = _compiled(_scalar)["error_and_log"]
