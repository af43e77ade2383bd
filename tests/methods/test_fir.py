"""The central FIR helpers against scipy: short stencils bit for bit scipy's direct
convolution, long kernels on a record one block covers bit for bit its ``fftconvolve``, on
longer ones (several kernels in one shared overlap-add) ``oaconvolve``'s values to rounding."""

import numpy as np
import pytest
from scipy import signal as sps

from diffbench.methods import _fir
from diffbench.methods._fir import apply_central_fir, apply_central_firs


def _scipy_central(x, taps, method):
    kernel = taps[::-1].reshape((-1,) + (1,) * (x.ndim - 1))
    if method == "oa":
        y = sps.oaconvolve(x, kernel, mode="same", axes=0)
    else:
        y = sps.convolve(x, kernel, mode="same", method="direct")
    half = taps.size // 2
    y[:half] = np.nan
    y[x.shape[0] - half :] = np.nan
    return y


@pytest.mark.parametrize("shape", [(1000,), (1000, 48), (9, 2, 3)])
@pytest.mark.parametrize("taps", [[2.5], [-500.0, 0.0, 500.0], [1e6, -2e6, 1e6]])
def test_short_stencils_equal_scipys_direct_convolution_bit_for_bit(shape, taps):
    taps = np.array(taps)
    x = np.random.default_rng(7).standard_normal(shape)
    y, valid = apply_central_fir(x, taps)
    np.testing.assert_array_equal(y, _scipy_central(x, taps, "direct"))
    assert valid.sum() == shape[0] - 2 * (taps.size // 2)


def test_kernels_sharing_one_overlap_add_equal_one_oaconvolve_each():
    rng = np.random.default_rng(11)
    x = rng.standard_normal((20_000, 2))
    kernels = [rng.standard_normal(211), rng.standard_normal(3), rng.standard_normal(65)]
    for taps, (y, valid) in zip(kernels, apply_central_firs(x, kernels), strict=True):
        reference = _scipy_central(x, taps, "oa" if taps.size >= 32 else "direct")
        scale = np.nanmax(np.abs(reference))
        np.testing.assert_allclose(y, reference, rtol=0, atol=1e-12 * scale)
        assert np.array_equal(valid, np.isfinite(reference[:, 0]))


def _fftconvolve_central(x, taps):
    """scipy's ``fftconvolve`` of the record with the kernel, the centred samples kept: what
    ``oaconvolve`` hands a one-block case over to."""
    kernel = taps[::-1].reshape((-1,) + (1,) * (x.ndim - 1))
    y = sps.fftconvolve(x, kernel, mode="same", axes=0)
    half = taps.size // 2
    y[:half] = np.nan
    y[x.shape[0] - half :] = np.nan
    return y


@pytest.mark.parametrize("channels", [(), (2,), (48,)])
def test_long_kernels_on_a_record_one_block_covers_are_scipys_fftconvolve_bit_for_bit(channels):
    """n + L - 1 samples at most ONE_TRANSFORM_UP_TO (4096 from 32 taps to 256, 16 L
    beyond): one transform of the whole record, scipy's fftconvolve bit for bit (what
    ``oaconvolve`` computes itself for about 1000 samples and 121 taps or more)."""
    rng = np.random.default_rng(5)
    for n, size in [(1000, 33), (1000, 121), (1001, 499), (999, 999), (257, 255), (3000, 1001)]:
        assert _fir.one_transform(n, size)
        x = rng.standard_normal((n, *channels))
        taps = rng.standard_normal(size)
        y, valid = apply_central_fir(x, taps)
        np.testing.assert_array_equal(y, _fftconvolve_central(x, taps))
        assert valid.sum() == n - 2 * (size // 2)


@pytest.mark.parametrize("channels", [(), (2,), (48,)])
def test_long_kernels_on_longer_records_equal_oaconvolve_to_rounding(channels):
    """Records past one block run the shared overlap-add: oaconvolve's values to rounding.
    Each output sums L products of the kernel and the record by FFTs of N points: the two
    computations differ by about eps log2(N) sum|a| max|x| (the transforms' error bound, N
    the block length); held to 4 times that."""
    rng = np.random.default_rng(5)
    for n, size in [(6000, 301), (20_000, 211), (9000, 33), (100_000, 53)]:
        assert not _fir.one_transform(n, size)
        x = rng.standard_normal((n, *channels))
        taps = rng.standard_normal(size)
        y, valid = apply_central_fir(x, taps)
        bound = np.finfo(float).eps * np.log2(_fir._block_size(size)) * np.abs(taps).sum()
        reference = _scipy_central(x, taps, "oa")
        np.testing.assert_allclose(y, reference, rtol=0, atol=4 * bound * np.abs(x).max())
        assert valid.sum() == n - 2 * (size // 2)


def test_a_kernels_output_does_not_depend_on_the_kernels_asked_with_it():
    """A method's orders are kernels of one length: each order's output the same bits asked
    alone or with the others, on a short record (one transform) and a long one (blocks)."""
    rng = np.random.default_rng(3)
    kernels = [rng.standard_normal(211) for _ in range(3)]
    for n in (1001, 50_000):
        x = rng.standard_normal((n, 2))
        together = apply_central_firs(x, kernels)
        for taps, (y, valid) in zip(kernels, together, strict=True):
            alone, alone_valid = apply_central_fir(x, taps)
            assert np.array_equal(y, alone, equal_nan=True)
            assert np.array_equal(valid, alone_valid)


@pytest.mark.parametrize("channels", [(), (3,), (64,)])
def test_the_overlap_add_in_groups_of_blocks_is_the_whole_record_at_once_bit_for_bit(
    channels, monkeypatch
):
    """Blocks transformed a group at a time (CHUNK_SAMPLES) give the bits of all blocks at
    once: each block's transforms are the same, and each output sample adds the same two
    terms (a block's head and the previous block's tail), whichever group they came from.
    Groups of one block, of three (a record's blocks not a multiple of it) and all at once."""
    rng = np.random.default_rng(17)
    kernels = [rng.standard_normal(211), rng.standard_normal(211), rng.standard_normal(33)]
    x = rng.standard_normal((30_011, *channels))
    size = _fir._block_size(211)
    results = []
    for group in (1, 3, 10**6):
        monkeypatch.setattr(_fir, "CHUNK_SAMPLES", group * size * max(1, int(np.prod(channels))))
        results.append(_fir._shared_overlap_add(x, kernels))
    for grouped in results[:-1]:
        for y, whole in zip(grouped, results[-1], strict=True):
            assert np.array_equal(y, whole)
    reference = _scipy_central(x, kernels[0], "oa")
    half = kernels[0].size // 2
    scale = np.abs(kernels[0]).sum() * np.abs(x).max()
    np.testing.assert_allclose(
        results[0][0][half:-half],
        reference[half:-half],
        rtol=0,
        atol=4 * np.finfo(float).eps * np.log2(size) * scale,
    )
