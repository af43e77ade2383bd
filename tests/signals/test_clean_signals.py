"""Clean signals: exact derivatives against independent computations, the registry, validation."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.polynomial import Polynomial as NumpyPolynomial
from scipy import integrate, stats

from diffbench import signals
from diffbench.signals import (
    Chirp,
    DampedOscillation,
    PaperSines,
    Polynomial,
    Signal,
    SmoothedKink,
    Truth,
    available_signals,
    clean,
    get_signal,
    register_signal,
    signal_class,
)

BUILTIN = ["chirp", "damped_oscillation", "paper_sines", "polynomial", "smoothed_kink"]
# drawn, not evaluated: tests/signals/test_stochastic
RANDOM = ["band_limited", "integrated_white_noise", "matern"]

# Dyadic times and steps: t ± h is then exact in binary floating point, so the finite
# differences below see exactly the step they divide by.
T_DYADIC = np.arange(-64, 129) * 2.0**-6  # [-1, 2] s in steps of 1/64 s
H_DYADIC = 2.0**-9


def richardson_derivative(f, t, h=H_DYADIC, levels=4):
    """Central difference (f(t+h) - f(t-h)) / 2h, Richardson-extrapolated to O(h^(2*levels)).

    A slow, obviously correct oracle: it only ever calls ``f`` (the signal's samples), never
    the analytic derivative under test.
    """
    table = []
    for k in range(levels):
        step = h / 2**k
        row = [(f(t + step) - f(t - step)) / (2 * step)]
        for j in range(1, k + 1):
            row.append(row[j - 1] + (row[j - 1] - table[k - 1][j - 1]) / (4**j - 1))
        table.append(row)
    return table[-1][-1]


def assert_derivatives_match_finite_differences(
    signal, t=T_DYADIC, rtol=1e-9, envelopes=(0.0, 0.0)
):
    """ẋ from finite differences of x, and ẍ from finite differences of ẋ.

    Tolerance: ``rtol`` times the largest value of the derivative, plus the rounding error of
    differencing the lower order, about eps·E/h_min ≈ 1e-12·E (with a margin of 100; it only
    matters for very slow signals whose derivatives are tiny), where E is the larger of
    max|x^(n-1)| and ``envelopes[n-1]``: the size of the terms the lower order is computed from
    (a sinusoid's amplitude, whose rounding stays when a phase near π makes x itself small).
    """
    truth = signal.evaluate(t)
    for order in (1, 2):
        numeric = richardson_derivative(lambda s, o=order: signal.evaluate(s)[o - 1], t)
        size = max(np.max(np.abs(truth[order - 1])), envelopes[order - 1])
        atol = rtol * np.max(np.abs(truth[order])) + 1e-10 * size
        atol += 1e-300  # subnormal signals (hypothesis tries rate_hz_per_s = 5e-324)
        np.testing.assert_allclose(truth[order], numeric, rtol=0, atol=atol)


# --- exactness ------------------------------------------------------------------------------


@pytest.mark.parametrize("name", BUILTIN)
def test_every_registered_signal_has_exact_derivatives(name):
    assert_derivatives_match_finite_differences(get_signal(name))


def test_finite_difference_oracle_is_sharp_enough_to_catch_a_wrong_derivative():
    # Drop the chirp's θ̈·cos θ term from ẍ: the oracle must see the difference.
    signal = Chirp()
    truth = signal.evaluate(T_DYADIC)
    wrong = truth[2] - signal.amplitude * 2 * np.pi * signal.rate_hz_per_s * np.cos(
        2 * np.pi * (signal.start_hz * T_DYADIC + 0.5 * signal.rate_hz_per_s * T_DYADIC**2)
    )
    numeric = richardson_derivative(lambda s: signal.evaluate(s)[1], T_DYADIC)
    assert np.max(np.abs(wrong - numeric)) > 1e3 * 1e-9 * np.max(np.abs(truth[2]))


@given(
    start_hz=st.floats(0.0, 20.0),
    rate_hz_per_s=st.floats(-10.0, 10.0),
    amplitude=st.floats(0.1, 5.0),
    phase_rad=st.floats(-math.pi, math.pi),
)
def test_chirp_derivatives_for_any_parameters(start_hz, rate_hz_per_s, amplitude, phase_rad):
    chirp = Chirp(
        start_hz=start_hz, rate_hz_per_s=rate_hz_per_s, amplitude=amplitude, phase_rad=phase_rad
    )
    fastest_hz = max(abs(start_hz + rate_hz_per_s * s) for s in (T_DYADIC[0], T_DYADIC[-1]))
    envelopes = (amplitude, amplitude * 2 * math.pi * fastest_hz)
    assert_derivatives_match_finite_differences(chirp, envelopes=envelopes)


@given(
    natural_hz=st.floats(0.5, 10.0),
    damping_ratio=st.floats(0.0, 0.95),
    amplitude=st.floats(0.1, 5.0),
    phase_rad=st.floats(-math.pi, math.pi),
)
def test_damped_oscillation_derivatives_for_any_parameters(
    natural_hz, damping_ratio, amplitude, phase_rad
):
    signal = DampedOscillation(
        natural_hz=natural_hz, damping_ratio=damping_ratio, amplitude=amplitude, phase_rad=phase_rad
    )
    assert_derivatives_match_finite_differences(signal, t=T_DYADIC[T_DYADIC >= 0])


@given(frequencies_hz=st.lists(st.floats(0.5, 30.0), min_size=1, max_size=4))
def test_paper_sines_derivatives_for_any_frequencies(frequencies_hz):
    assert_derivatives_match_finite_differences(PaperSines(frequencies_hz=tuple(frequencies_hz)))


def test_paper_sines_by_hand_at_zero_and_one_eighth():
    truth = PaperSines().evaluate(np.array([0.0, 0.125]))
    root2 = math.sqrt(2.0)
    # t = 0: every sine is 0 and every cosine 1, so ẋ = 2π(4 + 9 + 15) = 56π.
    assert truth[0][0] == 0.0
    assert truth[1][0] == pytest.approx(56 * math.pi, rel=1e-15)
    assert truth[2][0] == 0.0
    # t = 1/8: the phases are π, 9π/4 and 15π/4, whose sines are 0, √2/2, -√2/2 and whose
    # cosines are -1, √2/2, √2/2.
    assert truth[0][1] == pytest.approx(0.0, abs=1e-14)
    assert truth[1][1] == pytest.approx(-8 * math.pi + (18 + 30) * math.pi * root2 / 2, rel=1e-14)
    assert truth[2][1] == pytest.approx((30**2 - 18**2) * math.pi**2 * root2 / 2, rel=1e-14)


def test_paper_sines_default_is_the_papers_signal():
    t = np.linspace(0.0, 1.0, 101)
    expected = sum(np.sin(2 * np.pi * f * t) for f in (4.0, 9.0, 15.0))
    np.testing.assert_allclose(PaperSines().evaluate(t)[0], expected, rtol=0, atol=1e-14)


def test_chirp_by_hand():
    # f0 = 1 Hz, k = 2 Hz/s: θ(0.5) = 2π(0.5 + 0.25) = 3π/2, sin = -1, cos = 0,
    # θ̇(0.5) = 2π(1 + 1) = 4π, so ẋ = 0 and ẍ = -A·θ̇²·sin θ = 3·16π².
    truth = Chirp(start_hz=1.0, rate_hz_per_s=2.0, amplitude=3.0).evaluate([0.5])
    assert truth[0][0] == pytest.approx(-3.0, rel=1e-15)
    assert truth[1][0] == pytest.approx(0.0, abs=1e-13)
    assert truth[2][0] == pytest.approx(3.0 * 16 * math.pi**2, rel=1e-14)


def test_chirp_sweeps_from_start_to_start_plus_rate_times_t():
    # ẋ / (2π A) at a zero crossing of θ (cos θ = 1) is the instantaneous frequency f0 + k t.
    signal = Chirp(start_hz=1.0, rate_hz_per_s=9.5, amplitude=1.0)
    # θ(t) = 2π·m  ⇔  4.75 t² + t - m = 0.
    m = 20.0
    t_cross = (-1.0 + math.sqrt(1.0 + 4 * 4.75 * m)) / (2 * 4.75)
    truth = signal.evaluate([t_cross])
    assert truth[1][0] / (2 * math.pi) == pytest.approx(1.0 + 9.5 * t_cross, rel=1e-12)


def test_polynomial_matches_numpy_polynomial_class():
    coefficients = (0.5, 1.0, -1.5, 0.5, 0.25, -0.125)
    t = np.linspace(-2.0, 3.0, 57)
    truth = Polynomial(coefficients=coefficients).evaluate(t)
    p = NumpyPolynomial(coefficients)
    for order in range(3):
        np.testing.assert_allclose(truth[order], p.deriv(order)(t), rtol=1e-13, atol=1e-13)


def test_polynomial_default_cubic_by_hand():
    # x = 0.5 + t - 1.5t² + 0.5t³ at t = 2: 0.5 + 2 - 6 + 4 = 0.5;
    # ẋ = 1 - 3t + 1.5t² = 1; ẍ = -3 + 3t = 3.
    truth = Polynomial().evaluate([2.0])
    assert [float(v[0]) for v in truth.derivatives] == [0.5, 1.0, 3.0]


def test_polynomial_of_low_degree_has_zero_higher_derivatives():
    truth = Polynomial(coefficients=(2.5,)).evaluate(np.array([0.0, 1.0, 7.0]))
    np.testing.assert_array_equal(truth[0], [2.5, 2.5, 2.5])
    np.testing.assert_array_equal(truth[1], np.zeros(3))
    np.testing.assert_array_equal(truth[2], np.zeros(3))
    line = Polynomial(coefficients=(1.0, -2.0)).evaluate(np.array([0.0, 3.0]))
    np.testing.assert_array_equal(line[1], [-2.0, -2.0])
    np.testing.assert_array_equal(line[2], [0.0, 0.0])


def test_damped_oscillation_matches_the_real_form():
    signal = DampedOscillation(natural_hz=5.0, damping_ratio=0.1, amplitude=1.5, phase_rad=0.3)
    t = np.linspace(0.0, 2.0, 301)
    omega = 2 * np.pi * 5.0
    zeta = 0.1
    omega_d = omega * math.sqrt(1 - zeta**2)
    envelope = 1.5 * np.exp(-zeta * omega * t)
    sin, cos = np.sin(omega_d * t + 0.3), np.cos(omega_d * t + 0.3)
    truth = signal.evaluate(t)
    np.testing.assert_allclose(truth[0], envelope * sin, rtol=0, atol=1e-13)
    np.testing.assert_allclose(
        truth[1], envelope * (omega_d * cos - zeta * omega * sin), rtol=0, atol=1e-11
    )
    np.testing.assert_allclose(
        truth[2],
        envelope * ((zeta**2 * omega**2 - omega_d**2) * sin - 2 * zeta * omega * omega_d * cos),
        rtol=0,
        atol=1e-9,
    )


def test_damped_oscillation_solves_its_ode():
    # ẍ + 2ζω ẋ + ω² x = 0 for the free response of a second-order system.
    signal = DampedOscillation(natural_hz=3.0, damping_ratio=0.4, amplitude=2.0, phase_rad=1.0)
    truth = signal.evaluate(np.linspace(0.0, 3.0, 400))
    omega = 2 * np.pi * 3.0
    residual = truth[2] + 2 * 0.4 * omega * truth[1] + omega**2 * truth[0]
    assert np.max(np.abs(residual)) < 1e-12 * omega**2 * 2.0


def test_evaluate_accepts_any_order_of_times_and_lists():
    signal = PaperSines()
    t = np.array([0.7, 0.1, 0.4])
    forward = signal.evaluate(t)
    shuffled = signal.evaluate([0.4, 0.7, 0.1])
    np.testing.assert_array_equal(shuffled[0], forward[0][[2, 0, 1]])


# --- Truth ----------------------------------------------------------------------------------


def test_truth_indexing_returns_each_order_and_rejects_others():
    t = np.array([0.0, 0.5, 1.0])
    truth = Truth(t=t, derivatives=(t**2, 2 * t, np.full(3, 2.0)))
    np.testing.assert_array_equal(truth[0], [0.0, 0.25, 1.0])
    np.testing.assert_array_equal(truth[1], [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(truth[2], [2.0, 2.0, 2.0])
    for bad in (-1, 3, 1.0, "1", True):
        with pytest.raises(ValueError, match="`order`"):
            truth[bad]


def test_truth_rejects_wrong_shapes_and_counts():
    t = np.zeros(3)
    with pytest.raises(ValueError, match=r"`derivatives\[1\]`"):
        Truth(t=t, derivatives=(np.zeros(3), np.zeros(2), np.zeros(3)))
    with pytest.raises(ValueError, match="`derivatives`"):
        Truth(t=t, derivatives=(np.zeros(3), np.zeros(3)))
    with pytest.raises(ValueError, match="`t`"):
        Truth(t=np.zeros((3, 1)), derivatives=(np.zeros(3),) * 3)


def test_truth_is_frozen_and_read_only():
    truth = PaperSines().evaluate(np.linspace(0, 1, 5))
    with pytest.raises(dataclasses.FrozenInstanceError):
        truth.t = np.zeros(5)
    with pytest.raises(ValueError, match="read-only"):
        truth[1][0] = 1.0


# --- registry -------------------------------------------------------------------------------


def test_available_signals_lists_the_builtins_sorted():
    assert available_signals() == sorted(BUILTIN + RANDOM)
    assert signal_class("chirp") is Chirp
    assert signals.get_signal("damped_oscillation").name == "damped_oscillation"


def test_get_signal_passes_parameters():
    signal = get_signal("chirp", start_hz=2.0, rate_hz_per_s=-1.0)
    assert signal == Chirp(start_hz=2.0, rate_hz_per_s=-1.0)
    assert signal.describe() == (
        "chirp(start_hz=2.0, rate_hz_per_s=-1.0, amplitude=1.0, phase_rad=0.0)"
    )


def test_unknown_signal_lists_the_valid_names():
    with pytest.raises(ValueError, match=r"unknown signal 'sines'.*paper_sines"):
        get_signal("sines")
    with pytest.raises(ValueError, match=r"unknown signal.*chirp, damped_oscillation"):
        signal_class("nope")


def test_unknown_parameter_is_named_with_the_valid_ones():
    with pytest.raises(
        ValueError, match=r"unknown parameter `frequency_hz`.*amplitude, phase_rad, rate_hz_per_s"
    ):
        get_signal("chirp", frequency_hz=3.0)


def test_duplicate_registration_is_an_error(monkeypatch):
    monkeypatch.setattr(clean, "_REGISTRY", dict(clean._REGISTRY))

    @dataclasses.dataclass(frozen=True, kw_only=True)
    class Constant(Signal):
        level: float = 1.0

        def _derivatives(self, t):
            return np.full_like(t, self.level), np.zeros_like(t), np.zeros_like(t)

    register_signal("_test_constant")(Constant)
    assert "_test_constant" in available_signals()
    np.testing.assert_array_equal(get_signal("_test_constant", level=2.0).evaluate([0.0])[0], [2])
    with pytest.raises(ValueError, match="already registered"):
        register_signal("chirp")(Constant)
    with pytest.raises(TypeError, match="must subclass"):
        register_signal("_test_other")(int)

    @dataclasses.dataclass
    class Mutable(Signal):
        level: float = 1.0

        def _derivatives(self, t):
            return np.full_like(t, self.level), np.zeros_like(t), np.zeros_like(t)

    with pytest.raises(TypeError, match="must be a frozen dataclass"):
        register_signal("_test_mutable")(Mutable)


# --- validation -----------------------------------------------------------------------------

BAD_PARAMETERS = [
    (PaperSines, {"frequencies_hz": (4.0, -1.0)}, r"`frequencies_hz\[1\]` must be > 0, got -1.0"),
    (PaperSines, {"frequencies_hz": ()}, "`frequencies_hz` must be a non-empty sequence"),
    (PaperSines, {"frequencies_hz": 4.0}, "`frequencies_hz` must be a non-empty sequence"),
    (
        PaperSines,
        {"frequencies_hz": (4.0, math.nan)},
        r"`frequencies_hz\[1\]` must be a finite number, got nan",
    ),
    (PaperSines, {"amplitude": 0.0}, "`amplitude` must be > 0, got 0.0"),
    (Chirp, {"start_hz": -1.0}, "`start_hz` must be >= 0, got -1.0"),
    (Chirp, {"rate_hz_per_s": math.inf}, "`rate_hz_per_s` must be a finite number"),
    (Chirp, {"phase_rad": "0"}, "`phase_rad` must be a real number"),
    (Chirp, {"amplitude": math.nan}, "`amplitude` must be a finite number, got nan"),
    (Polynomial, {"coefficients": ()}, "`coefficients` must be a non-empty sequence"),
    (Polynomial, {"coefficients": (1.0, math.inf)}, r"`coefficients\[1\]` must be a finite"),
    (Polynomial, {"coefficients": "123"}, "`coefficients` must be a non-empty sequence"),
    (DampedOscillation, {"natural_hz": -1.0}, "`natural_hz` must be > 0, got -1.0"),
    (DampedOscillation, {"damping_ratio": 1.0}, "`damping_ratio` must be < 1, got 1.0"),
    (DampedOscillation, {"damping_ratio": -0.1}, "`damping_ratio` must be >= 0, got -0.1"),
    (DampedOscillation, {"amplitude": True}, "`amplitude` must be a real number"),
]


@pytest.mark.parametrize(("cls", "params", "message"), BAD_PARAMETERS)
def test_bad_parameters_are_rejected_by_name(cls, params, message):
    with pytest.raises(ValueError, match=message):
        cls(**params)


def test_parameters_are_keyword_only_and_normalised():
    with pytest.raises(TypeError):
        Chirp(1.0)
    signal = PaperSines(frequencies_hz=[4, np.float32(9.0)], amplitude=2)
    assert signal.frequencies_hz == (4.0, 9.0)
    assert isinstance(signal.amplitude, float)
    assert Polynomial(coefficients=np.array([1.0, 2.0])).coefficients == (1.0, 2.0)


@pytest.mark.parametrize(
    ("t", "message"),
    [
        (np.zeros((2, 2)), "`t` must be 1-D"),
        (np.array([]), "`t` must hold at least one sample"),
        (np.array([0.0, math.nan]), "`t` holds 1 NaN or inf"),
        (np.array([0.0, math.inf]), "`t` holds 1 NaN or inf"),
        (["a", "b"], "`t` must be an array of real numbers"),
        (0.5, "`t` must be 1-D"),
    ],
)
@pytest.mark.parametrize("name", BUILTIN)
def test_evaluate_rejects_bad_times(name, t, message):
    with pytest.raises(ValueError, match=message):
        get_signal(name).evaluate(t)


@given(
    kink_s=st.floats(-1.0, 2.0),
    width_s=st.floats(0.05, 1.0),
    amplitude=st.floats(0.1, 5.0),
)
def test_smoothed_kink_derivatives_for_any_wide_parameters(kink_s, width_s, amplitude):
    # the oracle's finest step is 2^-12 s: its error grows as (h / width)^8, so widths of at
    # least 50 ms here; the sharp kinks are checked against the normal law below
    signal = SmoothedKink(kink_s=kink_s, width_s=width_s, amplitude=amplitude)
    assert_derivatives_match_finite_differences(signal)


@pytest.mark.parametrize("width_s", [0.005, 0.0005])
def test_smoothed_kink_is_the_mean_of_the_kink_over_the_normal_law(width_s):
    """x = A E|u + σZ| by quadrature, ẋ = A (2Φ(u/σ) - 1) and ẍ = 2A φ(u/σ)/σ from scipy's
    normal law, independent of the erf form; quad's own error estimate bounds the first."""
    signal = SmoothedKink(kink_s=0.5, width_s=width_s, amplitude=2.0)
    t = np.array([0.0, 0.49, 0.5 - 0.3 * width_s, 0.5, 0.5 + 2.1 * width_s, 0.62, 1.0])
    truth = signal.evaluate(t)
    u = t - 0.5
    for k, uk in enumerate(u):
        value, error = integrate.quad(
            lambda z, uk=uk: abs(uk + width_s * z) * stats.norm.pdf(z),
            -40,
            40,
            points=[-uk / width_s],
        )
        assert truth[0][k] == pytest.approx(2.0 * value, abs=2.0 * error + 1e-15)
    np.testing.assert_allclose(
        truth[1], 2.0 * (2 * stats.norm.cdf(u / width_s) - 1), rtol=0, atol=1e-14
    )
    np.testing.assert_allclose(
        truth[2], 2.0 * 2 * stats.norm.pdf(u / width_s) / width_s, rtol=1e-13, atol=0
    )
    # the slope turns from -A to A: ẍ integrates to 2A (trapezoid on a fine grid)
    fine = np.linspace(0.5 - 12 * width_s, 0.5 + 12 * width_s, 20001)
    assert integrate.trapezoid(signal.evaluate(fine)[2], fine) == pytest.approx(4.0, rel=1e-9)
