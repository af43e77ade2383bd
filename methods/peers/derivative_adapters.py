"""The ``derivative`` package's differentiators as diffbench methods ``derivative.<kind>``.

``derivative`` (A. Kaptanoglu, B. de Silva et al.; the differentiators pysindy uses, installed
with it) returns ẋ (``Method.d``) and a smoothed signal (``Method.x``); ẍ is ``d`` applied to
that ẋ. Parameters keep ``derivative``'s names and units (time in seconds), except where a
class takes a function: ``derivative.spectral`` is given a brick-wall filter at ``cutoff_hz``.
The time axis passed is ``t = k·dt``.
"""

from __future__ import annotations

import importlib.util
from typing import ClassVar

import numpy as np

from diffbench.methods._plugins import note_missing
from diffbench.methods._registry import param, register
from diffbench.methods._validation import MAX_WINDOW_STEPS, check_frequency
from diffbench.methods.peers import PEERS_EXTRA
from diffbench.methods.peers._adapter import PeerMethod, tuned_preset


class _Peer(PeerMethod):
    package = "derivative"
    reference = "derivative (Kaptanoglu, de Silva et al.), as used by pysindy"
    kind: ClassVar[str] = ""

    def _peer(self):
        raise NotImplementedError

    def _smooth_and_first(self, x, dt):
        t = np.arange(x.shape[0]) * dt
        peer = self._peer()
        return peer.x(x, t, axis=0), peer.d(x, t, axis=0)

    def _second(self, first, dt):
        t = np.arange(first.shape[0]) * dt
        return self._peer().d(first, t, axis=0)


class Spectral(_Peer):
    """``derivative.Spectral(filter=lambda f: abs(f) < cutoff_hz)``: FFT differentiation of
    the record taken as periodic, with a brick-wall filter."""

    cutoff_hz: float = param(
        20.0,
        low=0.0,
        low_open=True,
        tune_low=0.5,
        tune_high=200.0,
        log=True,
        doc="brick-wall cutoff, Hz (below Nyquist)",
        kind="frequency",
    )
    peer_call = "derivative.Spectral"
    presets = tuned_preset("derivative", cutoff_hz=17.3)

    def check_step(self, dt: float) -> None:
        check_frequency("cutoff_hz", self.cutoff_hz, dt)

    def _peer(self):
        import derivative

        cutoff = self.cutoff_hz
        return derivative.Spectral(filter=lambda f: (np.abs(f) < cutoff).astype(float))


class Spline(_Peer):
    """``derivative.Spline(s, order=order)``: scipy's ``UnivariateSpline`` with residual sum
    of squares at most ``s``."""

    s: float = param(
        1.0,
        low=0.0,
        tune_low=1e-6,
        tune_high=1e3,
        log=True,
        doc="bound on the residual sum of squares (units of x²)",
    )
    order: int = param(3, low=1, high=5, integer=True, tune_low=3, tune_high=5, doc="spline degree")
    peer_call = "derivative.Spline"
    presets = tuned_preset("derivative", s=65.0, order=5)

    def min_samples(self, dt: float) -> int:
        return self.order + 2

    def _peer(self):
        import derivative

        return derivative.Spline(self.s, order=self.order)


class Kernel(_Peer):
    """``derivative.Kernel(sigma, lmbd, kernel="gaussian")``: Gaussian-process regression with
    a squared-exponential kernel, differentiated analytically."""

    sigma: float = param(
        0.02,
        low=0.0,
        low_open=True,
        tune_low=1e-3,
        tune_high=1.0,
        log=True,
        doc="kernel length scale, s",
    )
    lmbd: float = param(
        0.01,
        low=0.0,
        tune_low=1e-6,
        tune_high=10.0,
        log=True,
        doc="noise variance added to the kernel's diagonal",
    )
    peer_call = "derivative.Kernel"
    presets = tuned_preset("derivative", sigma=0.0473, lmbd=1.04e-05)
    max_samples_reason = "dense N×N kernel solve, O(N³): about 2 s at 1000 samples"

    def max_samples(self, dt: float) -> int | None:
        return 2_000

    def _peer(self):
        import derivative

        return derivative.Kernel(sigma=self.sigma, lmbd=self.lmbd, kernel="gaussian")


class Kalman(_Peer):
    """``derivative.Kalman(alpha)``: the maximum-likelihood smoother of a process whose
    derivative is a Brownian motion; ``alpha`` weighs smoothness against fit."""

    alpha: float = param(
        1.0,
        low=0.0,
        low_open=True,
        tune_low=1e-10,
        tune_high=1e3,
        log=True,
        doc="smoothness weight",
    )
    peer_call = "derivative.Kalman"
    presets = tuned_preset("derivative", alpha=4.85e-07)
    max_samples_reason = "dense 2N×2N solve, O(N³): about 0.25 s at 1000 samples"

    def max_samples(self, dt: float) -> int | None:
        return 4_000

    def _peer(self):
        import derivative

        return derivative.Kalman(alpha=self.alpha)


class SavitzkyGolay(_Peer):
    """``derivative.SavitzkyGolay(order, left=window_s/2, right=window_s/2)``: local
    least-squares polynomial over ``[t − window_s/2, t + window_s/2]``, the window truncated at
    the ends (a Python loop over samples)."""

    order: int = param(
        3, low=1, high=9, integer=True, tune_low=1, tune_high=7, doc="polynomial degree"
    )
    window_s: float = param(
        0.05,
        low=0.0,
        low_open=True,
        tune_low=0.002,
        tune_high=2.0,
        log=True,
        doc="window length, s",
        kind="window",
    )
    peer_call = "derivative.SavitzkyGolay"
    presets = tuned_preset("derivative", order=5, window_s=0.074)

    def check_step(self, dt: float) -> None:
        # the peer fits the samples within ±window_s/2: it needs order + 1 of them (fewer gave
        # garbage, not an error: ẋ 120 % off at window_s = 0.05 s, dt = 0.1 s)
        if self.window_s / dt < self.order:
            raise ValueError(
                f"`window_s` must hold order + 1 = {self.order + 1} samples at "
                f"dt={dt!r} s, i.e. be at least {self.order * dt:.6g} s, got "
                f"{self.window_s!r}"
            )

    def min_samples(self, dt: float) -> int:
        steps = self.window_s / dt
        if not steps <= MAX_WINDOW_STEPS:
            raise ValueError(
                f"`window_s` must span at most {MAX_WINDOW_STEPS} steps at dt={dt!r} "
                f"s, got {self.window_s!r}"
            )
        return max(self.order + 2, round(steps) + 1)

    def _peer(self):
        import derivative

        half = self.window_s / 2
        return derivative.SavitzkyGolay(order=self.order, left=half, right=half)


ADAPTERS = {
    "spectral": Spectral,
    "spline": Spline,
    "kernel": Kernel,
    "kalman": Kalman,
    "savitzky_golay": SavitzkyGolay,
}


def _register_all() -> None:
    if importlib.util.find_spec("derivative") is None:
        note_missing("derivative", f"the derivative package is not installed ({PEERS_EXTRA})")
        return
    for name, cls in ADAPTERS.items():
        register(f"derivative.{name}")(cls)


_register_all()
