"""Random signals with known spectra: exact derivatives, their laws, and the bound on any
differentiator's error (two independent computations and a Monte Carlo of the optimal
estimator)."""

import math

import numpy as np
import pytest
from scipy import integrate, linalg

from diffbench.bench.studies.limit import optimal_states
from diffbench.signals import NoiseStack, Scenario
from diffbench.signals.noise import Gaussian
from diffbench.signals.stochastic import (
    BandLimited,
    IntegratedWhiteNoise,
    Matern,
    gaussian_posterior,
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


@pytest.mark.parametrize("nu", [2.5, 3.5])
def test_matern_spectrum_and_state_model_give_its_variances(nu):
    # the spectral density integrates to σ² and (2πf)² times it to Var(ẋ) = σ²ν/((ν-1)ℓ²)
    # (-k''(0) of the Matérn covariance); the state model's stationary covariance agrees
    signal = Matern(smoothness=nu, length_scale_s=0.2, std=1.5)
    variance = integrate.quad(signal.spectral_density, -np.inf, np.inf, epsrel=1e-12)[0]
    slope = integrate.quad(
        lambda f: (2 * np.pi * f) ** 2 * signal.spectral_density(f), -np.inf, np.inf, epsrel=1e-12
    )[0]
    expected_slope = 1.5**2 * nu / ((nu - 1) * 0.2**2)
    assert variance == pytest.approx(1.5**2, rel=1e-9)
    assert slope == pytest.approx(expected_slope, rel=1e-9)
    stationary = signal.model().stationary_covariance()
    assert stationary[0, 0] == pytest.approx(1.5**2, rel=1e-10)
    assert stationary[1, 1] == pytest.approx(expected_slope, rel=1e-10)
    assert stationary[0, 1] == pytest.approx(0.0, abs=1e-10)  # x and ẋ uncorrelated at one t


@pytest.mark.parametrize("signal", SIGNALS, ids=IDS)
def test_drawn_derivatives_match_finite_differences_of_a_fine_realisation(signal):
    # drawn at 10 µs: central differences of x (and of ẋ) at 20 µs give ẋ (and ẍ), to 1e-7
    # .. 5e-6 (measured); rounding in the noise's covariance had made it 1.7e-3 for the
    # Matérn 7/2's ẍ. The highest derivative in the state is driven by white noise
    # (continuous, nowhere differentiable), so the difference below it converges only like
    # √h: 3e-2 there
    step = 1e-5
    t = np.arange(0.0, 0.2, step)
    truth = signal.draw(t, np.random.default_rng(3))
    top = signal.model().states - 1
    for order in signal.derivative_orders:
        below = truth[order - 1]
        differences = (below[2:] - below[:-2]) / (2 * step)
        exact = truth[order][1:-1]
        relative = np.sqrt(np.mean((differences - exact) ** 2) / np.mean(exact**2))
        assert relative < (3e-2 if order == top else 5e-5), (order, relative)
    if signal.model().states == 2:
        assert np.isnan(truth[2]).all()  # twice-integrated white noise has no ẍ


def test_a_scenario_on_a_random_signal_is_reproducible_per_seed():
    scenario = Scenario(
        name="matern-test",
        signal=Matern(),
        noise=NoiseStack((Gaussian(std=NOISE_STD),)),
        dt_s=DT,
        duration_s=0.5,
        interior_margin_s=0.1,
        description="test",
        preset="default",
    )
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
    np.testing.assert_allclose(
        optimal_states(signal, DT, NOISE_STD, y, causal=True) / scale,
        means / scale,
        rtol=0,
        atol=1e-9,
    )
    np.testing.assert_allclose(
        optimal_states(signal, DT, NOISE_STD, y) / scale, smoothed / scale, rtol=0, atol=1e-9
    )


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
        (lambda: BandLimited(band_hz=-1.0), "band_hz"),
        (lambda: BandLimited(lines=0), "`lines` must be an integer >= 1"),
        (lambda: gaussian_posterior(BandLimited(), DT, 1, NOISE_STD), "`samples`"),
        (lambda: gaussian_posterior(Matern(), DT, 10, -1.0), "noise_std"),
        (lambda: gaussian_posterior("matern", DT, 10, NOISE_STD), "stationary random signal"),
        (
            lambda: Matern().draw(np.array([0.0, 0.0, 1.0]), np.random.default_rng(0)),
            "strictly increasing",
        ),
    ],
)
def test_bad_input_names_the_argument(call, message):
    with pytest.raises(ValueError, match=message):
        call()


# --- the band-limited family: no state, its exact posterior on the record ---------------------
BAND = BandLimited(band_hz=20.0, std=1.5, lines=200)


def test_band_limited_draws_have_exact_derivatives():
    # drawn at 10 µs: central differences of x (of ẋ) give ẋ (ẍ) to O(h²ω²/6) ≈ 3e-7
    step = 1e-5
    t = np.arange(0.0, 0.2, step)
    truth = BAND.draw(t, np.random.default_rng(3))
    for order in (1, 2):
        differences = (truth[order - 1][2:] - truth[order - 1][:-2]) / (2 * step)
        exact = truth[order][1:-1]
        relative = np.sqrt(np.mean((differences - exact) ** 2) / np.mean(exact**2))
        assert relative < 1e-6, (order, relative)


def test_band_limited_draws_have_its_covariance_and_the_flat_band_is_its_limit():
    # 4000 draws at three times: every sample covariance of (x, ẋ, ẍ) within 4.5 standard
    # errors of cross_covariance; r(τ) is σ² sinc(2Bτ) to within the lines' spacing
    t = np.array([0.0, 0.013, 0.05])
    rng = np.random.default_rng(11)
    draws = [BAND.draw(t, rng) for _ in range(4000)]
    values = {a: np.array([d[a] for d in draws]) for a in range(3)}
    for a in range(3):
        for b in range(3):
            for i, j in [(1, 0), (2, 0), (2, 1), (0, 0)]:
                pairs = values[a][:, i] * values[b][:, j]
                expected = BAND.cross_covariance(t[i] - t[j], a, b)[0]
                assert abs(pairs.mean() - expected) < 4.5 * pairs.std() / math.sqrt(len(draws))
    lags = np.linspace(0.0, 0.5, 101)
    np.testing.assert_allclose(
        BAND.cross_covariance(lags, 0, 0), 1.5**2 * np.sinc(2 * 20.0 * lags), rtol=0, atol=2e-3
    )
    variance = integrate.quad(BAND.spectral_density, -30.0, 30.0, points=[-20.0, 20.0])[0]
    assert variance == pytest.approx(1.5**2, rel=1e-9)
    # Var ẋ = σ² mean(ω_k²): the flat band's (2πB)²/3 σ² within the midpoint rule's error
    assert BAND.cross_covariance(0.0, 1, 1)[0] == pytest.approx(
        1.5**2 * (2 * np.pi * 20.0) ** 2 / 3, rel=1e-4
    )


@pytest.mark.parametrize("causal", [False, True])
def test_the_dense_posterior_of_a_matern_is_the_rts_smoother_and_kalman_filter(causal):
    # two independent computations of the same optimal estimate: the Gaussian posterior from
    # the covariance function and the state-space recursions
    signal = Matern(smoothness=2.5, length_scale_s=0.05)
    n = 300
    truth = signal.draw(np.arange(n) * DT, np.random.default_rng(0))
    y = truth[0] + NOISE_STD * np.random.default_rng(1).standard_normal(n)
    posterior = gaussian_posterior(signal, DT, n, NOISE_STD, causal=causal)
    states = optimal_states(signal, DT, NOISE_STD, y, causal=causal)
    for order in (1, 2):
        scale = math.sqrt(signal.model().stationary_covariance()[order, order])
        gap = np.max(np.abs(posterior.weights[order] @ y - states[:, order])) / scale
        assert gap < 1e-8, (order, gap)
    if causal:  # the estimate at k uses samples up to k only
        assert np.all(np.triu(posterior.weights[1], 1) == 0.0)
    # far from the ends the variance is the steady-state bound
    for order in (1, 2):
        bound = smoother_bound(signal, DT, NOISE_STD, order, causal=causal)
        assert posterior.variance[order][150] == pytest.approx(bound, rel=1e-3)


def test_the_band_limited_bound_is_reached_by_its_optimal_estimator_within_monte_carlo_error():
    # 300 realisations of 1001 samples; the error on the middle 401: the exact posterior's
    # realised mean square error against its variance, from every sample and causally
    n, count, noise_std = 1001, 300, 0.01
    t = np.arange(n) * DT
    rng = np.random.default_rng(5)
    truths = [BAND.draw(t, rng) for _ in range(count)]
    y = np.stack([truth[0] for truth in truths], axis=1) + noise_std * rng.standard_normal(
        (n, count)
    )
    middle = slice(300, 701)
    for causal in (False, True):
        posterior = gaussian_posterior(BAND, DT, n, noise_std, causal=causal)
        for order in (1, 2):
            exact = np.stack([truth[order][middle] for truth in truths], axis=1)
            errors = np.mean(((posterior.weights[order] @ y)[middle] - exact) ** 2, axis=0)
            mean, standard_error = errors.mean(), errors.std(ddof=1) / math.sqrt(count)
            bound = posterior.variance[order][middle].mean()
            assert standard_error < 0.05 * bound  # precise enough to fail
            assert abs(mean - bound) < 3 * standard_error, (causal, order, mean, bound)
            if causal:
                assert (
                    bound
                    > gaussian_posterior(BAND, DT, n, noise_std).variance[order][middle].mean()
                )


def test_the_band_limited_record_bound_is_near_the_infinite_records_wiener_integral():
    # ∫ (2πf)^2n S N/(S + N) df over the flat band (S = σ²/2B, N = σ_n² Δt) is the infinite
    # record's bound; 3 s of record cost the middle second 3-25 % more (measured: 6 and 10 %)
    signal = BandLimited(band_hz=20.0, std=1.0, lines=300)
    dt, n, noise_std = 2e-3, 1501, 0.01
    posterior = gaussian_posterior(signal, dt, n, noise_std)
    flat, density = 1.0 / 40.0, noise_std**2 * dt
    for order in (1, 2):
        wiener = (
            flat
            * density
            / (flat + density)
            * 2
            * (2 * np.pi) ** (2 * order)
            * 20.0 ** (2 * order + 1)
            / (2 * order + 1)
        )
        ratio = posterior.variance[order][500:1001].mean() / wiener
        assert 1.03 < ratio < 1.25, (order, ratio)


@pytest.mark.parametrize("signal", SIGNALS, ids=IDS)
@pytest.mark.parametrize("dt", [1e-5, 1e-3, 0.1])
def test_the_noise_root_and_covariance_agree_entry_by_entry(signal, dt):
    """R Rᵀ = Q to each entry's own precision, though the entries span many decades (the
    state scaled by Δt^k before the block exponential); Q against the continuous-time
    integral ∫ e^{Fs} q_c L Lᵀ e^{Fᵀs} ds by quadrature."""
    model = signal.model()
    A, Q = model.discretise(dt)
    same_a, root = model.transition_and_root(dt)
    assert np.array_equal(A, same_a)
    scale = np.sqrt(np.outer(np.diag(Q), np.diag(Q)))
    assert np.all(np.abs(root @ root.T - Q) <= 1e-12 * scale)

    def integrand(s):
        e = linalg.expm(model.F * s)
        return (e @ np.outer(model.L, model.L) @ e.T * model.q_c).ravel()

    exact = integrate.quad_vec(integrand, 0.0, dt, epsabs=0, epsrel=1e-13)[0].reshape(Q.shape)
    assert np.all(np.abs(Q - exact) <= 1e-9 * scale)
