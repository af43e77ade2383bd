"""pytest-benchmark timing of every registered method at its paper-signal preset.

Seeded input, warmed up; the result is checked after timing; no wall-clock time is asserted.
`make test` runs this once untimed (--benchmark-disable); `pytest tests/timing
--benchmark-only` times it.
"""

import numpy as np
import pytest

from diffbench import methods
from diffbench.bench.studies.timing import size_cap, timed_sizes, timing_instance

DT = 1e-3
SIZES = [10_000, 100_000, 1_000_000]


LOOSER = {
    "total_variation": (0.05, "measured 2.1 %: a piecewise-quadratic fit leaves a staircase in ẋ"),
    "derivative.spline": (
        0.2,
        "measured 13 %: `s` bounds the residual sum of squares of the "
        "whole record, so the preset for 1000 samples over-smooths 10000",
    ),
}
"""Methods whose paper-signal setting is checked to a looser bound, and why."""

UNTIMED_CHECK_SAMPLES = {
    "pynumdiff.tvrdiff": (2_000, "its iterative solver costs 30 s on 10^4 samples"),
    "pynumdiff.rbfdiff": (2_000, "its dense radial-basis solve costs 12 s on 10^4 samples"),
}
"""Methods the untimed run (``make test``) checks on a shorter record than the smallest timed
size, and why (the timed run still times and checks every size)."""


def _cases():
    cases = []
    for name in methods.available():
        cap, why = size_cap(name, DT)
        timed = timed_sizes(name, SIZES, DT)
        for size in sorted({*SIZES, *timed}):
            skip = size not in timed
            marks = [pytest.mark.skip(reason=f"timed up to {cap} samples: {why}")] if skip else []
            cases.append(pytest.param(name, size, marks=marks, id=f"{name}-{size}"))
    return cases


@pytest.mark.parametrize(("name", "size"), _cases())
def test_method_throughput(benchmark, name, size):
    if benchmark.disabled and size != SIZES[0]:
        pytest.skip(
            "untimed run (--benchmark-disable): the smallest size checks the result (a method "
            "capped below it is checked against its peer library by the adapter tests)"
        )
    method = timing_instance(name)
    if benchmark.disabled and name in UNTIMED_CHECK_SAMPLES:
        size = UNTIMED_CHECK_SAMPLES[name][0]
    t = np.arange(size) * DT
    # seeded noise far below the check's tolerance, so the check below is against exact truth
    x = np.sin(2 * np.pi * 4 * t) + 1e-9 * np.random.default_rng(size).standard_normal(size)
    if not benchmark.disabled:
        method(x[:5000], DT)  # warm-up (lazy imports, caches): only worth its cost when timed
    estimate = benchmark(method, x, DT)
    benchmark.extra_info["samples_per_s"] = (
        size / benchmark.stats["mean"] if benchmark.stats else None
    )
    velocity = 2 * np.pi * 4 * np.cos(2 * np.pi * 4 * t)
    valid = estimate.valid[1]
    inner = valid & (t > 0.5) & (t < t[-1] - 0.5)
    # 4 Hz lies well inside every preset's passband: the velocity is within 2 % of its peak
    # (or the method's own bound, see LOOSER)
    bound = LOOSER.get(name, (0.02, ""))[0]
    assert np.max(np.abs(estimate[1][inner] - velocity[inner])) < bound * 2 * np.pi * 4
