"""Many bracketed roots at once (regula falsi, Illinois): against closed forms."""

import numpy as np

from inspect_validate.stats.roots import narrow_brackets


def test_brackets_close_on_the_roots_to_the_tolerance():
    rng = np.random.default_rng(0)
    c = rng.uniform(0.1, 2.0, 5000)

    def f(x, which):
        return np.log1p(x) - c[which]

    a, b = np.zeros(c.size), np.full(c.size, 10.0)
    left, right = narrow_brackets(a, b, f(a, np.arange(c.size)), f(b, np.arange(c.size)), f,
                                  tolerance=np.ldexp(10.0, -40))  # fmt: skip
    assert np.all(left <= np.expm1(c) + 1e-15) and np.all(np.expm1(c) <= right + 1e-15)
    assert np.all(right - left <= np.ldexp(10.0, -40))


def test_a_zero_met_on_the_way_is_the_root():
    """x − 1 on [0, 2]: the first secant point is the root itself, where the function is
    exactly 0; the bracket closes there (it was left open at [0, 1] and its middle, 0.5,
    returned)."""
    left, right = narrow_brackets(
        np.array([0.0]), np.array([2.0]), np.array([-1.0]), np.array([1.0]),
        lambda x, which: x - 1.0, tolerance=1e-15,
    )  # fmt: skip
    assert left[0] == right[0] == 1.0


def test_a_flat_function_falls_back_to_halving():
    """A step function gives secants outside the bracket or on its ends; the middle is
    taken and the bracket still closes."""

    def f(x, which):
        return np.where(x < 0.3, -1.0, 1.0)

    left, right = narrow_brackets(np.array([0.0]), np.array([1.0]), np.array([-1.0]),
                                  np.array([1.0]), f, tolerance=1e-12)  # fmt: skip
    assert left[0] <= 0.3 <= right[0] and right[0] - left[0] <= 1e-12
