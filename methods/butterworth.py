"""Zero-phase Butterworth low-pass filtering followed by central Euler differences: the
paper's baseline."""

from __future__ import annotations

import functools

import numpy as np
from scipy import signal as sps

from diffbench.methods._fir import fir_response
from diffbench.methods._local_poly import apply_fir_with_ends, end_evaluators
from diffbench.methods._registry import Method, Preset, param, register
from diffbench.methods._validation import check_frequency
from diffbench.methods.finite_difference import central_difference_weights

MIN_CUTOFF_FRACTION = 1e-3
"""Lowest ``cutoff_hz`` as a fraction of the Nyquist frequency. Below it, rounding in the
second-order sections grows like 1e-16/w² (w the cutoff over Nyquist): measured over orders
1-20, the gain at 0 Hz and a filtered constant are off by up to 3e-10 at w = 1e-3, 1e-9 at
3e-4, 1e-5 to 4e-1 at 1e-6, and at 1e-9 ``sosfiltfilt`` raises a singular-matrix error."""


MAX_CUTOFF_FRACTION = 1 - 1e-9
"""Highest ``cutoff_hz`` as a fraction of the Nyquist frequency: the design prewarps the
cutoff to tan(pi w / 2), and order 20 overflows (OverflowError in scipy's lp2lp_zpk) within
about 1e-15 of Nyquist; up to 1 - 1e-9 every order works."""


@functools.lru_cache(maxsize=256)
def _butter_sos(order: int, cutoff_hz: float, dt: float) -> np.ndarray:
    # scipy's zpk2sos takes about a millisecond: cached (callers get copies)
    return sps.butter(order, cutoff_hz, btype="low", output="sos", fs=1.0 / dt)


@register("butterworth")
class ButterworthEuler(Method):
    """Forward-backward Butterworth filter on the position, then central Euler differences.

    .. math::
        \\tilde x = \\mathrm{filtfilt}(B_{N,f_c}, x), \\quad
        \\hat{\\dot x}_k = \\frac{\\tilde x_{k+1} - \\tilde x_{k-1}}{2\\Delta t}, \\quad
        \\hat{\\ddot x}_k = \\frac{\\tilde x_{k+1} - 2\\tilde x_k + \\tilde x_{k-1}}{\\Delta t^2}

    :math:`B_{N,f_c}` is the digital Butterworth low-pass of order :math:`N` and cutoff
    :math:`f_c` (``scipy.signal.butter(..., output="sos", fs=1/dt)``), run forward and backward
    by ``scipy.signal.sosfiltfilt``. The record is padded at each end by its odd extension
    :math:`2x_0 - x_{j}` over the filter's settling length (:func:`settling_steps`: until its
    slowest pole has decayed to 1e-12; scipy's default pad, three times the number of taps, is
    far shorter than the transient and left the ends 90 % wrong). The first and last sample get
    the one-sided differences of the 3-point polynomial. The zero-phase response is
    :math:`|B|^2`: -6 dB at ``cutoff_hz`` and order :math:`2N` roll-off. An end sample stays
    valid only where its response is within twice the interior's error over the band the
    interior claims (:mod:`methods._ends`); the others are masked. Linear in the input; exact
    on straight lines (the odd extension continues them), not on higher degrees. A record
    shorter than the settling length (from 3 samples) is padded by its whole length instead:
    the filter has not settled there, so lines come out only close (16 samples of 10 ms at
    the defaults: ẋ within 0.4 % of its slope at the samples the ends check keeps).

    Parameters
    ----------
    order : int in [1, 20]
        Order of the forward filter.
    cutoff_hz : float in [1e-3 fs/2, (1 - 1e-9) fs/2]
        Cutoff frequency (-3 dB of the forward pass) in Hz; below Nyquist, and at least 1e-3
        of it (lower cutoffs lose the unit gain at 0 Hz to rounding: see
        ``MIN_CUTOFF_FRACTION`` and ``MAX_CUTOFF_FRACTION``). Checked against the step by
        ``check_step``.

    References
    ----------
    Guo, Gautier, Liu, Perruquetti, "Identification of robot dynamic parameters using Jacobi
    differentiator", IEEE/ASME AIM 2015: sec. III.C (order 6, 25 Hz on the test signal) and
    sec. IV (order 4, 0.1 fs/2 on the robot).
    """

    order: int = param(
        6, low=1, high=20, integer=True, tune_low=1, tune_high=10, doc="forward filter order"
    )
    cutoff_hz: float = param(
        25.0,
        low=0.0,
        low_open=True,
        tune_low=0.5,
        tune_high=200.0,
        log=True,
        doc="cutoff frequency of the forward filter, Hz (in [1e-3, 1) x Nyquist)",
        kind="frequency",
    )

    presets = {
        "paper-signal": Preset({"order": 6, "cutoff_hz": 25.0}, "paper, sec. III.C", by="paper"),
        "robot": Preset(
            {"order": 4, "cutoff_hz": 5.0}, "paper, sec. IV: 0.1 * fs/2 at fs = 100 Hz", by="paper"
        ),
    }
    reference = "Guo et al., AIM 2015"
    time_symmetric = False  # forward-backward differs from backward-forward near the ends

    def check_step(self, dt: float) -> None:
        nyquist = 0.5 / dt
        check_frequency(
            "cutoff_hz",
            self.cutoff_hz,
            dt,
            lowest_hz=MIN_CUTOFF_FRACTION * nyquist,
            highest_hz=MAX_CUTOFF_FRACTION * nyquist,
            why_high="within 1e-9 of Nyquist the design overflows",
            why_low=f"below {MIN_CUTOFF_FRACTION:g} of the Nyquist frequency the filter's "
            "sections lose their unit gain at 0 Hz to rounding, and from 1e-9 of it the filter "
            "fails",
        )

    def _sos(self, dt: float) -> np.ndarray:
        return _butter_sos(self.order, self.cutoff_hz, float(dt)).copy()  # scipy wants it writable

    def min_samples(self, dt: float) -> int:
        self.check_step(dt)
        # the central differences need three samples; the odd padding is cut to the record
        # (n - 1 samples), which the ends check then judges
        return 3

    def end_reach(self, dt: float) -> int | None:
        return settling_steps(self.order, self.cutoff_hz, float(dt)) + 1

    def exact_degree(self, order: int) -> float | None:
        # The odd extension continues a straight line, which the filter (unit DC gain,
        # symmetric response) passes exactly; the Euler differences are exact on lines.
        return 1

    def _response(self, frequencies, dt: float, order: int) -> np.ndarray:
        """:math:`|B(e^{i\\theta})|^2 D_n(\\theta)`: the zero-phase filter times the central
        difference (away from the ends, where the start-up transients have decayed)."""
        _, gain = sps.sosfreqz(self._sos(dt), worN=frequencies, fs=1.0 / dt)
        difference = np.ones(1) if order == 0 else central_difference_weights(order, 2) / dt**order
        return np.abs(gain) ** 2 * fir_response(difference, frequencies, dt)

    def _estimate(self, x, dt, orders):
        sos = self._sos(dt)
        pad = min(settling_steps(self.order, self.cutoff_hz, float(dt)), x.shape[0] - 1)
        if x.ndim == 2 and x.shape[1] > 1:
            # along contiguous rows (the ends check's probes: 64 and 48 channels), half the
            # time of axis 0, the same recursion and bits; handed on in the layout it came in
            along_rows = sps.sosfiltfilt(sos, x.T.copy(), axis=-1, padtype="odd", padlen=pad)
            smoothed = np.ascontiguousarray(along_rows.T)
        else:
            smoothed = sps.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=pad)
        values, valid = {}, {}
        every = np.ones(x.shape[0], dtype=bool)
        for order in orders:
            if order == 0:
                values[0], valid[0] = smoothed, every.copy()
            else:
                taps = central_difference_weights(order, 2) / dt**order
                ends = end_evaluators(1, 2, order, dt)
                values[order], valid[order] = (
                    apply_fir_with_ends(smoothed, taps, ends),
                    every.copy(),
                )
        return values, valid


SETTLING = 1e-12
"""What the slowest pole's power must fall below for the filter to count as settled (at 1e-7 a
straight line was off by 3e-10 at the ends)."""


@functools.lru_cache(maxsize=256)
def settling_steps(order: int, cutoff_hz: float, dt: float) -> int:
    """Steps until the impulse response of the Butterworth low-pass of ``order`` and
    ``cutoff_hz`` at step ``dt`` has decayed to 1e-12 of its start,
    :math:`\\lceil \\ln 10^{-12} / \\ln \\max|p| \\rceil` over its poles p (e.g. 683 for order 6 at
    25 Hz and 1 kHz). The poles are the design's own (no root finding on the sections)."""
    _, poles, _ = sps.butter(order, cutoff_hz, btype="low", output="zpk", fs=1.0 / dt)
    radius = float(np.max(np.abs(poles)))
    return int(np.ceil(np.log(SETTLING) / np.log(radius))) if radius > 0 else 1
