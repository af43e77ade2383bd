"""Jacobi at irregular time stamps, natively (issue 45 item 4): at each sample the weighted
least-squares polynomial of the Jacobi weight on the actual stamps (each sample weighted by
the span of time it stands for), with the ends the uniform record has (``boundary``: the
window cut by the record; ``shifted``: the window moved inside it; ``central``: none).

Checked against an independent route (numpy's weighted ``Polynomial.fit`` on the window's
samples), against the uniform path on uniform stamps, and for exactness on polynomials at
every sample. Every rounding bound is 10 eps times the condition of the weighted basis (its
square where one side solves normal equations), times the sum of the magnitudes of the
estimate's sample weights, times the largest |x|.
"""

import numpy as np
import pytest
from numpy.polynomial import legendre

from diffbench import methods
from diffbench.methods._local_poly import sample_spans

EPS = np.finfo(float).eps
DT = 1e-3
SETTING = {"kappa": 3.0, "mu": 5.0, "q": 4, "window_s": 0.04, "accel_window_s": 0.05}


def jittered(n: int = 300, seed: int = 45) -> np.ndarray:
    t = np.arange(n) * DT
    t[1:-1] += np.random.default_rng(seed).uniform(-0.3, 0.3, n - 2) * DT
    return t


def window_fit(method, times, k, order, degree, centre_s=None, extra=0.0):
    """The fit at sample ``k`` by numpy: the samples within the order's half window of
    ``centre_s`` (default: t_k), weights (1 - τ)^(μ+s) (1 + τ)^(κ+s) times the sample spans
    (s = ``extra``, the boundary fits' ``end_exponent``), the polynomial of ``degree``
    differentiated ``order`` times at t_k. Returns the estimate's
    sample weights (as a function of x) and the rounding bound's factor (condition and the
    sum of the weights' magnitudes)."""
    reach = method._window(order)[1] / 2
    centre = times[k] if centre_s is None else centre_s
    inside = np.abs(times - centre) <= reach * (1 + 1e-9)
    offsets = times[inside] - centre
    tau = np.clip(offsets / reach, -1.0, 1.0)
    exponents = max(method.mu, 0.0) + extra, max(method.kappa, 0.0) + extra
    weight = (1 - tau) ** exponents[0] * (1 + tau) ** exponents[1] * sample_spans(times)[inside]
    basis = legendre.legvander(offsets / reach, degree) * np.sqrt(weight)[:, None]
    condition = np.linalg.cond(basis)
    rows = legendre.legder(np.eye(degree + 1), order) if order else np.eye(degree + 1)
    at = legendre.legvander(np.array([(times[k] - centre) / reach]), degree - order) @ rows
    gains = (at @ np.linalg.pinv(basis) * np.sqrt(weight)[None, :])[0] / reach**order

    def estimate(x):
        fitted = np.polynomial.Polynomial.fit(offsets, x[inside], degree, w=np.sqrt(weight))
        return fitted.deriv(order)(times[k] - centre) if order else fitted(times[k] - centre)

    return estimate, condition, np.abs(gains).sum()


def fit_of(method, times, k, order):
    """The degree, window centre (None: the sample's own time) and extra weight exponent of
    the fit at sample ``k``: the interior's n + q; near an end, the boundary fit's degree at
    its distance to the end with ``end_exponent``, or the shifted window's centre half a
    window inside the record."""
    reach = method._window(order)[1] / 2
    m = round(reach / DT)
    distance = min(times[k] - times[0], times[-1] - times[k])
    if distance >= reach * (1 - 1e-9):
        return method._fit_degree(order), None, 0.0
    if method.ends == "boundary":
        step = min(int(np.floor(distance / reach * m + 1e-9)), m - 1)
        return int(method._boundary_degrees(order, m)[step]), None, method.end_exponent
    centre = float(np.clip(times[k], times[0] + reach, times[-1] - reach))
    return method._fit_degree(order), centre, 0.0


@pytest.mark.parametrize(
    ("ends", "end_exponent"), [("boundary", 0.0), ("boundary", 2.5), ("shifted", 0.0)]
)
def test_each_sample_is_the_weighted_fit_on_its_window(ends, end_exponent):
    """At jittered stamps, interior and end samples against numpy's weighted fit (the
    boundary fits at the degree of their distance to the end, the shifted ones centred half a
    window inside the record)."""
    t = jittered()
    x = np.sin(2 * np.pi * 7 * t) + 0.4 * np.cos(2 * np.pi * 17 * t + 0.3)
    method = methods.get("jacobi", **SETTING, ends=ends, end_degree=3, end_exponent=end_exponent)
    values, _ = method._estimate_at(x, t, (0, 1, 2))
    for order in (0, 1, 2):
        m = round(method._window(order)[1] / 2 / DT)
        for k in (0, 3, m // 2, 150, t.size - 2, t.size - 1):
            degree, centre, extra = fit_of(method, t, k, order)
            estimate, condition, gain = window_fit(method, t, k, order, degree, centre, extra)
            bound = 10 * EPS * condition**2 * gain * np.abs(x).max()
            assert abs(values[order][k] - estimate(x)) <= bound, (order, k, degree)


@pytest.mark.parametrize(
    ("ends", "end_exponent"), [("boundary", 0.0), ("boundary", 2.5), ("shifted", 0.0)]
)
def test_the_native_path_on_uniform_stamps_is_the_uniform_path(ends, end_exponent):
    """With the ``least_squares`` rule (the discretisation the stamps' fit is), on uniform
    stamps: the same values to rounding and the same trusted samples."""
    t = np.arange(300) * DT
    x = np.sin(2 * np.pi * 6 * t) + 0.05 * np.random.default_rng(2).standard_normal(t.size)
    method = methods.get(
        "jacobi", **SETTING, rule="least_squares", ends=ends, end_exponent=end_exponent
    )
    uniform = method(x, DT)
    values, valid = method._estimate_at(x, t, (0, 1, 2))
    for order in (0, 1, 2):
        np.testing.assert_array_equal(valid[order], uniform.valid[order])
        m = round(method._window(order)[1] / 2 / DT)
        worst = 0.0
        for k in (0, m // 2, 150):
            _, condition, gain = window_fit(method, t, k, order, *fit_of(method, t, k, order))
            worst = max(worst, 10 * EPS * condition**2 * gain * np.abs(x).max())
        keep = valid[order]
        np.testing.assert_allclose(values[order][keep], uniform[order][keep], rtol=0, atol=worst)


@pytest.mark.parametrize(
    ("ends", "end_exponent"), [("boundary", 0.0), ("boundary", 2.5), ("shifted", 0.0)]
)
def test_exact_on_polynomials_of_its_degree_at_every_sample_of_jittered_stamps(ends, end_exponent):
    t = jittered(seed=7)
    rng = np.random.default_rng(3)
    method = methods.get(
        "jacobi",
        **SETTING,
        rule="least_squares",
        ends=ends,
        end_degree=3,
        end_exponent=end_exponent,
    )
    for order in (0, 1, 2):
        degree = int(method.exact_degree(order))
        poly = np.polynomial.Polynomial(rng.standard_normal(degree + 1), domain=[0, t[-1]])
        x = poly(t)
        estimate = method._estimate_at(x, t, (order,))[0][order]
        expected = poly.deriv(order)(t) if order else x
        m = round(method._window(order)[1] / 2 / DT)
        worst = max(
            10 * EPS * condition * gain * np.abs(x).max()
            for condition, gain in (
                window_fit(method, t, k, order, *fit_of(method, t, k, order))[1:]
                for k in (0, m // 2, 150)
            )
        )
        assert worst < 1e-6 * np.abs(expected).max()  # a bound that can fail
        np.testing.assert_allclose(estimate, expected, rtol=0, atol=10 * worst)


def test_central_ends_are_not_estimated_and_a_window_need_not_fit_the_mean_step():
    """``central`` leaves the samples within half a window of an end NaN (and not valid); a
    window that is no whole even number of mean steps is taken as it is (the fit reads
    times, not steps)."""
    t = jittered(seed=9) * 10  # mean step 10 ms: 0.25 s is 25 steps
    x = np.sin(2 * np.pi * 1.5 * t)
    method = methods.get("jacobi", kappa=2.0, mu=2.0, q=2, window_s=0.25, accel_window_s=0.25)
    central = methods.get("jacobi", **{**method.params(), "ends": "central"})(x, t=t)
    for order in (0, 1, 2):
        inner = (t - t[0] >= 0.125) & (t[-1] - t >= 0.125)
        assert np.isfinite(central[order][inner]).all()
        assert np.isnan(central[order][~inner]).all() and not central.valid[order][~inner].any()
        assert np.isfinite(method(x, t=t)[order]).all()


def test_stamps_spanning_less_than_a_window_are_refused_naming_t_and_the_window():
    t = jittered(n=30)  # 29 ms of stamps
    method = methods.get("jacobi", **SETTING)  # windows of 40 and 50 ms
    with pytest.raises(ValueError, match=r"^`t` spans .* s, shorter than `window_s`=0.04 s"):
        method(np.sin(t), t=t)


def test_the_central_fits_are_computed_once_for_every_rule_and_end_treatment():
    """A tuning tries each setting of the numbers once per rule and end treatment: at time
    stamps their central fits are the same, kept from the first and read by the others (no
    new entry), and every estimate is the one computed afresh, bit for bit."""
    from itertools import product

    from diffbench.methods import jacobi

    times = jittered(400)
    x = np.sin(2 * np.pi * 3 * times) + 0.01 * np.random.default_rng(8).standard_normal(400)
    jacobi._kept_central_fits.cache_clear()
    combinations = list(product(("trapezoid", "linear", "least_squares"), jacobi.ENDS))
    read = []
    for rule, ends in combinations:
        read.append(methods.get("jacobi", **SETTING, rule=rule, ends=ends)(x, DT, t=times))
        assert len(jacobi._kept_central_fits) == 3  # orders 0, 1, 2 of one design
    for (rule, ends), kept in zip(combinations, read, strict=True):
        jacobi._kept_central_fits.cache_clear()
        fresh = methods.get("jacobi", **SETTING, rule=rule, ends=ends)(x, DT, t=times)
        for order in (0, 1, 2):
            assert np.array_equal(kept[order], fresh[order], equal_nan=True)
            assert np.array_equal(kept.valid[order], fresh.valid[order])
    # another design is another entry
    methods.get("jacobi", **{**SETTING, "kappa": 2.0})(x, DT, t=times)
    assert len(jacobi._kept_central_fits) == 6
