"""Applying a central FIR filter along the time axis of every channel at once."""

from __future__ import annotations

import numpy as np
from scipy import signal as sps

_OVERLAP_ADD_FROM = 32  # taps; shorter kernels are convolved directly


def central_mask(n_samples: int, half_width: int) -> np.ndarray:
    """Mask of the samples a central window of ``2*half_width + 1`` samples can reach."""
    mask = np.zeros(n_samples, dtype=bool)
    mask[half_width : n_samples - half_width] = True
    return mask


def apply_central_fir(x: np.ndarray, taps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Correlate ``x`` (time on axis 0) with a centred odd-length kernel.

    .. math:: y_k = \\sum_{j=-m}^{m} a_j \\, x_{k+j},\\qquad \\text{taps} = (a_{-m}, \\dots, a_m)

    Returns ``(y, valid)``: ``y`` has the shape of ``x`` with NaN on the first and last ``m``
    samples, which the window cannot reach (``valid`` is False there).
    """
    taps = np.asarray(taps, dtype=np.float64)
    if taps.ndim != 1 or taps.size % 2 == 0:
        raise ValueError(f"`taps` must be 1-D with an odd length, got shape {taps.shape}")
    half = taps.size // 2
    n = x.shape[0]
    if n < taps.size:
        return np.full(x.shape, np.nan), central_mask(n, half)
    if taps.size >= _OVERLAP_ADD_FROM:
        # Overlap-add FFT convolution along time for all channels at once: the fastest measured
        # for long kernels on long signals (tests/timing/test_jacobi_timing.py). "same" keeps
        # the output aligned with x, so the ends are overwritten in place (no copy).
        y = sps.oaconvolve(x, _kernel(taps, x.ndim), mode="same", axes=0)
    else:
        y = sps.convolve(x, _kernel(taps, x.ndim), mode="same")
    y[:half] = np.nan
    y[n - half :] = np.nan
    return y, central_mask(n, half)


def _kernel(taps: np.ndarray, ndim: int) -> np.ndarray:
    return taps[::-1].reshape((-1,) + (1,) * (ndim - 1))


def fir_response(taps: np.ndarray, frequency_hz, dt: float) -> np.ndarray:
    r"""Frequency response of the centred FIR filter of :func:`apply_central_fir`.

    .. math:: H(f) = \sum_{j=-m}^{m} a_j \, e^{i 2\pi f j \Delta t}

    (the output for the input :math:`e^{i 2\pi f t}` is :math:`H(f) e^{i 2\pi f t}`).
    """
    taps = np.asarray(taps, dtype=np.float64)
    theta = 2 * np.pi * np.atleast_1d(np.asarray(frequency_hz, dtype=np.float64)) * dt
    unit = np.exp(1j * theta)
    # Horner's scheme on the unit circle (stable), then the shift to the centred taps
    return np.polynomial.polynomial.polyval(unit, taps) * unit ** -(taps.size // 2)
