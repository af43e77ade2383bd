"""The Jacobi method on 1e6 samples beside scipy.signal.oaconvolve with the same kernel.

Targets: one order, the method's throughput >= 0.8x that of the bare convolution (its
overhead: input checks, the invalid-sample mask, the kernel lookup); orders 0-2 in one call,
>= 1.3x three oaconvolve calls with its kernels (one forward transform shared by the three
inverse ones). Compare the rows of each group of
`pytest tests/timing/test_jacobi_timing.py --benchmark-only`; no time is asserted here.
"""

import numpy as np
import pytest
from scipy import signal as sps

from diffbench import methods

SIZE = 1_000_000
DT = 1e-3


@pytest.fixture(scope="module")
def samples():
    return np.random.default_rng(2015).standard_normal(SIZE)


@pytest.fixture(scope="module")
def jacobi():
    method = methods.preset("jacobi", "paper-signal")
    return method


@pytest.mark.benchmark(group="jacobi-1e6")
def test_jacobi_method_velocity(benchmark, samples, jacobi):
    jacobi(samples[:10_000], DT, orders=(1,))  # warm the kernel cache
    estimate = benchmark(jacobi, samples, DT, orders=(1,))
    reference = sps.oaconvolve(samples, jacobi.taps(1, DT)[::-1], mode="valid")
    np.testing.assert_allclose(estimate[1][105:-105], reference, rtol=1e-9, atol=1e-9)


@pytest.mark.benchmark(group="jacobi-1e6")
def test_oaconvolve_same_kernel(benchmark, samples, jacobi):
    taps = jacobi.taps(1, DT)[::-1].copy()
    result = benchmark(sps.oaconvolve, samples, taps, mode="valid")
    assert result.shape == (SIZE - 210,)
    assert np.isfinite(result).all()


@pytest.mark.benchmark(group="jacobi-orders-0-2-1e6")
def test_jacobi_method_orders_0_to_2(benchmark, samples, jacobi):
    jacobi(samples[:10_000], DT)  # warm the kernel cache
    estimate = benchmark(jacobi, samples, DT, orders=(0, 1, 2))
    for order in (0, 1, 2):
        reference = sps.oaconvolve(samples, jacobi.taps(order, DT)[::-1], mode="valid")
        scale = np.abs(reference).max()
        np.testing.assert_allclose(estimate[order][105:-105], reference, rtol=0, atol=1e-12 * scale)


@pytest.mark.benchmark(group="jacobi-orders-0-2-1e6")
def test_three_oaconvolve_calls_with_its_kernels(benchmark, samples, jacobi):
    kernels = [jacobi.taps(order, DT)[::-1].copy() for order in (0, 1, 2)]

    def three():
        return [sps.oaconvolve(samples, kernel, mode="valid") for kernel in kernels]

    results = benchmark(three)
    assert all(result.shape == (SIZE - 210,) for result in results)
