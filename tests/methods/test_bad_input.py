"""Bad input: every case is a ValueError that names the argument and what is allowed."""

import math

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods import uniform_step
from diffbench.methods._validation import MAX_STEP_S, MIN_STEP_S, ArgumentTypeError

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
        (GOOD, "fast", r"`dt` must be a number of seconds in \[1e-30, 1e\+30\], got 'fast'"),
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


STEP_RANGE = r"`dt` must be a number of seconds in \[1e-30, 1e\+30\], got "


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize(
    ("dt", "message", "is_type"),
    [
        (True, STEP_RANGE + r"True \(a bool is not a step", True),
        (np.True_, STEP_RANGE + r"(np.)?True_? \(a bool is not a step", True),
        ("0.001", STEP_RANGE + r"'0.001' \(not a number", True),
        (1e-3 + 0j, STEP_RANGE + r"\(0.001\+0j\) \(not a number", True),
        (np.array([1e-3]), STEP_RANGE + r"array\(\[0.001\]\) \(not a number", True),
        (1e-300, STEP_RANGE + r"1e-300 \(the powers of the step .* overflow or underflow", False),
        (1e300, STEP_RANGE + r"1e\+300 \(the powers of the step", False),
        (np.nextafter(MIN_STEP_S, 0), STEP_RANGE + r"9.99", False),
        (np.nextafter(MAX_STEP_S, np.inf), STEP_RANGE + r"1.00", False),
    ],
    ids=["bool", "numpy-bool", "string", "complex", "array", "1e-300", "1e300", "below", "above"],
)
def test_steps_that_are_not_steps_or_overflow_are_refused(name, dt, message, is_type):
    """Issue 43: ``dt=True`` ran with dt = 1 s in 7 of the 19 native methods, ``dt=1e-300``
    divided by zero and ``dt=1e300`` overflowed; now each is one ValueError naming `dt`, the
    range and the fix (a wrong type also a TypeError, as Python's convention has it)."""
    method = methods.get(name)
    with pytest.raises(ValueError, match=message) as caught:
        method(GOOD, dt)
    assert isinstance(caught.value, TypeError) == is_type


@pytest.mark.parametrize("name", ALL)
def test_complex_samples_and_a_single_order_are_refused_by_name(name):
    method = methods.get(name)
    with pytest.raises(ArgumentTypeError, match=r"`x` must hold real samples, got complex"):
        method(GOOD + 1j * GOOD, DT)
    for orders in (1, "1"):
        with pytest.raises(
            ArgumentTypeError,
            match=r"`orders` must be a sequence of derivative orders in 0..2, e.g. \(1,\) or",
        ):
            method(GOOD, DT, orders=orders)


T_RANGE = r"`t` must have a mean step in \[1e-30, 1e\+30\] s, "


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize(
    ("t", "message", "is_type"),
    [
        (True, r"`t` must hold real times, got booleans", True),
        (np.arange(600) % 2 == 0, r"`t` must hold real times, got booleans", True),
        (np.arange(600) * (1 + 1j), r"`t` must hold real times, got complex values", True),
        (np.arange(600) * 1e-300, T_RANGE + r"got 1e-300", False),
        (np.arange(600) * 1e300, T_RANGE + r"got 1e\+300", False),
        (np.arange(600) ** 1.5 * 1e-300, T_RANGE, False),
    ],
    ids=["bool", "bools", "complex", "uniform-1e-300", "uniform-1e300", "irregular-1e-300"],
)
def test_time_stamps_are_checked_as_the_step_is(name, t, message, is_type):
    with pytest.raises(ValueError, match=message) as caught:
        methods.get(name)(GOOD, t=t)
    assert isinstance(caught.value, TypeError) == is_type


SCALE_UNKNOWN = {
    "levant": "`lipschitz` bounds a derivative of x: its unit is not in its name",
    "total_variation": "`penalty` weighs a sum over samples of a derivative: no unit in its name",
}
NATIVE = [n for n in ALL if methods.package_of(n).startswith("diffbench")]


@pytest.mark.parametrize("name", [n for n in NATIVE if n not in SCALE_UNKNOWN])
@pytest.mark.parametrize("dt", [MIN_STEP_S, MAX_STEP_S])
def test_the_ends_of_the_step_range_give_the_millisecond_results_rescaled(name, dt):
    """At the shortest and longest steps taken, every native method whose parameters carry
    their unit in their name (``_s`` scaled with the step, ``_hz`` against it) gives what it
    gives at dt = 1 ms, its derivatives of order n scaled by (1 ms / dt)^n: the range works,
    it is not only accepted. The two runs differ only by the roundings of the scaled step and
    parameters (an ulp each, 1.1e-16) carried through the method; 1e-10 of the peak allows a
    condition of 1e6 (measured: at most 3e-13, Butterworth's sections). ``gaussian_process_ml``
    fits its length scale to the optimiser's tolerance: 1e-6 (measured 2.4e-8)."""
    t = np.arange(1001) * 1e-3
    x = np.sin(2 * np.pi * 4 * t) + np.sin(2 * np.pi * 9 * t)
    scale = dt / 1e-3
    cls = methods.method_class(name)
    values = dict(methods.preset_spec(name, next(iter(cls.presets), "default")).values)

    def at(factor):
        return methods.get(
            name,
            **{
                key: value * factor
                if key.endswith("_s")
                else value / factor
                if key.endswith("_hz")
                else value
                for key, value in values.items()
            },
        )

    base, scaled = at(1.0)(x, 1e-3), at(scale)(x, dt)
    tolerance = 1e-6 if name == "gaussian_process_ml" else 1e-10
    for order in (0, 1, 2):
        np.testing.assert_array_equal(scaled.valid[order], base.valid[order])
        valid = base.valid[order]
        peak = np.max(np.abs(base[order][valid]))
        np.testing.assert_allclose(
            scaled[order][valid] * scale**order, base[order][valid], rtol=0, atol=tolerance * peak
        )
