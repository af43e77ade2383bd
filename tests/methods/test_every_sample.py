"""Every native offline method estimates every sample (issue 45): its ends, a record of 31
samples, jittered time stamps. What it does not trust there it marks not valid, keeping the
estimate (:class:`diffbench.methods.Estimate`: ``valid`` is the trust mark, the values are
finite wherever the method estimates).

Records: the paper signal at its 1 ms step over 1.237 s (ends that do not meet); the same
signal at 1 ms stamps moved by up to ±30 % of the step; 31 samples over 1 s of sin 3t (the
length of PyNumDiff's test records). Each method at its paper-signal preset (its defaults on
31 samples, where the presets' windows do not fit).
"""

import numpy as np
import pytest

from diffbench import methods, signals

NATIVE_OFFLINE = [
    name
    for name in methods.available()
    if methods.package_of(name).startswith("diffbench")
    and not name.startswith("_test")
    and not methods.method_class(name).causal
]


def _setting(name: str):
    cls = methods.method_class(name)
    return methods.preset(name, "paper-signal") if "paper-signal" in cls.presets else None


def _paper(seed: int = 0):
    scenario = signals.get_scenario("paper-signal-4937ms")
    return scenario.realise(seed).x[:1238], scenario.dt_s


def _jittered():
    rng = np.random.default_rng(45)
    t = np.arange(1238) * 1e-3
    t[1:-1] += rng.uniform(-0.3e-3, 0.3e-3, t.size - 2)
    x = sum(np.sin(2 * np.pi * f * t) for f in (4.0, 9.0, 15.0))
    return x + 0.01 * rng.standard_normal(t.size), t


def _estimated_everywhere(estimate) -> None:
    for order in (0, 1, 2):
        estimated = estimate.estimated(order)
        assert estimated.all(), f"order {order}: {np.count_nonzero(~estimated)} samples missing"
        # the trust mark is a part of them, and not empty on a record this long
        assert estimate.valid[order].any()


@pytest.mark.parametrize("name", NATIVE_OFFLINE)
def test_every_sample_of_a_uniform_record_is_estimated(name):
    x, dt = _paper()
    estimate = (_setting(name) or methods.get(name))(x, dt)
    _estimated_everywhere(estimate)


@pytest.mark.parametrize("name", NATIVE_OFFLINE)
def test_every_sample_at_jittered_stamps_is_estimated(name):
    x, t = _jittered()
    estimate = (_setting(name) or methods.get(name))(x, 1e-3, t=t)
    _estimated_everywhere(estimate)


@pytest.mark.parametrize("name", NATIVE_OFFLINE)
def test_every_sample_of_31_samples_is_estimated(name):
    t = np.linspace(0.0, 1.0, 31)
    x = np.sin(3 * t) + 0.01 * np.random.default_rng(31).standard_normal(t.size)
    _estimated_everywhere(methods.get(name)(x, t[1] - t[0]))
