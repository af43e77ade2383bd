"""The Kalman smoother against filterpy's own filter and smoother, by recursions and by
blocks (long records), its transient step by step and by block maps (the cached prior's)."""

import dataclasses
import math

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods import kalman
from diffbench.methods.kalman import (
    CONVERGED,
    ROUNDING,
    covariance_recursion,
    initial_state,
    integrated_white_noise,
    polynomial_model,
    rts_smooth,
    steady_state,
)


def _filterpy(z, model, mean0, covariance0):
    from filterpy.kalman import KalmanFilter

    kf = KalmanFilter(dim_x=model.states, dim_z=1)
    kf.F, kf.Q = model.F, model.Q
    kf.R = np.array([[model.R]])
    kf.H = np.eye(1, model.states)
    kf.x = mean0.reshape(-1, 1).copy()
    kf.P = covariance0.copy()
    means, covariances, _, _ = kf.batch_filter(z)
    smoothed, *_ = kf.rts_smoother(means, covariances)
    return smoothed[:, :, 0]


@pytest.fixture(params=["recursions", "blocks"])
def steady_path(request, monkeypatch):
    """Runs a test with the steady part by recursions (short records), and again by blocks
    (:func:`kalman._blocked_steady_passes`, long records) from 33 steady samples on."""
    if request.param == "blocks":
        monkeypatch.setattr(kalman, "BLOCKED_FROM", 1)
    return request.param


@pytest.fixture(params=["steps", "maps"])
def transient_path(request):
    """Runs a test with the transient stepped sample by sample (the recursion run for the
    record), and again by the block maps of :func:`kalman.prior_gains` (the cached prior's
    gains, as the method runs; on records longer than the transient)."""
    return request.param


def _fast_and_filterpy(model_order, n, bandwidth_hz, dt, transient_path="steps"):
    """The smoothed states of a noisy sine plus parabola by rts_smooth and by filterpy."""
    rng = np.random.default_rng(n + model_order)
    t = np.arange(n) * dt
    z = np.sin(2 * np.pi * 3 * t) + 0.5 * t**2 + 0.1 * rng.standard_normal(n)
    model = polynomial_model(model_order, dt, bandwidth_hz)
    mean0, covariance0 = initial_state(z[:, None], model.per_step_coefficient)
    gains = None
    if transient_path == "maps":
        gains = kalman.prior_gains(model_order, dt, bandwidth_hz)
        if n <= len(gains.filter_gains):
            pytest.skip("the block maps serve records longer than the transient")
        maps = kalman.transient_maps(gains.filter_gains, gains.smoother_gains, model.F)
        gains = dataclasses.replace(gains, transient=maps)
    fast = rts_smooth(z[:, None], model, mean0, covariance0, gains=gains)[:, :, 0]
    reference = _filterpy(z, model, mean0[:, 0], covariance0)
    return fast, reference


@pytest.mark.parametrize(
    ("model_order", "n", "bandwidth_hz", "dt"),
    [
        (2, 9, 20.0, 1e-3),
        (2, 60, 20.0, 1e-3),
        (3, 60, 40.0, 1e-3),
        (2, 3000, 20.0, 1e-3),
        (3, 3000, 5.0, 1e-3),
        (2, 500, 1.0, 0.01),
        (3, 2500, 60.0, 1e-3),
        (2, 4000, 150.0, 1e-3),
        (3, 3000, 300.0, 1e-3),
        (3, 1500, 440.0, 1e-3),
    ],
)
def test_fast_smoother_equals_filterpy(
    model_order, n, bandwidth_hz, dt, steady_path, transient_path
):
    fast, reference = _fast_and_filterpy(model_order, n, bandwidth_hz, dt, transient_path)
    scale = np.max(np.abs(reference), axis=0)
    # the vague prior (PRIOR_SCALE) leaves the first steps ill-conditioned: both computations
    # round differently there (measured 4e-9 of the jerk state's size at 5 Hz, 3000 samples)
    assert np.all(np.max(np.abs(fast - reference), axis=0) <= 1e-8 * scale)


@pytest.mark.parametrize(
    ("model_order", "n", "bandwidth_hz", "dt"),
    [(4, 3000, 20.0, 1e-3), (5, 3000, 24.0, 1e-3), (5, 500, 2.0, 0.01)],
)
def test_fast_smoother_equals_filterpy_at_the_higher_orders(
    model_order, n, bandwidth_hz, dt, transient_path
):
    """Orders 4 and 5 against filterpy too. Their vague prior is fitted through the first 4m
    samples by a Vandermonde V of m = 5, 6 columns (cond(VᵀV) 2e11, 9e14), whose inverse the
    prior's covariance is: the two computations start from it rounded differently, and the
    first estimates can differ by up to eps cond(VᵀV) times the state's size (seen: at most
    3e-6 of it, under SkylakeX, Haswell and Sandybridge)."""
    fast, reference = _fast_and_filterpy(model_order, n, bandwidth_hz, dt, transient_path)
    states = model_order + 1
    steps = np.arange(1, 4 * states + 1, dtype=float)
    vandermonde = steps[:, None] ** np.arange(states)[None, :]
    allowed = np.finfo(float).eps * np.linalg.cond(vandermonde.T @ vandermonde)
    assert np.max(np.abs(fast - reference)) <= allowed * np.max(np.abs(reference))


def test_the_fast_path_is_taken_and_the_transient_is_short_of_the_signal():
    model = polynomial_model(3, 1e-3, 24.0)
    _, covariance0 = initial_state(np.zeros((16, 1)), model.per_step_coefficient)
    gains = covariance_recursion(model, covariance0, 10**6)
    assert 50 < len(gains.filter_gains) < 5000  # steady long before 1e6 samples


@pytest.mark.parametrize("model_order", [2, 3, 4, 5])
@pytest.mark.parametrize("bandwidth_steps", [1e-4, 1e-3, 0.024, 0.3, 0.49])
def test_the_steady_state_solves_the_riccati_equation_and_the_recursion_reaches_it(
    model_order, bandwidth_steps
):
    """solve_discrete_are's P⁻ satisfies the Riccati equation (residual ~ rounding); the
    covariance recursion from the vague prior reaches it within 3 m / (bandwidth_hz * dt)
    steps, m = model_order + 1 states (measured 3.5 to 13.2, at most 2.2 m), its last gains
    are the steady ones to the tolerance, and the smoother gain is the recursion's formula
    at that P."""
    dt = 1e-3
    model = polynomial_model(model_order, dt, bandwidth_steps / dt)
    F, Q, R = model.F, model.Q, model.R
    steady = steady_state(model.F, model.Q, model.R)
    predicted = F @ steady.covariance @ F.T + Q
    gain = predicted[:, 0] / (predicted[0, 0] + R)
    np.testing.assert_allclose(gain, steady.filter_gain, rtol=1e-9, atol=0)
    update = predicted - np.outer(gain, predicted[0])  # (I - KH) P⁻, equal to Joseph's form
    scale = np.sqrt(np.outer(np.diag(steady.covariance), np.diag(steady.covariance)))
    assert np.all(abs(update - steady.covariance) <= 1e-9 * scale)
    _, covariance0 = initial_state(np.zeros((16, 1)), model.per_step_coefficient)
    gains = covariance_recursion(model, covariance0, 10**6)
    assert len(gains.filter_gains) <= 3 * (model_order + 1) / bandwidth_steps
    tolerance = max(CONVERGED, ROUNDING / (2 * np.pi * bandwidth_steps) ** 2)
    last = gains.filter_gains[-1]
    assert abs(last - steady.filter_gain).max() <= tolerance * abs(steady.filter_gain).max()
    np.testing.assert_allclose(
        gains.smoother_gains[-1],
        steady.smoother_gain,
        rtol=0,
        atol=1e-6 * abs(steady.smoother_gain).max(),
    )


def test_the_steady_response_is_what_the_time_domain_gives_at_a_low_bandwidth():
    """At 0.2 Hz and 1 kHz (bandwidth_hz * dt = 2e-4, where the covariance in states scaled by
    Δt^j/j! had condition number 6e19 and its smoother gain wandered by 1e-5) the frequency
    response from the steady state matches the smoother run on a long sinusoid."""
    dt, bandwidth, frequency = 1e-3, 0.2, 0.05
    method = methods.get("kalman", bandwidth_hz=bandwidth, model_order=3)
    n = 150_000
    t = np.arange(n) * dt
    middle = slice(n // 2 - 1000, n // 2 + 1000)
    estimates = method(np.sin(2 * np.pi * frequency * t), dt)
    for order in (0, 1, 2):
        response = method.frequency_response([frequency], dt, order)[0]
        estimate = estimates[order][middle]
        expected = np.imag(response * np.exp(2j * np.pi * frequency * t[middle]))
        np.testing.assert_allclose(
            estimate, expected, rtol=0, atol=1e-7 * (2 * np.pi * frequency) ** order
        )


def test_method_equals_filterpy_in_raw_derivative_units_on_every_channel(steady_path):
    dt = 1e-3
    rng = np.random.default_rng(5)
    x = rng.standard_normal((700, 2)).cumsum(axis=0) * 0.01
    method = methods.get("kalman", bandwidth_hz=30.0, model_order=2)
    estimate = method(x, dt)
    model = method.model(dt)
    for channel in range(2):
        mean0, covariance0 = initial_state(x[:, [channel]], model.per_step_coefficient)
        reference = _filterpy(x[:, channel], model, mean0[:, 0], covariance0)
        for order in (0, 1, 2):
            expected = reference[:, order] * model.to_derivatives[order]
            valid = estimate.valid[order]
            assert valid[100:-100].all()
            np.testing.assert_allclose(
                estimate[order][valid, channel],
                expected[valid],
                rtol=0,
                atol=1e-9 * np.max(np.abs(expected)),
            )


def test_scaled_model_is_filterpys_model_in_other_units():
    """F' = T F T^-1 and Q' = T Q T^T with T = diag(dt^j / j!), F and Q from filterpy's
    conventions (Q_continuous_white_noise)."""
    from filterpy.common import Q_continuous_white_noise

    dt, bandwidth = 2e-3, 10.0
    model = polynomial_model(3, dt, bandwidth)
    raw_f = np.array(
        [[1, dt, dt**2 / 2, dt**3 / 6], [0, 1, dt, dt**2 / 2], [0, 0, 1, dt], [0, 0, 0, 1]]
    )
    density = (2 * np.pi * bandwidth) ** 8 * dt
    raw_q = Q_continuous_white_noise(dim=4, dt=dt, spectral_density=density)
    scale = np.diag(1 / model.to_derivatives)
    np.testing.assert_allclose(model.F, scale @ raw_f @ np.linalg.inv(scale), rtol=1e-12)
    np.testing.assert_allclose(model.Q, scale @ raw_q @ scale.T, rtol=1e-12)


def test_bandwidth_is_the_half_gain_point_of_the_steady_smoother():
    """|H(f_b)| ~ 1/2 for the smoothed position (exact for the continuous Wiener smoother)."""
    for model_order, bandwidth in ((2, 10.0), (3, 24.0)):
        method = methods.get("kalman", bandwidth_hz=bandwidth, model_order=model_order)
        gain = abs(method.frequency_response([bandwidth], 1e-3, 0)[0])
        assert gain == pytest.approx(0.5, abs=0.02)
        assert abs(method.frequency_response([bandwidth / 10], 1e-3, 0)[0]) == pytest.approx(
            1.0, abs=1e-3
        )


@pytest.mark.parametrize(
    ("params", "dt", "x", "message"),
    [
        ({"bandwidth_hz": 0.0}, 1e-3, None, r"`bandwidth_hz` must be a finite number in \(0, "),
        ({"bandwidth_hz": -3.0}, 1e-3, None, r"`bandwidth_hz` must be a finite number"),
        ({"model_order": 6}, 1e-3, None, r"`model_order` must be one of \{2, 3, 4, 5\}"),
        ({"model_order": 1}, 1e-3, None, r"`model_order` must be one of \{2, 3, 4, 5\}"),
        ({"bandwidth_hz": 600.0}, 1e-3, np.zeros(100), r"`bandwidth_hz` must be below the Nyquist"),
        ({}, 1e-3, np.r_[np.zeros(50), np.nan], r"`x` holds 1 NaN"),
        ({}, 1e-3, np.zeros(5), r"`x` has 5 samples on axis 0; at least 6"),
    ],
)
def test_bad_input(params, dt, x, message):
    with pytest.raises(ValueError, match=message):
        method = methods.get("kalman", **params)
        method(np.zeros(100) if x is None else x, dt)


@pytest.mark.parametrize(
    ("model_order", "bandwidth_hz", "n"),
    [(2, 20.0, 10**6), (3, 300.0, 10**6), (3, 5.0, 37), (2, 1.0, 16)],
)
def test_the_recursion_tested_by_blocks_stops_at_the_first_converged_step(
    model_order, bandwidth_hz, n, monkeypatch
):
    """The convergence test on blocks of steps gives the recursion tested step by step, bit
    for bit: the same number of steps (the first converged one, or n) and the same gains."""
    from diffbench.methods import kalman

    model = polynomial_model(model_order, 1e-3, bandwidth_hz)
    _, covariance0 = initial_state(np.zeros((16, 1)), model.per_step_coefficient)
    blocks = covariance_recursion(model, covariance0, n)
    monkeypatch.setattr(kalman, "CONVERGENCE_BLOCK", 1)
    steps = covariance_recursion(model, covariance0, n)
    assert len(blocks.filter_gains) == len(steps.filter_gains) <= n
    assert np.array_equal(blocks.filter_gains, steps.filter_gains)
    assert np.array_equal(blocks.smoother_gains, steps.smoother_gains)


@pytest.mark.parametrize(
    ("model_order", "bandwidth_hz"), [(3, 24.0), (2, 5.0), (2, 100.0), (3, 300.0)]
)
@pytest.mark.parametrize(("n", "channels"), [(33, 1), (34, 1), (65, 2), (1001, 3), (2000, 1)])
def test_the_blocks_give_the_recursions_values(model_order, bandwidth_hz, n, channels):
    """The steady part by blocks of 32 against the same by recursions, for records of one
    block and a tail of 1 or 2 samples up to 62 blocks, one to three channels (the output not
    contiguous), the components asked in any order: to rounding, and the whole state at k = 0
    the same.

    Rounding: both evaluate the same linear map in the eigenbases V (filter) and W (smoother),
    whose changes of basis amplify a relative error by at most cond(V) cond(W); a first-order
    recursion with pole |p| accumulates eps per step over about g = 1 / (1 - max|p|) steps on
    values up to g times its input (eps g^2), and a block's products sum B = 32 terms. So each
    may differ from the exact map by about eps cond(V) cond(W) (B + g^2) times the output's
    size; the two are allowed that between them (seen: at most 0.021 of it, under OpenBLAS's
    SkylakeX, Haswell, Sandybridge and Prescott kernels)."""
    model = polynomial_model(model_order, 1e-3, bandwidth_hz)
    steady = steady_state(model.F, model.Q, model.R)
    rng = np.random.default_rng(n)
    t = np.arange(n) * 1e-3
    z = np.sin(2 * np.pi * 3 * t)[:, None] + 0.05 * rng.standard_normal((n, channels))
    before = rng.standard_normal((model.states, channels))
    components = [2, 0, 1] if channels > 1 else list(range(model.states))
    expected, expected_state = kalman._steady_passes(z, steady, model.F, before, components)
    blocks = np.full((len(components), n, channels), np.nan)
    state = kalman._blocked_steady_passes(z, steady, model.F, before, components, blocks)
    modes = kalman._smoother_modes(steady, model.F)
    growth = 1 / (1 - max(np.abs(modes.poles).max(), np.abs(modes.poles_c).max()))
    condition = np.linalg.cond(modes.vectors) * np.linalg.cond(modes.vectors_c)
    relative = np.finfo(float).eps * condition * (kalman.BLOCK_STEPS + growth**2)
    for row in range(len(components)):
        scale = np.max(np.abs(expected[row]))
        np.testing.assert_allclose(blocks[row], expected[row], rtol=0, atol=relative * scale)
    np.testing.assert_allclose(
        state, expected_state, rtol=0, atol=relative * np.max(np.abs(expected_state))
    )


def test_a_steady_part_of_one_sample_is_smoothed():
    """A record one sample longer than the covariance transient: the steady recursions run
    on one sample forward and none backward (an IndexError until 2026-11-27)."""
    dt, bandwidth_hz = 1e-3, 100.0
    model = polynomial_model(2, dt, bandwidth_hz)
    _, covariance0 = initial_state(np.zeros((12, 1)), model.per_step_coefficient)
    n = len(covariance_recursion(model, covariance0, 10**6).filter_gains) + 1
    z = np.sin(np.arange(n) * 0.01)
    mean0, covariance0 = initial_state(z[:, None], model.per_step_coefficient)
    fast = rts_smooth(z[:, None], model, mean0, covariance0)[:, :, 0]
    reference = _filterpy(z, model, mean0[:, 0], covariance0)
    assert np.all(np.max(np.abs(fast - reference), axis=0) <= 1e-8 * np.max(abs(reference), 0))


@pytest.mark.parametrize("states", [2, 3, 4])
@pytest.mark.parametrize("dt", [1e-4, 1e-3, 0.37])
def test_the_process_noise_is_filterpy_s_where_filterpy_has_one(states, dt):
    """integrated_white_noise against filterpy's Q_continuous_white_noise (2 to 4 states):
    each entry is q dt^p over a product of small integers on both sides, a handful of
    roundings each: within 16 eps relative."""
    from filterpy.common import Q_continuous_white_noise

    ours = integrated_white_noise(states, dt, 3.7)
    theirs = np.asarray(Q_continuous_white_noise(dim=states, dt=dt, spectral_density=3.7))
    np.testing.assert_allclose(ours, theirs, rtol=16 * np.finfo(float).eps, atol=0)


def test_the_process_noise_is_the_integral_of_the_state_transition():
    """Beyond filterpy's reach (6 states), Q = ∫₀^Δt e^{Fs} G q Gᵀ e^{Fᵀs} ds (Van Loan),
    the integral by scipy's adaptive quadrature of each entry (a polynomial in s, integrated
    to its relative tolerance 1e-12)."""
    from scipy import integrate

    states, dt, q = 6, 0.3, 2.5

    def integrand(s, i, j):
        # e^{Fs} G: the column of the integrated white noise, s^(m-1-i) / (m-1-i)!
        a = s ** (states - 1 - i) / math.factorial(states - 1 - i)
        b = s ** (states - 1 - j) / math.factorial(states - 1 - j)
        return q * a * b

    expected = np.array(
        [
            [
                integrate.quad(integrand, 0.0, dt, args=(i, j), epsrel=1e-12)[0]
                for j in range(states)
            ]
            for i in range(states)
        ]
    )
    np.testing.assert_allclose(integrated_white_noise(states, dt, q), expected, rtol=1e-11)


@pytest.mark.parametrize("model_order", [4, 5])
def test_the_higher_orders_reproduce_their_polynomials_on_every_estimated_sample(model_order):
    """A polynomial of degree ``model_order`` is the model's own noise-free signal: the
    smoother reproduces it and its derivatives on every sample it estimates, ends included.
    Rounding: as for the irregular-times test (test_time_stamps), within eps cond(V) max|x|
    j!/h^j for order j, V the prior's Vandermonde through the first 4m samples (seen: at
    most 1e-6 of it)."""
    dt = 1e-3
    method = methods.get("kalman", model_order=model_order, bandwidth_hz=20.0)
    t = np.arange(2000) * dt
    poly = np.polynomial.Polynomial([0.3, -1.0, 2.0, 1.5, -0.8, 0.4][: model_order + 1])
    estimate = method(poly(t), dt)
    states = model_order + 1
    steps = np.arange(1, 4 * states + 1, dtype=float)
    condition = np.linalg.cond(steps[:, None] ** np.arange(states)[None, :])
    for order in (0, 1, 2):
        estimated = estimate.estimated(order)
        assert estimated.all()
        truth = poly.deriv(order)(t) if order else poly(t)
        allowed = (
            np.finfo(float).eps
            * condition
            * np.max(np.abs(poly(t)))
            * math.factorial(order)
            / dt**order
        )
        np.testing.assert_allclose(estimate[order], truth, rtol=0, atol=allowed)


@pytest.mark.parametrize(("model_order", "bandwidth_hz"), [(2, 20.0), (3, 24.0), (5, 200.0)])
def test_the_transient_maps_are_the_steps_composed(model_order, bandwidth_hz):
    """Each block map applied to a basis vector is the recursion stepped through the block
    from it: Φ_i e_l the filter's i-th state from ŝ_{a-1} = e_l and no data, Ψ_ij the one from
    a unit sample at a + j; Γ_i, Ω_ij likewise backward. Each is a product of at most B
    matrices (rounding eps per product and entry, over entries summed with their absolute
    values: within B m eps times the product of the absolute matrices)."""
    dt = 1e-3
    gains = kalman.prior_gains(model_order, dt, bandwidth_hz)
    model = polynomial_model(model_order, dt, bandwidth_hz)
    m, F = model.states, model.F
    maps = kalman.transient_maps(gains.filter_gains, gains.smoother_gains, F)
    for block in sorted({min(1, len(maps.forward_state) - 1), len(maps.forward_state) - 1}):
        _check_block(gains, F, m, maps, block)  # the second (a full one) and the last


def _check_block(gains, F, m, maps, block):
    """One block of :func:`kalman.transient_maps` against its steps (see the test above)."""
    a = kalman.TRANSIENT_BLOCK * block
    size = maps.forward_state[block].shape[0]
    transitions = [F - np.outer(gains.filter_gains[a + i], F[0]) for i in range(size)]
    smoother = [gains.smoother_gains[a + i] for i in range(size)]
    eps = np.finfo(float).eps
    bound_forward, bound_backward = np.eye(m), np.eye(m)
    for i in range(size):
        bound_forward = np.abs(transitions[i]) @ bound_forward
        state = np.eye(m)
        for k in range(i + 1):
            state = transitions[k] @ state
        tolerance = size * m * eps * bound_forward
        assert np.all(np.abs(maps.forward_state[block][i] - state) <= tolerance)
        for j in range(i + 1):
            column = gains.filter_gains[a + j]
            for k in range(j + 1, i + 1):
                column = transitions[k] @ column
            np.testing.assert_allclose(
                maps.forward_data[block][i, :, j], column, rtol=0, atol=tolerance.max()
            )
    last = size - 1
    for i in range(last, -1, -1):
        bound_backward = np.abs(smoother[i]) @ bound_backward
        state = np.eye(m)
        for k in range(last, i - 1, -1):
            state = smoother[k] @ state
        tolerance = size * m * eps * bound_backward
        assert np.all(np.abs(maps.backward_state[block][i] - state) <= tolerance)
        own = np.eye(m) - smoother[i] @ F
        np.testing.assert_array_equal(maps.backward_data[block][i, :, i], own)
        for j in range(i + 1, size):
            through = np.eye(m) - smoother[j] @ F
            for k in range(j - 1, i - 1, -1):
                through = smoother[k] @ through
            scale = np.abs(through).max() + np.abs(own).max()
            np.testing.assert_allclose(
                maps.backward_data[block][i, :, j], through, rtol=0, atol=tolerance.max() * scale
            )


def test_cached_gains_run_their_maps_on_few_channels_and_short_transients_only():
    """Records of a few channels, longer than a transient of at most MAPS_MAX_STEPS steps, run
    it by the cached block maps; many channels or a longer transient step: a rule on the call
    alone, so the same call gives the same bits before and after the maps exist, and the
    maps' memory stays bounded (a transient of 8276 steps at order 5 would hold 94 MB)."""
    dt, bandwidth_hz = 1e-3, 37.0
    kalman._maps_of_prior.cache_clear()
    gains = kalman.prior_gains(3, dt, bandwidth_hz)
    assert len(gains.filter_gains) <= kalman.MAPS_MAX_STEPS
    model = polynomial_model(3, dt, bandwidth_hz)
    rng = np.random.default_rng(1)
    n = len(gains.filter_gains) + 300

    def smoothed(channels):
        z = np.sin(np.arange(n) * 0.01)[:, None] + 0.01 * rng.standard_normal((n, channels))
        mean0, covariance0 = initial_state(z, model.per_step_coefficient)
        return lambda: rts_smooth(z, model, mean0, covariance0, gains=gains)

    wide = smoothed(kalman.MAPS_MAX_CHANNELS + 1)
    before = wide()
    assert kalman._maps_of_prior.cache_info().currsize == 0
    narrow = smoothed(kalman.MAPS_MAX_CHANNELS)
    first = narrow()
    assert kalman._maps_of_prior.cache_info().currsize == 1
    assert np.array_equal(narrow(), first) and np.array_equal(wide(), before)
    long = kalman.prior_gains(5, dt, 2.0)  # a transient of thousands of steps
    assert len(long.filter_gains) > kalman.MAPS_MAX_STEPS
    assert kalman._cached_maps(long, 1) is None
    assert kalman.covariance_recursion(model, gains.steady.covariance, 10).key is None
