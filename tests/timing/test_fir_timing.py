"""The FIR methods beside ``scipy.signal.oaconvolve`` with their own kernels, at 1e4, 1e5 and
1e6 samples (``diffbench timing`` writes the same pairs' ratios to results/timing/ratios.md).

Targets: one order, the method (every sample estimated, its ends included) >= 1.0x one bare
convolution; orders 0-2 in one call >= 1.3x three (one forward transform shared by the three
inverse ones). Compare the rows of each group of
`pytest tests/timing/test_fir_timing.py --benchmark-only`; the outputs are checked against
oaconvolve's after timing, no time is asserted.
"""

import numpy as np
import pytest
from scipy import signal as sps

from diffbench import methods
from diffbench.bench.studies.ratios import FIR_METHODS, FIR_SIZES

DT = 1e-3
CASES = [(name, size) for name in FIR_METHODS for size in FIR_SIZES]
IDS = [f"{name}-{size:g}" for name, size in CASES]


def _case(name, size):
    method = methods.preset(name, "paper-signal")
    x = np.random.default_rng(2015).standard_normal(size)
    method(x[:5000], DT)  # warm the kernel caches
    return method, x


def _kernels(method, orders):
    return [np.array(method.taps(order, DT)[::-1]) for order in orders]


def _check(estimate, x, kernels, orders):
    for order, kernel in zip(orders, kernels, strict=True):
        reference = sps.oaconvolve(x, kernel, mode="valid")
        half = kernel.size // 2
        inside = estimate[order][half : x.size - half]
        # two FFT correlations of at most 2 x.size points each: eps log2(N) sum|a| max|x|
        # each (the transforms' error bound), held to 4 times that between them
        bound = np.finfo(float).eps * np.log2(2 * x.size) * np.abs(kernel).sum()
        np.testing.assert_allclose(inside, reference, rtol=0, atol=4 * bound * np.abs(x).max())


@pytest.mark.parametrize(("name", "size"), CASES, ids=IDS)
def test_fir_method_one_order(benchmark, name, size):
    benchmark.group = f"fir-one-order-{name}-{size:g}"
    method, x = _case(name, size)
    estimate = benchmark(method, x, DT, orders=(1,))
    _check(estimate, x, _kernels(method, (1,)), (1,))


@pytest.mark.parametrize(("name", "size"), CASES, ids=IDS)
def test_oaconvolve_its_kernel(benchmark, name, size):
    benchmark.group = f"fir-one-order-{name}-{size:g}"
    method, x = _case(name, size)
    (kernel,) = _kernels(method, (1,))
    result = benchmark(sps.oaconvolve, x, kernel, mode="valid")
    assert result.shape == (size - kernel.size + 1,) and np.isfinite(result).all()


@pytest.mark.parametrize(("name", "size"), CASES, ids=IDS)
def test_fir_method_orders_0_to_2(benchmark, name, size):
    benchmark.group = f"fir-orders-0-2-{name}-{size:g}"
    method, x = _case(name, size)
    estimate = benchmark(method, x, DT, orders=(0, 1, 2))
    _check(estimate, x, _kernels(method, (0, 1, 2)), (0, 1, 2))


@pytest.mark.parametrize(("name", "size"), CASES, ids=IDS)
def test_three_oaconvolve_calls_with_its_kernels(benchmark, name, size):
    benchmark.group = f"fir-orders-0-2-{name}-{size:g}"
    method, x = _case(name, size)
    kernels = _kernels(method, (0, 1, 2))

    def three():
        return [sps.oaconvolve(x, kernel, mode="valid") for kernel in kernels]

    results = benchmark(three)
    assert all(np.isfinite(result).all() for result in results)
