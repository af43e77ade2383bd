"""Frequency-domain scores of linear methods: response vs the ideal differentiator, cutoff
frequency and white-noise gain, and the split of the error into bias and noise parts."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
from scipy import optimize

from diffbench.bench.core.scores import estimate_on, is_uniform
from diffbench.methods import Estimate, Method


def ideal_response(frequency_hz, order: int) -> np.ndarray:
    """:math:`(i 2\\pi f)^n`, the response of the exact n-th derivative."""
    return (2j * np.pi * np.asarray(frequency_hz, dtype=np.float64)) ** order


def relative_response(method: Method, frequency_hz, dt: float, order: int) -> np.ndarray:
    """:math:`H(f) / (i2\\pi f)^n`: 1 where the method differentiates exactly."""
    return method.frequency_response(frequency_hz, dt, order) / ideal_response(frequency_hz, order)


def noise_gain(method: Method, dt: float, order: int, points: int = 1 << 15) -> float:
    """White-noise variance amplification of the estimate of ``order``.

    .. math:: G = \\frac{1}{\\pi} \\int_0^{\\pi} |H(e^{i\\theta})|^2 \\, d\\theta

    so unit-variance white noise gives an output variance G (in (units/s^n)^2). For a FIR
    filter it equals :math:`\\sum_j a_j^2`. Computed by the trapezoid rule on ``points``
    frequencies from 0 to Nyquist (spectrally accurate for these smooth periodic responses).
    """
    frequencies = np.linspace(0.0, 0.5 / dt, points)
    power = np.abs(method.frequency_response(frequencies, dt, order)) ** 2
    return float(np.trapezoid(power, dx=1.0 / (points - 1)))


def cutoff_hz(method: Method, dt: float, order: int, level: float = 1 / np.sqrt(2)) -> float:
    """The lowest frequency where :math:`|H(f)/(i2\\pi f)^n|` falls to ``level`` (default
    -3 dB): the method's usable bandwidth. Found on a grid from 0 to Nyquist, refined by
    Brent's method; ``nan`` if the response never falls that low."""
    nyquist = 0.5 / dt
    grid = np.linspace(nyquist * 1e-4, nyquist, 8192)
    gains = np.abs(relative_response(method, grid, dt, order))
    below = np.flatnonzero(gains < level)
    if below.size == 0:
        return float("nan")
    first = below[0]
    if first == 0:
        return float(grid[0])

    def excess(frequency):
        return abs(relative_response(method, [frequency], dt, order)[0]) - level

    return float(optimize.brentq(excess, grid[first - 1], grid[first], xtol=1e-10))


@dataclass(frozen=True)
class ErrorParts:
    """RMS of the total error and of its bias and noise parts on a set of samples.

    For a linear method D: D(x + e) - x^(n) = [D(x) - x^(n)] + D(e): ``bias`` is the method on
    the clean signal minus the truth, ``noise`` the method on the noise alone."""

    total: float
    bias: float
    noise: float


def decompose_error(
    method: Method, realisation, order: int, estimate: Estimate | None = None
) -> ErrorParts:
    """Split the error of a linear method on a realisation into bias and noise parts, scored
    on the realisation's interior (where the method is valid).

    ``estimate``: the method's estimate of the realisation's samples when the caller has it
    (orders including ``order``; the valid marks of an order do not depend on the other orders
    asked), so that it is not computed again. The estimate of the clean signal is the same for
    every noise seed of a scenario whose clean signal and time stamps do not change with the
    seed: it is kept for the last :data:`KEPT_CLEAN_ESTIMATES` (method, order, record)
    (:func:`_clean_estimate`), so a scenario's seeds compute it once, not once each."""
    if not method.linear:
        raise ValueError(f"`method` {method.name!r} is not linear: its error does not split")

    noisy = estimate_on(method, realisation, orders=(order,)) if estimate is None else estimate
    clean = _clean_estimate(method, realisation, order)
    noise_only = estimate_on(method, realisation, realisation.noise, orders=(order,))
    mask = realisation.interior & noisy.valid[order]
    truth = realisation.truth[order]

    def rms(values):
        return float(np.sqrt(np.mean(values[mask] ** 2)))

    return ErrorParts(
        total=rms(noisy[order] - truth),
        bias=rms(clean - truth),
        noise=rms(noise_only[order]),
    )


KEPT_CLEAN_ESTIMATES = 16
"""How many clean-signal estimates :func:`_clean_estimate` keeps (one order of one record
each): the cells of one setting over a scenario's seeds follow one another on a worker."""


def _clean_estimate(method: Method, realisation, order: int) -> np.ndarray:
    """``method``'s estimate of order ``order`` of ``realisation``'s clean signal (values,
    read-only), computed once for each (method, order, step, time stamps, clean samples):
    the same values as computed afresh, the method being a pure function of them."""
    uniform = is_uniform(realisation)
    return _kept_clean_estimate(
        method,
        order,
        float(realisation.dt_s),
        None if uniform else np.asarray(realisation.t, dtype=np.float64).tobytes(),
        np.asarray(realisation.truth[0], dtype=np.float64).tobytes(),
    )


@functools.lru_cache(maxsize=KEPT_CLEAN_ESTIMATES)
def _kept_clean_estimate(method, order, dt_s, times_bytes, clean_bytes) -> np.ndarray:
    clean = np.frombuffer(clean_bytes, dtype=np.float64)
    record = SimpleNamespace(x=clean, dt_s=dt_s, uniform=times_bytes is None)
    if times_bytes is not None:
        record.t = np.frombuffer(times_bytes, dtype=np.float64)
    values = np.array(estimate_on(method, record, orders=(order,))[order])
    values.setflags(write=False)
    return values
