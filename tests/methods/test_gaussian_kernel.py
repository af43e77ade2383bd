"""The Gaussian kernel taps against the continuous Gaussian and their moment conditions."""

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods.gaussian_kernel import gaussian_kernel_taps

DT = 1e-3


@pytest.mark.parametrize("sigma_s", [0.002, 0.0064, 0.03])
def test_moments_are_exact_and_the_shape_is_the_gaussians_derivative(sigma_s):
    for order in (0, 1, 2):
        taps = gaussian_kernel_taps(order, sigma_s, DT)
        u = (np.arange(taps.size) - taps.size // 2) * DT
        moments = [np.sum(taps * u**k) for k in range(5)]
        # the estimate of the derivative of `order` of u^k / k! at 0 is sum(taps * u^k) / k!
        expected = {0: [1, 0, None, 0, None], 1: [0, 1, 0, None, 0], 2: [0, 0, 2, 0, None]}
        for k, value in enumerate(expected[order]):
            if value is not None:
                assert moments[k] == pytest.approx(value, abs=1e-9 * DT**-order), (order, k)
    # for a wide kernel the taps follow the continuous Gaussian derivatives closely
    sigma = 0.03
    u = (np.arange(gaussian_kernel_taps(1, sigma, DT).size) - 120) * DT
    gauss = np.exp(-0.5 * (u / sigma) ** 2) / (sigma * np.sqrt(2 * np.pi))
    np.testing.assert_allclose(
        gaussian_kernel_taps(0, sigma, DT) / DT, gauss, atol=2e-3 * gauss.max()
    )
    derivative = u / sigma**2 * gauss  # -g'(u): correlation taps of the derivative
    np.testing.assert_allclose(
        gaussian_kernel_taps(1, sigma, DT) / DT, derivative, atol=2e-3 * derivative.max()
    )


def test_cached_taps_and_end_weights_are_the_fresh_ones_and_read_only():
    """A tuning reads a setting's taps and end weights again and again: cached, read-only,
    the same numbers as computed afresh (so a caller cannot change what the next call
    filters with)."""
    method = methods.get("gaussian_kernel", sigma_s=0.013)
    for order in (0, 1, 2):
        taps = method.taps(order, DT)
        np.testing.assert_array_equal(taps, gaussian_kernel_taps(order, 0.013, DT))
        assert not taps.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            taps[0] = 1.0
    half_width = method._half_width(DT)
    offsets = np.arange(-half_width, half_width + 1) * DT
    from diffbench.methods.gaussian_kernel import _cached_weights

    weights = _cached_weights(half_width, 0.013, DT)
    np.testing.assert_array_equal(weights, method._kernel(offsets))
    assert not weights.flags.writeable


def test_the_response_is_the_gaussians():
    method = methods.get("gaussian_kernel", sigma_s=0.01)
    f = np.array([2.0, 10.0, 20.0])
    gain = np.abs(method.frequency_response(f, DT, 0))
    np.testing.assert_allclose(gain, np.exp(-0.5 * (2 * np.pi * f * 0.01) ** 2), rtol=1e-3)


@pytest.mark.parametrize("sigma_s", [0.0005, 20.0])
def test_a_sigma_outside_one_step_to_the_window_cap_is_refused(sigma_s):
    with pytest.raises(ValueError, match="`sigma_s` must be in"):
        methods.get("gaussian_kernel", sigma_s=sigma_s)(np.zeros(100), DT)


# --- the boundary-corrected kernel at the ends, and irregular time stamps ----------------------
def _window_fit(times, k, sigma_s, reach_s, degree):
    """The kernel fit at sample ``k`` by an independent route: numpy's weighted
    ``Polynomial.fit`` on the samples within ``reach_s`` (weights: the square roots of the
    Gaussian times each sample's span of time), and a bound on what rounding may move the
    fitted estimate by: 10 eps times the condition of the weighted basis, times the sum of the
    magnitudes of the estimate's sample weights (by order), times the largest |x|."""
    from numpy.polynomial import legendre

    from diffbench.methods._local_poly import sample_spans

    inside = np.abs(times - times[k]) <= reach_s * (1 + 1e-9)
    offsets = times[inside] - times[k]
    weight = np.exp(-0.5 * (offsets / sigma_s) ** 2) * sample_spans(times)[inside]
    basis = legendre.legvander(offsets / reach_s, degree) * np.sqrt(weight)[:, None]
    condition = np.linalg.cond(basis)
    coefficients = np.linalg.pinv(basis) * np.sqrt(weight)[None, :]
    sums = {}
    for order in range(3):
        rows = legendre.legder(np.eye(degree + 1), order) if order else np.eye(degree + 1)
        at_zero = legendre.legvander(np.zeros(1), degree)[:, : rows.shape[0]] @ rows
        sums[order] = np.abs(at_zero @ coefficients).sum() / reach_s**order

    def fit(x):
        return np.polynomial.Polynomial.fit(offsets, x[inside], degree, w=np.sqrt(weight))

    return fit, condition, sums


@pytest.mark.parametrize("end_path", ["matrix", "correlations"])
@pytest.mark.parametrize("sigma_s", [0.002, 0.0064])
def test_the_ends_are_the_boundary_corrected_fit_and_the_interior_is_the_filter(
    sigma_s, end_path, monkeypatch
):
    """Every sample estimated before the ends check: the interior bit for bit the central
    filter's, each end sample the Gaussian-weighted fit of degree n + 1 on the samples the
    truncated kernel covers (against numpy's weighted polynomial fit, within the rounding
    bound of :func:`_window_fit` for normal equations), by the cached end matrix and by the
    record's correlations (the path of windows wider than END_MATRIX_UP_TO)."""
    from diffbench.methods import _local_poly
    from diffbench.methods._fir import apply_central_firs

    if end_path == "correlations":
        monkeypatch.setattr(_local_poly, "END_MATRIX_UP_TO", 0)

    t = np.arange(300) * DT
    x = np.sin(2 * np.pi * 4 * t) + 0.3 * np.cos(2 * np.pi * 11 * t + 0.4)
    method = methods.get("gaussian_kernel", sigma_s=sigma_s)
    values, valid = method._estimate(x, DT, (0, 1, 2))
    half_width = method._half_width(DT)
    filtered = apply_central_firs(x, [method.taps(order, DT) for order in (0, 1, 2)])
    for order in (0, 1, 2):
        assert valid[order].all()
        central = filtered[order][0]
        inner = slice(half_width, t.size - half_width)
        np.testing.assert_array_equal(values[order][inner], central[inner])
        for k in (0, 1, half_width - 1, t.size - half_width, t.size - 1):
            fit, condition, sums = _window_fit(t, k, sigma_s, half_width * DT, order + 1)
            bound = 10 * np.finfo(float).eps * condition**2 * sums[order] * np.abs(x).max()
            assert abs(values[order][k] - fit(x).deriv(order)(0.0)) <= bound, (order, k)


@pytest.mark.parametrize("stamps", ["uniform", "jittered"])
def test_exact_on_polynomials_of_degree_n_plus_one_at_every_sample(stamps):
    """x on lines, ẋ on quadratics, ẍ on cubics, the ends included (uniform: before the ends
    check masks any; jittered: the native path, at every sample)."""
    from diffbench.methods._local_poly import kernel_weighted_fit_at

    rng = np.random.default_rng(4)
    t = np.arange(250) * DT
    if stamps == "jittered":
        t = t + rng.uniform(-0.3, 0.3, t.size) * DT
    sigma_s = 0.004
    method = methods.get("gaussian_kernel", sigma_s=sigma_s)
    half_width = method._half_width(DT)
    for order in (0, 1, 2):
        poly = np.polynomial.Polynomial(rng.standard_normal(order + 2), domain=[0, 0.25])
        x = poly(t)
        if stamps == "uniform":
            estimate = method._estimate(x, DT, (order,))[0][order]
        else:
            estimate = kernel_weighted_fit_at(
                x, t, np.arange(t.size), half_width * DT, order + 1, order, method._kernel
            ).reshape(x.shape)
        expected = poly.deriv(order)(t) if order else x
        squared = 2 if stamps == "uniform" else 1  # normal equations there, QR on stamps
        worst = max(
            10 * np.finfo(float).eps * condition**squared * sums[order] * np.abs(x).max()
            for condition, sums in (
                _window_fit(t, k, sigma_s, half_width * DT, order + 1)[1:] for k in (0, 125)
            )
        )
        assert worst < 1e-6 * np.abs(expected).max()  # a bound that can fail
        np.testing.assert_allclose(estimate, expected, rtol=0, atol=10 * worst)


def test_the_native_path_on_uniform_stamps_is_the_uniform_path():
    """The irregular path itself on uniform stamps: the same trusted samples, the same values
    to rounding (interior: degree n + 1 there equals the filter's degree n by symmetry)."""
    t = np.arange(400) * DT
    x = np.sin(2 * np.pi * 6 * t) + 0.05 * np.random.default_rng(2).standard_normal(t.size)
    method = methods.get("gaussian_kernel", sigma_s=0.005)
    uniform = method(x, DT)
    values, valid = method._estimate_at(x, t, (0, 1, 2))
    half_width = method._half_width(DT)
    for order in (0, 1, 2):
        np.testing.assert_array_equal(valid[order], uniform.valid[order])
        _, condition, sums = _window_fit(t, 0, 0.005, half_width * DT, order + 1)
        bound = 10 * np.finfo(float).eps * condition**2 * sums[order] * np.abs(x).max()
        keep = valid[order]
        np.testing.assert_allclose(values[order][keep], uniform[order][keep], rtol=0, atol=bound)


def test_the_ends_check_keeps_part_of_each_end_on_the_paper_record():
    """At the paper preset on the 1.237 s paper record (ends that do not meet) the kernel
    overhangs 26 samples at each end; with the boundary fits the ends check keeps every x
    sample, all but 7 of ẋ and all but 12 of ẍ at each end (measured; before, all 26 were
    masked). That what it keeps is honest is test_valid_marks' check."""
    import dataclasses

    from diffbench import signals

    scenario = dataclasses.replace(
        signals.get_scenario("paper-signal-4937ms"), name="ends-apart", duration_s=1.237
    )
    realisation = scenario.realise(0)
    method = methods.preset("gaussian_kernel", "paper-signal")
    half_width = method._half_width(realisation.dt_s)
    assert half_width == 26
    estimate = method(realisation.x, realisation.dt_s)
    for order, most_masked in ((0, 0), (1, 7), (2, 12)):
        masked = ~estimate.valid[order]
        n = masked.size
        start, end = int(masked[:half_width].sum()), int(masked[n - half_width :].sum())
        assert max(start, end) <= most_masked, (order, start, end)
        assert not masked[half_width : n - half_width].any()
