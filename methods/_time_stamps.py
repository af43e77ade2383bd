"""Irregular time stamps for methods defined on a uniform grid: resample, differentiate,
interpolate back.

A method that has no estimate of its own at irregular times (``Method.time_stamps ==
"resampled"``) is given the record interpolated onto the uniform grid of the same span whose
step is nearest the nominal step :math:`\\Delta` (given as ``dt`` with ``t``; else the median
step), :math:`\\tau_k = t_0 + k h`, :math:`h = (t_{n-1} - t_0)/K`,
:math:`K = \\mathrm{round}((t_{n-1} - t_0)/\\Delta)` (a jittered or gappy record whose
ends are on the nominal grid keeps its step, and with it windows that are whole numbers of
steps), by the not-a-knot cubic
spline through the measured samples (scipy's ``CubicSpline``); its estimates on that grid are
brought back to the measured times by the cubic spline through its valid grid samples. The
interpolation adds its own error: for a signal with bounded fourth derivative it is
:math:`O(h^4 \\max|x^{(4)}|)` on the samples and :math:`O(h^{4-n})` on the derivative of
order n, where h is the largest gap; on noisy data it also colours the noise (de Boor, *A
Practical Guide to Splines*, 2001, ch. IV). A measured time outside the span of the valid grid
estimates has no estimate.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline


def uniform_grid(times: np.ndarray, nominal: float | None = None) -> tuple[np.ndarray, float]:
    """The uniform grid of the span of ``times`` (its ends exactly theirs) with the step
    nearest ``nominal`` (default: their median step); returns (grid, step)."""
    span = times[-1] - times[0]
    guide = float(np.median(np.diff(times))) if nominal is None else nominal
    intervals = max(1, round(span / guide))
    step = span / intervals
    grid = times[0] + np.arange(intervals + 1) * step
    grid[-1] = times[-1]
    return grid, float(step)


def to_grid(x: np.ndarray, times: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """``x`` sampled at ``times`` interpolated at ``grid`` (not-a-knot cubic spline, axis 0)."""
    return CubicSpline(times, x, axis=0)(grid)


def from_grid(
    values: np.ndarray, valid: np.ndarray, grid: np.ndarray, times: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Estimates on ``grid`` (``valid`` where they exist) brought back to ``times``: the cubic
    spline through the valid grid samples, NaN outside their span. Returns (values, valid)."""
    kept = np.flatnonzero(valid)
    out = np.full((times.size, *values.shape[1:]), np.nan)
    inside = np.zeros(times.size, dtype=bool)
    if kept.size >= 2:
        lo, hi = grid[kept[0]], grid[kept[-1]]
        inside = (times >= lo) & (times <= hi)
        out[inside] = CubicSpline(grid[kept], values[kept], axis=0)(times[inside])
    elif kept.size == 1:
        inside = times == grid[kept[0]]
        out[inside] = values[kept[0]]
    return out, inside
