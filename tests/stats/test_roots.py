"""Many bracketed roots at once (regula falsi, Illinois; safeguarded Newton where the
slope is given): against closed forms."""

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


def test_newton_closes_on_the_roots_in_a_few_passes():
    """log1p(x) − c with its slope: every root found within the tolerance of its closed
    form, expm1(c), in at most 7 passes (regula falsi takes 10 here, and 17 on the
    kernel mixtures of the spectral analysis where Newton takes 5 to 7); a root
    at a bracket's end, a slope of 0 and a step function still close."""
    rng = np.random.default_rng(1)
    c = rng.uniform(0.1, 2.0, 5000)
    passes = []

    def f(x, which):
        passes.append(which.size)
        return np.log1p(x) - c[which], 1.0 / (1.0 + x)

    a, b = np.zeros(c.size), np.full(c.size, 10.0)
    every = np.arange(c.size)
    tolerance = np.ldexp(10.0, -40)
    left, right = narrow_brackets(a, b, f(a, every)[0], f(b, every)[0], f,
                                  tolerance=tolerance, slope=True)  # fmt: skip
    passes = passes[2:]  # the ends' values
    root = np.expm1(c)
    assert np.all(np.abs(0.5 * (left + right) - root) <= tolerance + 4e-16 * root)
    assert np.all(right - left <= tolerance) and len(passes) <= 7, passes

    def odd(x, which):  # a root at 1, the slope 0 at 0 (x³ − 1 on [0, 2]) and a step
        return np.where(which == 0, x**3 - 1.0, np.where(x < 0.3, -1.0, 1.0)), np.where(
            which == 0, 3 * x**2, 0.0
        )

    ends = np.array([0.0, 0.0]), np.array([2.0, 1.0])
    left, right = narrow_brackets(*ends, np.array([-1.0, -1.0]), np.array([7.0, 1.0]), odd,
                                  tolerance=1e-12, slope=True)  # fmt: skip
    assert abs(0.5 * (left[0] + right[0]) - 1.0) <= 1e-12
    assert left[1] <= 0.3 <= right[1] and right[1] - left[1] <= 1e-12
