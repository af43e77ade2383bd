r"""What a record alone says about itself: its noise floor and the band its signal occupies.

No truth and no bandlimit typed in: the periodogram of the record is split where the signal
stops standing above the noise. The data-only tuning and ``recommend`` start from this.

The periodogram of the linearly detrended record with a Nuttall taper :math:`w` (sidelobes
93 dB down),

.. math:: P_k = \frac{\left|\sum_j w_j x_j e^{-2\pi i jk/N}\right|^2}{\sum_j w_j^2},

has mean :math:`\sigma^2` in every bin for white noise of variance :math:`\sigma^2`, and each
bin is then an exponential variable (half a :math:`\chi^2_2`), so its median is
:math:`\sigma^2 \ln 2`. The *noise floor* :math:`\nu` is the median of the bins above the band
(robust to lines such as a 200 Hz disturbance) over :math:`\ln 2`. The *band* ends at the last
bin whose running mean over :math:`m` bins stands above what noise alone reaches (the mean of
about :math:`m/2` independent exponential bins, the taper correlating neighbours: a gamma
variable; its quantile at ``FALSE_ALARM`` per record), before an octave of quiet: a line far
above the band (a disturbance) does not extend it. Floor and band are found in turn, from the
floor of the upper half of the spectrum, until the band no longer moves.

References: P. Welch, IEEE Trans. Audio Electroacoust. 15 (1967) (the tapered periodogram);
D. B. Percival, A. T. Walden, *Spectral Analysis for Physical Applications*, Cambridge (1993),
ch. 6 (its distribution).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal as sps
from scipy import stats

FALSE_ALARM = 1e-3
"""Chance that noise alone makes any bin of a record count as signal (shared by its bins)."""

MIN_BINS_ABOVE = 16
"""Fewest bins above the band the floor is taken from; with fewer, the upper half is used."""

DYNAMIC_RANGE = 1e-9
"""The floor is at least this fraction of the highest smoothed power: what a Nuttall taper
(sidelobes 93 dB down) leaves of strong lines, so that a noise-free record still shows the
quiet between its band and a disturbance far above it."""

ROUNDS = 5
"""Most alternations of floor and band (two or three settle it)."""


@dataclass(frozen=True)
class RecordSpectrum:
    """The record's periodogram, noise floor and signal band (see the module docstring).

    ``noise_std`` is :math:`\\sqrt{\\nu}`: the standard deviation of white noise with the
    measured floor (disturbance lines and the signal itself are not in it).
    """

    frequency_hz: np.ndarray
    power: np.ndarray
    smoothed: np.ndarray
    noise_floor: float
    band_hz: float
    smoothing_bins: int
    sharp_power: np.ndarray

    @property
    def noise_std(self) -> float:
        return math.sqrt(self.noise_floor)

    def threshold(self) -> float:
        """The smoothed power above which a bin counts as signal: the running mean of noise
        alone, about a gamma variable of shape m/2 (m/2 independent exponential bins) and
        mean ν, exceeds it in one bin of the record with chance ``FALSE_ALARM``."""
        shape = self.smoothing_bins / 2.0
        tail = FALSE_ALARM / self.frequency_hz.size
        return self.noise_floor * float(stats.gamma.isf(tail, shape, scale=1.0 / shape))


def periodogram(x: np.ndarray, dt: float, taper: str = "nuttall") -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and the tapered periodogram of the linearly detrended 1-D ``x``,
    normalised so that white noise of variance σ² has mean σ² in every bin. ``taper``: a
    scipy window name (``"nuttall"``: sidelobes 93 dB down, main lobe ±4 bins; ``"hann"``: 31
    dB, ±2 bins)."""
    samples = np.asarray(x, dtype=np.float64)
    weights = window(taper, samples.size)
    spectrum = np.fft.rfft(sps.detrend(samples, type="linear") * weights)
    return np.fft.rfftfreq(samples.size, dt), np.abs(spectrum) ** 2 / np.sum(weights**2)


def window(taper: str, n_samples: int) -> np.ndarray:
    """The periodic (DFT-even) taper ``taper`` of ``n_samples`` points the periodograms use."""
    return sps.windows.get_window(taper, n_samples, fftbins=True)


def smoothing_bins(n_bins: int) -> int:
    """m: an odd number of bins, about 1/100 of the spectrum and at least 5."""
    return 2 * max(2, n_bins // 200) + 1


def record_spectrum(x: np.ndarray, dt: float) -> RecordSpectrum:
    """The noise floor and signal band of the 1-D record ``x`` sampled every ``dt`` seconds.

    >>> t = np.arange(4096) * 1e-3
    >>> x = np.sin(2 * np.pi * 10 * t) + 0.1 * np.random.default_rng(0).standard_normal(t.size)
    >>> spectrum = record_spectrum(x, 1e-3)
    >>> round(spectrum.noise_std, 2), 10 <= spectrum.band_hz < 13
    (0.1, True)
    """
    frequency, power = periodogram(x, dt)
    _, sharp = periodogram(x, dt, "hann")
    bins = smoothing_bins(frequency.size)
    smoothed = np.convolve(power, np.ones(bins) / bins, mode="same")
    upper = frequency > frequency[-1] / 2
    least = DYNAMIC_RANGE * float(np.max(smoothed))
    floor = max(float(np.median(power[upper]) / math.log(2)), least)
    band = None
    for _ in range(ROUNDS):
        candidate = RecordSpectrum(frequency, power, smoothed, floor, 0.0, bins, sharp)
        new_band = band_edge(frequency, smoothed, candidate.threshold(), bins)
        above = frequency > new_band + bins * frequency[1]
        if np.count_nonzero(above) < MIN_BINS_ABOVE:
            above = upper
        floor = max(float(np.median(power[above]) / math.log(2)), least)
        if new_band == band:
            break
        band = new_band
    return RecordSpectrum(frequency, power, smoothed, floor, float(band), bins, sharp)


def band_edge(frequency: np.ndarray, smoothed: np.ndarray, threshold: float, bins: int) -> float:
    """The last loud bin (smoothed power above ``threshold``) before a quiet stretch at least
    as wide as the band so far (an octave), scanning up from 0 Hz, less the half-width of the
    running mean (which spreads a line over ``bins`` bins); 0 when nothing is loud."""
    loud = np.flatnonzero(smoothed > threshold)
    last = None
    for index in loud:
        if last is not None and frequency[index] - frequency[last] > max(
            frequency[last], 4 * frequency[1]
        ):
            break
        last = index
    if last is None:
        return 0.0
    return float(frequency[max(last - bins // 2, loud[0])])
