"""Which estimates at the ends of a record to trust: measured, for every linear local method.

A linear method estimates the ends of a record with other weights than its interior (one-sided
kernels, filter start-up transients, a prior). Whether an end sample deserves to be marked
valid is measured here, the same way for every such method, by probing it with sinusoids:

1. The *band*: the frequencies where the method's interior (steady-state) response
   :math:`H_c(f)` is within ``BAND_TOLERANCE`` (5 %) of the ideal :math:`D(f) = (i2\\pi f)^n`,
   from 0 up to the first frequency where it is not. It is where the method claims to work.
2. The *per-sample response* :math:`H_k(f)`: the method is run on :math:`e^{i2\\pi f t}`
   (cosine and sine as two channels) at ``PROBE_FREQUENCIES`` frequencies spread over the
   band; :math:`H_k(f) = \\hat y_k e^{-i2\\pi f t_k}` (linearity).
3. Sample k **passes** when its worst error over the band is at most ``END_ERROR_FACTOR``
   times the interior's worst error over the same band:

   .. math:: \\max_{f} |H_k(f) - D(f)| \\le c \\max_{f} |H_c(f) - D(f)|

   so on any signal within the band an end estimate marked valid is at most about ``c`` times
   as wrong as the method's own interior estimate;
4. and its **noise gain** :math:`\\lVert w_k\\rVert_2` (the RMS of its output for unit white
   noise: the end weights of a one-sided fit or a filter's start-up amplify noise, which a
   sinusoid does not show) is at most ``c`` times the interior's, :math:`\\lVert w_c
   \\rVert_2` (by Parseval from :math:`H_c`, :func:`noise_gain`; on a record too short to
   reach the interior, the larger of that and its middle sample's). The per-sample gain is
   measured with ``NOISE_PROBE`` seeded random-sign channels (relative standard error of
   :math:`\\lVert w_k\\rVert` at most :math:`1/\\sqrt{2 \\cdot 64}` = 9 %; the exact
   gain would take one channel per probe sample, 3 s for a Gaussian process).
   Without it, finite differences kept their one-sided end samples (3.6 times the interior's
   noise for ẋ), Savitzky-Golay up to 10 fit samples an end of ẍ (3.9 times the interior's
   RMS error, paper signal over 1.237 s, 20 seeds) and an oracle-tuned Jacobi (q = 11) every
   ẍ sample (6800 times).

   The error of a linear estimate is its bias and its noise,
   :math:`\\sqrt{b_k^2 + \\sigma^2 \\lVert w_k\\rVert^2}`: with both within ``c``
   times the interior's, so is the whole. Each end is trusted from the first sample after
   which every sample towards the interior passes; the samples before it are marked not valid
   (they keep their estimates), so the valid samples are one unbroken stretch.

Only the first and last ``reach`` samples can differ from the interior (``Method.end_reach``),
so the probe runs on ``min(n, 2 reach + 1)`` samples, whatever the record's length; the result
is cached per (method, length, step).
"""

from __future__ import annotations

import functools

import numpy as np

BAND_TOLERANCE = 0.05
"""Relative error of the interior response that bounds the band the method claims."""

END_ERROR_FACTOR = 2.0
"""How many times the interior's worst in-band error an end sample may have and stay valid."""

PROBE_FREQUENCIES = 24
"""Frequencies probed across the band."""

NOISE_PROBE = 64
"""Channels of the seeded random-sign probe that measures each sample's noise gain (half of
them the other half reversed in time)."""

NOISE_PROBE_SEED = 43
"""Seed of the noise probe (the check is deterministic)."""

_BAND_GRID = np.geomspace(1e-6, 1.0, 600)
"""Fractions of the Nyquist frequency searched for the band's edge (log-spaced, so that long
windows with a narrow band are resolved)."""


def ideal_response(frequency_hz: np.ndarray, order: int) -> np.ndarray:
    """:math:`(i 2\\pi f)^n`: the response of the exact derivative of ``order``."""
    return (2j * np.pi * frequency_hz) ** order


def lowest_band_hz(dt: float) -> float:
    """The first frequency of the band search: a band edge this low means no band at all."""
    return float(_BAND_GRID[0] * (0.5 / dt))


def band_edge_hz(central_response, order: int, dt: float) -> float:
    """Highest frequency up to which ``central_response(f)`` stays within ``BAND_TOLERANCE`` of
    the ideal (relative), found on a log grid from 1e-6 of Nyquist; at least the grid's first
    point (:func:`lowest_band_hz`), also when even there the response misses by more (a method
    that claims no band: its ends are then compared with its interior at that frequency)."""
    frequencies = _BAND_GRID * (0.5 / dt)
    ideal = ideal_response(frequencies, order)
    relative = np.abs(central_response(frequencies) - ideal) / np.abs(ideal)
    failing = np.flatnonzero(~(relative <= BAND_TOLERANCE))
    last = (failing[0] - 1) if failing.size else frequencies.size - 1
    return float(frequencies[max(last, 0)])


def noise_gain(central_response, dt: float, reach_samples: int) -> float:
    """White-noise gain :math:`\\lVert w\\rVert_2` of the interior's weights, from its
    response by Parseval: :math:`\\lVert w\\rVert^2 = 2\\Delta t\\int_0^{f_N}|H_c(f)|^2 df`,
    by the rectangle rule on M equally spaced frequencies over a period, which is exact for
    weights spanning fewer than M samples (M > 4 ``reach_samples``, at least 4096)."""
    half = max(2048, 2 * int(reach_samples) + 64)
    frequencies = np.arange(half + 1) * (0.5 / dt / half)
    power = np.abs(central_response(frequencies)) ** 2
    total = power[0] + power[-1] + 2 * np.sum(power[1:-1])
    return float(np.sqrt(total / (2 * half)))


def trusted_samples(
    method,
    n_samples: int,
    dt: float,
    orders: tuple[int, ...],
    factor: float = END_ERROR_FACTOR,
    short_record_middle: bool = False,
    skip: int = 0,
) -> dict:
    """Boolean masks (one per order) of the samples whose estimate is trusted (see the module
    docstring). ``method`` is linear and declares ``end_reach(dt)``; cached.

    ``skip``: the first and last ``skip`` samples are not read (:func:`unread_end_samples`):
    the probe is estimated by ``method._estimate_skipping_ends``, which may leave them NaN
    (they then come back not trusted); every other sample's mask is the full check's, bit for
    bit (an end is trusted from just after its last failing sample, and failures nearer the
    end than the samples read change none of theirs).

    ``factor`` is the criterion's c. With ``short_record_middle``, a record shorter than
    ``2 reach + 1`` samples (where no sample reaches the interior response) is judged against
    its own middle instead: the reference error is the larger of the interior's and the
    middle sample's, so the part of the record as good as its middle stays valid. It is for
    settings chosen by the data (``gaussian_process_ml``, whose likelihood picks a length
    scale near the span of a smooth short record); given settings are refused there instead.
    """
    return _trusted(
        method,
        int(n_samples),
        float(dt),
        tuple(orders),
        float(factor),
        bool(short_record_middle),
        int(skip),
    )


@functools.lru_cache(maxsize=512)
def _trusted(
    method,
    n_samples: int,
    dt: float,
    orders: tuple[int, ...],
    factor: float,
    short_record_middle: bool,
    skip: int = 0,
) -> dict:
    reach = method.end_reach(dt)
    length = probe_length(method, n_samples, dt)
    edges = {
        order: band_edge_hz(lambda f, o=order: method._response(f, dt, o), order, dt)
        for order in orders
    }
    masks = {}
    time = np.arange(length) * dt
    signs = np.random.default_rng(NOISE_PROBE_SEED).choice([-1.0, 1.0], (length, NOISE_PROBE // 2))
    # with each channel reversed in time too: a method symmetric under time reversal gets the
    # same gains at both ends, hence symmetric masks
    noise_probe = np.concatenate([signs, signs[::-1]], axis=1)

    def estimate(probe, orders):
        if skip:
            return method._estimate_skipping_ends(probe, dt, orders, skip)[0]
        return method._estimate(probe, dt, orders)[0]

    noise_values = estimate(noise_probe, orders)
    for order in orders:
        frequencies = np.linspace(1.0 / PROBE_FREQUENCIES, 1.0, PROBE_FREQUENCIES) * edges[order]
        # e^{-iφ}: its real part and minus its imaginary part are the cosine and sine probes
        # (the same values as np.cos and np.sin: one transcendental evaluation, not two)
        rotation = np.exp(-1j * (2 * np.pi * np.outer(time, frequencies)))
        probe = np.concatenate([rotation.real, -rotation.imag], axis=1)
        values = estimate(probe, (order,))
        output = values[order][:, :PROBE_FREQUENCIES] + 1j * values[order][:, PROBE_FREQUENCIES:]
        response = output * rotation
        ideal = ideal_response(frequencies, order)
        with np.errstate(invalid="ignore"):
            error = np.max(np.abs(response - ideal[None, :]), axis=1)
        interior = np.max(np.abs(method._response(frequencies, dt, order) - ideal))
        if short_record_middle and length < 2 * reach + 1 and np.isfinite(error[length // 2]):
            interior = max(interior, float(error[length // 2]))
        floor = 1e-9 * np.max(np.abs(ideal))
        good = error <= factor * interior + floor  # NaN (masked) compares False
        with np.errstate(invalid="ignore"):
            gain = np.sqrt(np.mean(noise_values[order] ** 2, axis=1))
        interior_gain = noise_gain(lambda f, o=order: method._response(f, dt, o), dt, length)
        if length < 2 * reach + 1 and np.isfinite(gain[length // 2]):
            # no sample of a short record reaches the interior's gain: its middle is the
            # reference (the noise a record of this length cannot average away)
            interior_gain = max(interior_gain, float(gain[length // 2]))
        good &= gain <= factor * interior_gain * (1 + 1e-9)  # NaN (masked) compares False
        ends = min(reach, length // 2)
        mask = np.ones(n_samples, dtype=bool)
        mask[:ends] = _from_last_failure(good[:ends])
        mask[n_samples - ends :] = _from_last_failure(good[length - ends :][::-1])[::-1]
        if length == n_samples and length % 2 and not good[length // 2]:
            mask[length // 2] = False
        masks[order] = mask
    return masks


def probe_length(method, n_samples: int, dt: float) -> int:
    """Samples the ends check runs ``method`` on: ``2 reach + 1`` (or the method's least
    record, if longer), at most the record's ``n_samples``."""
    return min(n_samples, max(2 * method.end_reach(dt) + 1, method.min_samples(dt)))


def check_reaches(method, n_samples: int, dt: float, first: int, last: int) -> bool:
    """Whether the ends check of ``method`` (a linear method with a reach) can mask any of the
    samples ``first`` to ``last`` of a record of ``n_samples``: on a record longer than the
    probe (:func:`probe_length`) it masks only the first and last ``end_reach(dt)`` samples;
    on one no longer, any sample (the middle one included)."""
    reach = method.end_reach(dt)
    if probe_length(method, n_samples, dt) >= n_samples:
        return True
    return not reach <= first <= last < n_samples - reach


def unread_end_samples(method, n_samples: int, dt: float, first: int, last: int) -> int:
    """How many samples at each end of a record of ``n_samples`` a caller reading samples
    ``first`` to ``last`` leaves unread, for ``method``'s ends check and end treatment to skip
    (``Method.estimate_within``): ``min(first, n - 1 - last)``, at most ``end_reach(dt)``;
    0 on a record no longer than the probe (:func:`probe_length`), where the check judges the
    middle sample too."""
    if probe_length(method, n_samples, dt) >= n_samples:
        return 0
    return max(0, min(int(first), n_samples - 1 - int(last), method.end_reach(dt)))


def _from_last_failure(passes: np.ndarray) -> np.ndarray:
    """True from just after the last failing sample on: an end is trusted from the first sample
    after which every sample towards the interior passes (no holes in the mask)."""
    failing = np.flatnonzero(~passes)
    trusted = np.ones(passes.size, dtype=bool)
    if failing.size:
        trusted[: failing[-1] + 1] = False
    return trusted


def trusted_times(
    method, times: np.ndarray, step: float, orders: tuple[int, ...], **criterion
) -> dict[int, np.ndarray]:
    """Which of the irregular ``times`` to trust, per order, for a method whose end treatment
    reaches a fixed span of time: the trusted end samples found by :func:`trusted_samples` on
    the uniform record of step ``step`` and the same span, as times (the first and last
    trusted grid times), then every measured time between them (none, on a record too short
    for any). ``criterion``: :func:`trusted_samples`' ``factor`` and ``short_record_middle``."""
    n_grid = round((times[-1] - times[0]) / step) + 1
    trusted = trusted_samples(method, n_grid, step, orders, **criterion)
    result = {}
    for order in orders:
        kept = np.flatnonzero(trusted[order])
        if not kept.size:
            result[order] = np.zeros(times.size, dtype=bool)
            continue
        start = times[0] + kept[0] * step - 1e-9 * step
        stop = times[0] + kept[-1] * step + 1e-9 * step
        result[order] = (times >= start) & (times <= stop)
    return result
