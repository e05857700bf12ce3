"""Roots of many bracketed functions at once.

The batched searches (ε's crossings of many mixtures, LSCV's slope in many columns)
each hold hundreds of brackets [a, b] with a sign change of a smooth function inside;
narrowing all of them together keeps the Python loop to a few array passes.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["narrow_brackets"]


def narrow_brackets(
    left: np.ndarray,
    right: np.ndarray,
    f_left: np.ndarray,
    f_right: np.ndarray,
    f: Callable[[np.ndarray, np.ndarray], np.ndarray],
    *,
    tolerance: np.ndarray | float,
    iterations: int = 200,
) -> tuple[np.ndarray, np.ndarray]:
    """Brackets [left, right] of sign changes of ``f`` narrowed to ``tolerance``.

    Regula falsi with the Illinois modification (an end kept twice has its value
    halved): superlinear, about 8 evaluations where bisection to 2⁻⁴⁰ takes 40, and the
    root stays bracketed. A bracket whose function is 0 at a point closes on it.

    Parameters
    ----------
    left, right : ndarray, (B,)
        The brackets' ends.
    f_left, f_right : ndarray, (B,)
        ``f`` there, of opposite signs.
    f : callable
        ``f(x, which)``: the function of brackets ``which`` (indices) at points ``x``.
    tolerance : ndarray or float, keyword-only
        Width at which a bracket is narrow enough, in x.
    iterations : int, keyword-only
        At most this many passes.

    Returns
    -------
    left, right : ndarray, (B,)
    """
    left, right = np.array(left, float), np.array(right, float)
    f_left, f_right = np.array(f_left, float), np.array(f_right, float)
    tolerance = np.broadcast_to(np.asarray(tolerance, float), left.shape)
    kept = np.zeros(left.size, np.int8)  # −1: left was kept last, +1: right was
    active = np.flatnonzero((right - left > tolerance) & (f_left != 0) & (f_right != 0))
    for _ in range(iterations):
        if active.size == 0:
            break
        a, b, fa, fb = left[active], right[active], f_left[active], f_right[active]
        with np.errstate(invalid="ignore", divide="ignore"):
            x = (a * fb - b * fa) / (fb - fa)
        x = np.where((x > a) & (x < b), x, 0.5 * (a + b))
        fx = f(x, active)
        low = np.signbit(fx) == np.signbit(fa)
        zero = fx == 0
        left[active] = np.where(low | zero, x, a)  # a zero is the crossing itself
        right[active] = np.where(low & ~zero, b, x)
        f_left[active] = np.where(low, fx, np.where(kept[active] == -1, 0.5 * fa, fa))
        f_right[active] = np.where(low, np.where(kept[active] == 1, 0.5 * fb, fb), fx)
        kept[active] = np.where(low, 1, -1)
        active = active[(right[active] - left[active] > tolerance[active]) & ~zero]
    return left, right
