"""Irregular time stamps for methods defined on a uniform grid: resample, differentiate,
interpolate back.

A method that has no estimate of its own at irregular times (``Method.time_stamps ==
"resampled"``) is given the record interpolated onto the uniform grid of the same span whose
step is nearest the nominal step :math:`\\Delta` (given as ``dt`` with ``t``; else the median
step), :math:`\\tau_k = t_0 + k h`, :math:`h = (t_{n-1} - t_0)/K`,
:math:`K = \\mathrm{round}((t_{n-1} - t_0)/\\Delta)` (a jittered or gappy record whose
ends are on the nominal grid keeps its step, and with it windows that are whole numbers of
steps; a given nominal step is kept exactly when the span is not a whole number of them, the
grid then ending less than a step past the last time: :func:`uniform_grid`), by the not-a-knot cubic
spline through the measured samples (scipy's ``CubicSpline``); its estimates on that grid are
brought back to the measured times by the cubic spline through its valid grid samples (and,
outside their span, through every grid sample it estimates: those times are estimated, not
valid). The
interpolation adds its own error: for a signal with bounded fourth derivative it is
:math:`O(h^4 \\max|x^{(4)}|)` on the samples and :math:`O(h^{4-n})` on the derivative of
order n, where h is the largest gap; on noisy data it also colours the noise (de Boor, *A
Practical Guide to Splines*, 2001, ch. IV). A measured time outside the span of the estimated
grid samples has no estimate.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from diffbench.methods._validation import finite_samples

ON_GRID_TOLERANCE = 1e-9
"""Relative difference from the nominal step below which the span's own step is taken (the
record's ends lie on the nominal grid)."""


def uniform_grid(times: np.ndarray, nominal: float | None = None) -> tuple[np.ndarray, float]:
    """The uniform grid for ``times``; returns (grid, step).

    Without ``nominal``: the grid of the span of ``times`` (its ends exactly theirs) with the
    step nearest their median step. With ``nominal``: the same when the span is a whole number
    of nominal steps (to ``ON_GRID_TOLERANCE``); otherwise the grid of step exactly ``nominal``
    from the first time, one point past the last (a recorder's time stamps rarely end on its
    own grid, e.g. 9.9981 s at 500 Hz; a step of span/K would make every window given in
    seconds miss a whole number of steps by a few parts in 1e5, and be refused): the
    interpolating spline is extended by less than one step there."""
    span = times[-1] - times[0]
    guide = float(np.median(np.diff(times))) if nominal is None else nominal
    intervals = max(1, round(span / guide))
    step = span / intervals
    if nominal is not None and abs(step - nominal) > ON_GRID_TOLERANCE * nominal:
        intervals = max(1, int(np.ceil(span / nominal)))
        return times[0] + np.arange(intervals + 1) * nominal, float(nominal)
    grid = times[0] + np.arange(intervals + 1) * step
    grid[-1] = times[-1]
    return grid, float(step)


def to_grid(x: np.ndarray, times: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """``x`` sampled at ``times`` interpolated at ``grid`` (not-a-knot cubic spline, axis 0)."""
    return CubicSpline(times, x, axis=0)(grid)


def from_grid(
    values: np.ndarray, valid: np.ndarray, grid: np.ndarray, times: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Estimates on ``grid`` brought back to ``times``. Returns (values, valid).

    The cubic spline through the grid's valid samples gives the times within their span (the
    valid ones: untrusted end estimates do not leak into them); the spline through every
    estimated (finite) grid sample gives the other times within the estimated span; times
    beyond it are NaN."""
    out = np.full((times.size, *values.shape[1:]), np.nan)
    estimated = np.flatnonzero(finite_samples(values))
    _interpolate(out, values, grid, times, estimated)
    inside = _interpolate(out, values, grid, times, np.flatnonzero(valid))
    return out, inside


def _interpolate(out, values, grid, times, kept) -> np.ndarray:
    """Writes into ``out`` the cubic spline through the grid samples ``kept`` at the ``times``
    within their span (the one value, at its own time, when one is kept); returns which."""
    inside = np.zeros(times.size, dtype=bool)
    if kept.size >= 2:
        inside = (times >= grid[kept[0]]) & (times <= grid[kept[-1]])
        out[inside] = CubicSpline(grid[kept], values[kept], axis=0)(times[inside])
    elif kept.size == 1:
        inside = times == grid[kept[0]]
        out[inside] = values[kept[0]]
    return inside
