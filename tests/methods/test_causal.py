"""The causal (online) methods: causality, streams equal to the batch bit for bit, and each
method against an independent implementation or exact truth."""

import math

import numpy as np
import pytest
from scipy import signal as sps

from diffbench import methods
from diffbench.methods import levant

CAUSAL = methods.available(causal=True)
DT = 1e-3


def _record(n=1500, channels=(), seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    clean = np.sin(2 * np.pi * 3 * t) + 0.3 * np.sin(2 * np.pi * 11 * t + 0.4)
    clean = clean.reshape((n,) + (1,) * len(channels)) * (
        1 + np.arange(np.prod(channels, dtype=int))
    ).reshape((1, *channels))
    return clean + 0.01 * rng.standard_normal(clean.shape)


def test_the_causal_methods_are_registered_apart_from_the_offline_ones():
    assert set(CAUSAL) == {
        "alpha_beta_gamma",
        "backward_difference",
        "causal_butterworth",
        "causal_jacobi",
        "high_gain_observer",
        "kalman_filter",
        "levant",
    }
    assert not set(CAUSAL) & set(methods.available())
    assert methods.available(causal=None) == sorted(set(CAUSAL) | set(methods.available()))
    assert all(methods.method_class(name).causal for name in CAUSAL)


@pytest.mark.parametrize("name", CAUSAL)
def test_changing_later_samples_never_changes_an_estimate(name):
    method = (
        methods.preset(name, "paper-signal")
        if "paper-signal" in methods.method_class(name).presets
        else methods.get(name)
    )
    x = _record(800)
    before = method(x, DT)
    for cut in (0, 1, 400, 797):  # (causal_jacobi with mu > 0 gives the newest sample no weight)
        changed = x.copy()
        changed[cut + 1 :] += np.random.default_rng(cut).standard_normal(changed.size - cut - 1)
        after = method(changed, DT)
        for order in (0, 1, 2):
            assert np.array_equal(
                after[order][: cut + 1], before[order][: cut + 1], equal_nan=True
            ), (name, cut, order)
        # and the change is seen after the cut (levant's ẍ sees only the sign of its error)
        assert not np.array_equal(after[0][cut + 1 :], before[0][cut + 1 :], equal_nan=True)


@pytest.mark.parametrize("name", CAUSAL)
@pytest.mark.parametrize("channels", [(), (2,)])
def test_a_stream_in_chunks_of_any_size_gives_the_batch_result_bit_for_bit(name, channels):
    method = methods.get(name)
    x = _record(600, channels)
    batch = method(x, DT)
    for size in (1, 7, x.shape[0]):
        stream = method.stream(DT)
        pieces = [stream.push(x[start : start + size]) for start in range(0, x.shape[0], size)]
        assert stream.samples == x.shape[0]
        for order in (0, 1, 2):
            streamed = np.concatenate([piece[order] for piece in pieces])
            assert np.array_equal(streamed, batch[order], equal_nan=True), (size, order)
            assert np.array_equal(
                np.concatenate([p.valid[order] for p in pieces]), batch.valid[order]
            )


def test_one_sample_at_a_time_may_come_as_scalars_or_rows():
    method = methods.get("alpha_beta_gamma")
    x = _record(50, (3,))
    rows = method.stream(DT, channels=(3,))
    estimates = [rows.push(sample)[1] for sample in x]
    np.testing.assert_array_equal(np.concatenate(estimates), method(x, DT)[1])
    single = method.stream(DT)
    scalars = [single.push(float(sample))[1] for sample in x[:, 0]]
    np.testing.assert_array_equal(np.concatenate(scalars), method(x[:, 0], DT)[1])


@pytest.mark.parametrize(
    ("push", "message"),
    [
        (np.zeros((0,)), "no sample"),
        (np.array([1.0, np.nan]), "NaN or inf"),
        (np.zeros((3, 2)), r"shape \(2,\), the stream's are \(\)"),
        ("a", "real numbers"),
    ],
)
def test_a_stream_refuses_bad_chunks_by_name(push, message):
    stream = methods.get("backward_difference").stream(DT)
    stream.push(np.zeros(4))
    with pytest.raises(ValueError, match=message):
        stream.push(push)


def _weighted_fit_derivative(samples, tau, weights, degree, order, at_tau, half_span_s):
    """Independent: numpy's weighted polyfit in tau, differentiated at at_tau (d/ds =
    (1/half_span) d/dtau)."""
    keep = weights > 0
    coefficients = np.polynomial.polynomial.polyfit(
        tau[keep], samples[keep], degree, w=np.sqrt(weights[keep])
    )
    derivative = np.polynomial.polynomial.polyder(coefficients, order)
    return np.polynomial.polynomial.polyval(at_tau, derivative) / half_span_s**order


@pytest.mark.parametrize(
    ("kappa", "mu", "q", "window_s", "delay_s"),
    [
        (1.0, 1.0, 1, 0.02, 0.0),
        (0.0, 0.0, 0, 0.01, 0.0),
        (2.5, 0.5, 2, 0.04, 0.007),
        (4.0, 0.0, 3, 0.03, 0.03),
    ],
)
def test_causal_jacobi_is_the_weighted_least_squares_fit_on_the_past_window(
    kappa, mu, q, window_s, delay_s
):
    method = methods.get(
        "causal_jacobi",
        kappa=kappa,
        mu=mu,
        q=q,
        window_s=window_s,
        accel_window_s=window_s,
        delay_s=delay_s,
    )
    x = _record(200)
    estimate = method(x, DT)
    half = round(window_s / DT / 2)
    tau = np.linspace(-1, 1, 2 * half + 1)  # oldest ... newest
    with np.errstate(divide="ignore"):
        weights = (1 - tau) ** mu * (1 + tau) ** kappa
    at_tau = 1 - 2 * delay_s / window_s
    for order in (0, 1, 2):
        assert not estimate.valid[order][: 2 * half].any()
        for k in (2 * half, 120, 199):
            window = x[k - 2 * half : k + 1]
            expected = _weighted_fit_derivative(
                window, tau, weights, order + q, order, at_tau, window_s / 2
            )
            assert estimate[order][k] == pytest.approx(expected, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("name", ["backward_difference", "causal_jacobi"])
def test_fir_methods_are_exact_on_the_polynomials_they_claim(name):
    method = (
        methods.get(name, accuracy=3) if name == "backward_difference" else methods.get(name, q=2)
    )
    dt = 0.01  # long enough a record that a degree more shows
    t = np.arange(400) * dt
    for order in (0, 1, 2):
        degree = method.exact_degree(order)
        degree = 5 if math.isinf(degree) else int(degree)
        coefficients = np.linspace(0.5, 1.5, degree + 1)
        poly = np.polynomial.Polynomial(coefficients)
        estimate = method(poly(t), dt)
        truth = poly.deriv(order)(t) if order else poly(t)
        valid = estimate.valid[order]
        np.testing.assert_allclose(
            estimate[order][valid], truth[valid], rtol=1e-7, atol=1e-7 * np.abs(truth).max()
        )
        if order == 0 and name == "backward_difference":
            continue  # the sample itself, exact on anything
        # one degree more is not reproduced
        higher = np.polynomial.Polynomial(np.r_[coefficients, 1.0])
        truth = higher.deriv(order)(t)
        assert np.abs(method(higher(t), dt)[order][valid] - truth[valid]).max() > 1e-6


def test_causal_butterworth_is_scipys_filter_then_backward_differences():
    method = methods.get("causal_butterworth", order=3, cutoff_hz=30.0, difference_accuracy=1)
    x = _record(500)
    sos = sps.butter(3, 30.0, output="sos", fs=1 / DT)
    smoothed, _ = sps.sosfilt(sos, x, zi=sps.sosfilt_zi(sos) * x[0])
    padded = np.r_[x[0], x[0], smoothed]  # at rest before the first sample
    estimate = method(x, DT)
    np.testing.assert_allclose(estimate[0], smoothed, rtol=0, atol=1e-12)
    np.testing.assert_allclose(estimate[1], np.diff(padded)[1:] / DT, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(estimate[2], np.diff(padded, 2) / DT**2, rtol=1e-9, atol=1e-6)


def test_the_kalman_filter_is_filterpys_batch_filter():
    from filterpy.common import Q_continuous_white_noise
    from filterpy.kalman import KalmanFilter

    x = _record(1200, (2,))
    for model_order, bandwidth_hz in ((2, 8.0), (3, 25.0)):
        method = methods.get("kalman_filter", model_order=model_order, bandwidth_hz=bandwidth_hz)
        estimate = method(x, DT)
        states = model_order + 1
        to_derivatives = np.array([math.factorial(j) / DT**j for j in range(states)])
        # the prior of `kalman`'s start, in raw derivative units
        steps = np.arange(1, 4 * states + 1, dtype=float)
        vandermonde = steps[:, None] ** np.arange(states)[None, :]
        scaled = 1e6 * np.linalg.inv(vandermonde.T @ vandermonde)
        for channel in range(2):
            kf = KalmanFilter(dim_x=states, dim_z=1)
            kf.F = np.array(
                [
                    [
                        DT ** (j - i) / math.factorial(j - i) if j >= i else 0.0
                        for j in range(states)
                    ]
                    for i in range(states)
                ]
            )
            density = (2 * math.pi * bandwidth_hz) ** (2 * states) * DT
            kf.Q = Q_continuous_white_noise(dim=states, dt=DT, spectral_density=density)
            kf.R = np.array([[1.0]])
            kf.H = np.eye(1, states)
            kf.x = np.zeros((states, 1))
            kf.x[0, 0] = x[0, channel]
            kf.P = scaled * np.outer(to_derivatives, to_derivatives)
            means, *_ = kf.batch_filter(x[:, channel])
            for order in (0, 1, 2):
                expected = means[:, order, 0]
                np.testing.assert_allclose(
                    estimate[order][:, channel],
                    expected,
                    rtol=0,
                    atol=1e-9 * np.abs(expected).max(),
                )


def test_alpha_beta_gamma_follows_a_constant_acceleration_with_no_steady_error():
    method = methods.get("alpha_beta_gamma", memory_s=0.01)
    alpha, beta, gamma = method.gains(DT)
    theta = math.exp(-0.1)
    assert (alpha, beta, gamma) == pytest.approx(
        (1 - theta**3, 1.5 * (1 - theta**2) * (1 - theta), 0.5 * (1 - theta) ** 3)
    )
    t = np.arange(3000) * DT
    x = 0.3 + 2.0 * t - 7.0 * t**2
    estimate = method(x, DT)
    late = t > 1.5  # theta^1500 = e^-150: the transient is gone
    truths = (x, 2.0 - 14.0 * t, np.full_like(t, -14.0))
    for order, truth in enumerate(truths):
        np.testing.assert_allclose(estimate[order][late], truth[late], rtol=0, atol=1e-6)
    # and the closed-loop poles are all at theta (critically damped)
    transition, gain = method._model(DT)
    poles = np.linalg.eigvals(transition - np.outer(gain, transition[0]))
    np.testing.assert_allclose(poles, theta, atol=2e-5)


@pytest.mark.parametrize("dimension", [3, 4])
def test_the_high_gain_observer_is_the_continuous_observer_on_the_interpolated_samples(
    dimension,
):
    """Khalil's equations in the unscaled states z, integrated by solve_ivp (DOP853, tight
    tolerances) from sample to sample with y the line between them: the method's estimate
    at every sample, to the integrator's accuracy."""
    from scipy.integrate import solve_ivp

    epsilon = 0.01
    gains = np.array([math.comb(dimension, i) for i in range(1, dimension + 1)])
    gains = gains / epsilon ** np.arange(1, dimension + 1)
    x = _record(200)

    def observer(t, z, start, slope):
        innovation = start + slope * t - z[0]
        return np.r_[z[1:], 0.0] + gains * innovation

    z = np.zeros(dimension)
    z[0] = x[0]
    states = [z]
    for k in range(x.size - 1):
        z = solve_ivp(
            observer,
            (0.0, DT),
            z,
            method="DOP853",
            rtol=1e-12,
            atol=1e-12,
            args=(x[k], (x[k + 1] - x[k]) / DT),
        ).y[:, -1]
        states.append(z)
    states = np.array(states)
    estimate = methods.get("high_gain_observer", observer_dimension=dimension, epsilon_s=epsilon)(
        x, DT
    )
    for order in (0, 1, 2):
        scale = np.abs(states[:, order]).max()
        np.testing.assert_allclose(estimate[order], states[:, order], rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("dimension", [3, 4, 5])
def test_the_high_gain_observer_places_all_its_poles_at_exp_minus_step_over_epsilon(dimension):
    from diffbench.methods.high_gain_observer import discrete_observer

    epsilon = 0.004
    transition, _, _ = discrete_observer(dimension, epsilon, DT)
    # the characteristic polynomial (a repeated root's eigenvalues are ill-conditioned)
    np.testing.assert_allclose(
        np.poly(transition), np.poly([math.exp(-DT / epsilon)] * dimension), atol=1e-12
    )


@pytest.mark.parametrize("dimension", [3, 4, 5])
def test_the_high_gain_observer_follows_a_ramp_exactly_and_a_parabola_to_second_order(
    dimension,
):
    epsilon = 0.005
    method = methods.get("high_gain_observer", observer_dimension=dimension, epsilon_s=epsilon)
    for dt in (DT, DT / 2):
        t = np.arange(round(0.4 / dt)) * dt
        late = t > 0.3  # 60 epsilon: the start transient (e^(-t/eps) t^(m-1)) is gone
        ramp = method(0.3 - 2.0 * t, dt)
        np.testing.assert_allclose(ramp[0][late], (0.3 - 2.0 * t)[late], rtol=0, atol=1e-12)
        np.testing.assert_allclose(ramp[1][late], -2.0, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ramp[2][late], 0.0, rtol=0, atol=1e-6)
    # the line between samples misses the parabola 5 t^2 by 5 dt^2 / 6 on average: x by as
    # much; its derivatives see only the miss's ripple at 1/dt, filtered: O(dt^4)
    misses = []
    for dt in (DT, DT / 2):
        t = np.arange(round(0.4 / dt)) * dt
        late = t > 0.3
        parabola = method(5.0 * t**2, dt)
        truths = (5.0 * t**2, 10.0 * t, np.full_like(t, 10.0))
        misses.append([np.abs(parabola[o][late] - truths[o][late]).max() for o in (0, 1, 2)])
    misses = np.array(misses)
    assert misses[0, 0] == pytest.approx(5 * DT**2 / 6, rel=0.05)
    np.testing.assert_allclose(misses[0] / misses[1], [4.0, 16.0, 16.0], rtol=0.02)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_levant_is_exact_on_polynomials_of_its_order_after_it_converges(n):
    t = np.arange(4000) * DT
    poly = np.polynomial.Polynomial(np.linspace(1.0, -2.0, n + 1) * 3.0 ** np.arange(n + 1))
    method = methods.get("levant", differentiator_order=n, lipschitz=1e3)
    orders = tuple(range(min(n, 2) + 1))
    estimate = method(poly(t), DT, orders=orders)
    errors = [np.abs(estimate[order] - poly.deriv(order)(t)) for order in orders]
    scales = [np.abs(poly.deriv(order)(t)).max() for order in orders]
    # converged: from there on every order is met to rounding (amplified by 1/dt^order and
    # accumulated over the steps), to the end of the record
    within = np.all([errors[o] <= 1e-7 * scales[o] for o in orders], axis=0)
    tail = np.minimum.accumulate(within[::-1])[::-1]
    assert tail.any() and not tail[0]
    converged = int(np.argmax(tail))
    assert converged < 2500, converged
    assert errors[-1][:converged].max() > 1e-2 * scales[-1]  # it had something to converge
    assert errors[0][converged:].max() <= 1e-12 * scales[0]


def test_levant_output_weights_are_the_backward_difference_series():
    # (-ln(1 - y))^2 = y^2 + y^3 + 11/12 y^4 + 5/6 y^5 + ...
    np.testing.assert_allclose(levant.output_weights(5)[2], [0, 0, 1, 1, 11 / 12, 5 / 6])
    np.testing.assert_allclose(levant.output_weights(3)[1], [0, 1, 1 / 2, 1 / 3])


def test_levant_refuses_an_order_above_its_own():
    with pytest.raises(ValueError, match="`differentiator_order`=1 gives derivatives up to"):
        methods.get("levant", differentiator_order=1)(_record(100), DT)


def test_causal_jacobi_refuses_a_delay_outside_its_window():
    with pytest.raises(ValueError, match=r"`delay_s`=0\.2 s must not exceed `window_s`"):
        methods.get("causal_jacobi", window_s=0.05, delay_s=0.2)(_record(300), DT)


@pytest.mark.parametrize("name", [n for n in CAUSAL if methods.method_class(n).linear])
def test_the_frequency_response_is_what_a_long_sinusoid_shows(name):
    method = methods.get(name)
    frequency_hz = 7.0
    t = np.arange(20000) * DT
    x = np.cos(2 * np.pi * frequency_hz * t)
    estimate = method(x, DT)
    late = t > 15.0  # every start transient gone
    for order in (0, 1, 2):
        response = method.frequency_response(frequency_hz, DT, order)[0]
        expected = np.real(response * np.exp(2j * np.pi * frequency_hz * t))
        scale = (2 * np.pi * frequency_hz) ** order
        np.testing.assert_allclose(estimate[order][late], expected[late], rtol=0, atol=1e-8 * scale)


@pytest.mark.parametrize("name", CAUSAL)
def test_irregular_time_stamps_are_refused_as_not_causal(name):
    t = np.cumsum(np.r_[0.0, np.full(299, DT)])
    t[100:] += 0.3 * DT
    with pytest.raises(ValueError, match="takes uniformly sampled records only"):
        methods.get(name)(_record(300), t=t)
    # uniform stamps take the uniform path: the same as `dt`
    uniform = np.arange(300) * DT
    np.testing.assert_array_equal(
        methods.get(name)(_record(300), t=uniform)[1], methods.get(name)(_record(300), DT)[1]
    )


def test_the_kalman_filter_s_gains_for_a_record_and_for_a_stream_agree_bit_for_bit():
    """A record gets the gains as far as it goes (a power of two of steps), a stream all of
    them until steady at its start: the recursion is the same, so are the estimates."""
    method = methods.get("kalman_filter", bandwidth_hz=0.5)  # settles after ~1e4 steps
    x = _record(3000)
    batch = method(x, DT)
    for size in (1, 1000):
        stream = method.stream(DT)
        pieces = [stream.push(x[i : i + size])[1] for i in range(0, x.shape[0], size)]
        np.testing.assert_array_equal(np.concatenate(pieces), batch[1])
