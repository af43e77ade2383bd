"""Defaults that run anywhere: ``methods.get(name)`` with no parameters works at any step.

Defaults are stated in seconds and Hz for the paper's 1 kHz signal; at a step where one does
not fit (a 25 Hz cutoff at 10 Hz sampling, a 0.21 s window at 0.1 s) the rule of
``Method.at_step`` adapts it, and only it: values the caller sets are refused by name as before.
Exact truth: one period of a sinusoid over the record, far inside every default's band.
"""

import math

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods._registry import DEFAULT_NYQUIST_FRACTION

STEPS_S = (1e-3, 7e-3, 0.1, 1.0, 10.0)
N_SAMPLES = 501


def _registered():
    return [name for name in methods.available() if not name.startswith("_test")]


def _native(name: str) -> bool:
    return methods.package_of(name).startswith("diffbench")


@pytest.mark.parametrize("name", _registered())
def test_defaults_run_at_every_step_and_ours_are_accurate_on_a_slow_sinusoid(name):
    """Every method (peers included) runs at its defaults from 1 ms to 10 s steps; ours keep
    ẋ on the middle half of the record within 10 % of the truth's amplitude on one period over
    the record (the peers' defaults are theirs: some smooth a 501-sample period flat, which is
    not a crash). The ends are test_ends.py's matter (the Gaussian process's default 10 ms
    length scale at 7 ms steps keeps ends 45 % off: its band reaches Nyquist)."""
    for dt in STEPS_S:
        t = np.arange(N_SAMPLES) * dt
        omega = 2 * np.pi / (N_SAMPLES * dt)
        estimate = methods.get(name)(np.sin(omega * t), dt)
        valid = estimate.valid[1]
        assert valid.mean() >= 0.5, (dt, valid.mean())
        assert np.isfinite(estimate[1][valid]).all()
        if _native(name):
            middle = slice(N_SAMPLES // 4, 3 * N_SAMPLES // 4)
            assert valid[middle].all()
            error = np.abs(estimate[1][middle] - omega * np.cos(omega * t[middle]))
            assert error.max() <= 0.1 * omega, (dt, error.max() / omega)


@pytest.mark.parametrize("name", [name for name in _registered() if _native(name)])
@pytest.mark.parametrize("dt", [0.1, 1.0])
def test_adapted_defaults_follow_the_stated_rule(name, dt):
    cls = methods.method_class(name)
    default = methods.get(name)
    adapted = default.at_step(dt)
    adapted.check_step(dt)  # the adapted method takes the step
    for spec in methods.params_of(cls):
        before, after = getattr(default, spec.name), getattr(adapted, spec.name)
        if spec.kind is None:
            assert after == before, spec.name
        elif spec.kind == "frequency":
            assert after == min(before, DEFAULT_NYQUIST_FRACTION * 0.5 / dt), spec.name
        elif spec.kind == "duration":
            assert after == max(before, dt), spec.name
        else:  # windows: whole even numbers of steps, printed cleanly
            steps = after / dt
            assert abs(steps - round(steps)) < 1e-9 and round(steps) % 2 == 0, (spec.name, after)
            assert after == float(f"{after:.12g}"), (spec.name, after)
            assert steps >= 2


@pytest.mark.parametrize("name", [name for name in _registered() if _native(name)])
def test_defaults_that_fit_the_step_are_left_alone(name):
    """At 1 kHz (the step the defaults were chosen at) nothing is adapted: the benchmark's
    stored results at default settings stay what they were."""
    method = methods.get(name)
    assert method.at_step(1e-3) is method


@pytest.mark.parametrize(
    ("name", "params", "message"),
    [
        ("butterworth", {"cutoff_hz": 20.0}, r"`cutoff_hz` must be below the Nyquist"),
        ("spectral", {"cutoff_hz": 30.0}, r"`cutoff_hz` must be below the Nyquist"),
        ("kalman", {"bandwidth_hz": 30.0}, r"`bandwidth_hz` must be below the Nyquist"),
        ("savitzky_golay", {"window_s": 0.11}, r"`window_s`=0\.11 s"),
        ("jacobi", {"window_s": 0.3}, r"`window_s`=0\.3 s"),
        ("gaussian_kernel", {"sigma_s": 0.05}, r"`sigma_s` must be in \[0\.1, "),
        ("gaussian_process", {"length_scale_s": 0.05}, r"`length_scale_s` must be in \[0\.1, "),
    ],
)
def test_values_the_caller_sets_are_refused_not_adapted(name, params, message):
    method = methods.get(name, **params)
    assert method.at_step(0.1) is method
    with pytest.raises(ValueError, match=message):
        method(np.zeros(201), 0.1)


def test_a_default_window_grows_until_the_rule_resolves_the_kernel():
    """Jacobi's 0.21 s windows at dt = 1 s snap to 2 steps (3 taps), too few for the trapezoid
    rule on the default kernel; the rule grows both until the kernel is resolved, and the
    adapted windows are no longer than 1.25 times (plus one step each side) the shortest that
    works, found here one even window at a time."""
    dt = 1.0
    adapted = methods.get("jacobi").at_step(dt)

    def takes(window_s: float, accel_window_s: float) -> bool:
        try:
            methods.get("jacobi", window_s=window_s, accel_window_s=accel_window_s).check_step(dt)
        except ValueError:
            return False
        return True

    shortest = next(2 * k * dt for k in range(1, 200) if takes(2 * k * dt, 2 * k * dt))
    assert not takes(2 * dt, 2 * dt)  # the snapped windows alone do not do
    assert shortest <= adapted.window_s <= 2 * math.ceil(1.25 * shortest / 2 + 1) * dt
    assert adapted.window_s == adapted.accel_window_s  # equal defaults grow together


# --- short records (issue 45 item 3): the defaults shrink to the record ----------------------
SHORT = [(n, dt) for n in (16, 31, 64) for dt in (1e-3, 1e-2)]


@pytest.mark.parametrize("name", [n for n in _registered() if _native(n)])
def test_defaults_run_on_records_of_16_to_64_samples(name):
    """Every native method at its defaults on 16, 31 and 64 samples of 1 ms and 10 ms: it
    estimates (offline methods: every sample), and the values it used (``at_record``) are the
    class defaults where the record holds them and shrunk windows and time scales, raised
    frequencies where it does not. Exact truth: a line, which each reproduces at its trusted
    samples to 1 % of its value and slope (not to rounding: Jacobi's trapezoid rule on short
    windows and a Butterworth padding cut to the record are not exact on lines)."""
    for n, dt in SHORT:
        t = np.arange(n) * dt
        x = 0.5 - 2.0 * t
        method = methods.get(name)
        estimate = method(x, dt)
        used = method.at_record(n, dt)
        assert used._takes_record(n, dt)
        defaults = method.at_step(dt).params()
        for spec in methods.params_of(type(method)):
            value, default = used.params()[spec.name], defaults[spec.name]
            if spec.kind in ("window", "duration"):
                assert value <= default, (spec.name, n, dt)
            elif spec.kind == "frequency":
                assert value >= default, (spec.name, n, dt)
            elif spec.name != "rule":  # Jacobi's least-squares rule for short windows
                assert value == default, (spec.name, n, dt)
        for order, truth in ((0, x), (1, -2.0 + 0 * t)):
            if not methods.method_class(name).causal:
                assert estimate.estimated(order).all(), (order, n, dt)
            valid = estimate.valid[order]
            error = np.abs(estimate[order] - truth)[valid]
            assert error.max(initial=0.0) <= 1e-2 * np.abs(truth).max(), (order, n, dt)


def test_a_record_too_short_for_a_value_the_caller_set_is_still_refused():
    with pytest.raises(ValueError, match="`x` has 16 samples on axis 0; at least 21"):
        methods.get("jacobi", window_s=0.2)(np.zeros(16), 0.01)
    assert methods.get("jacobi").at_record(16, 0.01).window_s < 0.16
