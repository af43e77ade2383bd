"""pytest-benchmark timing of every causal method on a stream: one sample per push (the online
case, whose cost per sample bounds the sample rate a controller can run it at) and chunks of
1000 samples.

Seeded input; the streamed result is checked against the batch call after timing; no
wall-clock time is asserted. `make test` runs each case once untimed on a short record;
`pytest tests/timing --benchmark-only` times it (``extra_info``: samples per second).
"""

import numpy as np
import pytest

from diffbench import methods

DT = 1e-3
TIMED_SAMPLES = {1: 5_000, 1000: 100_000}
"""Samples streamed per timed round, by chunk size."""


def _instance(name: str) -> methods.Method:
    if "paper-signal" in methods.method_class(name).presets:
        return methods.preset(name, "paper-signal")
    return methods.get(name)


def _stream_all(method, x, chunk):
    stream = method.stream(DT, orders=(1,))
    return np.concatenate([stream.push(x[i : i + chunk])[1] for i in range(0, x.size, chunk)])


@pytest.mark.parametrize("chunk", [1, 1000])
@pytest.mark.parametrize("name", methods.available(causal=True))
def test_streaming_throughput(benchmark, name, chunk):
    method = _instance(name)
    size = TIMED_SAMPLES[chunk] if not benchmark.disabled else 2 * chunk + 300
    t = np.arange(size) * DT
    x = np.sin(2 * np.pi * 4 * t) + 1e-3 * np.random.default_rng(size).standard_normal(size)
    if not benchmark.disabled:
        _stream_all(method, x[:2000], chunk)  # warm-up: caches of taps and gains
    streamed = benchmark(_stream_all, method, x, chunk)
    benchmark.extra_info["samples_per_s"] = (
        size / benchmark.stats["mean"] if benchmark.stats else None
    )
    np.testing.assert_array_equal(streamed, method(x, DT, orders=(1,))[1])
