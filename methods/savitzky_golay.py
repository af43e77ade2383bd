"""Savitzky-Golay filters: local least-squares polynomial fits on a sliding window."""

from __future__ import annotations

import numpy as np

from diffbench.methods._ends import trusted_times
from diffbench.methods._fir import apply_central_firs
from diffbench.methods._local_poly import (
    central_weights,
    local_polynomial_at,
    savitzky_golay_filter,
    window_samples,
)
from diffbench.methods._registry import FirMethod, Preset, param, register
from diffbench.methods._validation import mean_step


@register("savitzky_golay")
class SavitzkyGolay(FirMethod):
    """Least-squares polynomial of ``degree`` on a centred window, differentiated at its centre.

    .. math::
        \\hat x^{(n)}_k = \\frac{d^n}{dt^n} \\hat p_k(t_k), \\qquad
        \\hat p_k = \\arg\\min_{\\deg p \\le d} \\sum_{j=-m}^{m} (x_{k+j} - p(t_{k+j}))^2

    the same numbers as ``scipy.signal.savgol_filter(x, 2m+1, d, deriv=n, delta=dt, axis=0,
    mode="interp")``, computed in a well-conditioned Legendre basis (scipy 1.17's coefficients
    lose all accuracy for long windows with high degrees, e.g. 211 samples at degree 7; see
    :mod:`methods._local_poly`); scipy is the test oracle where it is accurate. The
    window spans ``window_s = 2m * dt`` (outer samples on the window's ends; ``2m + 1`` samples,
    odd), the same node convention as the Jacobi window T. Near the ends scipy's ``"interp"``
    mode evaluates the polynomial fitted to the first/last full window, so every sample is
    estimated; an end sample stays valid only where its response is within twice the
    interior's error over the band the interior claims (:mod:`methods._ends`; the others are
    masked). Exact on polynomials of degree <= ``degree``, ends included.

    Time stamps (``t=``) are handled natively: the same fit on the samples within
    ``window_s`` in time around each one (:func:`methods._local_poly.local_polynomial_at`),
    the ends trusted over the same spans of time as on the uniform grid whose step is nearest
    the mean step with ``window_s`` an even number of steps.

    Parameters
    ----------
    window_s : float > 0
        Window span in seconds; ``window_s / dt`` must be an even whole number, at most
        100 000 (``MAX_WINDOW_STEPS``).
    degree : int in [0, 20]
        Degree of the local polynomial; must be below the window's sample count.

    References
    ----------
    A. Savitzky, M. J. E. Golay, Anal. Chem. 36 (1964) 1627-1639; R. W. Schafer, "What is a
    Savitzky-Golay filter?", IEEE Signal Processing Magazine 28(4) (2011) 111-117.
    """

    window_s: float = param(
        0.1,
        low=0.0,
        low_open=True,
        tune_low=0.004,
        tune_high=1.0,
        log=True,
        doc="window span 2m*dt in seconds (odd sample count)",
        kind="window",
    )
    degree: int = param(
        3, low=0, high=20, integer=True, tune_low=1, tune_high=11, doc="polynomial degree"
    )

    presets = {
        "paper-signal": Preset(
            {"window_s": 0.132, "degree": 9},
            "diffbench, not in the paper: grid over window 20-400 ms x degree 1-9 on the held-out "
            "noise seed 10000, least interior ẍ RMSE (near-ties broken by ẋ RMSE)",
        ),
        "robot": Preset(
            {"window_s": 0.2, "degree": 5},
            "diffbench, not in the paper: grid on robot-sim, held-out noise seed 10000, least "
            "interior q̈ RMSE",
        ),
    }
    reference = "Savitzky & Golay (1964)"
    time_stamps = "native"

    def _samples(self, dt: float) -> int:
        return window_samples(self.window_s, self.degree, dt)

    def check_step(self, dt: float) -> None:
        self._samples(dt)

    def min_samples(self, dt: float) -> int:
        return self._samples(dt)

    def end_reach(self, dt: float) -> int | None:
        return self._samples(dt) // 2

    def exact_degree(self, order: int) -> float | None:
        return self.degree

    def taps(self, order: int, dt: float) -> np.ndarray:
        """Central taps (away from the ends) of the derivative of ``order``."""
        half_width = self._samples(dt) // 2
        if order > self.degree:
            return np.zeros(2 * half_width + 1)
        return central_weights(half_width, self.degree, order, float(dt))

    def _estimate(self, x, dt, orders):
        # savitzky_golay_filter of each order, the central filters of all orders in one call
        # (apply_central_firs: one transform of the record for every order)
        half_width = self._samples(dt) // 2
        valid = np.ones(x.shape[0], dtype=bool)
        fitted = [order for order in orders if order <= self.degree]
        filtered = apply_central_firs(x, [self.taps(order, dt) for order in fitted])
        values = {order: np.zeros_like(x) for order in orders}
        for order, (y, _) in zip(fitted, filtered, strict=True):
            values[order] = savitzky_golay_filter(x, half_width, self.degree, order, dt, y)
        return values, {order: valid.copy() for order in orders}

    def _estimate_away_from_ends(self, x, dt, orders):
        # the central filter alone: its values are those savitzky_golay_filter keeps inside
        # (it overwrites only the first and last half_width samples), the ends NaN; no end
        # evaluators, a third of a setting's cost in a tuning
        filtered = apply_central_firs(x, [self.taps(order, dt) for order in orders])
        return (
            {order: y for order, (y, _) in zip(orders, filtered, strict=True)},
            {order: keep for order, (_, keep) in zip(orders, filtered, strict=True)},
        )

    def _estimate_at(self, x, times, orders):
        span = times[-1] - times[0]
        mean = mean_step(times)
        steps = max(2, 2 * round(self.window_s / (2 * mean)))
        grid_step = self.window_s / steps
        if span < self.window_s:
            raise ValueError(
                f"`t` spans {span!r} s, shorter than `window_s`={self.window_s!r} s; use a "
                "shorter window or a longer record"
            )
        values = local_polynomial_at(x, times, self.window_s, self.degree, orders)
        valid = trusted_times(self, times, grid_step, orders)
        return values, valid
