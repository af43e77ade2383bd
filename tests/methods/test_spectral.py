"""The spectral method against exact answers: sinusoids its extension continues periodically
(every sample, ends included), the polynomial it takes out (against a direct minimisation of
its criterion), the records it refuses."""

import numpy as np
import pytest
from scipy import linalg

from diffbench import methods
from diffbench.methods.spectral import (
    extend,
    polynomial_trend,
    raised_cosine_lowpass,
    spectral_derivatives,
)
from diffbench.signals.scenarios import get_scenario

DT = 1e-3
N_STEPS = 2000  # (N - 1) dt = 2 s: integer-Hz sinusoids fill whole periods


@pytest.mark.parametrize(
    "extension, wave, n_samples",
    [
        ("none", "cos", N_STEPS),  # n dt = 2 s: periodic as it is
        ("none", "sin", N_STEPS),
        ("even", "cos", N_STEPS + 1),  # mirrored about t = 2 s: cos continues itself
        ("odd", "sin", N_STEPS + 1),  # reflected through (2 s, 0): sin continues itself
    ],
)
@pytest.mark.parametrize("rolloff", [0.0, 0.3])
def test_every_sample_equals_the_response_on_sinusoids_the_extension_continues(
    extension, wave, n_samples, rolloff
):
    method = methods.get("spectral", cutoff_hz=40.0, rolloff=rolloff, extension=extension)
    t = np.arange(n_samples) * DT
    for frequency in (3.0, 17.0, 39.0, 45.0, 210.0):
        omega = 2 * np.pi * frequency
        x = np.cos(omega * t) if wave == "cos" else np.sin(omega * t)
        phase = 0.0 if wave == "cos" else -np.pi / 2
        estimate = method(x, DT)
        for order in (0, 1, 2):
            response = method.frequency_response([frequency], DT, order)[0]
            expected = np.real(response * np.exp(1j * (omega * t + phase)))
            scale = max(1.0, omega**order)
            np.testing.assert_allclose(estimate[order], expected, rtol=0, atol=1e-9 * scale)
            assert estimate.valid[order].all()
    # the gain: passband 1, stopband 0, -6 dB at the cutoff for a smooth roll-off
    gain = raised_cosine_lowpass(np.array([10.0, 40.0, 70.0]), 40.0, rolloff)
    assert gain[0] == 1.0 and gain[2] == 0.0
    assert gain[1] == (1.0 if rolloff == 0 else pytest.approx(0.5))


def test_the_odd_extension_reproduces_lines_to_the_ends_and_even_does_not():
    t = np.arange(1001) * DT
    x = 3.0 - 7.0 * t
    odd = methods.get("spectral", extension="odd")(x, DT)
    np.testing.assert_allclose(odd[0], x, atol=1e-12)
    np.testing.assert_allclose(odd[1], -7.0, atol=1e-9)
    np.testing.assert_allclose(odd[2], 0.0, atol=1e-6)
    even = methods.get("spectral", extension="even")(x, DT)
    assert np.max(np.abs(even[1] + 7.0)) > 1.0  # the mirrored slope flips at the ends


def test_extension_shapes_and_channels():
    x = np.random.default_rng(0).standard_normal((11, 3))
    for extension, period in (("odd-fitted", 20), ("odd", 20), ("even", 20), ("none", 11)):
        extended = extend(x, extension)
        assert extended.shape == (period, 3)
        np.testing.assert_array_equal(extended[:11], x)
    for extension in ("odd-fitted", "odd"):
        method = methods.get("spectral", cutoff_hz=400.0, extension=extension, fit_degree=3)
        np.testing.assert_allclose(method(x, DT)[1][:, 1], method(x[:, 1], DT)[1], atol=1e-12)


@pytest.mark.parametrize("degree", [0, 1, 3])
def test_the_fitted_trend_minimises_the_energy_above_the_cutoff(degree):
    """Against the least-squares solution written with the explicit two-sided DFT matrix."""
    n, cutoff_hz = 301, 40.0
    x = np.random.default_rng(degree).standard_normal(n) + np.linspace(0, 3, n) ** 2
    period = 2 * (n - 1)
    f = np.fft.fftfreq(period, DT)
    stop = 1.0 - raised_cosine_lowpass(f, cutoff_hz, 0.3)
    k = np.arange(period)
    dft = np.exp(-2j * np.pi * np.outer(k, k) / period) * stop[:, None]
    tau = np.linspace(0.0, 1.0, n)
    powers = tau[:, None] ** np.arange(degree + 1)
    design = dft @ extend(powers, "odd")
    target = dft @ extend(x, "odd")
    direct = linalg.lstsq(np.vstack([design.real, design.imag]),
                          np.concatenate([target.real, target.imag]))[0]  # fmt: skip
    one_sided = 1.0 - raised_cosine_lowpass(np.fft.rfftfreq(period, DT), cutoff_hz, 0.3)
    fitted = polynomial_trend(x[:, None], "odd-fitted", degree, one_sided)[: degree + 1, 0]
    np.testing.assert_allclose(fitted, direct, rtol=1e-8, atol=1e-8)


def test_the_odd_extensions_reproduce_polynomials_of_their_degree_to_the_ends():
    t = np.arange(1001) * DT
    cubic = np.polynomial.Polynomial([0.5, -2.0, 3.0, 4.0])
    fitted = methods.get("spectral", extension="odd-fitted", fit_degree=3)(cubic(t), DT)
    for order in (0, 1, 2):
        scale = 1e-10 * DT**-order
        np.testing.assert_allclose(fitted[order], cubic.deriv(order)(t), rtol=0, atol=scale)
    line = 3.0 - 7.0 * t
    odd = methods.get("spectral", extension="odd")(line, DT)
    np.testing.assert_allclose(odd[1], -7.0, atol=1e-9)
    # a line taken out does not follow a cubic: far above rounding at the ends
    for extension in ("odd", "odd-fitted"):
        linear = methods.get("spectral", extension=extension, fit_degree=1)(cubic(t), DT)
        assert np.max(np.abs(linear[1] - cubic.deriv()(t))) > 1e-2


def test_passband_sinusoids_are_exact_and_stopband_ones_leak_only_at_the_ends():
    """odd-fitted on sines its reflection continues: in the passband the fit is zero and every
    sample is exact; a strong sine just above the cutoff moves the fit (its reflected spectrum
    overlaps the powers'), which shows within a few cutoff periods of the ends, the caveat of
    :func:`polynomial_trend`."""
    method = methods.get("spectral", cutoff_hz=40.0, rolloff=0.0, extension="odd-fitted")
    t = np.arange(N_STEPS + 1) * DT
    for frequency in (3.0, 17.0, 39.0):
        omega = 2 * np.pi * frequency
        estimate = method(np.sin(omega * t), DT)
        np.testing.assert_allclose(estimate[1], omega * np.cos(omega * t), atol=1e-9 * omega)
    omega = 2 * np.pi * 45.0
    leak = np.abs(method(np.sin(omega * t), DT)[1])
    middle = slice(N_STEPS // 4, 3 * N_STEPS // 4)
    assert np.max(leak[middle]) < 0.02 * omega  # -34 dB of the sine's own derivative
    assert np.max(leak[:20]) > 0.3 * omega  # the caveat: the ends follow the fit


def test_the_fitted_ends_beat_the_end_samples_on_the_paper_signal():
    """The least-squares ends take the noise of two samples out of the whole record: on the
    paper signal (10 seeds) the whole-record RMSE of x' falls by a fifth, the interior gains too."""
    scenario = get_scenario("paper-signal")
    whole, interior = {"odd": [], "odd-fitted": []}, {"odd": [], "odd-fitted": []}
    for seed in range(10):
        draw = scenario.realise(seed=seed)
        for extension in whole:
            estimate = spectral_derivatives(np.asarray(draw.x), DT, (1,), 15.2, 0.0, extension)
            error = estimate[1] - draw.truth[1]
            whole[extension].append(np.sqrt(np.mean(error**2)))
            interior[extension].append(np.sqrt(np.mean(error[draw.interior] ** 2)))
    assert np.mean(whole["odd-fitted"]) < 0.8 * np.mean(whole["odd"])
    assert np.mean(interior["odd-fitted"]) <= np.mean(interior["odd"])


def test_a_record_shorter_than_two_periods_of_the_cutoff_is_refused():
    with pytest.raises(ValueError, match="at least 201 are needed"):
        methods.get("spectral", cutoff_hz=10.0)(np.zeros(200), DT)
    with pytest.raises(ValueError, match="`cutoff_hz` must be at least 2e-06 Hz"):
        methods.get("spectral", cutoff_hz=1e-9)(np.zeros(200), DT)


def test_a_cutoff_at_or_above_nyquist_is_refused():
    with pytest.raises(ValueError, match="`cutoff_hz` must be below the Nyquist frequency 500"):
        methods.get("spectral", cutoff_hz=500.0)(np.zeros(100), DT)
    with pytest.raises(ValueError, match="`extension` must be one of"):
        methods.get("spectral", extension="reflect")
