"""Every value a parameter admits works, or is refused by a ValueError that names it.

A generated test draws, for every registered method, parameter values across their declared
ranges (edges included) and a sampling step, and requires either finite estimates and
responses or a ValueError naming a parameter, ``dt`` or ``x``. Then each measured limit (see
the method modules for the measurements): the two crashes that started this, and that the
ranges the messages state are where things stop working.
"""

import math
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from diffbench import methods
from diffbench.methods import MAX_WINDOW_STEPS
from diffbench.methods.jacobi_kernel import MAX_AMPLIFICATION, amplification, kernel

STEPS_S = (1e-4, 1e-3, 1e-2, 0.1)
N_SAMPLES = 301
ORDERS = (0, 1, 2)


def _registered():
    return [name for name in methods.available() if not name.startswith("_test")]


def _smooth(n: int, dt: float) -> np.ndarray:
    u = np.arange(n) / (n - 1)
    return np.sin(2 * np.pi * 1.3 * u + 0.4) + 0.3 * u**2


def _edges(spec) -> list:
    """The ends of a declared range (just inside an open end), and its tuning range."""
    low = spec.low if math.isfinite(spec.low) else -1e300
    high = spec.high if math.isfinite(spec.high) else 1e300
    values = [
        math.nextafter(low, math.inf) if spec.low_open else low,
        math.nextafter(high, -math.inf) if spec.high_open else high,
    ]
    values += [v for v in (spec.tune_low, spec.tune_high) if v is not None]
    return values


def _values(spec, dt: float):
    """Any admissible value of ``spec``, its edges weighted up; windows also as whole even
    numbers of steps up to the signal's length, frequencies also as fractions of Nyquist (else
    nearly every draw would be refused for not fitting the step)."""
    if spec.choices is not None:
        return st.sampled_from(spec.choices)
    if spec.integer:
        low, high = (int(bound) for bound in _edges(spec)[:2])
        return st.sampled_from([low, high]) | st.integers(low, high)
    anywhere = st.floats(
        min_value=spec.low if math.isfinite(spec.low) else None,
        max_value=spec.high if math.isfinite(spec.high) else None,
        exclude_min=spec.low_open and math.isfinite(spec.low),
        exclude_max=spec.high_open and math.isfinite(spec.high),
        allow_nan=False,
        allow_infinity=False,
    )
    strategy = st.sampled_from(_edges(spec)) | anywhere
    if spec.kind == "window":
        strategy |= st.integers(1, N_SAMPLES // 2).map(lambda k: 2 * k * dt)
    if spec.kind == "frequency":
        strategy |= st.floats(0.0, 1.0, exclude_min=True, exclude_max=True).map(
            lambda fraction: fraction * 0.5 / dt
        )
    return strategy


def _named(message: str, names: list[str]) -> bool:
    return any(f"`{name}`" in message for name in names)


@pytest.mark.parametrize("name", _registered())
@given(data=st.data())
def test_every_admitted_value_works_or_is_refused_naming_a_parameter(name, data):
    cls = methods.method_class(name)
    specs = methods.params_of(cls)
    dt = data.draw(st.sampled_from(STEPS_S), label="dt")
    params = {spec.name: data.draw(_values(spec, dt), label=spec.name) for spec in specs}
    x = _smooth(N_SAMPLES, dt)
    try:
        method = cls(**params)
        estimate = method(x, dt)
        for order in ORDERS:
            # it works: it estimates; on a record too short for its reach none of the
            # estimates may be trusted (valid), which the mark then says
            assert np.isfinite(estimate[order][estimate.valid[order]]).all()
            assert estimate.estimated(order).any()
        if cls.linear:
            frequencies = np.array([0.0, 0.01, 0.2, 0.45]) / dt
            for order in ORDERS:
                assert np.isfinite(method.frequency_response(frequencies, dt, order)).all()
    except ValueError as error:
        names = [spec.name for spec in specs] + ["dt", "x"]
        assert _named(str(error), names), f"{name} {params} dt={dt}: {error}"


# --- the two crashes that started this ------------------------------------------------------


def test_jacobi_exponents_of_500_are_refused_with_the_working_range():
    """kappa = mu = 500 used to overflow (OverflowError in the kernel's coefficients, or NaN
    taps); the kernel is accurate up to 440 (test_jacobi checks 400 against an independent
    weighted least-squares fit)."""
    with pytest.raises(
        ValueError, match=r"`kappa` must be a finite number in \[-0\.999, 400\], got 500"
    ):
        methods.get("jacobi", kappa=500.0, mu=500.0)
    with pytest.raises(
        ValueError, match=r"`mu` must be a finite number in \[-0\.999, 400\], got 500"
    ):
        methods.get("jacobi", mu=500.0)
    with pytest.raises(ValueError, match=r"`kappa` must be in \(-1, 400\]"):
        kernel(0.0, 1, 500.0, 500.0, 6)  # the pure function refuses too


def test_butterworth_cutoff_far_below_nyquist_is_refused_at_call_time_with_the_range():
    """cutoff_hz = 1e-6 at dt = 1e-3 used to raise numpy's LinAlgError (singular matrix) inside
    sosfiltfilt; the limit depends on the step, so the call refuses it."""
    method = methods.get("butterworth", cutoff_hz=1e-6)  # admissible until a step is known
    message = r"`cutoff_hz` must be in \[0\.5, 499\.9999995\] Hz at dt=0\.001 s \(.*\), got 1e-06"
    with pytest.raises(ValueError, match=message):
        method(_smooth(2000, 1e-3), 1e-3)
    with pytest.raises(ValueError, match=message):
        method.frequency_response([1.0], 1e-3, 1)


# --- step-dependent limits: at the edge it works, past it the message says where -----------


@pytest.mark.parametrize("order", [1, 6, 20])
def test_butterworth_at_its_lowest_cutoff_still_passes_a_constant(order):
    dt = 1e-3
    lowest = methods.get("butterworth", order=order, cutoff_hz=0.5)  # 1e-3 of Nyquist
    # a record long enough for the filter to settle (its ends take end_reach samples each)
    estimate = lowest(np.full(2 * lowest.end_reach(dt) + 1001, 3.25), dt)
    valid = estimate.valid[0]
    assert valid.sum() > 1000
    np.testing.assert_allclose(estimate[0][valid], 3.25, rtol=1e-9)
    with pytest.raises(ValueError, match=r"`cutoff_hz` must be in \[0\.5, 499\.9999995\] Hz"):
        methods.get("butterworth", order=order, cutoff_hz=0.4999)(np.zeros(3000), dt)
    nyquist = r"must be below the Nyquist frequency 50 Hz.*\[0\.05, 49\.99999995\] Hz"
    with pytest.raises(ValueError, match=nyquist):
        methods.get("butterworth", order=order, cutoff_hz=50.0)(np.zeros(3000), 0.01)
    # within 1e-9 of Nyquist order 20 used to overflow in scipy's design (OverflowError)
    with pytest.raises(ValueError, match=nyquist):
        methods.get("butterworth", order=order, cutoff_hz=49.9999999999999)(np.zeros(3000), 0.01)
    # it runs; its poles sit next to z = -1, so no end settles within 3000 samples: refused
    # as too short a record (naming `x`), never an overflow
    try:
        methods.get("butterworth", order=order, cutoff_hz=49.99999995)(np.zeros(3000), 0.01)
    except ValueError as error:
        assert str(error).startswith("`x` has 3000 samples on axis 0: too short for butterworth")


def test_kalman_bandwidth_limits_follow_the_step():
    x = _smooth(400, 1e-3)
    methods.get("kalman", bandwidth_hz=0.1)(x, 1e-3)  # 1e-4 / dt: the estimate is cheap
    with pytest.raises(
        ValueError,
        match=r"`bandwidth_hz` must be in \[0\.1, 500\) Hz at dt=0\.001 s \(.*\), got 0\.09",
    ):
        methods.get("kalman", bandwidth_hz=0.09)(x, 1e-3)
    with pytest.raises(ValueError, match=r"`bandwidth_hz` must be in \[0\.01, 50\) Hz"):
        methods.get("kalman", bandwidth_hz=1e-300).frequency_response([1.0], 0.01, 1)
    with pytest.raises(ValueError, match=r"below the Nyquist frequency 5 Hz.*\[0\.001, 5\) Hz"):
        methods.get("kalman", bandwidth_hz=5.0)(x, 0.1)


@pytest.mark.parametrize("name", ["savitzky_golay", "sindy_smoothing", "jacobi"])
def test_windows_longer_than_the_cap_are_refused_before_any_taps_are_built(name):
    window = 2 * (MAX_WINDOW_STEPS // 2 + 1) * 1e-3
    method = methods.get(name, window_s=window)
    with pytest.raises(ValueError, match=r"`window_s` must be in \(0, 100\] s at dt=0\.001 s"):
        method(np.zeros(100), 1e-3)
    with pytest.raises(ValueError, match=r"`window_s` must be in \(0, 100\] s"):
        methods.get(name, window_s=1e300)(np.zeros(100), 1e-3)


def test_long_savitzky_golay_windows_no_longer_build_a_quadratic_edge_matrix():
    """20001-sample window, degree 9: the ends used to need a 10000 x 20001 matrix (1.6 GB);
    the polynomial fitted at each end is now evaluated directly. Exact on degree 9."""
    dt = 1e-4
    t = np.arange(25_001) * dt
    u = t / t[-1] - 0.5
    poly = np.polynomial.Polynomial([0.1, -0.4, 0.8, 0.3, -1.0, 0.5, 0.2, -0.7, 0.9, 0.6])
    method = methods.get("savitzky_golay", window_s=2.0, degree=9)
    values, _ = method._estimate(poly(u), dt, (0, 1))  # every sample, before the validity check
    np.testing.assert_allclose(values[0], poly(u), rtol=0, atol=1e-9)
    np.testing.assert_allclose(values[1], poly.deriv()(u) / t[-1], rtol=0, atol=1e-6)


# --- Jacobi: lopsided designs and windows too short for their rule --------------------------


def _bound(pattern: str, message: str) -> float:
    return float(re.search(pattern, message).group(1))


def test_lopsided_jacobi_weights_are_refused_with_the_exponent_and_q_that_work():
    """kappa = 0, mu = 100, q = 12 multiplies rounding by 2.5e14: nothing of the estimate is
    left. The message states the range of mu (and the q) that works; its edges are checked."""
    with pytest.raises(ValueError) as refused:
        methods.get("jacobi", kappa=0.0, mu=100.0, q=12)
    message = str(refused.value)
    assert re.search(r"`mu` must be in \[0, [\d.]+\] with kappa=0\.0 and q=12 \(.*\)", message)
    high = _bound(r"`mu` must be in \[0, ([\d.]+)\]", message)
    lower_q = int(_bound(r"lower `q` to at most (\d+)", message))
    methods.get("jacobi", kappa=0.0, mu=high, q=12, rule="linear")
    methods.get("jacobi", kappa=0.0, mu=100.0, q=lower_q, rule="linear")
    with pytest.raises(ValueError, match=r"`mu` must be in"):
        methods.get("jacobi", kappa=0.0, mu=high + 0.01, q=12)
    with pytest.raises(ValueError, match=r"`mu` must be in"):
        methods.get("jacobi", kappa=0.0, mu=100.0, q=lower_q + 1)
    # the mirror image names kappa; the linear rule admits negative exponents down to -0.999
    with pytest.raises(ValueError, match=r"`kappa` must be in \[-0.999, [\d.]+\] with mu=-0\.5"):
        methods.get("jacobi", kappa=100.0, mu=-0.5, q=12, rule="linear")


def test_the_amplification_bound_keeps_least_squares_exact_to_rounding():
    """Just inside the bound the least-squares rule still reproduces polynomials of degree
    n + q to about 1e-8 of the data's size, in the derivative's natural units (the claim the
    bound protects)."""
    kappa, mu, q = 0.0, 46.0, 12
    assert max(amplification(n, kappa, mu, q) for n in ORDERS) <= MAX_AMPLIFICATION
    method = methods.get(
        "jacobi",
        kappa=kappa,
        mu=mu,
        q=q,
        rule="least_squares",
        window_s=0.2,
        accel_window_s=0.2,
        ends="shifted",  # exact on n + q at the ends too (the boundary fits: on end_degree)
    )
    dt, half = 1e-3, 100
    u = np.arange(-1.2 * half, 1.2 * half + 1) / half  # time in units of h = 0.1 s
    for order in ORDERS:
        degree = order + q
        poly = np.polynomial.Polynomial(
            np.linspace(0.3, 1.0, degree + 1) * (-1) ** np.arange(degree + 1)
        )
        estimate = method(poly(u), dt, orders=(order,))
        valid = estimate.valid[order]
        truth = poly.deriv(order)(u) / (half * dt) ** order
        error = np.max(np.abs(estimate[order][valid] - truth[valid])) * (half * dt) ** order
        assert error < 1e-6 * np.max(np.abs(poly(u))), (order, error)


def _follow_the_messages(params: dict, dt: float) -> dict:
    """Set each window a refusal names to the lowest value its message states, until the
    method accepts the step: the stated ranges must work."""
    for _ in range(3):
        try:
            methods.get("jacobi", **params).check_step(dt)
        except ValueError as error:
            found = re.search(r"`(\w*window_s)` must be in \[([\d.e-]+),", str(error))
            assert found, str(error)
            params = {**params, found.group(1): float(found.group(2))}
        else:
            return params
    raise AssertionError(f"still refused after following the messages: {params}")


@pytest.mark.parametrize(
    ("params", "dt", "name"),
    [
        # the trapezoid rule on 7 samples of a narrow kernel: the smoothed constant was 1.46x
        (
            {"kappa": 30.0, "mu": 30.0, "q": 2, "window_s": 0.06, "accel_window_s": 0.2},
            0.01,
            "window_s",
        ),
        # the trapezoid rule where the weight's derivative is infinite at the ends
        (
            {"kappa": 0.5, "mu": 0.5, "q": 2, "window_s": 0.02, "accel_window_s": 0.4},
            1e-3,
            "window_s",
        ),
        # least squares on 11 samples whose weights underflow: a singular fit
        (
            {
                "kappa": 400.0,
                "mu": 400.0,
                "rule": "least_squares",
                "window_s": 0.2,
                "accel_window_s": 0.01,
            },
            1e-3,
            "accel_window_s",
        ),
    ],
)
def test_windows_too_short_for_their_rule_are_refused_with_the_shortest_that_works(
    params, dt, name
):
    x = np.zeros(30_000)
    method = methods.get("jacobi", **params)
    with pytest.raises(ValueError, match=rf"`{name}` must be in \[[\d.e-]+, [\d.]+\] s at dt="):
        method(x, dt)
    with pytest.raises(ValueError) as refused:
        method.frequency_response([1.0], dt, 1)
    shortest = _bound(rf"`{name}` must be in \[([\d.e-]+),", str(refused.value))
    working = _follow_the_messages({**params, name: shortest}, dt)
    assert working[name] == shortest
    # the search stops within 2 % of the shortest window: 5 % shorter must fail
    shorter = {**working, name: 2 * math.floor(0.95 * shortest / (2 * dt)) * dt}
    if shorter[name] > 0:
        with pytest.raises(ValueError, match=rf"`{name}` must be in"):
            methods.get("jacobi", **shorter).check_step(dt)


@pytest.mark.parametrize(
    "params",
    [
        # passes the amplification bound, but its kernel is so large at the unweighted end
        # that the trapezoid rule misses by 6e4 on any window
        {"kappa": 0.0, "mu": 46.0, "q": 12},
        # kappa -> 0+: the end weight jumps from 0 to 1 within one step, whatever the step
        {"kappa": 1e-9},
    ],
)
def test_a_rule_that_fails_on_every_window_is_named_with_the_rules_that_work(params):
    method = methods.get("jacobi", **params)
    with pytest.raises(ValueError) as refused:
        method(np.zeros(1000), 1e-3)
    message = str(refused.value)
    assert message.startswith(f"`rule`='trapezoid' fails for kappa={method.kappa!r}"), message
    shortest = _bound(r"rule='linear' works from ([\d.]+) s", message)
    working = _follow_the_messages({**params, "rule": "linear", "window_s": shortest}, 1e-3)
    assert working["window_s"] == shortest


@pytest.mark.parametrize("ends", ["shifted", "boundary"])
def test_heavy_jacobi_weights_on_a_short_window_still_give_exact_ends(ends):
    """kappa = mu = 139 on 5 taps: the two end nodes weigh 0 and the next ones 4e-18 of the
    centre, so the degree-3 shifted fit for the second derivative had 3 samples to fit 4
    coefficients (CI: numpy's LinAlgError, singular matrix). Both end fits now drop to the
    degree their weighted samples determine, and nothing raises. Shifted: every sample is
    estimated, exact on the claimed degree wherever it is marked valid (the ends check marks
    the end samples these near-zero weights leave too noisy, see methods._ends). Boundary:
    ẍ's first and last two samples see one weighted sample on their side of the window, too
    few for a degree-2 fit, so they get no estimate (NaN); every other sample is estimated and
    exact."""
    dt = 1e-4
    method = methods.get(
        "jacobi",
        kappa=139.0,
        mu=139.0,
        q=0,
        window_s=0.004,
        accel_window_s=0.0004,
        rule="least_squares",
        ends=ends,
    )
    t = np.arange(301) * dt
    reach = {0: 20, 1: 20, 2: 2}  # half the window, in steps
    for order in ORDERS:
        degree = method.exact_degree(order)
        coefficients = np.arange(1.0, degree + 2) * 10.0 ** np.arange(degree + 1)
        signal = np.polynomial.Polynomial(coefficients)
        estimate = method(signal(t), dt)
        valid, estimated = estimate.valid[order], estimate.estimated(order)
        assert valid[reach[order] : -reach[order]].all(), order
        missing = [0, 1, 299, 300] if ends == "boundary" and order == 2 else []
        assert list(np.flatnonzero(~estimated)) == missing, order
        checked = valid if ends == "shifted" else estimated
        np.testing.assert_allclose(
            estimate[order][checked], signal.deriv(order)(t[checked]), rtol=1e-9, atol=1e-9
        )


PRESET_STEPS_S = {"paper-signal": (1e-3,), "robot": (2e-3, 5e-3, 1e-2)}
"""The steps the presets are used at: the paper's test signal at 1 kHz; the robots at 500 Hz
(DFKI, resampled), 200 Hz (simulation) and 100 Hz (the paper's robot)."""


@pytest.mark.parametrize("name", _registered())
def test_every_preset_still_works_at_the_steps_it_is_used_at(name):
    for key in methods.method_class(name).presets:
        method = methods.preset(name, key)
        for dt in PRESET_STEPS_S[key]:
            method.check_step(dt)
            reach = method.end_reach(dt) if method.linear else None
            length = max(3 * method.min_samples(dt), 2 * (reach or 0) + 1)
            estimate = method(_smooth(length, dt), dt)
            assert all(
                np.isfinite(estimate[order][estimate.valid[order]]).all() for order in ORDERS
            )


@pytest.mark.parametrize("name", ["savitzky_golay", "sindy_smoothing"])
@pytest.mark.parametrize("window_s", [0.05, 0.15, 0.2, 0.3, 0.7])
@pytest.mark.parametrize("degree", [2, 3, 5])
def test_windows_a_refusal_suggests_are_admissible(name, window_s, degree):
    """A window that is not a whole even number of steps, or too short for the degree, is
    refused with suggestions; every window suggested works with the same degree (at dt = 0.1
    s, 0.2 s used to be suggested for a cubic: 3 samples)."""
    dt = 0.1
    try:
        methods.get(name, window_s=window_s, degree=degree)(np.zeros(200), dt)
    except ValueError as error:
        message = str(error)
        suggested = re.search(r"(?:e\.g\.|use|at least) ([\d.]+(?: or [\d.]+)?)", message)
        assert suggested, message
        for value in suggested.group(1).split(" or "):
            estimate = methods.get(name, window_s=float(value), degree=degree)(np.zeros(200), dt)
            assert estimate.valid[1].any(), (message, value)
    else:
        assert degree < round(window_s / dt) + 1  # it fits: nothing to suggest
