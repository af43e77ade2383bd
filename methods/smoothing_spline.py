"""Cubic smoothing spline (scipy's ``make_smoothing_spline``), differentiated analytically."""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import make_smoothing_spline

from diffbench.methods._ends import mask_untrusted, trusted_times
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


@register("smoothing_spline")
class SmoothingSpline(Method):
    r"""Cubic smoothing spline through the samples, differentiated analytically.

    .. math:: \hat g = \arg\min_g \sum_k (x_k - g(t_k))^2 + \lambda \int g''(t)^2\,dt,
        \qquad \hat x^{(n)}_k = \hat g^{(n)}(t_k)

    computed by ``scipy.interpolate.make_smoothing_spline`` with
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
            "cutoff_hz", self.cutoff_hz, dt,
            lowest_hz=MIN_CUTOFF_FRACTION * 0.5 / dt,
            why_low=f"at least {MIN_CUTOFF_FRACTION:g} of the Nyquist frequency: lower cutoffs "
            "lose the straight line to rounding",
        )  # fmt: skip

    def min_samples(self, dt: float) -> int:
        return 5  # make_smoothing_spline's least

    def end_reach(self, dt: float) -> int | None:
        return math.ceil(END_REACH_PERIODS / (self.cutoff_hz * dt))

    def exact_degree(self, order: int) -> float | None:
        return 1

    def _response(self, frequency_hz, dt: float, order: int) -> np.ndarray:
        return smoothing_spline_response(frequency_hz, dt, self.cutoff_hz, order)

    def _estimate(self, x, dt, orders):
        return self._fit(x, np.arange(x.shape[0]) * dt, smoothing_parameter(self.cutoff_hz, dt),
                         orders)  # fmt: skip

    def _estimate_at(self, x, times, orders):
        if times.size < self.min_samples(1.0):
            raise ValueError(f"`x` has {times.size} samples on axis 0; at least 5 are needed")
        step = mean_step(times)
        self.check_step(step)
        values, _ = self._fit(x, times, smoothing_parameter(self.cutoff_hz, step), orders)
        valid = trusted_times(self, times, step, orders)
        for order in orders:
            values[order] = mask_untrusted(values[order], valid[order])
        return values, valid

    @staticmethod
    def _fit(x, t, lam, orders):
        # The least-squares line costs no penalty, so taking it out first leaves the spline
        # unchanged in exact arithmetic, and keeps the solver's rounding (1e-11 relative) off
        # the constants and lines it must reproduce.
        n = x.shape[0]
        centred = (t - t.mean()).reshape((n,) + (1,) * (x.ndim - 1))
        mean = x.mean(axis=0)
        slope = (centred * (x - mean)).sum(axis=0) / (centred**2).sum()
        line = mean + slope * centred
        spline = make_smoothing_spline(t, x - line, lam=lam, axis=0)
        values = {}
        for order in orders:
            values[order] = spline.derivative(order)(t) if order else spline(t)
            if order == 0:
                values[order] = values[order] + line
            elif order == 1:
                values[order] = values[order] + slope
        valid = {order: np.ones(n, dtype=bool) for order in orders}
        return values, valid
