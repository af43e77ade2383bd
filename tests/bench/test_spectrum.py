"""The noise floor and signal band a record shows by itself, against the noise and band that
made it (known noise models, known highest frequencies)."""

import numpy as np
import pytest

from diffbench import signals
from diffbench.bench.core.spectrum import periodogram, record_spectrum


def test_white_noise_has_its_variance_in_every_bin_and_no_band():
    rng = np.random.default_rng(0)
    sigma = 0.3
    x = sigma * rng.standard_normal(8192)
    frequency, power = periodogram(x, 1e-3)
    assert frequency[-1] == pytest.approx(500.0)
    assert np.mean(power[1:-1]) == pytest.approx(sigma**2, rel=0.03)
    spectrum = record_spectrum(x, 1e-3)
    assert spectrum.noise_std == pytest.approx(sigma, rel=0.03)
    assert spectrum.band_hz <= 1.0  # nothing stands above the floor but the detrended DC bin


@pytest.mark.parametrize("noise", ["gaussian", "combined"])
@pytest.mark.parametrize("level", [0.02, 0.2, 0.5])
@pytest.mark.parametrize("step", ["0.1ms", "1ms", "10ms"])
def test_the_paper_signal_shows_its_15_hz_band_and_its_white_noise(noise, level, step):
    """4/9/15 Hz sines with Gaussian noise of std ``level`` (and, combined, a 200 Hz
    disturbance and Poisson spikes of that amplitude on top) over 0.93 s: the band ends less
    than 4 Hz above 15 Hz whatever the noise, the disturbance not extending it, and the white
    noise is measured as well as the bins above the band allow. Measured over 20 seeds, std
    measured / std: 1.00 ± 0.014 at 0.1 ms (4650 bins), 0.96 ± 0.05 at 1 ms, 1.00 ± 0.21 at
    10 ms (47 bins); the spikes add 2-5 %."""
    scenario = signals.get_scenario(f"grid-{noise}-{level}-{step}")
    tolerance = {"0.1ms": 0.05, "1ms": 0.15, "10ms": 0.5}[step] + (noise == "combined") * 0.1
    for seed in range(3):
        realisation = scenario.realise(seed)
        spectrum = record_spectrum(realisation.x, realisation.dt_s)
        bin_hz = spectrum.frequency_hz[1]
        assert 15.0 - bin_hz <= spectrum.band_hz <= 19.0, (seed, spectrum.band_hz)
        assert spectrum.noise_std == pytest.approx(level, rel=tolerance), seed


@pytest.mark.parametrize("top_hz", [3.0, 30.0, 120.0])
def test_the_band_ends_at_the_highest_component(top_hz):
    dt = 1e-3
    t = np.arange(4000) * dt
    rng = np.random.default_rng(int(top_hz))
    components = np.linspace(top_hz / 6, top_hz, 6)
    x = sum(np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in components)
    x = x + 0.1 * rng.standard_normal(t.size)
    spectrum = record_spectrum(x, dt)
    bin_hz = 1 / (t.size * dt)
    assert top_hz - bin_hz <= spectrum.band_hz <= top_hz + 4 * bin_hz
    assert spectrum.noise_std == pytest.approx(0.1, rel=0.05)


def test_a_chirp_shows_the_band_it_sweeps():
    """chirp-gaussian sweeps from 1 Hz at 9.5 Hz/s over 2 s: up to 20 Hz, its last octave
    briefly (the band ends where its power still stands above the noise: 17.5 Hz)."""
    realisation = signals.get_scenario("chirp-gaussian").realise(0)
    spectrum = record_spectrum(realisation.x, realisation.dt_s)
    top_hz = 1.0 + 9.5 * (realisation.x.size - 1) * realisation.dt_s
    assert 0.8 * top_hz <= spectrum.band_hz <= 1.05 * top_hz
    assert spectrum.noise_std == pytest.approx(0.05, rel=0.05)


def test_a_noise_free_record_keeps_the_quiet_below_a_disturbance():
    """No white noise, a 200 Hz line: the floor is the taper's dynamic range, and the quiet
    octaves between 15 and 200 Hz end the band at the signal."""
    realisation = signals.get_scenario("grid-sinusoid-0.2-1ms").realise(0)
    spectrum = record_spectrum(realisation.x, realisation.dt_s)
    assert 15.0 <= spectrum.band_hz <= 19.0
    assert spectrum.noise_std < 1e-3
