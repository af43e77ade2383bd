"""The Gaussian process at irregular time stamps, natively (issue 45 item 4): the posterior
mean with the covariance of the actual times, factored as a band
(:func:`~diffbench.methods.gaussian_process.posterior_derivatives_at`).

Checked against a dense solve of the same posterior written out here with numpy (the
independent route), against the uniform path on uniform stamps, and for exactness on straight
lines. Each bound is the forward error of a backward-stable solve: 10 eps (or the uniform
path's conjugate-gradient tolerance) times the condition of K + r² I, times the largest
row sum of |k^(n)(t_i - t_j)|, times the largest |α| (plus the line's rounding).
"""

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods.gaussian_process import SOLVER_TOLERANCE, rbf_covariance

EPS = np.finfo(float).eps


def dense_posterior(x, times, length_scale_s, noise_ratio, order):
    """The posterior mean's derivative of ``order`` by a dense solve, and the bound's factor
    (condition of K + r² I times the largest row sum of |k^(n)| times the largest |α|)."""
    lags = times[:, None] - times[None, :]
    covariance = rbf_covariance(lags, length_scale_s, 0) + noise_ratio**2 * np.eye(times.size)
    slope, intercept = np.polyfit(times, x, 1)
    alpha = np.linalg.solve(covariance, x - (slope * times + intercept))
    cross = rbf_covariance(lags, length_scale_s, order)
    line = {0: slope * times + intercept, 1: slope * np.ones_like(times), 2: 0.0 * times}[order]
    factor = np.linalg.cond(covariance) * np.abs(cross).sum(axis=1).max() * np.abs(alpha).max()
    return cross @ alpha + line, factor


def stamps(n: int, step: float, kind: str, seed: int = 5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * step
    if kind == "jitter":
        t[1:-1] += rng.uniform(-0.45, 0.45, n - 2) * step
    elif kind == "dropout":
        t = np.sort(np.concatenate([t[:1], rng.choice(t[1:-1], int(0.7 * (n - 2)), False), t[-1:]]))
    return t


@pytest.mark.parametrize("kind", ["jitter", "dropout"])
@pytest.mark.parametrize(("length_scale_s", "noise_ratio"), [(0.03, 0.02), (0.01, 0.3)])
def test_the_banded_posterior_is_the_dense_one(kind, length_scale_s, noise_ratio):
    t = stamps(400, 2e-3, kind)
    x = np.sin(2 * np.pi * 4 * t) + 0.3 * np.cos(2 * np.pi * 9 * t) + 0.5 * t
    x += 0.02 * np.random.default_rng(1).standard_normal(t.size)
    method = methods.get("gaussian_process", length_scale_s=length_scale_s, noise_ratio=noise_ratio)
    values, _ = method._estimate_at(x, t, (0, 1, 2))
    for order in (0, 1, 2):
        expected, factor = dense_posterior(x, t, length_scale_s, noise_ratio, order)
        bound = 10 * EPS * (factor + np.abs(expected).max())
        assert bound < 1e-6 * np.abs(expected).max()  # a bound that can fail
        np.testing.assert_allclose(values[order], expected, rtol=0, atol=bound)


def test_the_native_path_on_uniform_stamps_is_the_uniform_path():
    """The same values to the uniform path's solver tolerance, the same trusted samples."""
    dt = 2e-3
    t = np.arange(500) * dt
    x = np.sin(2 * np.pi * 3 * t) + 0.05 * np.random.default_rng(2).standard_normal(t.size)
    method = methods.get("gaussian_process", length_scale_s=0.02, noise_ratio=0.05)
    uniform = method(x, dt)
    values, valid = method._estimate_at(x, t, (0, 1, 2))
    for order in (0, 1, 2):
        np.testing.assert_array_equal(valid[order], uniform.valid[order])
        _, factor = dense_posterior(x, t, 0.02, 0.05, order)
        bound = 10 * (SOLVER_TOLERANCE + EPS) * (factor + np.abs(uniform[order]).max())
        np.testing.assert_allclose(values[order], uniform[order], rtol=0, atol=bound)


@pytest.mark.parametrize("kind", ["jitter", "dropout"])
def test_straight_lines_are_exact_at_irregular_stamps(kind):
    """The line is the prior mean, so the residual is rounding only: |y_i| <= 4 eps (|x| +
    |slope t|), α = (K + r² I)^-1 y within ||y||_2 / λ_min, and the estimate's excess within
    the largest row 2-norm of k^(n) times that (10 times, for the solve's own rounding)."""
    t = stamps(300, 1e-3, kind, seed=8)
    x = 2.5 - 4.0 * t
    length_scale_s, noise_ratio = 0.01, 0.1
    estimate = methods.get(
        "gaussian_process", length_scale_s=length_scale_s, noise_ratio=noise_ratio
    )(x, t=t)
    lags = t[:, None] - t[None, :]
    covariance = rbf_covariance(lags, length_scale_s, 0) + noise_ratio**2 * np.eye(t.size)
    residual = 4 * EPS * np.linalg.norm(np.abs(x) + 4.0 * np.abs(t))
    alpha = residual / np.linalg.eigvalsh(covariance)[0]
    for order, expected in ((0, x), (1, -4.0 + 0 * t), (2, 0 * t)):
        rows = np.linalg.norm(rbf_covariance(lags, length_scale_s, order), axis=1).max()
        bound = 10 * (rows * alpha + EPS * np.abs(expected).max())
        assert bound < 1e-6 * 4.0  # a bound that can fail (4: the slope)
        np.testing.assert_allclose(estimate[order], expected, rtol=0, atol=bound)


def test_a_band_too_large_is_refused_naming_t():
    t = stamps(20_000, 1e-4, "jitter")
    method = methods.get("gaussian_process", length_scale_s=0.05, noise_ratio=0.1)
    with pytest.raises(ValueError, match=r"`t` has 20000 samples with up to .* use a shorter"):
        method(np.sin(t), t=t)


def test_the_ml_process_on_uniform_stamps_is_its_uniform_path():
    """``gaussian_process_ml`` at stamps fits on the grid they lie on (here: themselves), so
    on uniform stamps it is its uniform path: the same trusted samples, the same values within
    the bound of the given-setting test at the fitted setting."""
    from diffbench.methods import gaussian_process as gp

    dt = 2e-3
    t = np.arange(500) * dt
    x = np.sin(2 * np.pi * 3 * t) + 0.05 * np.random.default_rng(4).standard_normal(t.size)
    uniform = methods.get("gaussian_process_ml")(x, dt)
    values, valid = methods.get("gaussian_process_ml")._estimate_at(x, t, (0, 1, 2))
    length, ratio, _ = gp.fit_hyperparameters(gp._canonical(x), dt, 400)
    length = dt * gp.snap_to_grid(length / dt, 1.0, max(2.0, t.size - 1.0))
    ratio = gp.snap_to_grid(ratio, gp.MIN_NOISE_RATIO, gp.MAX_NOISE_RATIO)
    for order in (0, 1, 2):
        np.testing.assert_array_equal(valid[order], uniform.valid[order])
        _, factor = dense_posterior(x, t, length, ratio, order)
        bound = 10 * (SOLVER_TOLERANCE + EPS) * (factor + np.abs(uniform[order]).max())
        assert bound < 1e-3 * np.abs(uniform[order]).max()  # ill-conditioned (ℓ long), can fail
        np.testing.assert_allclose(values[order], uniform[order], rtol=0, atol=bound)


@pytest.mark.parametrize("kind", ["jitter", "dropout"])
def test_the_ml_process_at_stamps_is_the_given_process_at_the_fitted_setting(kind):
    """At irregular stamps: the hyperparameters the likelihood picks on the record resampled
    to its grid, then ``gaussian_process``'s native posterior at the stamps with them."""
    from diffbench.methods import gaussian_process as gp
    from diffbench.methods._time_stamps import to_grid, uniform_grid

    t = stamps(400, 2e-3, kind, seed=11)
    x = np.sin(2 * np.pi * 4 * t) + 0.02 * np.random.default_rng(6).standard_normal(t.size)
    estimate = methods.get("gaussian_process_ml")(x, t=t)
    grid, step = uniform_grid(t)
    length, ratio, _ = gp.fit_hyperparameters(gp._canonical(to_grid(x, t, grid)), step, 400)
    length = step * gp.snap_to_grid(length / step, 1.0, max(2.0, t.size - 1.0))
    ratio = gp.snap_to_grid(ratio, gp.MIN_NOISE_RATIO, gp.MAX_NOISE_RATIO)
    given = methods.get("gaussian_process", length_scale_s=length, noise_ratio=ratio)(x, t=t)
    for order in (0, 1, 2):
        np.testing.assert_array_equal(estimate[order], given[order])  # the same computation
        assert estimate.valid[order].mean() > 0.5
