r"""Surrogate records: records like the user's, whose truth is known.

A record alone cannot score a differentiator (its truth is unknown), but its spectrum says
what kind of signal and noise it holds (:mod:`diffbench.bench.spectrum`). A *surrogate* is a
record drawn from that description: a signal with the record's signal spectrum and random
phases, plus noise with its noise spectrum,

.. math::
    s(t) = \sum_k a_k \cos(2\pi f_k t + \varphi_k), \qquad
    a_k = \sqrt{2 w_k \hat S_k / N},\quad \varphi_k \sim U(0, 2\pi),

:math:`\hat S_k = \max(P_k - \nu, 0)` below the band and 0 above it (:math:`w_k = 2`, or 1 at
0 Hz and Nyquist, so that the signal's variance is :math:`\frac1N \sum_k w_k \hat S_k`, that of
the record less its noise), and the noise Gaussian with the spectrum :math:`\nu` below the band
and :math:`P_k` above it (a disturbance line stays where it was). Sinusoids (peaks standing far
above their neighbourhood, :func:`spectral_lines`) stay lines, at their measured frequency and
amplitude. The derivatives of the signal are exact (the sums differentiated term by term), so
any method, linear or not, can be scored and tuned on surrogates with the oracle criterion:
data-only tuning for every method.

The signal is drawn on a grid ``LENGTH_FACTOR`` times as fine in frequency (the record's
spectrum interpolated onto it) and taken on the record's span, so that a surrogate is not
periodic over the record: a method that assumes it is (an FFT) pays at the ends as on data.

Reference: J. Theiler et al., "Testing for nonlinearity in time series: the method of
surrogate data", Physica D 58 (1992) 77-94 (random-phase surrogates).
"""

from __future__ import annotations

import numpy as np

from diffbench import signals
from diffbench.bench.spectrum import RecordSpectrum, window

LENGTH_FACTOR = 3
"""The surrogate's frequency grid is this many times finer than the record's."""

LINE_RATIO = 30.0
"""A peak of the Hann periodogram this many times above its neighbourhood is a sinusoid (a
line), not part of a continuous spectrum: the surrogate keeps it a line, at its frequency."""

LINE_NEIGHBOURS = 8
"""Bins each side, beyond the main lobe, whose median a line must stand above."""

END_FRACTION = 0.05
"""The samples within this fraction of the record of either end are left out of a surrogate's
``interior`` (a method may mask a few end samples and still be scored)."""


def surrogate_records(
    spectrum: RecordSpectrum, n_samples: int, dt: float, count: int, seed: int = 0
) -> list[signals.Realisation]:
    """``count`` surrogate realisations of ``n_samples`` samples at step ``dt`` drawn from
    ``spectrum`` (that of a record of ``n_samples`` samples), seeded by ``seed``."""
    if spectrum.frequency_hz.size != n_samples // 2 + 1:
        raise ValueError(
            f"`spectrum` is that of a record of {2 * (spectrum.frequency_hz.size - 1)} or so "
            f"samples, not of {n_samples}"
        )
    long = LENGTH_FACTOR * n_samples
    fine = np.fft.rfftfreq(long, dt)
    in_band = spectrum.frequency_hz <= spectrum.band_hz
    signal_power = np.where(
        in_band, np.maximum(spectrum.sharp_power - spectrum.noise_floor, 0.0), 0.0
    )
    line_hz, line_amplitude, lobes = spectral_lines(spectrum, n_samples)
    signal_power[lobes] = 0.0
    noise_power = np.where(in_band, spectrum.noise_floor, spectrum.power)
    # on the finer grid each bin holds 1/LENGTH_FACTOR of the variance of the record's bin
    fine_signal = np.interp(fine, spectrum.frequency_hz, signal_power) / LENGTH_FACTOR
    fine_signal[0] = fine_signal[-1] = 0.0  # no constant (detrended), no Nyquist term
    amplitude = 2 * np.sqrt(fine_signal / n_samples)  # a_k = sqrt(2 w_k S_k / N), w_k = 2
    omega = 2 * np.pi * fine
    line_omega = 2 * np.pi * line_hz
    t = np.arange(n_samples) * dt
    interior = np.zeros(n_samples, dtype=bool)
    margin = int(END_FRACTION * n_samples)
    interior[margin : n_samples - margin] = True
    rng = np.random.default_rng([7, seed])
    realisations = []
    for index in range(count):
        # the continuum by inverse FFT on the long grid (its derivatives: (iω)^n times each
        # term), a window of the record's length taken at random; the lines summed directly
        phase = np.exp(1j * rng.uniform(0.0, 2 * np.pi, fine.size))
        start = int(rng.integers(0, long - n_samples + 1))
        line_phase = rng.uniform(0.0, 2 * np.pi, line_hz.size)
        argument = np.outer(t + start * dt, line_omega) + line_phase
        derivatives = []
        for order in range(3):
            terms = (long / 2) * amplitude * phase * (1j * omega) ** order
            continuum = np.fft.irfft(terms, long)[start : start + n_samples]
            lines = np.real((1j * line_omega) ** order * np.exp(1j * argument)) @ line_amplitude
            derivatives.append(continuum + lines)
        truth = signals.Truth(t=t, derivatives=tuple(derivatives))
        noise = _coloured_noise(noise_power, n_samples, rng)
        realisations.append(
            signals.Realisation(
                t=t,
                dt_s=dt,
                x=truth[0] + noise,
                truth=truth,
                noise=noise,
                seed=seed * 1000 + index,
                interior=interior,
            )
        )
    return realisations


def spectral_lines(
    spectrum: RecordSpectrum, n_samples: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sinusoids in the band: the peaks of the Hann periodogram that stand ``LINE_RATIO`` times
    above the noise floor and the median of the quieter side of their neighbourhood
    (``LINE_NEIGHBOURS`` bins each side beyond the main lobe), their frequency refined by a
    parabola through the log power of the peak bin and its neighbours, their amplitude from
    the peak power corrected for the taper's gain off the bin centre.

    Returns the frequencies (Hz), amplitudes, and a mask of the bins their main lobes cover
    (taken out of the continuous part of the signal spectrum).
    """
    power, frequency = spectrum.sharp_power, spectrum.frequency_hz
    taper = window("hann", n_samples)  # the sharp periodogram's taper
    coherent = np.sum(taper) ** 2 / np.sum(taper**2)
    lobes = np.zeros(power.size, dtype=bool)
    found_hz, found_amplitude = [], []
    last = np.searchsorted(frequency, spectrum.band_hz, side="right") - 1
    for k in range(2, min(last + 1, power.size - 2)):
        if not (power[k] >= power[k - 1] and power[k] > power[k + 1]):
            continue
        sides = [power[max(0, k - 2 - LINE_NEIGHBOURS) : max(0, k - 2)],
                 power[k + 3 : k + 3 + LINE_NEIGHBOURS]]  # fmt: skip
        # the quieter side: a neighbouring line's lobe on the other does not hide this one
        quieter = min(float(np.median(side)) for side in sides if side.size)
        if power[k] < LINE_RATIO * max(quieter, spectrum.noise_floor):
            continue
        left, centre, right = np.log(power[k - 1 : k + 2])
        offset = 0.5 * (left - right) / (left - 2 * centre + right)
        gain = np.sinc(offset) / (1 - offset**2)  # Hann's response off the bin centre
        found_hz.append((k + offset) * frequency[1])
        found_amplitude.append(2 * np.sqrt(power[k] / coherent) / gain)
        lobes[k - 2 : k + 3] = True
    return np.array(found_hz), np.array(found_amplitude), lobes


def _coloured_noise(power: np.ndarray, n_samples: int, rng: np.random.Generator) -> np.ndarray:
    """Gaussian noise whose periodogram has mean ``power`` (one value per rfft bin)."""
    coefficients = rng.standard_normal(power.size) + 1j * rng.standard_normal(power.size)
    coefficients *= np.sqrt(power * n_samples / 2)
    coefficients[0] = coefficients[0].real * np.sqrt(2)
    if n_samples % 2 == 0:
        coefficients[-1] = coefficients[-1].real * np.sqrt(2)
    return np.fft.irfft(coefficients, n_samples)
