"""PyNumDiff's test records (diffbench.signals.pynumdiff_suite): the functions f0-f5, their
exact derivatives, PyNumDiff's grid, noise level and irregular stamps."""

import numpy as np
import pytest

from diffbench import signals
from diffbench.signals import pynumdiff_suite as suite

EPS = np.finfo(float).eps
H = 1e-30
"""Complex step: Im f(t + iH)/H is f'(t) with no subtraction, so to a few eps (relative)."""

# PyNumDiff's functions and its first derivatives, as its test file states them
FORMULAS = {
    "f0": (lambda t: 1.0 + 0 * t, lambda t: 0 * t),
    "f1": (lambda t: 2 * t + 1, lambda t: 2 + 0 * t),
    "f2": (lambda t: t**2 - t + 1, lambda t: 2 * t - 1),
    "f3": (lambda t: np.sin(3 * t) + 0.5, lambda t: 3 * np.cos(3 * t)),
    "f4": (
        lambda t: np.exp(t) * np.sin(5 * t),
        lambda t: np.exp(t) * (5 * np.cos(5 * t) + np.sin(5 * t)),
    ),
    "f5": (
        lambda t: np.sin(8 * t) / (t + 0.1) ** 1.5,
        lambda t: ((0.8 + 8 * t) * np.cos(8 * t) - 1.5 * np.sin(8 * t)) / (0.1 + t) ** 2.5,
    ),
}


def complex_step(function, t):
    return np.imag(function(t + 1j * H)) / H


def _tolerance(values):
    # at most 3 terms each up to about 10x the result (cancellation), each a few roundings:
    # 1e3 eps of the largest value on the record
    return 1e3 * EPS * max(1.0, float(np.max(np.abs(values))))


@pytest.mark.parametrize("function", list(FORMULAS))
@pytest.mark.parametrize("stamps", ["grid", "irregular"])
def test_derivatives_are_exact(function, stamps):
    x_of, dx_of = FORMULAS[function]
    t = np.linspace(0, 3, 31) if stamps == "grid" else 3 * np.linspace(0, 1, 31) ** 1.5
    truth = suite.FUNCTIONS[function][0].evaluate(t)
    np.testing.assert_allclose(truth[0], x_of(t), rtol=0, atol=_tolerance(truth[0]))
    # ẋ: PyNumDiff's stated derivative and the complex step of the function
    for reference in (dx_of(t), complex_step(x_of, t)):
        np.testing.assert_allclose(truth[1], reference, rtol=0, atol=_tolerance(truth[1]))
    # ẍ: the complex step of PyNumDiff's stated derivative
    reference = complex_step(dx_of, t)
    np.testing.assert_allclose(truth[2], reference, rtol=0, atol=_tolerance(truth[2]))


def test_a_wrong_derivative_would_be_caught():
    # the tolerance is far below a real mistake: f5's ẍ with the last term's sign flipped
    t = np.linspace(0, 3, 31)
    truth = suite.FUNCTIONS["f5"][0].evaluate(t)
    u = t + 0.1
    flipped = truth[2] - 2 * 1.5 * 2.5 * np.sin(8 * t) * u**-3.5
    assert np.max(np.abs(flipped - truth[2])) > 1e6 * _tolerance(truth[2])


def test_records_are_pynumdiffs_grid_and_noise():
    assert suite.names()[:6] == [f"pynumdiff-f{k}" for k in range(6)]
    for name in suite.names():
        scenario = suite.get(name)
        assert scenario.n_samples == 31 and scenario.dt_s == 0.1
        assert scenario.noise.models == (signals.Gaussian(std=0.05),)
        realisation = scenario.realise(3)
        assert realisation.interior.all()  # scored over every sample
        np.testing.assert_array_equal(realisation.x, realisation.truth[0] + realisation.noise)
    # the noise is drawn per seed, reproducibly
    a, b = suite.get("pynumdiff-f3").realise(1), suite.get("pynumdiff-f3").realise(2)
    np.testing.assert_array_equal(a.x, suite.get("pynumdiff-f3").realise(1).x)
    assert not np.array_equal(a.noise, b.noise)


def test_irregular_stamps_are_pynumdiffs():
    irregular = suite.get("pynumdiff-f4-irregular").realise(0)
    assert not irregular.uniform
    np.testing.assert_allclose(irregular.t, 3 * np.linspace(0, 1, 31) ** 1.5, rtol=0, atol=4 * EPS)
    # the earlier revision's stamps: the grid jostled by U(-dt/3, dt/3) from RandomState(7),
    # drawn after its 31 noise samples; the same for every seed
    legacy = np.random.RandomState(7)
    legacy.randn(31)
    expected = np.linspace(0, 3, 31) + legacy.uniform(-0.1 / 3, 0.1 / 3, 31)
    for seed in (0, 5):
        jostled = suite.get("pynumdiff-f4-jostled").realise(seed)
        np.testing.assert_allclose(jostled.t, expected, rtol=0, atol=8 * EPS)
    np.testing.assert_array_equal(jostled.truth[1], suite.FUNCTIONS["f4"][0].evaluate(jostled.t)[1])


def test_the_records_are_not_in_the_projects_registry():
    assert not any(name.startswith("pynumdiff-") for name in signals.available_scenarios())
    with pytest.raises(ValueError, match=r"unknown PyNumDiff test record 'f9'.*pynumdiff-f0"):
        suite.get("f9")
