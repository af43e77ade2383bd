"""pytest-benchmark timing of every registered method at its paper-signal preset.

Seeded input, warmed up; the result is checked after timing; no wall-clock time is asserted.
`make test` runs this once untimed (--benchmark-disable); `pytest tests/timing
--benchmark-only` times it.
"""

import numpy as np
import pytest

from diffbench import methods

DT = 1e-3
SIZES = [10_000, 100_000, 1_000_000]


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("name", methods.available())
def test_method_throughput(benchmark, name, size):
    method = methods.preset(name, "paper-signal")
    t = np.arange(size) * DT
    # seeded noise far below the check's tolerance, so the check below is against exact truth
    x = np.sin(2 * np.pi * 4 * t) + 1e-9 * np.random.default_rng(size).standard_normal(size)
    method(x[:5000], DT)  # warm-up (lazy imports, caches)
    estimate = benchmark(method, x, DT)
    benchmark.extra_info["samples_per_s"] = (
        size / benchmark.stats["mean"] if benchmark.stats else None
    )
    velocity = 2 * np.pi * 4 * np.cos(2 * np.pi * 4 * t)
    valid = estimate.valid[1]
    inner = valid & (t > 0.5) & (t < t[-1] - 0.5)
    # 4 Hz lies well inside every preset's passband: the velocity is within 2 % of its peak.
    assert np.max(np.abs(estimate[1][inner] - velocity[inner])) < 0.02 * 2 * np.pi * 4
