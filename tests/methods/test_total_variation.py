"""The total-variation (ℓ1 trend filtering) differentiator against exact truth: the optimality
conditions of the convex problem checked independently of the solver, a general-purpose
solver on a small problem, the closed-form limits (λ → 0: the data; λ >= λ_max: the
least-squares polynomial), exactness of the difference stencils, and bad input."""

import numpy as np
import pytest
from scipy.optimize import LinearConstraint, minimize

from diffbench import methods
from diffbench.methods.total_variation import (
    END_SAMPLES,
    difference_adjoint,
    fused_penalty,
    trend_derivatives,
    trend_filter,
)


def _noisy(n: int, seed: int) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)
    rng = np.random.default_rng(seed)
    return np.sin(2 * np.pi * 1.5 * t) + 0.5 * np.abs(t - 0.4) + 0.1 * rng.standard_normal(n)


def _dual_from_residual(residual: np.ndarray, count: int) -> np.ndarray:
    """The ν with Dᵀν = residual, by running sums (independent of the solver)."""
    nu = residual
    for _ in range(count):
        nu = -np.cumsum(nu)[:-1]
    return nu


@pytest.mark.parametrize("tv_order", [1, 2])
@pytest.mark.parametrize("fraction", [1e-4, 1e-3, 1e-2, 0.1, 0.5])
@pytest.mark.parametrize("n", [12, 60, 400])
def test_solution_satisfies_the_optimality_conditions(tv_order, fraction, n):
    """z is optimal iff x - z = Dᵀν with |ν| <= λ and ν_i = λ·sign((Dz)_i) where (Dz)_i != 0
    (subgradient of λ‖Dz‖₁). ν is rebuilt from x - z alone, by running sums."""
    if tv_order == 2 and n == 400 and fraction >= 0.01:
        pytest.skip("quadratic stretches of ~100+ samples: the documented ill-conditioned case")
    count = tv_order + 1
    x = _noisy(n, seed=n + tv_order)
    limit, _ = fused_penalty(x, tv_order)
    penalty = fraction * limit
    z = trend_filter(x, penalty, tv_order)
    nu = _dual_from_residual(x - z, count)
    np.testing.assert_allclose(difference_adjoint(nu, count), x - z, atol=1e-12)
    assert np.max(np.abs(nu)) <= penalty * (1 + 1e-9)
    bends = np.diff(z, count)
    kinks = np.abs(bends) > 1e-9 * np.max(np.abs(x))
    assert kinks.any()  # below λ_max the trend is not one polynomial
    np.testing.assert_allclose(nu[kinks], penalty * np.sign(bends[kinks]), rtol=1e-9)


@pytest.mark.parametrize("tv_order", [1, 2])
def test_agrees_with_a_general_solver_on_the_split_problem(tv_order):
    """min ½‖x - z‖² + λ Σ t  s.t.  -t <= Dz <= t, smooth in (z, t), by scipy's SLSQP."""
    count = tv_order + 1
    n = 16
    x = _noisy(n, seed=3)
    penalty = 0.05 * fused_penalty(x, tv_order)[0]
    difference = np.diff(np.eye(n), count, axis=0)
    m = difference.shape[0]

    def objective(v):
        return 0.5 * np.sum((x - v[:n]) ** 2) + penalty * np.sum(v[n:])

    def gradient(v):
        return np.concatenate([v[:n] - x, np.full(m, penalty)])

    bounds = LinearConstraint(
        np.block([[difference, np.eye(m)], [-difference, np.eye(m)]]), 0.0, np.inf
    )
    start = np.concatenate([x, np.abs(difference @ x)])
    reference = minimize(
        objective,
        start,
        jac=gradient,
        constraints=[bounds],
        method="SLSQP",
        options={"ftol": 1e-14, "maxiter": 1000},
    )
    # status 8: SLSQP's line search found no descent left at rounding level (seen under
    # OpenBLAS Sandybridge at ftol 1e-14): the point is then judged by the checks below
    assert reference.success or reference.status == 8, reference.message
    z = trend_filter(x, penalty, tv_order)
    np.testing.assert_allclose(z, reference.x[:n], atol=1e-6)
    assert objective(np.concatenate([z, np.abs(difference @ z)])) <= reference.fun + 1e-12


@pytest.mark.parametrize("tv_order", [1, 2])
def test_a_tiny_penalty_gives_back_the_data(tv_order):
    """‖z - x‖∞ <= λ 2^{k+1} always (|(Dᵀν)_i| <= λ Σ|taps|), so λ → 0 returns x."""
    x = _noisy(300, seed=1)
    for penalty in (1e-9, 1e-6):
        z = trend_filter(x, penalty, tv_order)
        assert np.max(np.abs(z - x)) <= penalty * 2 ** (tv_order + 1) * (1 + 1e-6)
    np.testing.assert_array_equal(trend_filter(x, 1e-300, tv_order), x)


@pytest.mark.parametrize("tv_order", [1, 2])
def test_a_large_penalty_gives_the_least_squares_polynomial(tv_order):
    x = _noisy(250, seed=2)
    u = np.arange(x.size, dtype=float)
    fit = np.polynomial.Polynomial.fit(u, x, tv_order)(u)
    limit, polynomial = fused_penalty(x, tv_order)
    np.testing.assert_allclose(polynomial, fit, atol=1e-12)
    for penalty in (limit, 10 * limit, np.inf):
        np.testing.assert_allclose(trend_filter(x, penalty, tv_order), fit, atol=1e-12)
    # just below λ_max the trend bends once (and is no longer the fit)
    below = trend_filter(x, 0.999 * limit, tv_order)
    assert np.max(np.abs(below - fit)) > 1e-6


@pytest.mark.parametrize("tv_order", [1, 2])
def test_polynomials_of_degree_k_are_kept_and_differentiated_exactly(tv_order):
    dt = 0.002
    t = np.arange(500) * dt
    poly = np.polynomial.Polynomial([0.3, -1.2, 0.7][: tv_order + 1])
    estimate = methods.get("total_variation", penalty=1e-3, tv_order=tv_order)(poly(t), dt)
    for order in (0, 1, 2):
        valid = estimate.valid[order]  # all but the end samples that read the trend's ends
        assert valid.sum() == t.size - 2 * END_SAMPLES[order]
        np.testing.assert_allclose(
            estimate[order][valid], poly.deriv(order)(t[valid]), rtol=0, atol=1e-9
        )


def test_difference_stencils_are_exact_on_quadratics_at_every_sample():
    dt = 0.01
    t = np.arange(7) * dt
    z = 2.0 - 3.0 * t + 5.0 * t**2
    derivatives = trend_derivatives(z, dt, (0, 1, 2))
    np.testing.assert_allclose(derivatives[1], -3.0 + 10.0 * t, rtol=0, atol=1e-11)
    np.testing.assert_allclose(derivatives[2], 10.0, rtol=0, atol=1e-9)
    # by hand at the first sample: (-3·z0 + 4·z1 - z2) / (2 dt)
    assert derivatives[1][0] == pytest.approx((-3 * z[0] + 4 * z[1] - z[2]) / (2 * dt))


def test_penalty_is_per_second_not_per_sample():
    """λ = α / Δt^{k+1}: the method at (α, Δt) is the trend filter at that λ."""
    x = _noisy(200, seed=4)
    for tv_order, dt in ((1, 0.004), (2, 0.001)):
        alpha = 1e-6
        estimate = methods.get("total_variation", penalty=alpha, tv_order=tv_order)(x, dt)
        direct = trend_filter(x, alpha / dt ** (tv_order + 1), tv_order)
        valid = estimate.valid[0]
        assert valid.sum() == x.size - 2 * END_SAMPLES[0]
        np.testing.assert_array_equal(estimate[0][valid], direct[valid])


def test_a_kink_in_the_slope_is_kept_sharp():
    """A piecewise-linear signal with one kink: the k = 1 trend is piecewise linear with its
    bend at the kink, and its slope away from the kink is right to within a few %."""
    dt = 1e-3
    t = np.arange(1000) * dt
    truth = np.where(t < 0.5, 2.0 * t, 1.0 - 1.0 * (t - 0.5))
    slope = np.where(t < 0.5, 2.0, -1.0)
    x = truth + 0.01 * np.random.default_rng(5).standard_normal(t.size)
    estimate = methods.get("total_variation", penalty=1e-4, tv_order=1)(x, dt)
    away = (np.abs(t - 0.5) > 0.05) & estimate.valid[1]
    assert np.max(np.abs(estimate[1][away] - slope[away])) < 0.1
    bends = np.abs(np.diff(estimate[0], 2)) > 1e-9
    assert bends.sum() <= 40 and np.all(np.abs(t[1:-1][bends] - 0.5) < 0.1)


def test_deterministic_and_equivariant_to_scale():
    x = _noisy(300, seed=6)
    method = methods.get("total_variation", penalty=1e-7, tv_order=2)
    first, second = method(x, 1e-3), method(x, 1e-3)
    np.testing.assert_array_equal(first[2], second[2])
    scaled = methods.get("total_variation", penalty=4e-7, tv_order=2)(4 * x, 1e-3)
    np.testing.assert_allclose(scaled[1], 4 * first[1], rtol=1e-7, atol=1e-6)  # NaN at ends


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"penalty": 0.0}, r"`penalty` must be a finite number in \(0, inf\), got 0"),
        ({"penalty": -1e-6}, r"`penalty` must be a finite number in \(0, inf\)"),
        ({"penalty": np.inf}, r"`penalty` must be a finite number"),
        ({"tv_order": 3}, r"`tv_order` must be one of \{1, 2\}, got 3"),
        ({"tv_order": 0}, r"`tv_order` must be one of \{1, 2\}, got 0"),
    ],
)
def test_bad_parameters_are_refused_by_name(params, message):
    with pytest.raises(ValueError, match=message):
        methods.get("total_variation", **params)


@pytest.mark.parametrize("tv_order", [1, 2])
def test_records_without_a_valid_sample_are_refused(tv_order):
    # k + 2 samples make the penalty; the masked ends and one valid sample between need more
    shortest = 2 * max(END_SAMPLES.values()) + 1
    assert shortest >= tv_order + 2
    method = methods.get("total_variation", tv_order=tv_order)
    with pytest.raises(ValueError, match=rf"`x` has {shortest - 1} samples .* {shortest}"):
        method(np.arange(shortest - 1.0), 1e-3)
    estimate = method(np.arange(float(shortest)) ** 2, 1e-3)
    for order in (0, 1, 2):
        assert estimate.valid[order].sum() == shortest - 2 * END_SAMPLES[order]
        assert np.isfinite(estimate[order][estimate.valid[order]]).all()


def test_the_method_holds_fewer_than_eleven_record_length_arrays(peak_arrays):
    # outputs (three) and temporaries: the interior-point iteration holds ν, μ₁, μ₂, the
    # Newton step and the band of its solve (the version that kept its slacks, Dx and the
    # steps of μ held 31); the 1 GB target at 1e7 samples is 12.5
    method = methods.preset("total_variation", "paper-signal")
    assert peak_arrays(method, 100_000) < 11
