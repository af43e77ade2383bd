"""Applying a central FIR filter along the time axis of every channel at once."""

from __future__ import annotations

import numpy as np
from scipy import fft as sp_fft
from scipy import signal as sps

_OVERLAP_ADD_FROM = 32  # taps; shorter kernels are convolved directly
_SLICED_UP_TO = 3  # taps; up to this many, summed from shifted slices


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
        # FFT correlation along time for all channels at once (:func:`fft_correlate`), aligned
        # with x, so the ends are overwritten in place (no copy)
        y = fft_correlate(x, [taps])[0]
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

    The long kernels (>= 32 taps) that fit the record share the record's transform
    (:func:`fft_correlate`): each block of ``x`` is transformed once and multiplied by each
    kernel's spectrum before its own inverse transform, instead of one ``oaconvolve`` per
    kernel (each transforming ``x`` again): measured 2.0-2.5 times faster for the three 211-tap
    kernels of Jacobi's paper preset on 1e6 samples; equal to ``oaconvolve`` to rounding (7e-12
    there). A kernel's output does not depend on the others asked with it, when they are no
    longer than it (a method's orders: kernels of one length).
    """
    taps_list = [np.asarray(taps, dtype=np.float64) for taps in taps_list]
    n = x.shape[0]
    long_enough = [
        taps.ndim == 1 and taps.size % 2 == 1 and _OVERLAP_ADD_FROM <= taps.size <= n
        for taps in taps_list
    ]
    shared = [i for i, fits in enumerate(long_enough) if fits]
    if not shared:
        return [apply_central_fir(x, taps) for taps in taps_list]
    filtered = dict(zip(shared, fft_correlate(x, [taps_list[i] for i in shared]), strict=True))
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


BLOCK_PER_TAP = 8
"""Overlap-add blocks of about this many times the longest kernel, at least
:data:`SHORTEST_BLOCK` samples (measured on 1e4-1e6 samples and 53-211 taps: blocks of 1024
to 2048 samples cost 0.7-0.8 of 4096-sample ones at 1e4 samples, about the same at 1e6)."""

SHORTEST_BLOCK = 1024

ONE_TRANSFORM_UP_TO = 4096
"""Records (plus the kernel, less one) up to this many samples, or 16 times the kernel, are
transformed whole rather than by blocks (a record of about 1000 samples in one FFT)."""


CHUNK_SAMPLES = 2**15
"""Samples (blocks times channels) transformed at a time by the overlap-add: 256 kB of input,
so that a group of blocks is transformed, multiplied and added back while it is in cache. On a
record of 1e5-1e6 samples and 53-211 taps the whole record's blocks at once took 2.1-2.6 times
as long (their arrays, 1-9 MB each, pass through memory at every step; 1e4 samples make one
group); each block's transforms are the same computation either way, bit for bit."""


def _shared_overlap_add(x: np.ndarray, taps_list) -> list[np.ndarray]:
    r"""Each centred kernel correlated with ``x`` along axis 0 ("same" alignment), by one
    overlap-add whose forward transforms all kernels share.

    The record is cut into blocks of ``hop`` = N - L + 1 samples (N = :func:`_block_size`,
    L the longest kernel), each zero-padded to N; block b's correlation with a kernel is the
    ``irfft`` of the product of their transforms, and the output is the sum of the blocks'
    results, block b's shifted by b ``hop``: its first ``hop`` samples land on block b, its last
    L - 1 on the start of block b + 1 (two terms a sample, added in either order: the same
    bits). The blocks go through in groups of :data:`CHUNK_SAMPLES` samples.

    Reference: A. V. Oppenheim, R. W. Schafer, *Discrete-Time Signal Processing*, 3rd ed.,
    Pearson (2010), sec. 8.7.3 (the overlap-add method)."""
    n = x.shape[0]
    flat = x.reshape(n, -1).T  # (channels, n)
    channels = flat.shape[0]
    longest = max(taps.size for taps in taps_list)
    size = _block_size(longest)
    hop = size - longest + 1
    blocks = -(-n // hop)
    group = max(1, CHUNK_SAMPLES // (size * channels))
    kernels = [sp_fft.rfft(taps[::-1], size) for taps in taps_list]
    sums = [np.zeros((channels, blocks + 1, hop)) for _ in taps_list]  # hop samples a row
    padded = np.zeros((channels, min(group, blocks), size))  # the zero padding stays zero
    for first in range(0, blocks, group):
        count = min(group, blocks - first)
        begin, end = first * hop, (first + count) * hop
        chunk = padded[:, :count]
        if end <= n:
            chunk[..., :hop] = flat[:, begin:end].reshape(channels, count, hop)
        else:  # the last group: the record's last samples, then zeros
            last = np.zeros((channels, count * hop))
            last[:, : n - begin] = flat[:, begin:]
            chunk[..., :hop] = last.reshape(channels, count, hop)
        spectra = sp_fft.rfft(chunk, axis=-1)
        for kernel, total in zip(kernels, sums, strict=True):
            pieces = sp_fft.irfft(spectra * kernel, size, axis=-1)
            total[:, first : first + count] += pieces[..., :hop]
            total[:, first + 1 : first + count + 1, : longest - 1] += pieces[..., hop:]
    out = []
    for taps, total in zip(taps_list, sums, strict=True):
        start = (taps.size - 1) // 2
        series = total.reshape(channels, -1)
        out.append(np.ascontiguousarray(series[:, start : start + n].T).reshape(x.shape))
    return out


def fft_correlate(x: np.ndarray, taps_list) -> list[np.ndarray]:
    """Each centred kernel of ``taps_list`` (each at most the record's length) correlated with
    ``x`` along axis 0 ("same" alignment: an output per sample), all sharing the record's
    transform.

    A record of n + L - 1 samples at most :data:`ONE_TRANSFORM_UP_TO` or 16 L (L the
    longest kernel) is transformed whole: one ``rfft`` of the record and of each kernel
    at ``next_fast_len(n + L - 1)``, their product's ``irfft``, the centred n samples (for one
    kernel the same computation, bit for bit, as scipy's ``fftconvolve``, to which
    ``oaconvolve`` hands a one-block case over). Longer records run the overlap-add of
    :func:`_shared_overlap_add`, which beats ``oaconvolve`` on one kernel too (its blocks of
    :data:`BLOCK_PER_TAP` times the kernel, transformed a cache-sized group at a time),
    equal to it to rounding. Direct transforms
    skip scipy's N-D argument handling, most of a call's cost on records of about 1000
    samples, where a tuner evaluates hundreds of windows. ``scipy.signal.oaconvolve`` is the
    tests' oracle."""
    n = x.shape[0]
    longest = max(taps.size for taps in taps_list)
    if not one_transform(n, longest):
        return _shared_overlap_add(x, taps_list)
    size = sp_fft.next_fast_len(n + longest - 1, real=True)
    spectrum = sp_fft.rfft(x, size, axis=0)
    out = []
    for taps in taps_list:
        product = spectrum * sp_fft.rfft(_kernel(taps, x.ndim), size, axis=0)
        start = (taps.size - 1) // 2
        out.append(sp_fft.irfft(product, size, axis=0)[start : start + n])
    return out


def one_transform(n: int, longest: int) -> bool:
    """Whether :func:`fft_correlate` transforms a record of ``n`` samples whole for kernels of
    at most ``longest`` taps (:data:`ONE_TRANSFORM_UP_TO`), rather than by blocks."""
    return n + longest - 1 <= max(ONE_TRANSFORM_UP_TO, 16 * longest)


def _block_size(longest: int) -> int:
    """Samples of an overlap-add block for kernels of at most ``longest`` taps."""
    return sp_fft.next_fast_len(max(BLOCK_PER_TAP * longest, SHORTEST_BLOCK), real=True)


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
