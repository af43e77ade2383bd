r"""Surrogate records: records like the user's, whose truth is known.

A record alone cannot score a differentiator (its truth is unknown), but its spectrum says
what kind of signal and noise it holds (:mod:`diffbench.bench.core.spectrum`). A *surrogate* is a
record drawn from that description: the record's own sinusoids, a continuum with the rest of
its signal spectrum and random phases, and fresh noise with its noise spectrum,

.. math::
    s(t) = \sum_l A_l \cos(2\pi f_l t + \phi_l)
         + \sum_k a_k \cos(2\pi f_k t + \varphi_k), \qquad
    a_k = \sqrt{2 w_k \hat S_k / N},\quad \varphi_k \sim U(0, 2\pi).

The *lines* (peaks standing far above their neighbourhood, :func:`spectral_lines`) are
fitted to the record by least squares, frequency, amplitude and phase (:func:`fit_lines`): a
surrogate keeps them as they are in the record, so that what a method does with this
record's deterministic part (at its ends too) is what it is tuned on. The continuum
:math:`\hat S_k = \max(\hat P_k - \nu, 0)` comes from the multitaper spectrum
:math:`\hat P_k` of the whole record less its lines (:func:`continuum_spectrum`), below the
band that spectrum shows above its noise and its own leakage, and is 0 above it
(:math:`w_k = 2`, or 1 at 0 Hz and Nyquist, so that its variance is
:math:`\frac1N \sum_k w_k \hat S_k`); the noise is Gaussian with the spectrum :math:`\nu`
below the band and, above it, the periodogram of the record less every fitted line, plus the
disturbances (lines more than an octave above the band) as fitted to the record: a
noise-free record's surrogates are noise-free too, not given the 93 dB taper leakage of its
lines as white noise. The derivatives of the signal are exact (the sums differentiated term
by term), so any method, linear or not, can be scored and tuned on surrogates with the
oracle criterion: data-only tuning for every method.

The continuum is drawn on a grid ``LENGTH_FACTOR`` times as fine in frequency (the
spectrum interpolated onto it) and taken on the record's span, so that a surrogate is not
periodic over the record: a method that assumes it is (an FFT) pays at the ends as on data.

References: J. Theiler et al., "Testing for nonlinearity in time series: the method of
surrogate data", Physica D 58 (1992) 77-94 (random-phase surrogates); D. J. Thomson,
"Spectrum estimation and harmonic analysis", Proc. IEEE 70 (1982) 1055-1096 (multitaper
estimate; lines removed before the continuum is estimated).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats
from scipy import signal as sps

from diffbench import signals
from diffbench.bench.core.spectrum import (
    DYNAMIC_RANGE,
    FALSE_ALARM,
    RecordSpectrum,
    band_edge,
    periodogram,
    window,
)

LENGTH_FACTOR = 3
"""The surrogate's frequency grid is this many times finer than the record's."""

LINE_RATIO = 30.0
"""A peak of the Hann periodogram this many times above its neighbourhood is a sinusoid (a
line), not part of a continuous spectrum: the surrogate keeps it as fitted to the record."""

LINE_NEIGHBOURS = 8
"""Bins each side, beyond the main lobe, whose median a line must stand above."""

END_FRACTION = 0.05
"""The samples within this fraction of the record of either end are left out of a surrogate's
``interior`` (a method may mask a few end samples and still be scored)."""

TIME_BANDWIDTH = 4.0
"""NW of the continuum's multitaper estimate: its resolution is ±NW/T Hz (T: the record's
span). Its five tapers weigh the record 0.08 of its mean at 5 % from an end, 0.45 at 10 %,
1.40 in the middle, so a chirp's last frequencies are under-represented. NW = 6 (nine
tapers: 0.27, 0.99, 1.23) weighs the ends more, but its wider spread blurred steep spectra:
the limit study's data-only tunings lost a third to a half of their efficiency on the
band-limited signal and on Matérn 7/2 at noise 0.01, so it stays at 4."""

SHORT_RECORD_CYCLES = 2.0
"""A record spanning fewer cycles of its band than this (a band of 0 Hz: none) is short: its
signal shows as a trend, not as a spectrum, and the surrogates take the record's polynomial
trend (:func:`record_trend`), its coefficients drawn as the noise leaves them possible
(:func:`trend_draws`), with its exact derivatives."""

MAX_TREND_DEGREE = 6
"""The highest degree :func:`record_trend` considers."""

MIN_TREND_DEGREE = 3
"""The lowest: a cubic, so that ẋ and ẍ of the surrogates vary with what the noise leaves
possible (:func:`trend_draws`), not fixed at the zero curvature of a line."""

MIN_CONCENTRATION = 0.999
"""The Slepian tapers used keep at least this fraction of their energy within ±NW/T: at
NW = 4, five of the seven, so that less than 1e-3 of a strong component leaks elsewhere."""


def surrogate_records(
    spectrum: RecordSpectrum,
    x: np.ndarray,
    dt: float,
    count: int,
    seed: int = 0,
    scored: np.ndarray | None = None,
) -> list[signals.Realisation]:
    """``count`` surrogate realisations of the record ``x`` (uniform step ``dt``, its
    spectrum ``spectrum``), seeded by ``seed``. ``scored``: the samples whose derivatives are
    wanted (the surrogates' ``interior``; default all but ``END_FRACTION`` of the record at
    either end). The first batch of
    :func:`surrogate_model`'s draws."""
    return surrogate_model(spectrum, x, dt, scored).draw(count, seed)


@dataclass(frozen=True, eq=False)
class SurrogateModel:
    """What a record's surrogates share (see the module docstring), fitted once by
    :func:`surrogate_model`: the time stamps and scored samples, the record's signal lines
    and their first two derivatives (``line_terms``), its disturbances, the continuum's
    amplitudes on the ``LENGTH_FACTOR`` times finer grid ``fine_hz``, the noise's power per
    rfft bin of the record, and the short record's polynomial trend (``None`` otherwise)
    with the noise variance its coefficients are drawn with."""

    t: np.ndarray
    dt: float
    interior: np.ndarray
    line_terms: tuple
    disturbance: np.ndarray
    fine_hz: np.ndarray
    amplitude: np.ndarray
    noise_power: np.ndarray
    trend: np.polynomial.Polynomial | None
    floor: float

    def draw(self, count: int, seed: int = 0, batch: int = 0) -> list[signals.Realisation]:
        """``count`` surrogate realisations, seeded by ``seed`` and ``batch``: each batch is
        its own stream, so further batches add surrogates without changing a first batch's
        (batch 0 is :func:`surrogate_records`'s)."""
        rng = np.random.default_rng([7, seed] if batch == 0 else [7, seed, batch])
        n_samples = self.t.size
        long = LENGTH_FACTOR * n_samples
        omega = 2 * np.pi * self.fine_hz
        t, trend = self.t, self.trend
        if trend is not None:
            trends = trend_draws(trend, t, self.floor, count, rng)
        realisations = []
        for index in range(count):
            # the continuum by inverse FFT on the long grid (its derivatives: (iω)^n times
            # each term), a window of the record's length taken at random
            phase = np.exp(1j * rng.uniform(0.0, 2 * np.pi, self.fine_hz.size))
            start = int(rng.integers(0, long - n_samples + 1))
            derivatives = []
            for order in range(3):
                terms = (long / 2) * self.amplitude * phase * (1j * omega) ** order
                continuum = np.fft.irfft(terms, long)[start : start + n_samples]
                derivatives.append(continuum + self.line_terms[order])
            if trend is not None:
                derivatives = [
                    d + trends[index].deriv(order)(t) for order, d in enumerate(derivatives)
                ]
            truth = signals.Truth(t=t, derivatives=tuple(derivatives))
            noise = _coloured_noise(self.noise_power, n_samples, rng) + self.disturbance
            realisations.append(
                signals.Realisation(
                    t=t,
                    dt_s=self.dt,
                    x=truth[0] + noise,
                    truth=truth,
                    noise=noise,
                    seed=seed * 1000 + index,
                    interior=self.interior,
                )
            )
        return realisations


def surrogate_model(
    spectrum: RecordSpectrum, x: np.ndarray, dt: float, scored: np.ndarray | None = None
) -> SurrogateModel:
    """The :class:`SurrogateModel` of the record ``x`` (uniform step ``dt``, its spectrum
    ``spectrum``); ``scored`` as for :func:`surrogate_records`."""
    x = np.asarray(x, dtype=np.float64)
    n_samples = x.size
    if spectrum.frequency_hz.size != n_samples // 2 + 1:
        raise ValueError(
            f"`spectrum` is that of a record of {2 * (spectrum.frequency_hz.size - 1)} or so "
            f"samples, not of {n_samples}"
        )
    interior = default_scored(n_samples) if scored is None else np.asarray(scored, dtype=bool)
    if interior.shape != (n_samples,) or interior.sum() < 16:
        raise ValueError(
            f"`scored` must be a boolean mask of {n_samples} samples with at least 16 set"
        )
    long = LENGTH_FACTOR * n_samples
    fine = np.fft.rfftfreq(long, dt)
    # every line is fitted (a disturbance's too: what it leaves would bias the signal's) and
    # the signal's kept; the noise above the band has the spectrum of the record less them
    # (disturbances in it, not the reach of the signal lines' taper leakage)
    line_hz, line_amplitude, line_phase, rest = fit_lines(
        x, dt, spectral_lines(spectrum, n_samples, up_to_hz=spectrum.frequency_hz[-1])[0]
    )
    line_hz, line_growth, line_amplitude, line_phase, rest, grown = fit_line_growth(
        x, dt, line_hz, line_amplitude, line_phase, rest
    )
    # frequency, amplitude, phase (and growth, where fitted) per line; constant, slope
    fitted = (4 if grown else 3) * line_hz.size + 2
    # a line more than an octave above the band is a disturbance (the band's own rule); one
    # just above the band's edge (its fitted frequency past the edge bin) is the signal's
    signal = line_hz <= 2 * spectrum.band_hz
    rate = line_growth + 2j * np.pi * line_hz
    t = np.arange(n_samples) * dt
    waves = np.exp(np.outer(t, rate) + 1j * line_phase)  # the record's own lines
    line_terms = [
        np.real(rate[signal] ** order * waves[:, signal]) @ line_amplitude[signal]
        for order in range(3)
    ]
    # a disturbance is kept as fitted too, in the noise: the noise above the band is the rest
    # (what no line explains), not the lines' taper leakage, 93 dB under a line, which gave a
    # noise-free record's surrogates white noise the record does not have
    disturbance = np.real(waves[:, ~signal]) @ line_amplitude[~signal]
    above_power = periodogram(rest, dt)[1]
    trend = None
    if spectrum.band_hz * n_samples * dt < SHORT_RECORD_CYCLES:
        # a record shorter than its signal's cycles: its signal is its trend (see below)
        trend = record_trend(t, rest, min_degree=min(MIN_TREND_DEGREE, n_samples // 4))
        rest = rest - trend(t)
        fitted += trend.degree() + 1 - 2
    # over the whole record, not only the scored samples: where those are its middle third
    # (the limit study) three times the samples, a third of the spread W and less variance;
    # with the leakage rule of the edge, the surrogate-tuned settings' MSE on the limit
    # study's records fell to 0.76 of what it was (geometric mean; 0.22 to 0.5 for the
    # spectral method on the band-limited signal, whose edge stood at 32 Hz for 20), though
    # up to 2.1 times higher on thrice-integrated noise at 0.1, whose red spectrum leaks more
    # over a longer record
    everywhere = np.ones(n_samples, dtype=bool)
    rest_power, continuum_hz, floor = continuum_spectrum(rest, dt, spectrum, everywhere, fitted)
    signal_power = np.where(
        spectrum.frequency_hz <= continuum_hz, np.maximum(rest_power - floor, 0.0), 0.0
    )
    noise_power = np.where(
        spectrum.frequency_hz <= max(continuum_hz, spectrum.band_hz),
        floor,
        above_power,
    )
    # on the finer grid each bin holds 1/LENGTH_FACTOR of the variance of the record's bin
    fine_signal = np.interp(fine, spectrum.frequency_hz, signal_power) / LENGTH_FACTOR
    fine_signal[0] = fine_signal[-1] = 0.0  # no constant (detrended), no Nyquist term
    amplitude = 2 * np.sqrt(fine_signal / n_samples)  # a_k = sqrt(2 w_k S_k / N), w_k = 2
    return SurrogateModel(
        t=t,
        dt=dt,
        interior=interior,
        line_terms=tuple(line_terms),
        disturbance=disturbance,
        fine_hz=fine,
        amplitude=amplitude,
        noise_power=noise_power,
        trend=trend,
        floor=floor,
    )


def spectral_lines(
    spectrum: RecordSpectrum, n_samples: int, up_to_hz: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sinusoids in the band (or up to ``up_to_hz``: disturbances too): the peaks of the Hann
    periodogram that stand ``LINE_RATIO`` times above the noise floor and the median of the
    quieter side of their neighbourhood (``LINE_NEIGHBOURS`` bins each side beyond the main
    lobe), their frequency refined by a parabola through the log power of the peak bin and its
    neighbours, their amplitude from the peak power corrected for the taper's gain off the
    bin centre.

    Returns the frequencies (Hz), amplitudes, and a mask of the bins their main lobes cover
    (the surrogates no longer use it: they fit the lines and measure the continuum on the
    record less them, :func:`fit_lines`).
    """
    power, frequency = spectrum.sharp_power, spectrum.frequency_hz
    taper = window("hann", n_samples)  # the sharp periodogram's taper
    coherent = np.sum(taper) ** 2 / np.sum(taper**2)
    lobes = np.zeros(power.size, dtype=bool)
    found_hz, found_amplitude = [], []
    top = spectrum.band_hz if up_to_hz is None else up_to_hz
    last = np.searchsorted(frequency, top, side="right") - 1
    for k in range(2, min(last + 1, power.size - 2)):
        if not (power[k] >= power[k - 1] and power[k] > power[k + 1]):
            continue
        sides = [
            power[max(0, k - 2 - LINE_NEIGHBOURS) : max(0, k - 2)],
            power[k + 3 : k + 3 + LINE_NEIGHBOURS],
        ]
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


def record_trend(t: np.ndarray, x: np.ndarray, min_degree: int = 0) -> np.polynomial.Polynomial:
    r"""The polynomial trend of the record ``x`` at times ``t``: the least-squares polynomial
    (in the scaled time of ``numpy.polynomial.Polynomial.fit``) of the degree d in
    ``min_degree``..``MAX_TREND_DEGREE`` (and at most n/4) of least Bayesian information
    criterion,

    .. math:: \mathrm{BIC}_d = n \ln(\mathrm{RSS}_d / n) + (d + 1) \ln n

    (G. Schwarz, "Estimating the dimension of a model", Ann. Statist. 6 (1978) 461-464): the
    degree beyond which the residual is noise. A residual below rounding (16 eps max|x| a
    sample) counts as that, so that exact data keep their degree."""
    n = x.size
    # a residual at rounding level is no residual: exact data keep their own degree
    rounding = n * (16 * np.finfo(float).eps * float(np.max(np.abs(x)))) ** 2
    best, best_bic = None, math.inf
    for degree in range(min(min_degree, n // 4), min(MAX_TREND_DEGREE, n // 4) + 1):
        trend = np.polynomial.Polynomial.fit(t, x, degree)
        residual = max(float(np.sum((x - trend(t)) ** 2)), rounding, np.finfo(float).tiny)
        bic = n * math.log(residual / n) + (degree + 1) * math.log(n)
        if bic < best_bic:
            best, best_bic = trend, bic
    return best


def trend_draws(
    trend: np.polynomial.Polynomial,
    t: np.ndarray,
    noise_variance: float,
    count: int,
    rng: np.random.Generator,
) -> list[np.polynomial.Polynomial]:
    r"""``count`` trends as the record's noise leaves them possible: the least-squares fit
    ``trend`` at times ``t`` with its coefficients drawn from their sampling distribution,
    :math:`c \sim \mathcal N(\hat c, \sigma^2 (V^\top V)^{-1})` (V the Vandermonde matrix
    of the fit's scaled times, σ² ``noise_variance``). A curvature below what the noise
    resolves then varies between the surrogates as much as it may in the record: a method
    that returns ẍ = 0 is not scored as exact on a short record whose curvature the noise
    hides (fixed at the fit, a line fitted to 16 samples gave every surrogate ẍ = 0)."""
    scaled = trend.mapparms()[0] + trend.mapparms()[1] * t
    vandermonde = np.vander(scaled, trend.degree() + 1, increasing=True)
    covariance = noise_variance * np.linalg.inv(vandermonde.T @ vandermonde)
    draws = rng.multivariate_normal(trend.coef, covariance, size=count, method="cholesky")
    return [np.polynomial.Polynomial(c, domain=trend.domain, window=trend.window) for c in draws]


def default_scored(n_samples: int) -> np.ndarray:
    """All but ``END_FRACTION`` of ``n_samples`` at either end."""
    scored = np.zeros(n_samples, dtype=bool)
    margin = int(END_FRACTION * n_samples)
    scored[margin : n_samples - margin] = True
    return scored


def continuum_spectrum(
    rest: np.ndarray, dt: float, spectrum: RecordSpectrum, scored: np.ndarray, fitted: int = 0
) -> tuple[np.ndarray, float, float]:
    r"""The spectrum of the record less its lines, ``rest``, over the stretch ``scored``
    spans (the surrogates give all of it), the band it occupies and the white-noise floor
    under it.

    A multitaper estimate (Thomson 1982) on the stretch of the linearly detrended ``rest``
    from the first to the last ``scored`` sample:

    .. math:: \hat P_k = \frac1K \sum_{j<K} \Big|\sum_i v^{(j)}_i r_i e^{-2\pi i ik/M}\Big|^2,

    with the Slepian tapers :math:`v^{(j)}` of time-bandwidth ``TIME_BANDWIDTH`` (NW) whose
    concentration within ±W = NW/T Hz is at least ``MIN_CONCENTRATION``. Unlike one tapered
    periodogram, which hardly sees the first and last fifths of the record, the tapers
    together weigh more of the stretch, though its outer tenths still little (see
    ``TIME_BANDWIDTH``). The band ends at the last bin standing
    above what noise and the estimate's own leakage reach together (:func:`taper_leakage`
    added to ν; a gamma variable of shape K: ``FALSE_ALARM`` per record) before an octave of
    quiet, and within an octave of the record's band (a line
    far above it, a disturbance, is noise); 0 Hz when nothing stands out (a record of lines
    and noise). The tapers spread each component over ±W, so the band may end up to W past
    the signal's last frequency, at a falling level: taking W off the edge instead cut the
    upper half of a damped oscillation's peak, or a line left in the continuum, out of the
    surrogates (their settings then smoothed 3 to 6 times too much). The floor ν: the median
    of the Hann periodogram of ``rest`` above that band over ln 2 (lines removed, every bin
    above the continuum is noise: a short record's floor is no longer taken from the few bins
    above its band), starting from the record's, times N/(N − p) when ``fitted`` = p
    parameters were fitted to the record to leave ``rest`` (they took p/N of the noise's
    variance with them).

    Returns :math:`\hat P` on the record's rfft grid (interpolated), the band edge in Hz and
    ν.
    """
    rest = np.asarray(rest, dtype=np.float64)
    where = np.flatnonzero(scored)
    stretch = sps.detrend(rest[where[0] : where[-1] + 1])
    tapers, concentration = sps.windows.dpss(
        stretch.size,
        TIME_BANDWIDTH,
        int(2 * TIME_BANDWIDTH) - 1,
        sym=False,
        return_ratios=True,
    )
    tapers = tapers[concentration >= MIN_CONCENTRATION]
    power = np.mean(np.abs(np.fft.rfft(tapers * stretch, axis=1)) ** 2, axis=0)
    frequency = np.fft.rfftfreq(stretch.size, dt)
    count = tapers.shape[0]
    quantile = float(stats.gamma.isf(FALSE_ALARM / frequency.size, count, scale=1.0 / count))
    # an octave of quiet above the record's band: what lies beyond is a disturbance (noise)
    below = frequency <= 2 * spectrum.band_hz
    rest_frequency, rest_power = periodogram(rest, dt, "hann")  # every line removed
    floor = spectrum.noise_floor
    least = DYNAMIC_RANGE * float(np.max(rest_power))  # the taper's reach, lines removed
    leakage = taper_leakage(power, tapers)[below]
    for _ in range(2):  # the edge under the record's floor, the floor above that edge, again
        edge = band_edge(frequency[below], power[below], quantile * (floor + leakage), 1)
        quiet = rest_power[(rest_frequency > edge) & (rest_frequency > 2 * rest_frequency[1])]
        if quiet.size >= 8:
            floor = float(np.median(quiet) / np.log(2)) * rest.size / (rest.size - fitted)
            floor = max(floor, least)
    return np.interp(spectrum.frequency_hz, frequency, power), edge, floor


def taper_leakage(power: np.ndarray, tapers: np.ndarray) -> np.ndarray:
    r"""What the multitaper estimate ``power`` (on the rfft grid of the ``tapers``' length
    m) holds at each frequency from components farther than NW + 1 bins away: their reach
    through the tapers' mean spectral window :math:`H` outside its main lobe,

    .. math:: L_f = \frac1m \sum_{|f - g| > NW + 1} \hat P_g\, H_{f - g},

    since :math:`E \hat P_f = \frac1m \sum_g S_g H_{f - g}` (:math:`\sum_f H_f = m` for
    tapers of unit energy; the estimate stands in for the spectrum S). Above a strong band
    this is the estimate's own leakage, not signal: with a thousandth of each component's
    energy outside ±W, a band a hundred thousand times above the noise floor reaches far
    above its edge (D. B. Percival, A. T. Walden, *Spectral Analysis for Physical
    Applications*, Cambridge 1993, sec. 7.1: the spectral window of a multitaper
    estimate)."""
    m = tapers.shape[1]
    window = np.mean(np.abs(np.fft.fft(tapers, axis=1)) ** 2, axis=0)  # H at each offset
    lobe = int(np.ceil(TIME_BANDWIDTH)) + 1  # the main lobe's bins (W = NW bins) and one
    window[:lobe] = 0.0
    window[m - lobe + 1 :] = 0.0
    two_sided = np.concatenate([power, power[1 : m - power.size + 1][::-1]])
    reach = np.real(np.fft.ifft(np.fft.fft(two_sided) * np.fft.fft(window))) / m
    return np.maximum(reach[: power.size], 0.0)


def fit_lines(
    x: np.ndarray, dt: float, frequency_hz: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    r"""The sinusoids near ``frequency_hz`` fitted to the record ``x`` (step ``dt``) by
    nonlinear least squares, with a constant and a slope:

    .. math:: x_j \approx c_0 + c_1 t_j + \sum_l A_l \cos(2\pi f_l t_j + \phi_l),

    each :math:`f_l` kept within one periodogram bin of its starting value (the amplitudes and
    phases are linear given the frequencies: solved exactly for each trial, the frequencies by
    ``scipy.optimize.least_squares``). Returns the frequencies (Hz), amplitudes, phases (rad)
    and the record less the fitted sinusoids (its constant and slope kept)."""
    x = np.asarray(x, dtype=np.float64)
    start = np.asarray(frequency_hz, dtype=np.float64)
    if start.size == 0:
        return start, start.copy(), start.copy(), x.copy()
    t = np.arange(x.size) * dt
    centred = t - t.mean()

    def fitted(frequency):
        argument = np.outer(t, 2 * np.pi * frequency)
        design = np.column_stack([np.ones_like(t), centred, np.cos(argument), np.sin(argument)])
        coefficients, *_ = np.linalg.lstsq(design, x, rcond=None)
        return design, coefficients

    def residual(frequency):
        design, coefficients = fitted(frequency)
        return design @ coefficients - x

    resolution = 1.0 / (x.size * dt)
    solution = optimize.least_squares(
        residual,
        start,
        bounds=(start - resolution, start + resolution),
        x_scale=resolution,
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
    )
    design, coefficients = fitted(solution.x)
    cosine, sine = np.split(coefficients[2:], 2)
    # A cos(ωt + φ) = A cos φ cos ωt − A sin φ sin ωt
    amplitude, phase = np.hypot(cosine, sine), np.arctan2(-sine, cosine)
    return solution.x, amplitude, phase, x - design[:, 2:] @ coefficients[2:]


GROWTH_SPAN = 12.0
"""The most a fitted line's amplitude may grow or decay over the record: by :math:`e^{12}`
(its growth rate at most 12/T in magnitude)."""


def fit_line_growth(x, dt, line_hz, amplitude, phase, rest):
    r"""The lines ``line_hz`` (as :func:`fit_lines` fitted them, with their ``amplitude``,
    ``phase`` and the record less them, ``rest``) refitted with an exponential envelope each,

    .. math:: x_j \approx c_0 + c_1 t_j + \sum_l A_l e^{\kappa_l t_j}
        \cos(2\pi f_l t_j + \phi_l),

    the frequencies and growth rates :math:`\kappa_l` by nonlinear least squares (the
    amplitudes and phases linear given them), kept when the Bayesian information criterion
    says the record holds them (:math:`n \ln(\mathrm{RSS}/n) + k \ln n`, one more parameter
    per line): a damped oscillation is then a line that decays as the record's does, not a
    steady line and a continuum that cancels it where the record has gone quiet. Returns the
    frequencies (Hz), growth rates (1/s; zeros for steady lines), amplitudes and phases at
    t = 0, the record less the lines, and whether the growth was kept.
    """
    line_hz = np.asarray(line_hz, dtype=np.float64)
    steady = (line_hz, np.zeros(line_hz.size), amplitude, phase, rest, False)
    if line_hz.size == 0:
        return steady
    n = x.size
    t = np.arange(n) * dt
    centred = t - t.mean()
    span = n * dt
    resolution = 1.0 / span

    def design_of(parameters):
        frequency, growth = np.split(parameters, 2)
        envelope = np.exp(np.outer(t, growth))
        argument = np.outer(t, 2 * np.pi * frequency)
        return np.column_stack(
            [np.ones_like(t), centred, envelope * np.cos(argument), envelope * np.sin(argument)]
        )

    def residual(parameters):
        design = design_of(parameters)
        coefficients, *_ = np.linalg.lstsq(design, x, rcond=None)
        return design @ coefficients - x

    most = GROWTH_SPAN / span
    start = np.concatenate([line_hz, np.zeros(line_hz.size)])
    solution = optimize.least_squares(
        residual,
        start,
        bounds=(
            np.concatenate([line_hz - resolution, np.full(line_hz.size, -most)]),
            np.concatenate([line_hz + resolution, np.full(line_hz.size, most)]),
        ),
        x_scale=np.concatenate([np.full(line_hz.size, resolution), np.full(line_hz.size, most)]),
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
    )
    steady_rss = float(np.sum((rest - np.polyval(np.polyfit(centred, rest, 1), centred)) ** 2))
    grown_rss = float(np.sum(solution.fun**2))
    tiny = np.finfo(float).tiny
    if n * math.log(max(grown_rss, tiny) / max(steady_rss, tiny)) + line_hz.size * math.log(n) >= 0:
        return steady
    design = design_of(solution.x)
    coefficients, *_ = np.linalg.lstsq(design, x, rcond=None)
    cosine, sine = np.split(coefficients[2:], 2)
    frequency, growth = np.split(solution.x, 2)
    return (
        frequency,
        growth,
        np.hypot(cosine, sine),
        np.arctan2(-sine, cosine),
        x - design[:, 2:] @ coefficients[2:],
        True,
    )


def _coloured_noise(power: np.ndarray, n_samples: int, rng: np.random.Generator) -> np.ndarray:
    """Gaussian noise whose periodogram has mean ``power`` (one value per rfft bin)."""
    coefficients = rng.standard_normal(power.size) + 1j * rng.standard_normal(power.size)
    coefficients *= np.sqrt(power * n_samples / 2)
    coefficients[0] = coefficients[0].real * np.sqrt(2)
    if n_samples % 2 == 0:
        coefficients[-1] = coefficients[-1].real * np.sqrt(2)
    return np.fft.irfft(coefficients, n_samples)
