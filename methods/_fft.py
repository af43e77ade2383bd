"""Real FFTs of long records in bounded memory: one complex transform of half the length,
split into two short ones (the "four-step" FFT).

numpy's ``rfft`` of a length whose half has a large prime factor (2(N-1) for N = 1e7 is
2 · 3² · 239 · 4649) runs Bluestein's algorithm at a smooth length of at least twice the
record, in complex numbers: 2.9 GB and 12-15 s for that transform of 19,999,998 samples on
the machine this was written on. The split below transforms the same record in 1.3 s with
313 MiB, its output included (one complex array of half the length besides); numpy's FFT
stays its test oracle.

References: W. M. Gentleman, G. Sande, "Fast Fourier transforms: for fun and profit",
AFIPS Fall Joint Computer Conference (1966) (the two-factor split with twiddles); D. H.
Bailey, "FFTs in external or hierarchical memory", J. Supercomputing 4 (1990) (the
"four-step" ordering); W. H. Press et al., *Numerical Recipes*, 3rd ed. (2007), sec. 12.3
(a real record of 2M samples as M complex ones).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft

SPLIT_FROM = 2**21
"""Real transform lengths from which :func:`rfft` and :func:`irfft` split the transform
(below it numpy's transform is used as it is: its bits, and its memory, are unchanged)."""

SHORTEST_FACTOR = 64
"""The least factor of the half length a split may use: a shorter one leaves the other
factor nearly as long as the record, and with it Bluestein's memory."""

BLOCK = 2**16
"""Frequencies or rows handled at once in the loops that pack and unpack, so that their
temporaries stay a few MiB whatever the record's length."""


def split_of(length: int) -> tuple[int, int] | None:
    """The factors (l1, l2) of the half length M = ``length``/2 that :func:`rfft` splits
    into (l1 the divisor of M nearest √M from below, l2 = M/l1), or None where the
    transform is used whole: ``length`` odd or below :data:`SPLIT_FROM`, or M without a
    divisor of :data:`SHORTEST_FACTOR` or more up to √M (M prime, say)."""
    if length < SPLIT_FROM or length % 2:
        return None
    half = length // 2
    for l1 in range(math.isqrt(half), SHORTEST_FACTOR - 1, -1):
        if half % l1 == 0:
            return l1, half // l1
    return None


def _twiddle(rows: np.ndarray, columns: int, length: int, sign: float) -> np.ndarray:
    r""":math:`e^{\pm 2\pi i\, r c / L}` for the rows r × columns c = 0..``columns`` - 1, as
    the products :math:`e^{\pm 2\pi i\, r c_h s / L}\, e^{\pm 2\pi i\, r c_l / L}`
    (c = c_h s + c_l, s ≈ √columns): 2√columns exponentials a row instead of ``columns``,
    each angle reduced modulo L in integers first, so that it keeps its precision (the
    product is within 2 ulps)."""
    stride = math.isqrt(columns - 1) + 1
    high = np.arange(-(-columns // stride)) * stride

    def turns(c):
        return np.exp(sign * 2j * np.pi * ((rows[:, None] * c[None, :]) % length) / length)

    product = turns(high)[:, :, None] * turns(np.arange(stride))[:, None, :]
    return product.reshape(rows.size, -1)[:, :columns]


def _rotation(start: int, count: int, half: int, sign: float, base: np.ndarray) -> np.ndarray:
    r""":math:`e^{\pm i\pi k / M}` for k = ``start`` .. ``start + count`` - 1, from ``base``
    (the same for k = 0..): one exponential a block."""
    return base[:count] * np.exp(sign * 1j * np.pi * start / half)


def split_fft(z: np.ndarray, l1: int, l2: int, inverse: bool = False) -> np.ndarray:
    r"""The DFT of the complex ``z`` (length M = l1 l2, overwritten), or its inverse (with
    the 1/M), by transforms of lengths l1 and l2:

    .. math:: Z_{k_1 + l_1 k_2} = \sum_{j_2} e^{\mp 2\pi i j_2 k_2 / l_2} \left[
        e^{\mp 2\pi i j_2 k_1 / M} \sum_{j_1} e^{\mp 2\pi i j_1 k_1 / l_1}
        z_{j_1 l_2 + j_2} \right]

    (Gentleman & Sande 1966): the inner sums are columns of z seen as an l1 × l2 array, the
    outer ones its rows, both transformed in place by ``scipy.fft``. Returns that array (z's
    memory), which holds :math:`Z_k` at ``[k % l1, k // l1]`` (:func:`_read`): no copy."""
    transform = scipy.fft.ifft if inverse else scipy.fft.fft
    grid = transform(z.reshape(l1, l2), axis=0, overwrite_x=True)
    sign = 1.0 if inverse else -1.0
    step = max(1, BLOCK // l2)
    for start in range(0, l1, step):
        rows = np.arange(start, min(start + step, l1))
        grid[rows[0] : rows[-1] + 1] *= _twiddle(rows, l2, l1 * l2, sign)
    return transform(grid, axis=1, overwrite_x=True)


def _segment(grid: np.ndarray, start: int, stop: int) -> np.ndarray:
    """Values ``start`` to ``stop`` - 1 (0 <= start <= stop <= M) of the transform
    :func:`split_fft` left in ``grid`` (which holds :math:`Z_k` at ``[k % l1, k // l1]``): a
    copy of the columns that hold them, read out in order."""
    l1 = grid.shape[0]
    first = start // l1
    block = grid[:, first : -(-stop // l1)].T.reshape(-1)[start - first * l1 : stop - first * l1]
    return block.copy() if np.shares_memory(block, grid) else block  # one column: a view


def _mirrored(values, start: int, stop: int, size: int) -> np.ndarray:
    """:math:`v_{(M-k) \bmod M}` for k = ``start`` .. ``stop`` - 1, from ``values(a, b)``
    (:math:`v_a .. v_{b-1}`) of a sequence of ``size`` M."""
    if start == 0:
        return np.concatenate([values(0, 1), values(size - stop + 1, size)[::-1]])
    return values(size - stop + 1, size - start + 1)[::-1]


def _reflected(record: np.ndarray, reflect: float, parity: int, out: np.ndarray) -> None:
    """Writes the samples 2j + ``parity`` (j = 0..M-1) of ``record`` extended by its
    reflection (length 2M = 2(n-1): :math:`y_i = x_i` for i < n, ``reflect`` ·
    :math:`x_{2M-i}` after) into ``out``, by strided slices."""
    n, length = record.size, out.size * 2
    inside = (n - parity + 1) // 2  # the j with 2j + parity < n
    out[:inside] = record[parity:n:2]
    np.multiply(record[length - 2 * inside - parity : 0 : -2], reflect, out=out[inside:])


def rfft(record: np.ndarray, reflect=None) -> np.ndarray:
    r"""``numpy.fft.rfft`` of the real 1-D ``record``, or of it extended by its reflection
    (``reflect`` ±1, :func:`_extended`: length L = 2(n-1)), without forming the extension
    where the transform is split (:func:`split_of`): its L/2 complex samples
    :math:`z_j = y_{2j} + i y_{2j+1}` are transformed (:func:`split_fft`) and unpacked,

    .. math:: Y_k = E_k + e^{-2\pi i k / L} O_k, \quad E_k = \tfrac12 (Z_k + \bar Z_{M-k}),
        \quad O_k = \tfrac1{2i} (Z_k - \bar Z_{M-k}), \quad k = 0..M

    (indices modulo M; Press et al. 2007, sec. 12.3). Peak: two complex arrays of M."""
    n = record.shape[0]
    length = n if reflect is None else 2 * (n - 1)
    split = split_of(length)
    if split is None:
        if reflect is None:
            return np.fft.rfft(record)
        return np.fft.rfft(np.concatenate([record, reflect * record[-2:0:-1]]))
    half = length // 2
    z = np.empty(half, dtype=complex)
    if reflect is None:
        z.real, z.imag = record[0::2], record[1::2]
    else:
        _reflected(record, reflect, 0, z.real)
        _reflected(record, reflect, 1, z.imag)
    grid = split_fft(z, *split)
    spectrum = np.empty(half + 1, dtype=complex)
    base = np.exp(-1j * np.pi * np.arange(BLOCK) / half)
    for start in range(0, half + 1, BLOCK):
        stop = min(start + BLOCK, half + 1)
        here = _segment(grid, start, min(stop, half))
        if stop > half:  # Z_M is Z_0
            here = np.concatenate([here, grid[:1, 0]])
        mirror = np.conj(_mirrored(lambda a, b: _segment(grid, a, b), start, stop, half))
        odd = np.subtract(here, mirror)
        odd *= _rotation(start, stop - start, half, -1.0, base)
        here += mirror
        here -= 1j * odd
        np.multiply(here, 0.5, out=spectrum[start:stop])
    return spectrum


def irfft(spectrum: np.ndarray, length: int, keep: int, factor=None) -> np.ndarray:
    r"""The first ``keep`` samples of ``numpy.fft.irfft(spectrum * factor(k), length)``, k the
    bins' indices (``factor``: a function of them, or None for 1), the product formed block
    by block. Split (:func:`split_of`) from :data:`SPLIT_FROM` samples on: the spectrum (its
    0 Hz and Nyquist bins taken as real, as numpy does) is packed into M = L/2 complex bins

    .. math:: Z_k = E_k + i O_k, \quad E_k = \tfrac12 (Y_k + \bar Y_{M-k}), \quad
        O_k = \tfrac12 e^{2\pi i k / L} (Y_k - \bar Y_{M-k}), \quad k = 0..M-1,

    whose inverse transform (:func:`split_fft`) :math:`z_j = y_{2j} + i y_{2j+1}` holds the
    samples, two a value. Peak: one complex array of M and the output."""
    split = split_of(length)
    if split is None:
        product = spectrum if factor is None else spectrum * factor(np.arange(spectrum.size))
        return np.fft.irfft(product, n=length)[:keep]
    half = length // 2
    z = np.empty(half, dtype=complex)
    base = np.exp(1j * np.pi * np.arange(BLOCK) / half)
    for start in range(0, half, BLOCK):
        stop = min(start + BLOCK, half)
        k = np.arange(start, stop)
        here = spectrum[start:stop].copy()  # written below: never the caller's
        mirror = np.conj(spectrum[half - stop + 1 : half - start + 1][::-1])
        if factor is not None:
            here *= factor(k)
            mirror *= np.conj(factor(half - k))
        if start == 0:  # 0 Hz and Nyquist are real in a real record's spectrum
            here[0], mirror[0] = here[0].real, mirror[0].real
        odd = np.subtract(here, mirror)
        odd *= _rotation(start, stop - start, half, 1.0, base)
        here += mirror
        here += 1j * odd
        np.multiply(here, 0.5, out=z[start:stop])
    grid = split_fft(z, *split, inverse=True)
    out = np.empty(keep)
    for start in range(0, (keep + 1) // 2, BLOCK):
        stop = min(start + BLOCK, (keep + 1) // 2)
        values = _segment(grid, start, stop)
        out[2 * start : 2 * stop : 2] = values.real
        odd = min(stop, keep // 2) - start  # the samples 2j + 1 < keep
        out[2 * start + 1 : 2 * (start + odd) : 2] = values.imag[:odd]
    return out
