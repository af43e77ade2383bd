"""Applying a central FIR filter along the time axis of every channel at once."""

from __future__ import annotations

import numpy as np
from scipy import fft as sp_fft
from scipy import signal as sps

_OVERLAP_ADD_FROM = 32  # taps; shorter kernels are convolved directly
_SLICED_UP_TO = 3  # taps; up to this many, summed from shifted slices

try:  # scipy's rule for when oaconvolve is one FFT convolution (see _oaconvolve_same)
    from scipy.signal._signaltools import _calc_oa_lens

    def _one_block(n: int, m: int) -> bool:
        return _calc_oa_lens(n, m)[1] is None

except ImportError:  # a scipy without it: oaconvolve throughout
    _one_block = None


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
        y = _oaconvolve_same(x, _kernel(taps, x.ndim))
    elif taps.size <= _SLICED_UP_TO:
        # a short stencil (Euler differences): shifted slices summed in the order of scipy's
        # direct convolution (equal to it bit for bit), without its N-D machinery (5x faster
        # on 48 channels)
        y = np.empty(x.shape)
        core = taps[0] * x[: n - 2 * half]
        for j in range(1, taps.size):
            core = core + taps[j] * x[j : n - 2 * half + j]
        y[half : n - half] = core
    else:
        y = sps.convolve(x, _kernel(taps, x.ndim), mode="same")
    y[:half] = np.nan
    y[n - half :] = np.nan
    return y, central_mask(n, half)


def apply_central_firs(x: np.ndarray, taps_list) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`apply_central_fir` for several kernels on the same ``x`` (e.g. the derivative
    orders of one method): ``[(y, valid), ...]`` in the order of ``taps_list``.

    Two or more long kernels (>= 32 taps) that fit the record share one overlap-add: each block
    of ``x`` is transformed once (``scipy.fft.rfft``, all channels and blocks at once) and
    multiplied by each kernel's spectrum before its own inverse transform, instead of one
    ``oaconvolve`` per kernel (each transforming ``x`` again): measured 2.0-2.5 times faster for
    the three 211-tap kernels of Jacobi's paper preset on 1e6 samples; equal to ``oaconvolve``
    to rounding (7e-12 there).
    """
    taps_list = [np.asarray(taps, dtype=np.float64) for taps in taps_list]
    n = x.shape[0]
    long_enough = [
        taps.ndim == 1 and taps.size % 2 == 1 and _OVERLAP_ADD_FROM <= taps.size <= n
        for taps in taps_list
    ]
    shared = [i for i, fits in enumerate(long_enough) if fits]
    if len(shared) < 2:
        return [apply_central_fir(x, taps) for taps in taps_list]
    filtered = dict(
        zip(shared, _shared_overlap_add(x, [taps_list[i] for i in shared]), strict=True)
    )
    out = []
    for i, taps in enumerate(taps_list):
        if i not in filtered:
            out.append(apply_central_fir(x, taps))
            continue
        y, half = filtered[i], taps.size // 2
        y[:half] = np.nan
        y[n - half :] = np.nan
        out.append((y, central_mask(n, half)))
    return out


BLOCK_PER_TAP = 16
"""Overlap-add blocks of about this many times the longest kernel (at least 4096 samples):
measured fastest at 16-20 for 211 taps on 1e6 samples."""


def _shared_overlap_add(x: np.ndarray, taps_list) -> list[np.ndarray]:
    """Each centred kernel correlated with ``x`` along axis 0 ("same" alignment), by one
    overlap-add whose forward transforms all kernels share."""
    n = x.shape[0]
    flat = x.reshape(n, -1).T  # (channels, n)
    channels = flat.shape[0]
    longest = max(taps.size for taps in taps_list)
    size = sp_fft.next_fast_len(max(BLOCK_PER_TAP * longest, 4096), real=True)
    hop = size - longest + 1
    blocks = -(-n // hop)
    padded = np.zeros((channels, blocks, size))
    series = np.zeros((channels, blocks * hop))
    series[:, :n] = flat
    padded[..., :hop] = series.reshape(channels, blocks, hop)
    spectra = sp_fft.rfft(padded, axis=-1)
    out = []
    for taps in taps_list:
        pieces = sp_fft.irfft(spectra * sp_fft.rfft(taps[::-1], size), size, axis=-1)
        full = np.zeros((channels, (blocks + 1) * hop))
        full[:, : blocks * hop].reshape(channels, blocks, hop)[...] = pieces[..., :hop]
        tails = full[:, hop:].reshape(channels, blocks, hop)
        tails[..., : longest - 1] += pieces[..., hop:]
        start = (taps.size - 1) // 2
        out.append(np.ascontiguousarray(full[:, start : start + n].T).reshape(x.shape))
    return out


def _oaconvolve_same(x: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """``scipy.signal.oaconvolve(x, kernel, mode="same", axes=0)``, the same numbers bit for bit.

    Where scipy's overlap-add would be one block (its ``_calc_oa_lens`` finds no block shorter
    than the record: about 1000 samples and 121 taps or more), scipy hands over to
    ``fftconvolve``, whose transforms are done here directly: one ``rfft`` of the record and of
    the kernel at ``next_fast_len(n + m - 1)``, their product's ``irfft``, the centred ``n``
    samples. That skips about 40 µs of argument handling a call, most of the cost on records
    of about 1000 samples, where a tuner evaluates hundreds of windows. ``oaconvolve`` stays
    the path for every other case, and the test oracle of this one."""
    n, m = x.shape[0], kernel.shape[0]
    if _one_block is None or n == m or np.iscomplexobj(x) or not _one_block(n, m):
        return sps.oaconvolve(x, kernel, mode="same", axes=0)
    total = n + m - 1
    size = sp_fft.next_fast_len(total, real=True)
    spectrum = sp_fft.rfft(x, size, axis=0) * sp_fft.rfft(kernel, size, axis=0)
    start = (m - 1) // 2
    return sp_fft.irfft(spectrum, size, axis=0)[start : start + n]


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
