"""Each method against a well-kept library called directly, and against the analytic
response of the paper's test signal."""

import numpy as np
import pytest
from scipy import signal as sps

from diffbench import methods
from diffbench.methods._local_poly import local_polynomial_weights
from diffbench.methods.finite_difference import central_difference_weights

DT = 1e-3


def _pysindy_fd_weights(order, accuracy):
    from pysindy import FiniteDifference

    return FiniteDifference(order=accuracy, d=order)._constant_coefficients(1.0)


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("accuracy", [2, 4, 6])
def test_central_difference_weights_match_pysindy(order, accuracy):
    np.testing.assert_allclose(
        central_difference_weights(order, accuracy),
        _pysindy_fd_weights(order, accuracy),
        rtol=1e-12,
        atol=1e-12,
    )


def test_central_difference_weights_by_hand():
    np.testing.assert_allclose(central_difference_weights(1, 2), [-0.5, 0, 0.5], atol=1e-15)
    np.testing.assert_allclose(central_difference_weights(2, 2), [1, -2, 1], atol=1e-14)
    np.testing.assert_allclose(
        central_difference_weights(1, 4), np.array([1, -8, 0, 8, -1]) / 12, atol=1e-15
    )


@pytest.mark.parametrize("accuracy", [2, 4, 6])
def test_finite_difference_matches_pysindy_on_the_interior(accuracy):
    from pysindy import FiniteDifference

    x = np.random.default_rng(1).standard_normal((500, 2))
    estimate = methods.get("finite_difference", accuracy_order=accuracy)(x, DT)
    for order in (1, 2):
        reference = FiniteDifference(order=accuracy, d=order, drop_endpoints=True)(x, t=DT)
        interior = np.isfinite(reference[:, 0])
        assert estimate.valid[order][interior].all()
        np.testing.assert_allclose(estimate[order][interior], reference[interior], rtol=1e-10)


@pytest.mark.parametrize("accuracy", [2, 4, 6])
def test_finite_difference_ends_are_the_derivative_of_numpys_polynomial_fit(accuracy):
    """Where the central stencil does not fit: the derivative of numpy's least-squares
    polynomial of degree p + n - 1 through the first (last) 2 m_e + 1 samples, at each
    sample's own position."""
    x = np.random.default_rng(1).standard_normal(200)
    method = methods.get("finite_difference", accuracy_order=accuracy)
    values, _ = method._estimate(x, DT, (1, 2))  # before the validity check masks any
    for order in (1, 2):
        degree = accuracy + order - 1
        window = 2 * -(-degree // 2) + 1
        t = np.arange(window) * DT
        ends = accuracy // 2 + (order + 1) // 2 - 1  # where the central stencil does not fit
        first = np.polynomial.Polynomial.fit(t, x[:window], degree).deriv(order)
        last = np.polynomial.Polynomial.fit(t, x[-window:], degree).deriv(order)
        np.testing.assert_allclose(values[order][:ends], first(t)[:ends], rtol=1e-8)
        np.testing.assert_allclose(values[order][-ends:], last(t)[-ends:], rtol=1e-8)


@pytest.mark.parametrize(("window", "degree"), [(11, 2), (21, 3), (51, 5), (31, 4)])
def test_savitzky_golay_matches_scipy_where_scipy_is_accurate(window, degree):
    """scipy's savgol_coeffs solves its least-squares problem on the window's unscaled powers
    -h..h: its coefficients are accurate to eps times that Vandermonde matrix's condition
    (1.3e-9 for 51 samples and degree 5: it moved by 1.7e-10 of the scale under OpenBLAS
    Sandybridge), and to no better than 1e-10 for the smaller ones here."""
    half = window // 2
    vandermonde = np.vander(np.arange(-half, half + 1.0), degree + 1)
    relative = max(1e-10, np.finfo(float).eps * np.linalg.cond(vandermonde))
    x = np.random.default_rng(2).standard_normal((400, 3))
    method = methods.get("savitzky_golay", window_s=(window - 1) * DT, degree=degree)
    estimate = method(x, DT)
    for order in (0, 1, 2):
        reference = sps.savgol_filter(
            x, window, degree, deriv=order, delta=DT, axis=0, mode="interp"
        )
        scale = np.max(np.abs(reference))
        valid = estimate.valid[order]
        assert valid[window // 2 : -(window // 2)].all()  # only end samples may be masked
        np.testing.assert_allclose(
            estimate[order][valid], reference[valid], rtol=0, atol=relative * scale
        )
        unchecked, _ = method._estimate(x, DT, (order,))  # scipy's ends, before masking
        np.testing.assert_allclose(unchecked[order], reference, rtol=0, atol=relative * scale)


def test_savitzky_golay_weights_stay_exact_where_scipy_loses_accuracy():
    """211 samples, degree 7 (the paper window at 1 kHz): the smoothing weights must sum to 1
    and reproduce the moments of degree <= 7 exactly. (scipy 1.17's savgol_coeffs sums to
    6.5e-7 here: scipy issue #20825.)"""
    weights = local_polynomial_weights(105, 7, 0, np.array([0.0]))[0]
    offsets = np.arange(-105, 106) / 105
    moments = [np.sum(weights * offsets**k) for k in range(8)]
    np.testing.assert_allclose(moments, [1, 0, 0, 0, 0, 0, 0, 0], atol=1e-12)
    first = local_polynomial_weights(105, 7, 1, np.array([0.0]), dt=DT)[0]
    np.testing.assert_allclose(np.sum(first * np.arange(-105, 106) * DT), 1.0, rtol=1e-11)


@pytest.mark.parametrize(("window", "degree", "accuracy"), [(11, 3, 2), (21, 4, 4), (41, 5, 2)])
def test_sindy_smoothing_matches_pysindy_called_directly(window, degree, accuracy):
    from pysindy import SmoothedFiniteDifference

    x = np.random.default_rng(4).standard_normal((300, 2))
    method = methods.get(
        "sindy_smoothing", window_s=(window - 1) * DT, degree=degree, accuracy_order=accuracy
    )
    estimate = method(x, DT)
    for order in (1, 2):
        sfd = SmoothedFiniteDifference(
            smoother_kws={"window_length": window, "polyorder": degree},
            order=accuracy,
            d=order,
        )
        reference = sfd(x, t=DT)
        scale = np.max(np.abs(reference))
        valid = estimate.valid[order]
        assert valid[window:-window].all()  # only end samples may be masked
        np.testing.assert_allclose(
            estimate[order][valid], reference[valid], rtol=0, atol=1e-9 * scale
        )
        valid = estimate.valid[0]
        np.testing.assert_allclose(estimate[0][valid], sfd.smoothed_x_[valid], rtol=0, atol=5e-12)


def test_butterworth_matches_sosfiltfilt_and_central_differences():
    x = np.random.default_rng(5).standard_normal((2000, 2))
    method = methods.get("butterworth", order=6, cutoff_hz=25.0)
    values, _ = method._estimate(x, DT, (0, 1, 2))  # before the validity check masks any
    sos = sps.butter(6, 25.0, output="sos", fs=1 / DT)
    # odd extension over the settling length: 683 steps for order 6 at 25 Hz and 1 kHz
    smooth = sps.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=683)
    np.testing.assert_allclose(values[0], smooth, rtol=1e-12, atol=1e-15)
    velocity = (smooth[2:] - smooth[:-2]) / (2 * DT)
    acceleration = (smooth[2:] - 2 * smooth[1:-1] + smooth[:-2]) / DT**2
    np.testing.assert_allclose(values[1][1:-1], velocity, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(values[2][1:-1], acceleration, rtol=1e-9, atol=1e-6)
    # the end samples: one-sided differences of the 3-point polynomial
    np.testing.assert_allclose(
        values[1][0], (-3 * smooth[0] + 4 * smooth[1] - smooth[2]) / (2 * DT)
    )
    np.testing.assert_allclose(values[2][-1], (smooth[-1] - 2 * smooth[-2] + smooth[-3]) / DT**2)
    estimate = method(x, DT)
    for order in (0, 1, 2):
        valid = estimate.valid[order]
        assert valid[683:-683].all() and not valid[0]
        np.testing.assert_array_equal(estimate[order][valid], values[order][valid])


def test_butterworth_is_exact_on_a_line_up_to_the_ends():
    """The odd extension continues a line, so the filter passes it to the first sample."""
    t = np.arange(4001) * DT
    line = 0.3 + 2.5 * t
    values, _ = methods.get("butterworth", order=6, cutoff_hz=25.0)._estimate(line, DT, (0, 1, 2))
    np.testing.assert_allclose(values[0], line, atol=1e-9)
    np.testing.assert_allclose(values[1], 2.5, atol=1e-6)
    np.testing.assert_allclose(values[2], 0.0, atol=1e-3)


# --- the noiseless paper signal, against its analytic frequency response -------------------
FREQUENCIES_HZ = (4.0, 9.0, 15.0)


def _taps_response(taps, theta):
    offsets = np.arange(taps.size) - taps.size // 2
    return np.sum(taps[np.newaxis, :] * np.exp(1j * np.outer(theta, offsets)), axis=1)


def _response(name, params, order, frequencies_hz):
    """H(e^{i w dt}) of each linear method from a library or a formula, independently of the
    time-domain code: taps from scipy (SG), pysindy (differences), sosfreqz (Butterworth)."""
    theta = 2 * np.pi * np.asarray(frequencies_hz) * DT
    if order == 0:
        difference = np.ones_like(theta, dtype=complex)
    else:
        accuracy = params.get("accuracy_order", 2)
        difference = _taps_response(_pysindy_fd_weights(order, accuracy), theta) / DT**order
    if name == "finite_difference":
        return difference
    if name == "butterworth":
        sos = sps.butter(params["order"], params["cutoff_hz"], output="sos", fs=1 / DT)
        _, gain = sps.sosfreqz(sos, worN=np.asarray(frequencies_hz), fs=1 / DT)
        return np.abs(gain) ** 2 * difference
    window = round(params["window_s"] / DT) + 1
    if name == "savitzky_golay":
        taps = local_polynomial_weights(window // 2, params["degree"], order, [0.0], DT)[0]
        return _taps_response(taps, theta)
    if name == "sindy_smoothing":
        taps = local_polynomial_weights(window // 2, params["degree"], 0, [0.0], DT)[0]
        return _taps_response(taps, theta) * difference
    raise AssertionError(f"no reference response for {name}")


@pytest.mark.parametrize(
    "name", ["finite_difference", "butterworth", "savitzky_golay", "sindy_smoothing"]
)
def test_noiseless_paper_signal_error_equals_the_predicted_response(name):
    """On x = sum sin(2 pi f t), f = 4, 9, 15 Hz, an LTI estimator returns
    sum Im(H(f) e^{i 2 pi f t}) away from the ends, so its error is
    e(t) = sum Im((H(f) - (i 2 pi f)^n) e^{i 2 pi f t}) and is bounded by
    sum |H(f) - (i 2 pi f)^n|: both are checked (Butterworth 1 s away from the ends, where
    its start-up transient has decayed below 1e-9)."""
    method = methods.preset(name, "paper-signal")
    params = method.params()
    t = np.arange(3001) * DT
    x = sum(np.sin(2 * np.pi * f * t) for f in FREQUENCIES_HZ)
    estimate = method(x, DT)
    interior = (t >= 1.0) & (t <= 2.0)
    for order in (0, 1, 2):
        omegas = 2 * np.pi * np.asarray(FREQUENCIES_HZ)
        response = _response(name, params, order, FREQUENCIES_HZ)
        predicted = sum(
            np.imag(h * np.exp(1j * w * t)) for h, w in zip(response, omegas, strict=True)
        )
        truth = sum(np.imag((1j * w) ** order * np.exp(1j * w * t)) for w in omegas)
        bound = np.sum(np.abs(response - (1j * omegas) ** order))
        error = np.abs(estimate[order][interior] - truth[interior])
        scale = np.max(np.abs(truth))
        np.testing.assert_allclose(
            estimate[order][interior], predicted[interior], rtol=0, atol=1e-8 * scale
        )
        assert np.max(error) <= bound * (1 + 1e-9) + 1e-8 * scale


def test_butterworth_is_time_symmetric_away_from_the_ends():
    """Zero phase: reversing time flips the sign of odd derivatives; only the start-up
    transients at the ends differ between forward-backward and backward-forward."""
    x = np.random.default_rng(12).standard_normal(4001)
    method = methods.get("butterworth", order=6, cutoff_hz=25.0)
    forward, backward = method(x, DT), method(x[::-1], DT)
    interior = slice(1000, 3001)
    for order in (0, 1, 2):
        scale = np.max(np.abs(forward[order][interior]))
        np.testing.assert_allclose(
            backward[order][::-1][interior],
            (-1) ** order * forward[order][interior],
            rtol=0,
            atol=1e-9 * scale,
        )
