"""Registered methods as pysindy's differentiation method.

Exact truth: the Lorenz system's coefficients (σ = 10, ρ = 28, β = 8/3), recovered by SINDy
from a noisy trajectory integrated to 1e-12.
"""

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

ps = pytest.importorskip("pysindy")

from diffbench import methods  # noqa: E402
from diffbench.methods.for_pysindy import Differentiation  # noqa: E402

DT = 0.002


def _lorenz(_t, state, sigma=10.0, rho=28.0, beta=8.0 / 3.0):
    x, y, z = state
    return [sigma * (y - x), x * (rho - z) - y, x * y - beta * z]


@pytest.fixture(scope="module")
def noisy_lorenz():
    """10 s of the Lorenz system at 2 ms, Gaussian noise of 5 % of each state's spread."""
    t = np.arange(0.0, 10.0, DT)
    solution = solve_ivp(_lorenz, (0.0, t[-1]), [-8.0, 8.0, 27.0], t_eval=t, rtol=1e-12, atol=1e-12)
    states = solution.y.T
    rng = np.random.default_rng(0)
    return states + 0.05 * states.std(axis=0) * rng.standard_normal(states.shape)


def _coefficient_error(differentiation, x) -> tuple[float, np.ndarray, np.ndarray]:
    model = ps.SINDy(
        optimizer=ps.STLSQ(threshold=0.5),
        feature_library=ps.PolynomialLibrary(degree=2),
        differentiation_method=differentiation,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit(x, t=DT)
    index = {name: i for i, name in enumerate(model.get_feature_names())}
    truth = np.zeros((3, len(index)))
    truth[0, [index["x0"], index["x1"]]] = -10.0, 10.0
    truth[1, [index["x0"], index["x1"], index["x0 x2"]]] = 28.0, -1.0, -1.0
    truth[2, [index["x2"], index["x0 x1"]]] = -8.0 / 3.0, 1.0
    found = model.coefficients()
    return np.linalg.norm(found - truth) / np.linalg.norm(truth), found, truth


@pytest.mark.parametrize(
    ("name", "params"),
    [
        ("savitzky_golay", {"window_s": 0.04, "degree": 3}),
        ("spectral", {}),
        ("kalman", {}),
        ("smoothing_spline", {}),
    ],
)
def test_sindy_recovers_lorenz_at_least_as_well_as_pysindys_default(noisy_lorenz, name, params):
    """Measured: pysindy's SmoothedFiniteDifference 7.6e-3 relative coefficient error;
    Savitzky-Golay (40 ms, cubic) 4.7e-3, spectral 2.7e-3, Kalman 2.8e-3, smoothing spline
    3.2e-3 (at their defaults, nothing tuned). The maximum-likelihood Gaussian process gets
    5.8e-2: its ends are not checked yet (issue 17)."""
    reference, _, _ = _coefficient_error(ps.SmoothedFiniteDifference(), noisy_lorenz)
    error, found, truth = _coefficient_error(Differentiation(name, params), noisy_lorenz)
    assert error <= reference, (error, reference)
    np.testing.assert_array_equal(found != 0, truth != 0)  # the same seven terms


def test_it_is_the_registered_method_with_masked_samples_as_nan():
    t = np.arange(400) * DT
    x = np.column_stack([np.sin(5 * t), np.cos(3 * t)])
    differentiation = Differentiation("jacobi", {"ends": "central"})
    x_dot = differentiation(x, DT)
    estimate = methods.get("jacobi", ends="central")(x, DT, orders=(0, 1))
    np.testing.assert_array_equal(x_dot, estimate[1])  # NaN where masked
    np.testing.assert_array_equal(differentiation.smoothed_x_, estimate[0])
    assert np.isnan(x_dot[0]).all() and np.isfinite(x_dot[200]).all()
    # time stamps: uniform ones give exactly what the step gives
    np.testing.assert_array_equal(differentiation(x, t), x_dot)
    raw = Differentiation("jacobi", {"ends": "central"}, smoothed_x=False)
    raw(x, DT)
    np.testing.assert_array_equal(raw.smoothed_x_, x)


def test_bad_names_and_parameters_are_refused_by_name_and_params_clone():
    with pytest.raises(ValueError, match="unknown method 'no_such_method'"):
        Differentiation("no_such_method")(np.zeros((50, 1)), DT)
    with pytest.raises(ValueError, match=r"unknown parameter.*window"):
        Differentiation("savitzky_golay", {"window": 0.1})(np.zeros((50, 1)), DT)
    from sklearn.base import clone

    original = Differentiation("spectral", {"cutoff_hz": 30.0}, smoothed_x=False)
    copy = clone(original)
    assert copy.get_params() == original.get_params()
