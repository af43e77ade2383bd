"""The Kalman smoother against filterpy's own filter and smoother, with the gains of the
covariance recursion run for the record and with the cached prior's (their step tables), and
its compiled loops against themselves: padded to either width, channel by channel."""

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


@pytest.fixture(params=["recursion", "prior"])
def transient_path(request):
    """Runs a test with the gains of the covariance recursion run for the record, and again
    with :func:`kalman.prior_gains`' (the cached prior's, with their step tables, as the
    method runs on records of 4m samples or more)."""
    return request.param


def _fast_and_filterpy(model_order, n, bandwidth_hz, dt, transient_path="recursion"):
    """The smoothed states of a noisy sine plus parabola by rts_smooth and by filterpy."""
    rng = np.random.default_rng(n + model_order)
    t = np.arange(n) * dt
    z = np.sin(2 * np.pi * 3 * t) + 0.5 * t**2 + 0.1 * rng.standard_normal(n)
    model = polynomial_model(model_order, dt, bandwidth_hz)
    mean0, covariance0 = initial_state(z[:, None], model.per_step_coefficient)
    gains = None
    if transient_path == "prior":
        if n < 4 * model.states:
            pytest.skip("the prior's gains serve records of 4m samples or more")
        gains = kalman.prior_gains(model_order, dt, bandwidth_hz)
        assert gains.tables
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
def test_fast_smoother_equals_filterpy(model_order, n, bandwidth_hz, dt, transient_path):
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


def test_method_equals_filterpy_in_raw_derivative_units_on_every_channel():
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
def test_the_recursion_run_by_chunks_stops_at_the_first_converged_step(
    model_order, bandwidth_hz, n, monkeypatch
):
    """The recursion by chunks of steps gives the recursion run a step a call, bit for bit:
    the same number of steps (the first converged one, or n) and the same gains."""
    from diffbench.methods import kalman

    model = polynomial_model(model_order, 1e-3, bandwidth_hz)
    _, covariance0 = initial_state(np.zeros((16, 1)), model.per_step_coefficient)
    blocks = covariance_recursion(model, covariance0, n)
    monkeypatch.setattr(kalman, "RECURSION_CHUNK", 1)
    steps = covariance_recursion(model, covariance0, n)
    assert len(blocks.filter_gains) == len(steps.filter_gains) <= n
    assert np.array_equal(blocks.filter_gains, steps.filter_gains)
    assert np.array_equal(blocks.smoother_gains, steps.smoother_gains)


def _tables_and_record(model_order, bandwidth_hz, n, channels, width=None):
    """A noisy sine on ``channels`` channels, its prior, and the step tables of the prior's
    gains padded to ``width`` (default: the model's own, :func:`_kalman_loops.width`)."""
    from diffbench.methods import _kalman_loops as loops

    dt = 1e-3
    model = polynomial_model(model_order, dt, bandwidth_hz)
    gains = kalman.prior_gains(model_order, dt, bandwidth_hz)
    width = width or loops.width(model.states)
    tables = [
        np.asarray(loops.padded(table[(..., *(slice(0, model.states),) * axes)], axes, width))
        for table, axes in zip(gains.tables, (2, 1, 2, 2), strict=True)
    ]
    rng = np.random.default_rng(n + channels)
    t = np.arange(n) * dt
    z = np.sin(2 * np.pi * 3 * t)[:, None] + 0.05 * rng.standard_normal((n, channels))
    mean0, _ = initial_state(z, model.per_step_coefficient)
    return z, loops.padded(mean0.T, 1, width), tables, model.states


@pytest.mark.parametrize(("model_order", "bandwidth_hz"), [(2, 5.0), (3, 24.0), (3, 300.0)])
@pytest.mark.parametrize("n", [16, 300, 2000])
def test_a_model_padded_to_six_states_gives_the_bits_of_four(model_order, bandwidth_hz, n):
    """The compiled loop of 6 states on a model of 3 or 4 padded with zeros gives the bits of
    the loop of 4: each row's sum adds exact zero products (the wide loop's only other
    difference), so the two are equal bit for bit, not merely to rounding; and the padded
    states stay zero."""
    from diffbench.methods import _kalman_loops as loops

    z, start, tables, states = _tables_and_record(model_order, bandwidth_hz, n, 2)
    narrow = loops.smooth(z.T, start, *tables)
    z, start, tables, _ = _tables_and_record(model_order, bandwidth_hz, n, 2, width=6)
    wide = loops.smooth(z.T, start, *tables)
    assert np.array_equal(wide[:, :, :4], narrow)
    assert not wide[:, :, states:].any()


@pytest.mark.parametrize(("model_order", "bandwidth_hz"), [(3, 24.0), (5, 20.0)])
def test_a_channel_gives_the_same_bits_alone_and_among_many(model_order, bandwidth_hz):
    """A channel's smoothed states do not depend on the channels beside it (the ends check
    smooths a hundred probes at once, a call one record): the first of 112 channels, smoothed
    alone, bit for bit; and the components are the states asked, in the order asked."""
    dt = 1e-3
    model = polynomial_model(model_order, dt, bandwidth_hz)
    gains = kalman.prior_gains(model_order, dt, bandwidth_hz)
    n = len(gains.filter_gains) + 500
    z = _tables_and_record(model_order, bandwidth_hz, n, 112)[0]
    mean0, covariance0 = initial_state(z, model.per_step_coefficient)
    many = rts_smooth(z, model, mean0, covariance0, components=[2, 0, 1], gains=gains)
    alone = rts_smooth(z[:, :1], model, mean0[:, :1], covariance0, gains=gains)
    assert np.array_equal(many[:, :, 0], alone[:, [2, 0, 1], 0])


@pytest.mark.parametrize(
    ("model_order", "bandwidth_hz", "dt"), [(2, 20.0, 1e-3), (3, 24.0, 1e-3), (5, 2.0, 0.01)]
)
def test_the_compiled_covariance_steps_give_filterpys_gains(model_order, bandwidth_hz, dt):
    """Every step's filter gain K_k (from filterpy's predicted covariances: P⁻H/(HP⁻Hᵀ + R))
    and smoother gain C_k (``rts_smoother``'s own) against the compiled recursion's, over the
    whole transient from the vague prior. Both round differently from the ill-conditioned
    prior on (the smoothed states agree within 1e-8 of their size, or eps cond(VᵀV) at orders
    4 and 5: the tests above), so the gains are held to as much of their size; and the last
    step's gain is within CONVERGED (or the rounding floor) of the steady one."""
    from filterpy.kalman import KalmanFilter

    model = polynomial_model(model_order, dt, bandwidth_hz)
    _, covariance0 = initial_state(np.zeros((16, 1)), model.per_step_coefficient)
    gains = covariance_recursion(model, covariance0, 10**6)
    steps = len(gains.filter_gains)
    kf = KalmanFilter(dim_x=model.states, dim_z=1)
    kf.F, kf.Q, kf.R, kf.H = model.F, model.Q, np.array([[model.R]]), np.eye(1, model.states)
    kf.x, kf.P = np.zeros((model.states, 1)), covariance0.copy()
    means, covariances, _, predicted = kf.batch_filter(np.zeros(steps + 1))
    filter_gains = predicted[:, :, 0] / (predicted[:, 0, 0] + model.R)[:, None]
    _, _, smoother_gains, _ = kf.rts_smoother(means, covariances)
    vandermonde = np.arange(1.0, 4 * model.states + 1)[:, None] ** np.arange(model.states)
    relative = max(1e-8, np.finfo(float).eps * np.linalg.cond(vandermonde.T @ vandermonde))
    for ours, theirs in (
        (gains.filter_gains, filter_gains),
        (gains.smoother_gains, smoother_gains),
    ):
        scale = np.abs(theirs[:steps]).max()
        np.testing.assert_allclose(ours, theirs[:steps], rtol=0, atol=relative * scale)
    steady = gains.steady.filter_gain
    reach = model.F[0, 1]
    allowed = max(CONVERGED, ROUNDING / reach**2) * np.abs(steady).max()
    assert np.abs(gains.filter_gains[-1] - steady).max() <= allowed


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


def _filterpy_per_step(z, Fs, Qs, mean0, covariance0):
    """filterpy's filter and smoother with each step's own model (``Fs=``, ``Qs=``)."""
    from filterpy.kalman import KalmanFilter

    kf = KalmanFilter(dim_x=Fs.shape[1], dim_z=1)
    kf.x = mean0.copy()
    kf.P = covariance0.copy()
    kf.H = np.eye(1, Fs.shape[1])
    kf.R = np.eye(1)
    means, covariances, _, _ = kf.batch_filter(z, Fs=Fs, Qs=Qs)
    return kf.rts_smoother(means, covariances, Fs=Fs, Qs=Qs)[0]


@pytest.mark.parametrize(
    ("model_order", "bandwidth_hz", "n", "step"),
    [(2, 5.0, 3000, 1e-3), (3, 20.0, 2000, 2e-3), (4, 10.0, 1500, 1e-3), (5, 3.0, 1000, 1e-2)],
)
def test_the_smoother_at_irregular_times_is_filterpys_with_per_step_models(
    model_order, bandwidth_hz, n, step
):
    """irregular_smooth against filterpy's ``batch_filter`` + ``rts_smoother`` given the
    per-step transitions and noises (``Fs``, ``Qs`` of :func:`kalman.irregular_models`) at
    jittered times, on two channels at once, every state.

    Rounding: both carry the state scaled to steps, whose components are at most about
    max|x| for these signals; each starts from the least-squares prior through the first 4m
    samples (Vandermonde V: within eps cond(V) max|x| of it), and each of the n steps adds a
    few roundings of the state's size, which the stable filter and smoother only carry
    forward, not amplify. So each is within about eps (cond(V) + 4 n) max|x| of the exact
    states, and the two within twice that (seen: at most 0.06 of it)."""
    rng = np.random.default_rng(model_order)
    t = np.cumsum(step * (1 + 0.3 * rng.uniform(-1, 1, n)))
    x = np.stack([np.sin(2 * np.pi * 2 * t), 0.5 * t**2 - np.cos(t)], axis=1)
    x += 0.01 * rng.standard_normal(x.shape)
    Fs, Qs, _ = kalman.irregular_models(model_order, t, bandwidth_hz)
    states = model_order + 1
    steps = (t - t[0]) / ((t[-1] - t[0]) / (n - 1)) + 1.0
    mean0, covariance0 = initial_state(x, np.ones(states), steps)
    fast = kalman.irregular_smooth(x, Fs, Qs, 1.0, mean0, covariance0)
    vandermonde = steps[: 4 * states, None] ** np.arange(states)[None, :]
    for channel in range(x.shape[1]):
        reference = _filterpy_per_step(x[:, channel], Fs, Qs, mean0[:, channel], covariance0)
        size = np.max(np.abs(x[:, channel]))
        allowed = 2 * np.finfo(float).eps * (np.linalg.cond(vandermonde) + 4 * n) * size
        assert np.max(np.abs(fast[:, :, channel] - reference)) <= allowed


def test_the_per_step_models_are_the_uniform_model_at_each_gap():
    """Each step's F and Q of :func:`kalman.irregular_models` (all at once) are the uniform
    model's at that gap: F_ij = Δ^(j-i)/(j-i)!, Q = integrated_white_noise(Δ), in the states
    scaled by the mean step (to rounding: the same products in another order)."""
    t = np.array([0.0, 0.011, 0.019, 0.032, 0.040, 0.0515])
    Fs, Qs, to_derivatives = kalman.irregular_models(3, t, 7.0)
    h = (t[-1] - t[0]) / (t.size - 1)
    density = (2 * np.pi * 7.0) ** 8 * h
    scale = np.outer(to_derivatives, to_derivatives)
    for k, gap in enumerate(np.r_[h, np.diff(t)]):
        raw = np.array(
            [
                [gap ** (j - i) / math.factorial(j - i) if j >= i else 0.0 for j in range(4)]
                for i in range(4)
            ]
        )
        expected_f = raw * to_derivatives[None, :] / to_derivatives[:, None]
        np.testing.assert_allclose(Fs[k], expected_f, rtol=4 * np.finfo(float).eps, atol=0)
        expected_q = integrated_white_noise(4, gap, density) / scale
        np.testing.assert_allclose(Qs[k], expected_q, rtol=8 * np.finfo(float).eps, atol=0)
