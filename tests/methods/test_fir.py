"""The central FIR helpers against scipy: short stencils bit for bit scipy's direct
convolution, several kernels in one shared overlap-add equal to one ``oaconvolve`` each."""

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


@pytest.mark.parametrize("channels", [(), (2,), (48,)])
def test_long_kernels_equal_oaconvolve_bit_for_bit_on_either_side_of_its_one_block_rule(channels):
    # around 1000 samples scipy's overlap-add is one block from 121 taps on (its fftconvolve,
    # which apply_central_fir runs itself); shorter kernels or longer records take blocks
    rng = np.random.default_rng(5)
    one_block = 0
    for n, size in [
        (1000, 33),
        (1000, 101),
        (1000, 121),
        (1000, 185),
        (1001, 499),
        (999, 999),
        (4097, 301),
        (20_000, 211),
        (257, 255),
    ]:
        x = rng.standard_normal((n, *channels))
        taps = rng.standard_normal(size)
        y, valid = apply_central_fir(x, taps)
        np.testing.assert_array_equal(y, _scipy_central(x, taps, "oa"))
        assert valid.sum() == n - 2 * (size // 2)
        one_block += _fir._one_block(n, size) and n != size
    assert one_block == 4  # (1000, 121), (1000, 185), (1001, 499), (257, 255): the direct path
