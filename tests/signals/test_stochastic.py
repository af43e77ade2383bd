"""Random signals with known spectra: exact derivatives, their laws, and the bound on any
differentiator's error (two independent computations and a Monte Carlo of the optimal
estimator)."""

import math

import numpy as np
import pytest
from scipy import integrate

from diffbench.bench.limit import optimal_states
from diffbench.signals import NoiseStack, Scenario
from diffbench.signals.noise import Gaussian
from diffbench.signals.stochastic import (
    IntegratedWhiteNoise,
    Matern,
    smoother_bound,
    smoother_bound_spectral,
    steady_bounds,
)

DT, NOISE_STD = 1e-3, 0.01
SIGNALS = [
    Matern(smoothness=2.5, length_scale_s=0.1),
    Matern(smoothness=3.5, length_scale_s=0.1),
    IntegratedWhiteNoise(times=2, intensity=1e4),
    IntegratedWhiteNoise(times=3, intensity=1e6),
]
IDS = [s.describe() for s in SIGNALS]


def _orders(signal):
    return range(1, min(signal.model().states, 3))


@pytest.mark.parametrize("nu", [2.5, 3.5])
def test_matern_spectrum_and_state_model_give_its_variances(nu):
    # the spectral density integrates to σ² and (2πf)² times it to Var(ẋ) = σ²ν/((ν-1)ℓ²)
    # (-k''(0) of the Matérn covariance); the state model's stationary covariance agrees
    signal = Matern(smoothness=nu, length_scale_s=0.2, std=1.5)
    variance = integrate.quad(signal.spectral_density, -np.inf, np.inf, epsrel=1e-12)[0]
    slope = integrate.quad(lambda f: (2 * np.pi * f) ** 2 * signal.spectral_density(f),
                           -np.inf, np.inf, epsrel=1e-12)[0]  # fmt: skip
    expected_slope = 1.5**2 * nu / ((nu - 1) * 0.2**2)
    assert variance == pytest.approx(1.5**2, rel=1e-9)
    assert slope == pytest.approx(expected_slope, rel=1e-9)
    stationary = signal.model().stationary_covariance()
    assert stationary[0, 0] == pytest.approx(1.5**2, rel=1e-10)
    assert stationary[1, 1] == pytest.approx(expected_slope, rel=1e-10)
    assert stationary[0, 1] == pytest.approx(0.0, abs=1e-10)  # x and ẋ uncorrelated at one t


@pytest.mark.parametrize("signal", SIGNALS, ids=IDS)
def test_drawn_derivatives_match_finite_differences_of_a_fine_realisation(signal):
    # drawn at 10 µs: central differences of x (and of ẋ) at 20 µs give ẋ (and ẍ). The
    # highest derivative in the state is driven by white noise (continuous, nowhere
    # differentiable), so the difference below it converges only like √h: 3e-2 there
    step = 1e-5
    t = np.arange(0.0, 0.2, step)
    truth = signal.draw(t, np.random.default_rng(3))
    top = signal.model().states - 1
    for order in _orders(signal):
        below = truth[order - 1]
        differences = (below[2:] - below[:-2]) / (2 * step)
        exact = truth[order][1:-1]
        relative = np.sqrt(np.mean((differences - exact) ** 2) / np.mean(exact**2))
        assert relative < (3e-2 if order == top else 3e-4), (order, relative)
    if signal.model().states == 2:
        assert np.isnan(truth[2]).all()  # twice-integrated white noise has no ẍ


def test_a_scenario_on_a_random_signal_is_reproducible_per_seed():
    scenario = Scenario(
        name="matern-test", signal=Matern(), noise=NoiseStack((Gaussian(std=NOISE_STD),)),
        dt_s=DT, duration_s=0.5, interior_margin_s=0.1, description="test", preset="default",
    )  # fmt: skip
    first, again, other = scenario.realise(4), scenario.realise(4), scenario.realise(5)
    np.testing.assert_array_equal(first.x, again.x)
    np.testing.assert_array_equal(first.truth[2], again.truth[2])
    assert not np.allclose(first.truth[0], other.truth[0])
    np.testing.assert_array_equal(first.x - first.truth[0], first.noise)
    with pytest.raises(ValueError, match="random signal: draw a realisation"):
        Matern().evaluate(np.arange(3) * DT)


@pytest.mark.parametrize("signal", SIGNALS, ids=IDS)
def test_the_bound_from_the_spectra_equals_the_steady_state_smoother(signal):
    for order in range(min(signal.model().states, 3)):
        steady = smoother_bound(signal, DT, NOISE_STD, order)
        spectral = smoother_bound_spectral(signal, DT, NOISE_STD, order)
        assert spectral == pytest.approx(steady, rel=1e-7), order
        causal = smoother_bound(signal, DT, NOISE_STD, order, causal=True)
        assert causal > steady  # the future helps


def test_without_aliasing_the_bound_is_the_continuous_wiener_integral():
    # a Matérn 7/2 far inside Nyquist: the discrete bound is ∫ (2πf)^2n S N/(S+N) df
    signal = Matern(smoothness=3.5, length_scale_s=0.2)
    density = NOISE_STD**2 * DT
    for order in (1, 2):

        def error(f, order=order):
            s = signal.spectral_density(f)
            return (2 * np.pi * f) ** (2 * order) * s * density / (s + density)

        continuous = 2 * integrate.quad(error, 0, 0.5 / DT, epsrel=1e-10, limit=400)[0]
        assert smoother_bound(signal, DT, NOISE_STD, order) == pytest.approx(continuous, rel=1e-4)


def test_optimal_states_equal_filterpys_kalman_filter_and_rts_smoother():
    from filterpy.kalman import KalmanFilter

    signal = Matern(smoothness=2.5, length_scale_s=0.05)
    t = np.arange(400) * DT
    truth = signal.draw(t, np.random.default_rng(0))
    y = truth[0] + NOISE_STD * np.random.default_rng(1).standard_normal(t.size)
    A, Q = signal.model().discretise(DT)
    kalman = KalmanFilter(dim_x=3, dim_z=1)
    kalman.F, kalman.Q, kalman.H, kalman.R = A, Q, np.array([[1.0, 0, 0]]), NOISE_STD**2
    kalman.x, kalman.P = np.zeros(3), signal.model().stationary_covariance()
    # filterpy predicts before its first update; ours updates the prior at the first sample:
    # start filterpy one step back, from the prior pulled back through A
    kalman.P = np.linalg.solve(A, np.linalg.solve(A, kalman.P - Q).T).T
    means, covariances, _, _ = kalman.batch_filter(y)
    smoothed, *_ = kalman.rts_smoother(means, covariances)
    scale = np.array([1.0, 10.0, 1000.0])
    np.testing.assert_allclose(optimal_states(signal, DT, NOISE_STD, y, causal=True) / scale,
                               means / scale, rtol=0, atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(optimal_states(signal, DT, NOISE_STD, y) / scale,
                               smoothed / scale, rtol=0, atol=1e-9)  # fmt: skip


@pytest.mark.parametrize("signal", SIGNALS, ids=IDS)
def test_the_optimal_estimator_reaches_the_bound_within_monte_carlo_error(signal):
    # 100 realisations of 3000 samples; the error on the middle 1000 (1000 samples, 10 or more
    # of the smoother's memory lengths, from each end); per realisation its mean square error,
    # so that the standard error is across independent realisations
    n, count = 3000, 100
    t = np.arange(n) * DT
    rng = np.random.default_rng(7)
    truths = [signal.draw(t, rng) for _ in range(count)]
    x = np.stack([truth[0] for truth in truths], axis=1)
    y = x + NOISE_STD * rng.standard_normal(x.shape)
    middle = slice(1000, 2000)
    for causal in (False, True):
        estimates = optimal_states(signal, DT, NOISE_STD, y, causal=causal)
        for order in range(min(signal.model().states, 3)):
            exact = np.stack([truth[order][middle] for truth in truths], axis=1)
            errors = np.mean((estimates[middle, order] - exact) ** 2, axis=0)
            mean, standard_error = errors.mean(), errors.std(ddof=1) / math.sqrt(count)
            bound = smoother_bound(signal, DT, NOISE_STD, order, causal=causal)
            assert standard_error < 0.05 * bound  # precise enough to fail
            assert abs(mean - bound) < 3 * standard_error, (causal, order, mean, bound)


def test_steady_bounds_are_covariances():
    bounds = steady_bounds(SIGNALS[1], DT, NOISE_STD)
    for matrix in (bounds.filtered, bounds.smoothed):
        np.testing.assert_allclose(matrix, matrix.T)
        assert np.all(np.linalg.eigvalsh(matrix) > 0)
    assert np.all(np.diag(bounds.filtered) > np.diag(bounds.smoothed))


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: Matern(smoothness=1.5), "`smoothness` must be 2.5 or 3.5"),
        (lambda: IntegratedWhiteNoise(times=4), "`times` must be 2 or 3"),
        (lambda: Matern(length_scale_s=0.0), "length_scale_s"),
        (
            lambda: smoother_bound(IntegratedWhiteNoise(times=2), DT, NOISE_STD, 2),
            "no derivative of order 2",
        ),
        (lambda: smoother_bound(Matern(), DT, 0.0, 1), "noise_std"),
        (
            lambda: Matern().draw(np.array([0.0, 0.0, 1.0]), np.random.default_rng(0)),
            "strictly increasing",
        ),
    ],
)
def test_bad_input_names_the_argument(call, message):
    with pytest.raises(ValueError, match=message):
        call()
