"""The central Jacobi differentiator against independent computations and exact truth."""

import numpy as np
import pytest
from scipy import signal as sps
from scipy import special

from diffbench import methods
from diffbench.methods.jacobi_kernel import (
    continuous_response,
    fir_weights,
    jacobi_polynomials,
    kernel,
)


def _weighted_least_squares(order, kappa, mu, q, func):
    """n-th derivative at 0 of the degree n+q polynomial fitted to func with weight
    (1-t)^mu (1+t)^kappa: Gauss-Jacobi nodes make the discrete fit the continuous one."""
    nodes, weights = special.roots_jacobi(90, mu, kappa)
    basis = np.polynomial.legendre.legvander(nodes, order + q)
    root = np.sqrt(weights)
    coefficients, *_ = np.linalg.lstsq(basis * root[:, None], func(nodes) * root, rcond=None)
    return np.polynomial.legendre.legval(0.0, np.polynomial.legendre.legder(coefficients, order))


def _apply_kernel(order, kappa, mu, q, func):
    nodes, weights = special.roots_jacobi(90, mu, kappa)
    weight = (1 - nodes) ** mu * (1 + nodes) ** kappa
    return np.sum(weights * kernel(nodes, order, kappa, mu, q) / weight * func(nodes))


def _smooth(t):
    return np.sin(3 * t + 0.3) + np.exp(0.5 * t)


@pytest.mark.parametrize(("a", "b"), [(0.5, 2.0), (12.0, 12.0), (-0.5, 3.0), (-0.9, -0.3)])
def test_recurrence_matches_scipy_eval_jacobi(a, b):
    x = np.linspace(-1, 1, 11)
    values = jacobi_polynomials(10, a, b, x)
    for k in range(11):
        np.testing.assert_allclose(
            values[k], special.eval_jacobi(k, a, b, x), rtol=1e-11, atol=1e-11
        )


@pytest.mark.parametrize(
    ("order", "kappa", "mu", "q"),
    [
        (0, 0.0, 0.0, 0),
        (1, 12.0, 12.0, 6),
        (2, 12.0, 12.0, 6),
        (1, 1.0, 3.0, 2),
        (2, -0.5, 0.7, 3),
        (2, 6.0, 6.0, 2),
        (1, 6.0, 6.0, 2),
        (1, -0.7, -0.2, 4),
        (2, 4.0, 0.0, 5),
        (1, 50.0, 50.0, 20),
        (2, 100.0, 100.0, 20),
        # the declared limits: kappa, mu <= 400 (measured: still 1e-10 here at q = 40)
        (0, 400.0, 400.0, 40),
        (1, 400.0, 400.0, 40),
        (2, 400.0, 400.0, 40),
        (2, 400.0, 380.0, 12),
    ],
)
def test_kernel_equals_an_independent_weighted_least_squares_fit(order, kappa, mu, q):
    estimate = _apply_kernel(order, kappa, mu, q, _smooth)
    reference = _weighted_least_squares(order, kappa, mu, q, _smooth)
    assert abs(estimate - reference) <= 1e-9 * max(1.0, abs(reference))


@pytest.mark.parametrize(
    ("order", "kappa", "mu", "q"), [(1, 12.0, 12.0, 6), (2, 2.0, 5.0, 3), (2, -0.5, -0.5, 2)]
)
def test_kernel_is_exact_on_polynomials_up_to_n_plus_q(order, kappa, mu, q):
    for degree in range(order + q + 1):
        monomial = np.polynomial.Polynomial.basis(degree)
        exact = monomial.deriv(order)(0.0)
        assert _apply_kernel(order, kappa, mu, q, monomial) == pytest.approx(exact, abs=1e-10)


def test_symmetric_weight_with_even_q_gains_one_degree_and_odd_q_equals_q_minus_1():
    tau = np.linspace(-1, 1, 41)
    for order in (1, 2):
        # kappa = mu, q even: exact on degree n + q + 1 too ...
        monomial = np.polynomial.Polynomial.basis(order + 4 + 1)
        exact = monomial.deriv(order)(0.0)
        assert _apply_kernel(order, 3.0, 3.0, 4, monomial) == pytest.approx(exact, abs=1e-10)
        # ... but not with kappa != mu
        assert abs(_apply_kernel(order, 3.0, 5.0, 4, monomial) - exact) > 1e-3
        # odd q with kappa = mu is the kernel of q - 1
        np.testing.assert_allclose(
            kernel(tau, order, 3.0, 3.0, 5), kernel(tau, order, 3.0, 3.0, 4), rtol=1e-10, atol=1e-10
        )
        assert np.max(np.abs(kernel(tau, order, 3.0, 5.0, 5) - kernel(tau, order, 3.0, 5.0, 4))) > 1


def test_mu_weights_the_future_end():
    """q = 0, n = 0 is the weighted mean: on a ramp x_k = k it returns
    k + M (kappa - mu) / (kappa + mu + 2), pulled towards the end with the smaller exponent."""
    m, kappa, mu = 100, 0.0, 5.0
    taps = fir_weights(0, kappa, mu, 0, m, 1.0, "linear")
    ramp = np.arange(-m, m + 1, dtype=float)
    assert np.sum(taps * ramp) == pytest.approx(m * (kappa - mu) / (kappa + mu + 2), rel=1e-3)
    assert np.sum(taps[:m]) > 0.9  # the past samples (j < 0) carry the weight
    estimate = methods.get(
        "jacobi", kappa=0.0, mu=5.0, q=0, window_s=0.2, accel_window_s=0.2, rule="linear"
    )(np.arange(1001.0), 1e-3, orders=(0,))
    assert estimate[0][500] == pytest.approx(500 + 100 * (0 - 5) / 7, rel=1e-4)


def _rate(errors):
    errors = np.asarray(errors)
    return np.log2(errors[:-1] / errors[1:])


@pytest.mark.parametrize(
    ("order", "kappa", "mu", "q", "rule", "low", "high"),
    [
        (2, -0.5, -0.5, 2, "linear", 1.95, 2.15),
        (1, 0.3, 1.5, 2, "linear", 1.95, 2.05),
        (2, 0.0, 0.0, 2, "trapezoid", 1.95, 2.05),
        (1, 2.0, 2.0, 1, "trapezoid", 3.9, 4.1),
        (1, 2.0, 2.0, 1, "least_squares", 3.9, 4.1),
    ],
)
def test_measured_convergence_order_of_each_rule(order, kappa, mu, q, rule, low, high):
    reference = _apply_kernel(order, kappa, mu, q, _smooth)
    errors = []
    for m in (20, 40, 80, 160):
        taps = fir_weights(order, kappa, mu, q, m, 1.0 / m, rule)  # h = 1
        errors.append(abs(np.sum(taps * _smooth(np.arange(-m, m + 1) / m)) - reference))
    rates = _rate(errors)
    assert np.all((rates > low) & (rates < high)), rates


def test_trapezoid_is_spectrally_accurate_for_the_paper_kernel():
    reference = _apply_kernel(2, 12.0, 12.0, 6, _smooth)
    taps = fir_weights(2, 12.0, 12.0, 6, 105, 1.0 / 105, "trapezoid")
    estimate = np.sum(taps * _smooth(np.arange(-105, 106) / 105))
    assert abs(estimate - reference) < 1e-11


@pytest.mark.parametrize(("window", "degree", "order"), [(11, 2, 1), (21, 4, 2), (31, 3, 1)])
def test_kappa_mu_zero_least_squares_rule_is_savitzky_golay(window, degree, order):
    dt = 1e-3
    q = degree - order
    taps = fir_weights(order, 0.0, 0.0, q, window // 2, dt, "least_squares")
    reference = sps.savgol_coeffs(window, degree, deriv=order, delta=dt, use="dot")
    np.testing.assert_allclose(taps, reference, rtol=1e-9, atol=1e-9 * np.max(np.abs(reference)))


def test_paper_settings_give_the_published_gain_at_15_hz():
    """Fig. 2 of the paper reads 78.5 dB at 15 Hz for n = 2 (ideal (2 pi 15)^2 = 78.97 dB)."""
    gain = abs(continuous_response(2, 12.0, 12.0, 6, 0.21, 15.0)[0])
    assert gain == pytest.approx(0.9606, abs=5e-4)
    assert abs(continuous_response(1, 12.0, 12.0, 6, 0.21, 15.0)[0]) == pytest.approx(
        0.9535, abs=5e-4
    )
    taps = methods.preset("jacobi", "paper-signal").taps(2, 1e-3)
    theta = 2 * np.pi * 15 * 1e-3
    response = np.sum(taps * np.exp(1j * theta * np.arange(-105, 106)))
    decibels = 20 * np.log10(abs(response))
    assert decibels == pytest.approx(20 * np.log10(gain * (2 * np.pi * 15) ** 2), abs=1e-3)
    assert decibels == pytest.approx(78.5, abs=0.2)


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"kappa": -1.0}, r"`kappa` must be a finite number in \[-0.999, 400\]"),
        ({"mu": -1.5}, r"`mu` must be a finite number in \[-0.999, 400\]"),
        ({"mu": -0.9995}, r"`mu` must be a finite number in \[-0.999, 400\], got -0.9995"),
        ({"mu": 400.5}, r"`mu` must be a finite number in \[-0.999, 400\], got 400.5"),
        ({"q": -1}, r"`q` must be an integer in \[0, 40\]"),
        ({"q": 2.5}, r"`q` must be an integer"),
        ({"rule": "simpson"}, r"`rule` must be one of \{trapezoid, linear, least_squares\}"),
        ({"kappa": -0.5}, r"`rule`='trapezoid' needs kappa, mu >= 0.*use rule='linear'"),
        ({"mu": -0.5, "rule": "least_squares"}, r"`rule`='least_squares' needs kappa, mu >= 0"),
    ],
)
def test_bad_parameters(params, message):
    with pytest.raises(ValueError, match=message):
        methods.get("jacobi", **params)


@pytest.mark.parametrize(
    ("params", "n_samples", "message"),
    [
        ({"window_s": 0.2105}, 1000, r"`window_s`=0.2105 s is 210.5 sampling steps"),
        ({"accel_window_s": 0.211}, 1000, r"`accel_window_s`=0.211 s spans 211 steps.*odd"),
        ({"window_s": 0.6, "accel_window_s": 1.1}, 1000, r"`x` has 1000 samples.*1101"),
        (
            {"window_s": 0.004, "q": 6},
            1000,
            r"window holds 5 samples; a Jacobi estimate with n \+ q = 6 needs at least 8",
        ),
    ],
)
def test_windows_that_do_not_fit(params, n_samples, message):
    method = methods.get("jacobi", **params)
    with pytest.raises(ValueError, match=message):
        method(np.zeros(n_samples), 1e-3)


def test_kernel_rejects_bad_design():
    with pytest.raises(ValueError, match=r"`order` must be an integer >= 0"):
        kernel(0.0, -1, 1.0, 1.0, 2)
    with pytest.raises(ValueError, match=r"`kappa` must be a finite number > -1"):
        kernel(0.0, 1, -1.0, 1.0, 2)
    with pytest.raises(ValueError, match=r"`q` must be an integer >= 0"):
        kernel(0.0, 1, 1.0, 1.0, 1.5)


def test_a_refusal_composes_its_search_only_when_read_and_pickles_as_a_value_error():
    """A window too short for the rule is refused at once; the shortest window that works
    (a search that computes taps) is composed when the message is read, once, and a worker
    process's copy (pickled) is a plain ValueError with the same message."""
    import pickle

    from diffbench.methods import jacobi_kernel

    # trapezoid misses by 6e4 on any window here (see test_parameter_limits)
    method = methods.get("jacobi", kappa=0.0, mu=46.0, q=12)
    jacobi_kernel.discretisation_error.cache_clear()
    with pytest.raises(ValueError) as refused:
        method(np.zeros(1000), 1e-3)
    searched_before = jacobi_kernel.discretisation_error.cache_info().currsize
    message = str(refused.value)
    searched_after = jacobi_kernel.discretisation_error.cache_info().currsize
    assert searched_after > searched_before  # the search ran when the message was read
    assert message.startswith("`rule`='trapezoid' fails for kappa=0.0"), message
    assert "rule='linear' works from" in message
    assert str(refused.value) == message
    assert jacobi_kernel.discretisation_error.cache_info().currsize == searched_after  # once
    copy = pickle.loads(pickle.dumps(refused.value))
    assert type(copy) is ValueError and str(copy) == message


@pytest.mark.parametrize("order", [0, 1, 2])
def test_the_boundary_fits_by_stored_weights_are_the_fits(monkeypatch, order):
    """Boundary ends computed once as weights and applied to two records (the cache) against
    the same fits by QR record by record: equal to rounding, NaN at the same samples.

    Rounding: both evaluate :math:`e^T R^{-1} Q^T \\sqrt{w} x` of one QR, grouped differently;
    each product's error is at most :math:`\\gamma_{s+d+1}` (s window samples, d + 1
    coefficients) times :math:`\\sum_j \\sqrt{w_j} |x_j| \\sum_i |Q_{ji}| |z_i| \\le \\lVert z
    \\rVert_2 \\sum_j \\sqrt{w_j} |x_j|` (rows of Q have norm at most 1), z = R^{-T} e, whose
    norm the stored row gives: :math:`\\lVert z\\rVert_2 = \\lVert W_a / \\sqrt{w}\\rVert_2` on
    the window (seen: at most 0.005 of it)."""
    from diffbench.methods import jacobi as jacobi_module

    dt = 1e-3
    method = methods.get("jacobi", window_s=0.1, accel_window_s=0.1, end_degree=4)
    rng = np.random.default_rng(order)
    t = np.arange(1201) * dt
    records = [
        np.sin(2 * np.pi * 4 * t + phase) + 0.01 * rng.standard_normal(t.size)
        for phase in (0.0, 1.0)
    ]
    stored = [method(x, dt)[order] for x in records]
    # the weights kept for the last setting only are the same weights
    with monkeypatch.context() as patch:
        patch.setattr(jacobi_module, "CACHED_END_WEIGHTS", 0)
        for x, kept in zip(records, stored, strict=True):
            np.testing.assert_array_equal(method(x, dt)[order], kept)
    monkeypatch.setattr(jacobi_module, "LAST_END_WEIGHTS", 0)
    fitted = [method(x, dt)[order] for x in records]
    m = method._half_width(order, dt)
    size = 2 * m + 1
    starts, ends = jacobi_module._boundary_weights(method, order, m, size)
    offsets = (np.arange(size)[None, :] - np.arange(m)[:, None]) / m
    root = {
        "start": np.sqrt(method._weight(offsets)),
        "end": np.sqrt(method._weight(-offsets))[::-1, ::-1],
    }
    degree = method._fit_degree(order)
    gamma = (
        (size + degree + 1) * np.finfo(float).eps / (1 - (size + degree + 1) * np.finfo(float).eps)
    )
    for x, a, b in zip(records, stored, fitted, strict=True):
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        for end, weights, rows, data in (
            ("start", starts, slice(0, m), x[:size]),
            ("end", ends, slice(x.size - m, x.size), x[-size:]),
        ):
            carried = root[end] > 0
            z_norm = np.sqrt(
                np.sum(
                    np.where(carried, weights / np.where(carried, root[end], 1.0), 0.0) ** 2, axis=1
                )
            )
            allowed = 2 * gamma * z_norm * (root[end] @ np.abs(data)) / dt**order
            finite = np.isfinite(a[rows])
            assert np.all(np.abs(a[rows] - b[rows])[finite] <= allowed[finite]), end
        np.testing.assert_array_equal(a[m:-m], b[m:-m])
