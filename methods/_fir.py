"""Applying a central FIR filter along the time axis of every channel at once."""

from __future__ import annotations

import numpy as np
from scipy import signal as sps

from methods._registry import central_mask


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
    kernel = taps[::-1].reshape((-1,) + (1,) * (x.ndim - 1))
    y = np.full(x.shape, np.nan)
    if n >= taps.size:
        y[half : n - half] = sps.convolve(x, kernel, mode="valid", method="auto")
    return y, central_mask(n, half)
