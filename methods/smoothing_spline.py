"""Cubic smoothing spline (Reinsch's banded algorithm), differentiated analytically at the
samples."""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import cho_solve_banded, cholesky_banded

from diffbench.methods._ends import trusted_times
from diffbench.methods._registry import Method, Preset, param, register
from diffbench.methods._validation import check_frequency, mean_step

END_REACH_PERIODS = 5.0
"""How far, in periods of the cutoff, the ends of a record change the spline: its weights (the
equivalent kernel, Silverman 1984: :math:`e^{-|u|/\\sqrt2 h}` with :math:`h = 1/(2\\pi f_c)`)
fall below 1e-9 of their peak 4.7 periods away. The samples within this reach of an end are
the ones the ends check probes (:mod:`methods._ends`); those estimated worse than twice the
interior are masked (the natural ends, g'' = 0, miss ẍ most)."""

MIN_CUTOFF_FRACTION = 1e-3
"""Lowest ``cutoff_hz`` as a fraction of the Nyquist frequency: λ grows as the cutoff to the
power -4, and below this the banded system loses the straight line it must reproduce."""


def smoothing_parameter(cutoff_hz: float, dt: float) -> float:
    r"""The λ of :math:`\sum_k (x_k - g(t_k))^2 + \lambda \int g''(t)^2 dt` whose response
    (:func:`smoothing_spline_response`) is one half at ``cutoff_hz`` for slow sampling:
    :math:`\lambda = 1 / (\Delta t\, (2\pi f_c)^4)`."""
    return 1.0 / (dt * (2 * np.pi * cutoff_hz) ** 4)


def smoothing_spline_response(frequency_hz, dt: float, cutoff_hz: float, order: int):
    r"""Response of the spline's derivative of ``order`` at the samples, away from the ends.

    With θ = 2πf Δt, the smoothed samples are :math:`H = 1/(1 + \lambda K)`,
    :math:`K = 6(2 - 2\cos\theta)^2 / (\Delta t^3 (4 + 2\cos\theta))` (the penalty
    :math:`Q R^{-1} Q^T` of Reinsch's algorithm on a uniform grid), and the cubic through them
    has at the knots the derivatives :math:`D_1 = 6i\sin\theta / (\Delta t (4 + 2\cos\theta))`,
    :math:`D_2 = 6(2\cos\theta - 2) / (\Delta t^2 (4 + 2\cos\theta))`.

    Reference: C. H. Reinsch, "Smoothing by spline functions", Numer. Math. 10 (1967) 177-183.
    """
    theta = 2 * np.pi * np.asarray(frequency_hz, dtype=float) * dt
    cos = np.cos(theta)
    lam = smoothing_parameter(cutoff_hz, dt)
    gain = 1.0 / (1.0 + lam * 6 * (2 - 2 * cos) ** 2 / (dt**3 * (4 + 2 * cos)))
    if order == 0:
        return gain.astype(complex)
    if order == 1:
        return gain * 6j * np.sin(theta) / (dt * (4 + 2 * cos))
    return gain * 6 * (2 * cos - 2) / (dt**2 * (4 + 2 * cos)) + 0j


def natural_smoothing_spline(step, y: np.ndarray, lam: float, overwrite_y: bool = False):
    r"""The cubic smoothing spline of samples ``y`` (time on axis 0, at least 5 samples, one
    spline per column) and its first two derivatives at the samples:

    .. math:: \hat g = \arg\min_g \sum_k (y_k - g(t_k))^2 + \lambda \int g''(t)^2 dt

    ``step``: the steps :math:`h_i = t_{i+1} - t_i` > 0 between the samples (n - 1 of them),
    or one float for uniform samples. :math:`\hat g` is the natural cubic spline with knots
    :math:`t_k` (g'' = 0 at both ends) whose values g and second derivatives γ at the knots
    solve Reinsch's banded system

    .. math:: (R + \lambda Q^\top Q)\, \gamma = Q^\top y, \qquad g = y - \lambda Q\gamma,

    with Q the n×(n-2) second divided difference (:math:`(Q^\top v)_j = (v_{j-1} - v_j)/h_{j-1}
    + (v_{j+1} - v_j)/h_j`) and R the (n-2)×(n-2) tridiagonal
    :math:`R_{jj} = (h_{j-1} + h_j)/3`, :math:`R_{j,j+1} = h_j/6`. The pentadiagonal
    :math:`R + \lambda Q^\top Q` is symmetric positive definite: one banded Cholesky
    factorisation (LAPACK ``pbtrf``), O(n) time and about eight arrays of n at its peak for
    uniform samples. Its condition grows as λ/h³; one step of iterative refinement on the
    spline's own condition :math:`Q^\top g = R\gamma` (the residual solved with the same
    factor) takes the error at the lowest cutoff the method allows from 1e-5 to 2e-9 of the
    spline's size (against a long-double solve). On each interval the cubic gives

    .. math:: g'(t_i) = \frac{g_{i+1} - g_i}{h_i} - \frac{h_i (2\gamma_i + \gamma_{i+1})}{6},
        \qquad g'(t_{n-1}) = \frac{g_{n-1} - g_{n-2}}{h_{n-2}}
        + \frac{h_{n-2}(\gamma_{n-2} + 2\gamma_{n-1})}{6}, \qquad g''(t_i) = \gamma_i.

    The same spline as ``scipy.interpolate.make_smoothing_spline(t, y, lam=lam)``, its test
    oracle, which builds a general banded system in the B-spline basis with a Python loop over
    the samples (about 7e4 samples a second) and holds about 40 arrays of n.

    References: C. H. Reinsch, "Smoothing by spline functions", Numer. Math. 10 (1967)
    177-183; P. J. Green, B. W. Silverman, *Nonparametric Regression and Generalized Linear
    Models*, Chapman & Hall (1994), sec. 2.3.

    Returns
    -------
    (g, slope, curvature) : three arrays shaped like ``y``: :math:`\hat g, \hat g', \hat g''`
        at the samples (g in ``y``'s memory with ``overwrite_y``).
    """
    n = y.shape[0]
    h = step if np.ndim(step) == 0 else np.asarray(step, dtype=float)
    inverse = 1.0 / h
    bands = np.empty((3, n - 2), order="F")  # upper form for LAPACK: bands[2 + i - j, j]
    # (QᵀQ)_jj = 1/h_{j-1}² + (1/h_{j-1} + 1/h_j)² + 1/h_j², (QᵀQ)_{j,j+1} = -(1/h_{j-1} +
    # 2/h_j + 1/h_{j+1}) / h_j, (QᵀQ)_{j,j+2} = 1/(h_j h_{j+1})
    before, after = _part(inverse, 0, -1), _part(inverse, 1, 0)
    bands[2] = before * before + after * after + (before + after) ** 2
    bands[2] *= lam
    bands[2] += (_part(h, 0, -1) + _part(h, 1, 0)) / 3.0
    inner = _part(inverse, 1, -1)
    bands[1, 1:] = _part(h, 1, -1) / 6.0 - lam * inner * (
        _part(inverse, 0, -2) + 2.0 * inner + _part(inverse, 2, 0)
    )
    bands[0, 2:] = lam * _part(inverse, 1, -2) * _part(inverse, 2, -1)
    bands[0, :2] = bands[1, 0] = 0.0  # outside the matrix
    factor = (cholesky_banded(bands, overwrite_ab=True, check_finite=False), False)
    del bands
    g = y.reshape(n, -1)
    if not overwrite_y:
        g = g.copy()
    curvature = np.zeros_like(g)  # γ, 0 at the natural ends
    gamma = curvature[1:-1]
    gamma[...] = _q_transpose(inverse, g)
    gamma[...] = cho_solve_banded(factor, gamma, overwrite_b=True, check_finite=False)
    _subtract_q(g, inverse, lam, gamma)
    residual = _q_transpose(inverse, g)  # Qᵀg - Rγ: zero in exact arithmetic
    _subtract_r(residual, h, gamma)
    correction = cho_solve_banded(factor, residual, overwrite_b=True, check_finite=False)
    del factor, residual
    gamma += correction
    _subtract_q(g, inverse, lam, correction)
    del correction
    slope = np.empty_like(g)
    np.subtract(g[1:], g[:-1], out=slope[:-1])
    slope[:-1] *= _column(inverse)
    bend = 2.0 * curvature[:-1]
    bend += curvature[1:]
    bend *= _column(h / 6.0)
    slope[:-1] -= bend
    del bend
    last_step = h if np.ndim(h) == 0 else h[-1]
    slope[-1] = (g[-1] - g[-2]) / last_step
    slope[-1] += last_step * (curvature[-2] + 2.0 * curvature[-1]) / 6.0
    return g.reshape(y.shape), slope.reshape(y.shape), curvature.reshape(y.shape)


def _part(values, start: int, stop: int):
    """``values[start:len(values) + stop]`` of the n - 1 steps (or their inverses); the
    float itself for uniform samples."""
    return values if np.ndim(values) == 0 else values[start : values.shape[0] + stop]


def _column(values):
    """``values`` broadcast against the columns of an (n, channels) array."""
    return values if np.ndim(values) == 0 else values[:, None]


def _q_transpose(inverse, v: np.ndarray) -> np.ndarray:
    """:math:`Q^\top v = (v_{j-1} - v_j)/h_{j-1} + (v_{j+1} - v_j)/h_j`, j = 1..n-2 (columns
    of v), with ``inverse`` = 1/h."""
    before, after = _part(inverse, 0, -1), _part(inverse, 1, 0)
    out = v[:-2] - v[1:-1]
    out *= _column(before)
    ahead = v[2:] - v[1:-1]
    ahead *= _column(after)
    out += ahead
    return out


def _subtract_q(g: np.ndarray, inverse, lam: float, gamma: np.ndarray) -> None:
    """g -= λ Q γ in place (column j of Q: 1/h_{j-1}, -1/h_{j-1} - 1/h_j, 1/h_j on rows
    j-1, j, j+1)."""
    before, after = _part(inverse, 0, -1), _part(inverse, 1, 0)
    weighted = gamma * _column(before)
    weighted *= lam
    g[:-2] -= weighted
    g[1:-1] += weighted
    np.multiply(gamma, _column(after), out=weighted)
    weighted *= lam
    g[1:-1] += weighted
    g[2:] -= weighted


def _subtract_r(out: np.ndarray, h, gamma: np.ndarray) -> None:
    """out -= R γ in place (R the tridiagonal of :func:`natural_smoothing_spline`)."""
    term = gamma * _column((_part(h, 0, -1) + _part(h, 1, 0)) / 3.0)
    out -= term
    inner = _column(_part(h, 1, -1) / 6.0)
    np.multiply(gamma[1:], inner, out=term[:-1])
    out[:-1] -= term[:-1]
    np.multiply(gamma[:-1], inner, out=term[:-1])
    out[1:] -= term[:-1]


@register("smoothing_spline")
class SmoothingSpline(Method):
    r"""Cubic smoothing spline through the samples, differentiated analytically.

    .. math:: \hat g = \arg\min_g \sum_k (x_k - g(t_k))^2 + \lambda \int g''(t)^2\,dt,
        \qquad \hat x^{(n)}_k = \hat g^{(n)}(t_k)

    computed by Reinsch's banded algorithm (:func:`natural_smoothing_spline`; scipy's
    ``make_smoothing_spline`` is its test oracle) with
    :math:`\lambda = 1/(\Delta t (2\pi f_c)^4)` (:func:`smoothing_parameter`): the response
    (:func:`smoothing_spline_response`) is one half near ``cutoff_hz`` and falls as
    :math:`f^{-4}`. Every sample is estimated (natural spline ends: g'' = 0 beyond the record);
    the end samples worse than twice the interior over its band are masked (``END_REACH_PERIODS``,
    :mod:`methods._ends`).
    Linear in the input; exact on straight lines everywhere (they cost no penalty: the
    least-squares line is taken out before the fit and added back exactly). Time stamps
    (``t=``) are native: the same fit at the measured times, λ set by the mean step.

    Parameters
    ----------
    cutoff_hz : float in [1e-3 fs/2, fs/2)
        Frequency of half gain, Hz.

    References
    ----------
    Reinsch, Numer. Math. 10 (1967); G. Wahba, *Spline Models for Observational Data*, SIAM
    (1990), ch. 1.
    """

    cutoff_hz: float = param(
        20.0,
        low=0.0,
        low_open=True,
        tune_low=0.5,
        tune_high=200.0,
        log=True,
        doc="frequency of half gain, Hz (in [1e-3, 1) x Nyquist)",
        kind="frequency",
    )
    presets = {
        "paper-signal": Preset(
            {"cutoff_hz": 26.8},
            "diffbench, not in the paper: oracle tuning on the held-out noise seed 10000, least "
            "interior ẍ RMSE",
        ),
        "robot": Preset(
            {"cutoff_hz": 5.0},
            "diffbench, not in the paper: the cutoff of the paper's Butterworth (0.1 fs/2, "
            "sec. IV)",
        ),
    }
    reference = "Reinsch (1967)"
    time_stamps = "native"

    def check_step(self, dt: float) -> None:
        check_frequency(
            "cutoff_hz",
            self.cutoff_hz,
            dt,
            lowest_hz=MIN_CUTOFF_FRACTION * 0.5 / dt,
            why_low=f"at least {MIN_CUTOFF_FRACTION:g} of the Nyquist frequency: lower cutoffs "
            "lose the straight line to rounding",
        )

    def min_samples(self, dt: float) -> int:
        return 5  # the least scipy's make_smoothing_spline, the solver's oracle, takes

    def end_reach(self, dt: float) -> int | None:
        return math.ceil(END_REACH_PERIODS / (self.cutoff_hz * dt))

    def exact_degree(self, order: int) -> float | None:
        return 1

    def _response(self, frequency_hz, dt: float, order: int) -> np.ndarray:
        return smoothing_spline_response(frequency_hz, dt, self.cutoff_hz, order)

    def _estimate(self, x, dt, orders):
        n = x.shape[0]
        centred = (np.arange(n) - 0.5 * (n - 1)) * dt
        return self._fit(x, float(dt), centred, smoothing_parameter(self.cutoff_hz, dt), orders)

    def _estimate_at(self, x, times, orders):
        if times.size < self.min_samples(1.0):
            raise ValueError(f"`x` has {times.size} samples on axis 0; at least 5 are needed")
        step = mean_step(times)
        self.check_step(step)
        values, _ = self._fit(
            x,
            np.diff(times),
            times - times.mean(),
            smoothing_parameter(self.cutoff_hz, step),
            orders,
        )
        valid = trusted_times(self, times, step, orders)
        return values, valid

    @staticmethod
    def _fit(x, step, centred, lam, orders):
        # `step`: dt or the n - 1 steps; `centred`: the times less their mean. The
        # least-squares line costs no penalty, so taking it out first leaves the spline
        # unchanged in exact arithmetic, and keeps the solver's rounding off the constants and
        # lines it must reproduce.
        n = x.shape[0]
        centred = centred.reshape((n,) + (1,) * (x.ndim - 1))
        mean = x.mean(axis=0)
        residual = x - mean
        slope = (centred * residual).sum(axis=0) / (centred**2).sum()
        residual -= slope * centred
        fitted = natural_smoothing_spline(step, residual, lam, overwrite_y=True)
        values = {}
        for order in orders:
            values[order] = fitted[order]
            if order == 0:
                values[0] += mean
                values[0] += slope * centred
            elif order == 1:
                values[1] += slope
        valid = {order: np.ones(n, dtype=bool) for order in orders}
        return values, valid
