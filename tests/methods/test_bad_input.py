"""Bad input: every case is a ValueError that names the argument and what is allowed."""

import math

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods import uniform_step

DT = 1e-3
GOOD = np.sin(np.linspace(0, 3, 600))
ALL = [name for name in methods.available() if not name.startswith("_test")]


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize(
    ("x", "dt", "message"),
    [
        (np.r_[GOOD[:10], np.nan, GOOD[11:]], DT, r"`x` holds 1 NaN or inf"),
        (np.r_[GOOD[:10], np.inf, GOOD[11:]], DT, r"`x` holds 1 NaN or inf"),
        (np.array([]), DT, r"`x` has 0 samples"),
        (np.float64(1.0), DT, r"`x` must have time on axis 0"),
        (GOOD[:2], DT, r"`x` has 2 samples on axis 0; at least \d+ are needed"),
        (GOOD, 0.0, r"`dt` must be a finite number > 0"),
        (GOOD, -1e-3, r"`dt` must be a finite number > 0"),
        (GOOD, math.nan, r"`dt` must be a finite number > 0"),
        (GOOD, "fast", r"`dt` must be a finite number > 0"),
        (["a", "b"], DT, r"`x` must be an array of real numbers"),
    ],
    ids=[
        "nan",
        "inf",
        "empty",
        "scalar",
        "too-short",
        "dt-zero",
        "dt-negative",
        "dt-nan",
        "dt-string",
        "strings",
    ],
)
def test_bad_signals_and_steps(name, x, dt, message):
    method = methods.preset(name, "paper-signal")
    with pytest.raises(ValueError, match=message):
        method(x, dt)


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize(
    ("orders", "message"),
    [
        ((-1,), r"`orders` must hold integers 0..2, got -1"),
        ((3,), r"`orders` must hold integers 0..2, got 3"),
        ((1.5,), r"`orders` must hold integers 0..2, got 1.5"),
        ((), r"`orders` must name at least one"),
    ],
)
def test_bad_derivative_orders(name, orders, message):
    with pytest.raises(ValueError, match=message):
        methods.get(name)(GOOD, DT, orders=orders)


@pytest.mark.parametrize(
    ("name", "params", "dt", "message"),
    [
        ("savitzky_golay", {"window_s": 0.1}, 0.003, r"`window_s`=0.1 s is 33.3333 sampling steps"),
        ("savitzky_golay", {"window_s": 0.011}, DT, r"`window_s`=0.011 s spans 11 steps.*odd"),
        ("sindy_smoothing", {"window_s": 0.011}, DT, r"`window_s`=0.011 s spans 11 steps.*odd"),
        (
            "savitzky_golay",
            {"window_s": 0.004, "degree": 5},
            DT,
            r"`degree`=5 must be below the window's 5 samples",
        ),
        ("savitzky_golay", {"window_s": 2.0}, DT, r"`x` has 600 samples on axis 0; at least 2001"),
        (
            "butterworth",
            {"cutoff_hz": 500.0},
            DT,
            r"`cutoff_hz` must be below the Nyquist frequency 500 Hz",
        ),
        (
            "butterworth",
            {"cutoff_hz": 25.0},
            0.04,
            r"`cutoff_hz` must be below the Nyquist frequency 12.5 Hz",
        ),
    ],
    ids=[
        "sg-window-not-whole",
        "sg-even-window",
        "sindy-even-window",
        "sg-degree-too-high",
        "sg-window-longer-than-signal",
        "bw-cutoff-nyquist",
        "bw-cutoff-above-nyquist",
    ],
)
def test_parameters_that_do_not_fit_the_signal(name, params, dt, message):
    with pytest.raises(ValueError, match=message):
        methods.get(name, **params)(GOOD, dt)


def test_window_tolerance_accepts_floating_point_spans():
    # 0.21 / 0.001 = 209.99999999999997 in floating point: a whole number within tolerance.
    estimate = methods.get("savitzky_golay", window_s=0.21, degree=3)(GOOD, DT)
    assert estimate.valid[1][105:-105].all()  # 211 samples: the central window fits there


@pytest.mark.parametrize(
    ("t", "message"),
    [
        ([0.0, 0.1, 0.3], r"`t` is not uniformly sampled"),
        ([0.0, 0.2, 0.1], r"`t` must be strictly increasing; t\[2\]=0.1"),
        ([0.0, 0.1, 0.1], r"`t` must be strictly increasing"),
        ([0.0, np.nan, 0.2], r"`t` holds NaN"),
        ([0.0], r"`t` must be a 1-D array of at least 2"),
        ([[0.0, 1.0]], r"`t` must be a 1-D array"),
    ],
)
def test_bad_time_vectors(t, message):
    with pytest.raises(ValueError, match=message):
        uniform_step(t)


def test_uniform_step_of_a_good_time_vector():
    assert uniform_step(np.arange(11) * 0.01) == pytest.approx(0.01, rel=1e-12)


@pytest.mark.parametrize("odd", [False, True])
@pytest.mark.parametrize("span_s", [0.1, 0.13, 0.21, 0.3, 1.15, 0.05])
def test_a_refused_window_suggests_only_spans_that_are_accepted(span_s, odd):
    dt = 0.1
    try:
        intervals = methods.samples_in_span("window_s", span_s, dt, odd=odd)
    except ValueError as error:
        message = str(error)
    else:  # an accepted span: whole, and even when odd is asked for
        assert abs(intervals * dt - span_s) < 1e-12 and not (odd and intervals % 2)
        return
    suggested = message.split("e.g. ")[-1] if "e.g. " in message else message.split("use ")[-1]
    spans = [float(text) for text in suggested.split(" or ")]
    # printed as 1.2, not 1.2000000000000002
    assert spans and all(len(text) <= 6 for text in suggested.split(" or "))
    for span in spans:
        intervals = methods.samples_in_span("window_s", span, dt, odd=odd)
        assert intervals >= 1 and not (odd and intervals % 2)
