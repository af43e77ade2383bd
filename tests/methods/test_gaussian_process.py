"""The Gaussian-process methods against exact answers: scikit-learn's posterior and its finite
differences, a dense numpy posterior, sinusoids through the stated response, analytic
derivatives of a smooth signal, the noise level of synthetic data, and the inputs refused."""

import warnings

import numpy as np
import pytest
import scipy.linalg
from scipy.sparse.linalg import LinearOperator, cg
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

from diffbench import methods
from diffbench.methods import gaussian_process
from diffbench.methods.gaussian_process import (
    EXACT_PRECONDITIONER_COLUMNS,
    _GohbergSemencul,
    _ToeplitzKernel,
    fit_hyperparameters,
    gaussian_process_response,
    likelihood_optimum,
    posterior_derivatives,
    rbf_covariance,
    rbf_log_marginal_likelihood,
)

DT = 1e-3


def _line(x, dt):
    centred = (np.arange(x.size) - (x.size - 1) / 2) * dt
    slope = np.sum(centred * (x - x.mean())) / np.sum(centred**2)
    return x.mean() + slope * centred, slope


def _dense_posterior(x, dt, length_scale_s, noise_ratio):
    """The posterior mean and its derivatives by a dense solve: the slow, obvious version."""
    line, slope = _line(x, dt)
    t = np.arange(x.size) * dt
    lag = t[:, None] - t[None, :]
    gram = rbf_covariance(lag, length_scale_s, 0) + noise_ratio**2 * np.eye(x.size)
    alpha = np.linalg.solve(gram, x - line)
    return {
        0: rbf_covariance(lag, length_scale_s, 0) @ alpha + line,
        1: rbf_covariance(lag, length_scale_s, 1) @ alpha + slope,
        2: rbf_covariance(lag, length_scale_s, 2) @ alpha,
    }


def _noisy_record(n, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    return np.sin(2 * np.pi * 4 * t) + 0.5 * t + 0.1 * rng.standard_normal(n)


def test_kernel_derivatives_equal_finite_differences_of_the_kernel():
    lag, ell, step = np.linspace(-0.05, 0.05, 41), 0.013, 1e-6
    for order in (1, 2):
        lower = rbf_covariance(lag - step, ell, order - 1)
        upper = rbf_covariance(lag + step, ell, order - 1)
        numeric = (upper - lower) / (2 * step)
        exact = rbf_covariance(lag, ell, order)
        np.testing.assert_allclose(exact, numeric, rtol=0, atol=1e-6 * np.max(np.abs(exact)))
    assert rbf_covariance(0.0, ell, 2) == pytest.approx(-1 / ell**2)  # -k(0)/ℓ²
    with pytest.raises(ValueError, match="`order` must be 0, 1 or 2, got 3"):
        rbf_covariance(0.0, ell, 3)


def test_equals_scikit_learns_posterior_and_its_finite_differences():
    """Order 0 is sklearn's predict at the samples; orders 1 and 2 are its central
    differences in t (step ℓ/1000: truncation and rounding well below the tolerances)."""
    ell, ratio = 0.012, 0.2
    x = _noisy_record(700)
    t = np.arange(x.size) * DT
    line, slope = _line(x, DT)
    regressor = GaussianProcessRegressor(RBF(ell, "fixed"), alpha=ratio**2, optimizer=None)
    regressor.fit(t[:, None], x - line)

    def predict(times):
        return regressor.predict(times[:, None])

    estimate = posterior_derivatives(x, DT, (0, 1, 2), ell, ratio)
    np.testing.assert_allclose(estimate[0], predict(t) + line, rtol=0, atol=1e-10)
    h1, h2 = ell / 1000, ell / 1000
    first = (predict(t + h1) - predict(t - h1)) / (2 * h1) + slope
    second = (predict(t + h2) - 2 * predict(t) + predict(t - h2)) / h2**2
    np.testing.assert_allclose(estimate[1], first, rtol=0, atol=1e-6 * np.max(np.abs(first)))
    np.testing.assert_allclose(estimate[2], second, rtol=0, atol=1e-5 * np.max(np.abs(second)))
    # the registered method is this posterior where its ends check keeps it
    method = methods.get("gaussian_process", length_scale_s=ell, noise_ratio=ratio)(x, DT)
    for order in (0, 1, 2):
        valid = method.valid[order]
        assert valid.mean() > 0.9
        np.testing.assert_array_equal(method[order][valid], estimate[order][valid])


@pytest.mark.parametrize(
    ("length_scale_s", "noise_ratio"),
    [(0.002, 1.0), (0.01, 0.1), (0.05, 0.003), (0.4, 0.01), (5.0, 0.01)],
)
def test_the_fft_solver_equals_a_dense_solve_of_the_whole_record(length_scale_s, noise_ratio):
    """Conjugate gradients on FFT products against numpy's dense solve, 2500 samples, over
    short and long length scales (5 s: longer than the record), much and little noise."""
    x = _noisy_record(2500, seed=2)
    dense = _dense_posterior(x, DT, length_scale_s, noise_ratio)
    fast = posterior_derivatives(x, DT, (0, 1, 2), length_scale_s, noise_ratio)
    for order in (0, 1, 2):
        scale = np.max(np.abs(dense[order]))
        np.testing.assert_allclose(fast[order], dense[order], rtol=0, atol=1e-8 * scale)


@pytest.mark.parametrize(
    ("length_scale_s", "noise_ratio"), [(0.002, 1.0), (0.05, 0.003), (0.4, 0.01)]
)
def test_the_batched_solver_equals_scipys_cg_column_by_column(length_scale_s, noise_ratio):
    """The solver runs every column at once; scipy's ``cg``, one right-hand side at a time
    with the same operator, preconditioner and tolerance, is its oracle. The columns mix a
    noisy record, sinusoids of several frequencies (they converge after different numbers of
    iterations, so columns stop while others go on) and a zero column (whose solution is 0)."""
    n = 1200
    t = np.arange(n) * DT
    columns = [_noisy_record(n, seed=5)] + [np.cos(2 * np.pi * f * t) for f in (1, 30, 240)]
    y = np.column_stack([*columns[:2], np.zeros(n), *columns[2:]])
    kernel = _ToeplitzKernel(n, DT, length_scale_s, noise_ratio)
    system = LinearOperator(
        (n, n), matvec=lambda v: kernel.apply(v, 0) + noise_ratio**2 * v, dtype=float
    )
    preconditioner = LinearOperator((n, n), matvec=kernel.precondition, dtype=float)
    together = kernel.solve(y)
    for index in range(y.shape[1]):
        oracle, info = cg(system, y[:, index], rtol=1e-14, atol=0.0, M=preconditioner, maxiter=2000)
        assert info == 0
        alone = kernel.solve(y[:, index : index + 1])[:, 0]
        # two runs that each meet the tolerance differ in α by up to the tolerance times the
        # condition number (~1e7 here), in the posterior mean K α, what the estimates are made
        # of, by much less: the accuracy the dense-solve test above asks of the solver
        smoothed = kernel.apply(oracle, 0)
        scale = max(np.max(np.abs(smoothed)), 1e-300)
        for solution in (together[:, index], alone):
            np.testing.assert_allclose(
                kernel.apply(solution, 0), smoothed, rtol=0, atol=1e-8 * scale
            )
    assert not together[:, 2].any()


@pytest.mark.parametrize(
    ("length_scale_s", "noise_ratio"),
    [(0.002, 1.0), (0.01, 0.1), (0.05, 0.003), (0.4, 0.01), (5.0, 0.01), (0.02, 0.001)],
)
def test_the_gohberg_semencul_inverse_is_the_dense_inverse(length_scale_s, noise_ratio):
    """The formula, from the first column of the inverse, against numpy's dense solve of
    T = K + r² I (600 samples; condition numbers 6 to 5e7). A backward-stable solve is
    accurate to about eps·cond(T) relative (Higham, *Accuracy and Stability of Numerical
    Algorithms*, 2002, ch. 7), and so is the formula, whose two terms are each of the size of
    T's inverse; 4 eps·cond(T) is asked of their difference (0.1-0.5 eps·cond measured)."""
    n = 600
    column = rbf_covariance(np.arange(n) * DT, length_scale_s, 0)
    column[0] += noise_ratio**2
    system = scipy.linalg.toeplitz(column)
    vectors = np.random.default_rng(3).standard_normal((n, 5))
    dense = np.linalg.solve(system, vectors)
    inverse = _GohbergSemencul(np.linalg.solve(system, np.eye(n)[:, 0]))
    bound = 4 * np.finfo(float).eps * np.linalg.cond(system) * np.max(np.abs(dense))
    np.testing.assert_allclose(inverse.apply(vectors), dense, rtol=0, atol=bound)


def _probe_columns(n, count):
    """Seeded random signs and sinusoids, as the ends check's probes, and a zero column."""
    t = np.arange(n) * DT
    signs = np.random.default_rng(7).choice([-1.0, 1.0], (n, count // 2))
    waves = np.cos(2 * np.pi * np.outer(t, np.linspace(1, 200, count - count // 2 - 1)))
    return np.column_stack([signs, np.zeros(n), waves])


@pytest.mark.parametrize(
    ("length_scale_s", "noise_ratio"), [(0.002, 1.0), (0.05, 0.003), (0.4, 0.01)]
)
def test_many_columns_are_solved_with_the_exact_inverse_to_the_same_tolerance(
    length_scale_s, noise_ratio, monkeypatch
):
    """From ``EXACT_PRECONDITIONER_COLUMNS`` columns the solver is preconditioned by the
    Gohberg-Semencul inverse; its posterior means are the circulant path's to the accuracy the
    dense-solve test asks (two runs that meet the tolerance differ in α by up to the
    tolerance times the condition number, in K α by much less), and it took the exact path:
    at most 3 iterations a column."""
    n = 1200
    y = _probe_columns(n, 2 * EXACT_PRECONDITIONER_COLUMNS)
    kernel = _ToeplitzKernel(n, DT, length_scale_s, noise_ratio)
    circulant = kernel._conjugate_gradients(y, False, kernel.precondition, 2000)
    iterations = []
    inner = gaussian_process._GohbergSemencul.apply

    def counted(self, vectors):
        iterations.append(vectors.shape[1])
        return inner(self, vectors)

    monkeypatch.setattr(gaussian_process._GohbergSemencul, "apply", counted)
    exact = kernel.solve(y)
    assert 0 < len(iterations) <= 3  # the first preconditioning and at most 2 more
    assert not exact[:, EXACT_PRECONDITIONER_COLUMNS].any()  # the zero column
    smoothed = kernel.apply(circulant, 0)
    scale = np.max(np.abs(smoothed), axis=0)
    np.testing.assert_array_less(
        np.max(np.abs(kernel.apply(exact, 0) - smoothed), axis=0), 1e-8 * scale + 1e-300
    )


def test_the_solver_falls_back_to_the_circulant_preconditioner(monkeypatch):
    """A generator that cannot be used, or an exact-inverse run that does not converge in its
    iterations (none allowed here), leaves the circulant path's solution, bit for bit."""
    n, ell, ratio = 1200, 0.05, 0.003
    y = _probe_columns(n, 2 * EXACT_PRECONDITIONER_COLUMNS)
    reference = _ToeplitzKernel(n, DT, ell, ratio)
    circulant = reference._conjugate_gradients(y, False, reference.precondition, 2000)
    monkeypatch.setattr(gaussian_process, "EXACT_PRECONDITIONER_ITERATIONS", 0)
    np.testing.assert_array_equal(_ToeplitzKernel(n, DT, ell, ratio).solve(y), circulant)
    monkeypatch.undo()
    unusable = _ToeplitzKernel(n, DT, ell, ratio)
    monkeypatch.setattr(unusable, "exact_inverse", lambda: None)
    np.testing.assert_array_equal(unusable.solve(y), circulant)


def test_lines_are_reproduced_to_the_ends_and_the_ends_check_keeps_most_samples():
    """Every sample is estimated (the posterior is exact on the line, ends included); the
    ends check then keeps 99 %, 97 %, 97 % of 1.2 s at the default 10 ms length scale."""
    t = np.arange(1200) * DT
    x = 2.5 - 4.0 * t
    posterior = posterior_derivatives(x, DT, (0, 1, 2), 0.01, 0.1)
    np.testing.assert_allclose(posterior[0], x, atol=1e-12)
    np.testing.assert_allclose(posterior[1], -4.0, atol=1e-9)
    np.testing.assert_allclose(posterior[2], 0.0, atol=1e-9)
    estimate = methods.get("gaussian_process")(x, DT)
    for order, least in ((0, 0.98), (1, 0.96), (2, 0.96)):
        valid = estimate.valid[order]
        assert valid.mean() >= least, (order, valid.mean())
        np.testing.assert_array_equal(estimate[order][valid], posterior[order][valid])


def test_a_smooth_signal_is_differentiated_accurately_on_every_valid_sample():
    """sin(2π·3t) + t² on 2 s without noise, against its analytic derivatives (errors relative
    to their peak). At least 0.3 s from the ends: 1e-7, 3e-6, 5e-5 for x, ẋ, ẍ. At the ends
    the zero-mean process reverts to the record's line, losing the curvature of t² (measured on
    every sample: 4e-5, 6e-3, 0.17); the ends check masks 57-89 samples each side, and the
    valid samples stay within 3e-6, 7e-5, 8e-4."""
    t = np.arange(2001) * DT
    omega = 2 * np.pi * 3
    truth = [
        np.sin(omega * t) + t**2,
        omega * np.cos(omega * t) + 2 * t,
        -(omega**2) * np.sin(omega * t) + 2,
    ]
    estimate = methods.get("gaussian_process", length_scale_s=0.03, noise_ratio=1e-3)(truth[0], DT)
    inner = slice(300, -300)
    for order, middle_bound, end_bound in ((0, 1e-7, 1e-5), (1, 3e-6, 2e-4), (2, 5e-5, 2e-3)):
        error = np.abs(estimate[order] - truth[order]) / np.max(np.abs(truth[order]))
        valid = estimate.valid[order]
        assert np.max(error[inner]) < middle_bound, (order, np.max(error[inner]))
        assert np.max(error[valid]) < end_bound, (order, np.max(error[valid]))
        assert valid.mean() > 0.9


@pytest.mark.parametrize(("length_scale_s", "noise_ratio"), [(0.01, 0.1), (0.0472, 0.00405)])
def test_the_response_is_what_sinusoids_get_away_from_the_ends(length_scale_s, noise_ratio):
    """Middle third of 6 s: the Wiener filter H on the sinusoid, plus (1 - H0(0)) times the
    record's least-squares line (taken out before a filter that passes 0 Hz at H0(0) < 1), to
    rounding."""
    method = methods.get("gaussian_process", length_scale_s=length_scale_s, noise_ratio=noise_ratio)
    n = 6001
    t = np.arange(n) * DT
    middle = slice(n // 3, 2 * n // 3)
    shrink = 1 - gaussian_process_response([0.0], DT, length_scale_s, noise_ratio, 0)[0].real
    assert 0 < shrink < 1e-2
    for frequency in (3.0, 17.0, 61.0, 210.0):
        omega = 2 * np.pi * frequency
        for x, part in ((np.cos(omega * t), np.real), (np.sin(omega * t), np.imag)):
            estimate = method(x, DT)
            line, slope = _line(x, DT)
            for order, trend in ((0, line), (1, slope), (2, 0.0)):
                response = method.frequency_response([frequency], DT, order)[0]
                expected = part(response * np.exp(1j * omega * t[middle])) + shrink * (
                    trend[middle] if order == 0 else trend
                )
                scale = max(1.0, omega**order)
                np.testing.assert_allclose(
                    estimate[order][middle], expected, rtol=0, atol=1e-8 * scale
                )


def test_the_response_is_the_wiener_gain_of_the_spectral_density():
    ell, ratio = 0.02, 0.1
    f = np.array([0.0, 5.0, 20.0, 40.0])
    density = np.sqrt(2 * np.pi) * ell * np.exp(-2 * (np.pi * ell * f) ** 2)
    gain = density / (density + ratio**2 * DT)
    for order in (0, 1, 2):
        response = gaussian_process_response(f, DT, ell, ratio, order)
        np.testing.assert_allclose(response, (2j * np.pi * f) ** order * gain, rtol=1e-12)
    # half gain where 2π²ℓ²f² = ln(√(2π) ℓ / (r² Δt))
    half = np.sqrt(np.log(np.sqrt(2 * np.pi) * ell / (ratio**2 * DT)) / 2) / (np.pi * ell)
    assert gaussian_process_response([half], DT, ell, ratio, 0)[0].real == pytest.approx(0.5)


def test_the_marginal_likelihood_recovers_a_known_noise_level_and_length_scale():
    """A draw of the RBF prior (ℓ = 20 ms, σ_f = 1) plus white noise of std 0.1, 400 samples:
    the fit finds the noise within 15 % and the length scale within 30 %."""
    rng = np.random.default_rng(5)
    t = np.arange(400) * DT
    prior = rbf_covariance(t[:, None] - t[None, :], 0.02, 0) + 1e-9 * np.eye(t.size)
    signal = np.linalg.cholesky(prior) @ rng.standard_normal(t.size)
    x = signal + 0.1 * rng.standard_normal(t.size)
    length_scale_s, ratio, noise_std = fit_hyperparameters(x, DT)
    assert noise_std == pytest.approx(0.1, rel=0.15)
    assert length_scale_s == pytest.approx(0.02, rel=0.3)
    assert ratio == pytest.approx(noise_std / np.std(x), rel=0.5)


def _scikit_learn_regressor(t, start_length_s, span_s, restarts=1):
    kernel = ConstantKernel(1.0, (1e-2, 1e2)) * RBF(
        start_length_s, (t[1] - t[0], span_s)
    ) + WhiteKernel(0.1, (1e-8, 10.0))
    return GaussianProcessRegressor(
        kernel, alpha=1e-10, n_restarts_optimizer=restarts, random_state=0
    )


@pytest.mark.parametrize(
    "steps",
    # two separated segments, as the fit's samples are laid out on long records; a whole
    # record of odd length (the folded even block is bordered by the middle sample); 3 samples
    [np.r_[np.arange(150), np.arange(900, 1050)], np.arange(301), np.arange(3)],
    ids=["two-segments", "odd-record", "three-samples"],
)
@pytest.mark.parametrize(
    ("signal_variance", "length_scale_s", "noise_variance"),
    [(1.0, 0.01, 0.1), (3.7, 0.2, 1e-6), (0.02, 0.001, 5.0), (50.0, 0.05, 1e-8)],
)
def test_the_log_marginal_likelihood_and_its_gradient_are_scikit_learns(
    signal_variance, length_scale_s, noise_variance, steps
):
    t = steps * DT
    y = np.sin(2 * np.pi * 4 * t) + 0.05 * np.random.default_rng(1).standard_normal(t.size)
    regressor = _scikit_learn_regressor(t, 0.01, 1.0)
    regressor.optimizer = None
    regressor.fit(t[:, None], y)
    log_params = np.log([signal_variance, length_scale_s, noise_variance])
    theirs, their_gradient = regressor.log_marginal_likelihood(log_params, eval_gradient=True)
    ours, gradient = rbf_log_marginal_likelihood(log_params, t, y)
    # two rounding paths through K's factor differ by up to about eps * cond(K): 3e-13 to
    # 8e-7 here (measured 0 to 4e-7; cond(K) from 1 to 5e11)
    covariance = signal_variance * rbf_covariance(t[:, None] - t, length_scale_s, 0)
    covariance += (noise_variance + 1e-10) * np.eye(t.size)
    rel = max(1e-12, 1e-14 * np.linalg.cond(covariance))
    assert ours == pytest.approx(theirs, rel=rel)
    np.testing.assert_allclose(
        gradient, their_gradient, rtol=0, atol=rel * np.abs(their_gradient).max()
    )


def test_the_likelihood_refuses_times_not_symmetric_about_their_middle():
    t = np.r_[np.arange(150), np.arange(900, 1051)] * DT
    with pytest.raises(ValueError, match=r"`times_s` must hold at least 2 times symmetric"):
        rbf_log_marginal_likelihood(np.zeros(3), t, np.ones(t.size))


def test_the_likelihood_gradient_is_the_derivative_of_the_likelihood():
    t = np.arange(200) * DT
    y = np.cos(2 * np.pi * 3 * t) + 0.1 * np.random.default_rng(2).standard_normal(t.size)
    log_params = np.log([2.0, 0.03, 0.02])
    _, gradient = rbf_log_marginal_likelihood(log_params, t, y)
    for k in range(3):
        step = np.zeros(3)
        step[k] = 1e-5
        up, _ = rbf_log_marginal_likelihood(log_params + step, t, y)
        down, _ = rbf_log_marginal_likelihood(log_params - step, t, y)
        assert (up - down) / 2e-5 == pytest.approx(gradient[k], rel=1e-6, abs=1e-6)


@pytest.mark.parametrize(
    ("noise_std", "tolerance"),
    # an interior optimum agrees to rounding (measured: 2e-11 in log-parameters); noise-free
    # data put the noise level on its floor, where the likelihood is flat along the bound and
    # the optimiser's last steps follow rounding (measured: log σ_f² 1.0e-4 apart, log ℓ
    # 7.7e-6, log p 4.7e-10, within L-BFGS-B's ftol of 2.2e-9)
    [(0.05, 1e-9), (0.0, 1e-3)],
)
def test_the_likelihood_optimum_is_scikit_learns(noise_std, tolerance):
    """The same optimiser from the same starts (a seeded restart included) as
    scikit-learn's regressor with ConstantKernel * RBF + WhiteKernel finds the same optimum;
    fit_hyperparameters returns it in seconds and noise units."""
    rng = np.random.default_rng(7)
    n = 1500  # longer than fit_samples: two segments of 200
    t = np.arange(n) * DT
    x = np.sin(2 * np.pi * 4 * t) + 0.3 * np.sin(2 * np.pi * 9 * t) + 5 * t
    x += noise_std * rng.standard_normal(n)
    line = np.polyval(np.polyfit(t, x, 1), t)
    scale = np.sqrt(np.mean((x - line) ** 2))
    samples = np.r_[np.arange(200), np.arange(n - 200, n)]
    y = (x - line)[samples] / scale
    regressor = _scikit_learn_regressor(t, 10 * DT, (n - 1) * DT)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        regressor.fit(t[samples, None], y)

    start, bounds = regressor.kernel.theta, regressor.kernel.bounds
    optimum = likelihood_optimum(t[samples], y, start, bounds)
    np.testing.assert_allclose(optimum.x, regressor.kernel_.theta, rtol=0, atol=tolerance)
    assert -optimum.fun == pytest.approx(regressor.log_marginal_likelihood_value_, rel=3e-9)

    length_scale_s, ratio, noise = fit_hyperparameters(x, DT)
    signal_variance, their_length_s, noise_variance = np.exp(regressor.kernel_.theta)
    assert length_scale_s == pytest.approx(their_length_s, rel=tolerance)
    assert noise == pytest.approx(np.sqrt(noise_variance) * scale, rel=tolerance)
    their_ratio = np.clip(np.sqrt(noise_variance / signal_variance), 1e-3, 1e3)
    assert ratio == pytest.approx(their_ratio, rel=tolerance)


def test_the_data_only_method_is_accurate_on_the_paper_signal_and_a_line_is_a_line():
    from diffbench import signals

    realisation = signals.get_scenario("paper-signal").realise(3)
    estimate = methods.get("gaussian_process_ml")(realisation.x, realisation.dt_s)
    inside = realisation.interior
    for order, bound in ((0, 0.08), (1, 5.0)):
        error = estimate[order][inside] - realisation.truth[order][inside]
        assert np.sqrt(np.mean(error**2)) < bound, order
    t = np.arange(500) * DT
    line = methods.get("gaussian_process_ml")(1.0 + 3.0 * t, DT)
    np.testing.assert_allclose(line[0], 1.0 + 3.0 * t, atol=1e-12)
    np.testing.assert_allclose(line[1], 3.0, atol=1e-9)
    np.testing.assert_allclose(line[2], 0.0, atol=1e-9)
    assert fit_hyperparameters(1.0 + 3.0 * t, DT) is None


@pytest.mark.parametrize(
    ("params", "dt", "message"),
    [
        ({"length_scale_s": 5e-4}, DT, r"`length_scale_s` must be in \[0.001, 1000\] s"),
        ({"length_scale_s": 2000.0}, DT, r"`length_scale_s` must be in \[0.001, 1000\] s"),
        ({"length_scale_s": 0.01}, 0.1, r"`length_scale_s` must be in \[0.1, 100000\] s"),
    ],
)
def test_a_length_scale_outside_one_step_to_a_million_is_refused(params, dt, message):
    with pytest.raises(ValueError, match=message):
        methods.get("gaussian_process", **params)(np.zeros(100), dt)
    with pytest.raises(ValueError, match=message):
        methods.get("gaussian_process", **params).frequency_response([1.0], dt, 1)


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"noise_ratio": 1e-4}, r"`noise_ratio` must be a finite number in \[0.001, 1000\]"),
        ({"noise_ratio": 0.0}, r"`noise_ratio` must be a finite number in \[0.001, 1000\]"),
        ({"length_scale_s": -1.0}, r"`length_scale_s` must be a finite number in \(0, inf\)"),
        ({"length_scale_s": "long"}, r"`length_scale_s` must be a finite number"),
    ],
)
def test_bad_hyperparameters_are_refused_by_name(params, message):
    with pytest.raises(ValueError, match=message):
        methods.get("gaussian_process", **params)
    with pytest.raises(ValueError, match=r"unknown parameter\(s\) length_scale_s"):
        methods.get("gaussian_process_ml", length_scale_s=0.01)
    with pytest.raises(ValueError, match=r"`fit_samples` must be one of \{200, 400, 800\}"):
        methods.get("gaussian_process_ml", fit_samples=300)


def test_the_data_only_estimate_uses_the_fit_rounded_to_its_grid():
    """``gaussian_process_ml`` forms its posterior at the fitted length scale and noise ratio
    rounded to the 1 % grid, so a perturbation of the record at rounding level (as another BLAS
    kernel's rounding makes: it moves the flat likelihood's optimum by about 1e-8) leaves them
    unchanged, and the estimate moves only by the posterior's linear response to it."""
    from diffbench import signals
    from diffbench.methods.gaussian_process import FIT_GRID, _canonical, snap_to_grid

    realisation = signals.get_scenario("paper-signal").realise(3)
    x, dt = realisation.x, realisation.dt_s
    nudged = x * (1 + 1e-13 * np.random.default_rng(0).standard_normal(x.size))
    fits = [fit_hyperparameters(_canonical(record), dt) for record in (x, nudged)]
    assert fits[0][:2] != fits[1][:2]  # the raw optimum moves with rounding...
    snapped = [  # the length scale on the grid in sampling steps
        (dt * snap_to_grid(fit[0] / dt, 1.0, x.size - 1.0), snap_to_grid(fit[1], 1e-3, 1e3))
        for fit in fits
    ]
    assert snapped[0] == snapped[1]  # ...the grid point does not
    for value in (snapped[0][0] / dt, snapped[0][1]):  # a point of the grid, near the fit
        assert np.log(value) / FIT_GRID == pytest.approx(round(np.log(value) / FIT_GRID), abs=1e-6)
    assert snapped[0][0] == pytest.approx(fits[0][0], rel=FIT_GRID)
    estimate = methods.get("gaussian_process_ml")(x, dt, orders=(0, 1, 2))
    expected = posterior_derivatives(x, dt, (0, 1, 2), *snapped[0])
    for order in (0, 1, 2):
        valid = estimate.valid[order]
        np.testing.assert_array_equal(estimate[order][valid], expected[order][valid])
