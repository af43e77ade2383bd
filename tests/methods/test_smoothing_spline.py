"""The smoothing spline: Reinsch's banded solve against an exact rational solve and against
scipy's ``make_smoothing_spline`` (the B-spline formulation), the method against scipy
called directly, its response's half-gain point and its memory."""

from fractions import Fraction

import numpy as np
import pytest
from scipy.interpolate import make_smoothing_spline

from diffbench import methods
from diffbench.methods.smoothing_spline import (
    natural_smoothing_spline,
    smoothing_parameter,
    smoothing_spline_response,
)

DT = 1e-3


def _exact_reinsch(steps, y, lam):
    """g and γ of the smoothing spline in rational arithmetic: Reinsch's system
    (R + λQᵀQ)γ = Qᵀy, g = y - λQγ, built densely from its definition and solved by
    elimination without rounding."""
    n, m = len(y), len(y) - 2
    q = [[Fraction(0)] * m for _ in range(n)]
    for j in range(m):
        q[j][j], q[j + 2][j] = 1 / steps[j], 1 / steps[j + 1]
        q[j + 1][j] = -1 / steps[j] - 1 / steps[j + 1]
    a = [[lam * sum(q[r][i] * q[r][k] for r in range(n)) for k in range(m)] for i in range(m)]
    for j in range(m):
        a[j][j] += (steps[j] + steps[j + 1]) / 3
        if j + 1 < m:
            a[j][j + 1] += steps[j + 1] / 6
            a[j + 1][j] += steps[j + 1] / 6
    b = [sum(q[r][j] * y[r] for r in range(n)) for j in range(m)]
    for c in range(m):  # positive definite: no pivoting; the band is 2 wide
        for r in range(c + 1, min(m, c + 3)):
            factor = a[r][c] / a[c][c]
            for k in range(c, min(m, c + 3)):
                a[r][k] -= factor * a[c][k]
            b[r] -= factor * b[c]
    gamma = [Fraction(0)] * m
    for c in reversed(range(m)):
        ahead = sum(a[c][k] * gamma[k] for k in range(c + 1, min(m, c + 3)))
        gamma[c] = (b[c] - ahead) / a[c][c]
    g = [y[r] - lam * sum(q[r][j] * gamma[j] for j in range(m)) for r in range(n)]
    return np.array(g, dtype=float), np.array([0, *gamma, 0], dtype=float)


@pytest.mark.parametrize("uniform", [True, False])
def test_reinsch_solve_equals_the_exact_rational_solve_at_the_lowest_cutoff(uniform):
    rng = np.random.default_rng(5)
    n = 60
    steps = np.full(n - 1, DT) if uniform else DT * rng.uniform(0.6, 1.4, n - 1)
    y = np.sin(np.arange(n) / 7.0) + 0.1 * rng.standard_normal(n)
    lam = smoothing_parameter(1e-3 * 0.5 / DT, DT)  # the lowest cutoff the method takes
    g, slope, curvature = natural_smoothing_spline(DT if uniform else steps, y, lam)
    exact_g, exact_gamma = _exact_reinsch(
        [Fraction(s) for s in steps], [Fraction(v) for v in y], Fraction(lam)
    )
    np.testing.assert_allclose(g, exact_g, rtol=0, atol=1e-12 * np.max(np.abs(exact_g)))
    np.testing.assert_allclose(
        curvature, exact_gamma, rtol=0, atol=1e-10 * np.max(np.abs(exact_gamma))
    )
    # g' from the cubic on each interval, at its left knot (at the last knot: its right one)
    h = steps
    expected = np.empty(n)
    expected[:-1] = np.diff(exact_g) / h - h * (2 * exact_gamma[:-1] + exact_gamma[1:]) / 6
    expected[-1] = (exact_g[-1] - exact_g[-2]) / h[-1] + h[-1] * (
        exact_gamma[-2] + 2 * exact_gamma[-1]
    ) / 6
    np.testing.assert_allclose(slope, expected, rtol=0, atol=1e-10 * np.max(np.abs(expected)))


@pytest.mark.parametrize(("cutoff_hz", "rtol"), [(2.0, 1e-6), (12.0, 1e-9), (100.0, 1e-12)])
@pytest.mark.parametrize("uniform", [True, False])
def test_reinsch_solve_equals_scipys_b_spline_solve(cutoff_hz, rtol, uniform):
    # rtol: scipy's own error against a long-double solve is 3e-8 at 2 Hz, 4e-11 at 12 Hz
    rng = np.random.default_rng(11)
    n = 1500
    t = np.arange(n) * DT
    if not uniform:
        t = t + rng.uniform(-0.3, 0.3, n) * DT
    y = np.stack([np.sin(2 * np.pi * 4 * t), np.cos(2 * np.pi * 9 * t)], axis=1)
    y += 0.2 * rng.standard_normal(y.shape)
    lam = smoothing_parameter(cutoff_hz, DT)
    ours = natural_smoothing_spline(DT if uniform else np.diff(t), y, lam)
    spline = make_smoothing_spline(t, y, lam=lam, axis=0)
    for order in range(3):
        theirs = spline.derivative(order)(t) if order else spline(t)
        np.testing.assert_allclose(ours[order], theirs, rtol=0, atol=rtol * np.max(np.abs(theirs)))


def test_equals_scipys_smoothing_spline_with_the_stated_lambda():
    rng = np.random.default_rng(3)
    t = np.arange(1500) * DT
    x = np.sin(2 * np.pi * 4 * t) + 0.5 * t**2 + 0.2 * rng.standard_normal(t.size)
    estimate = methods.get("smoothing_spline", cutoff_hz=12.0)(x, DT)
    spline = make_smoothing_spline(t, x, lam=1.0 / (DT * (2 * np.pi * 12.0) ** 4))
    for order, atol in ((0, 1e-9), (1, 1e-7), (2, 1e-4)):
        valid = estimate.valid[order]  # the ends check masks a few natural-end samples
        assert valid.mean() > 0.9
        np.testing.assert_allclose(
            estimate[order][valid], spline.derivative(order)(t[valid]), atol=atol
        )


def test_the_method_holds_fewer_than_ten_record_length_arrays(peak_arrays):
    # outputs (three) and temporaries; scipy's make_smoothing_spline held 43
    assert peak_arrays(methods.get("smoothing_spline", cutoff_hz=26.8), 100_000) < 10


def test_the_response_is_one_half_near_the_cutoff_for_slow_sampling():
    assert smoothing_parameter(10.0, DT) == pytest.approx(1 / (DT * (2 * np.pi * 10.0) ** 4))
    gain = smoothing_spline_response([1.0, 2.0], 1e-5, cutoff_hz=1.0, order=0)
    assert abs(gain[0]) == pytest.approx(0.5, abs=1e-6)
    assert abs(gain[1]) == pytest.approx(1 / 17, rel=1e-4)  # 1 / (1 + 2^4)


@pytest.mark.parametrize("cutoff_hz", [500.0, 0.4])
def test_a_cutoff_outside_the_working_range_is_refused(cutoff_hz):
    with pytest.raises(ValueError, match=r"`cutoff_hz` must be .*in \[0\.5, 500\) Hz"):
        methods.get("smoothing_spline", cutoff_hz=cutoff_hz)(np.zeros(100), DT)
