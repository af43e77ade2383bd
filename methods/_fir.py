"""Applying a central FIR filter along the time axis of every channel at once."""

from __future__ import annotations

import numpy as np
from scipy import signal as sps

from methods._registry import central_mask

_OVERLAP_ADD_FROM = 32  # taps; shorter kernels are convolved directly


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
