"""The spectral method against exact answers: sinusoids its extension continues periodically
(every sample, ends included), the line it takes out, the records it refuses."""

import numpy as np
import pytest

from diffbench import methods
from diffbench.methods.spectral import periodic_extension, raised_cosine_lowpass

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


def test_the_odd_extension_reproduces_lines_to_the_ends_and_the_others_do_not():
    t = np.arange(1001) * DT
    x = 3.0 - 7.0 * t
    odd = methods.get("spectral", extension="odd")(x, DT)
    np.testing.assert_allclose(odd[0], x, atol=1e-12)
    np.testing.assert_allclose(odd[1], -7.0, atol=1e-9)
    np.testing.assert_allclose(odd[2], 0.0, atol=1e-6)
    even = methods.get("spectral", extension="even")(x, DT)
    assert np.max(np.abs(even[1] + 7.0)) > 1.0  # the mirrored slope flips at the ends


def test_periodic_extension_shapes_and_channels():
    x = np.random.default_rng(0).standard_normal((11, 3))
    for extension, period in (("odd", 20), ("even", 20), ("none", 11)):
        extended, trend = periodic_extension(x, extension)
        assert extended.shape == (period, 3)
        np.testing.assert_allclose(extended[:11] + trend, x, atol=1e-15)
    method = methods.get("spectral", cutoff_hz=400.0)
    np.testing.assert_allclose(method(x, DT)[1][:, 1], method(x[:, 1], DT)[1], atol=1e-12)


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
