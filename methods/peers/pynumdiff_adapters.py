"""PyNumDiff 0.3's differentiators as diffbench methods ``pynumdiff.<function>``.

PyNumDiff (F. van Breugel, J. N. Kutz, B. W. Brunton, "Numerical differentiation of noisy data:
a unifying multi-objective optimization framework", IEEE Access 8 (2020); Y. Aditya et al.,
"PyNumDiff: A Python package for numerical differentiation of noisy time-series data", JOSS 7
(2022)) returns the smoothed signal and ẋ; ẍ is the same call applied to that ẋ. Parameters
keep PyNumDiff's names and units: windows in samples, cutoffs as a fraction of the Nyquist
frequency. Where PyNumDiff has a default the class default is the same; where it has none
the default is a setting of ours (``class defaults`` in the tables), and the presets are
tuned. Written for PyNumDiff 0.3 (its parameters change between releases); another version
is not registered, and says so.
"""

from __future__ import annotations

import importlib.util
from importlib import metadata

from diffbench.methods._plugins import note_missing
from diffbench.methods._registry import param, register
from diffbench.methods.peers import PEERS_EXTRA
from diffbench.methods.peers._adapter import PeerMethod, tuned_preset

SUPPORTED = "0.3"
"""The PyNumDiff release line these adapters are written for."""


def _installed() -> str | None:
    """Why the adapters cannot be registered, or None if they can."""
    if importlib.util.find_spec("pynumdiff") is None:
        return f"PyNumDiff is not installed ({PEERS_EXTRA})"
    version = metadata.version("pynumdiff")
    if version.split(".")[:2] != SUPPORTED.split("."):
        return (
            f"the adapters are written for PyNumDiff {SUPPORTED}.x, found {version} "
            f"({PEERS_EXTRA} installs {SUPPORTED})"
        )
    return None


def _pynumdiff():
    import pynumdiff  # heavy (imports cvxpy when present): only when a method runs

    return pynumdiff


def _cutoff(default: float):
    return param(
        default,
        low=0.0,
        high=1.0,
        low_open=True,
        high_open=True,
        tune_low=0.002,
        tune_high=0.5,
        log=True,
        doc="cutoff as a fraction of the Nyquist frequency (PyNumDiff's unit)",
    )


def _window(default: int, low: int = 3, doc: str = "window, samples"):
    return param(
        default,
        low=low,
        high=100_001,
        integer=True,
        tune_low=max(low, 3),
        tune_high=1001,
        log=True,
        doc=doc,
    )


class _Peer(PeerMethod):
    package = "pynumdiff"
    reference = "van Breugel, Kutz & Brunton (2020)"


class SpectralDiff(_Peer):
    """``pynumdiff.spectraldiff(x, dt, cutoff_freq, extension, pad_to_flat)``: FFT
    differentiation with a brick-wall cutoff, the record made periodic by ``extension`` ("none"
    is PyNumDiff's ``None``; 1 in ``pad_to_flat``: the ends first padded with smoothed-in
    repeats of the end values, discarded after)."""

    cutoff_freq: float = _cutoff(0.1)
    extension: str = param(
        "odd",
        choices=("odd", "even", "detrend", "none"),
        doc="how PyNumDiff makes the record periodic",
    )
    pad_to_flat: int = param(
        0, choices=(0, 1), integer=True, doc="1: pad the ends flat before the extension"
    )
    peer_call = "pynumdiff.spectraldiff"
    presets = tuned_preset("PyNumDiff", cutoff_freq=0.037, extension="detrend")

    def _smooth_and_first(self, x, dt):
        extension = None if self.extension == "none" else self.extension
        return _pynumdiff().spectraldiff(
            x, dt, self.cutoff_freq, extension=extension, pad_to_flat=bool(self.pad_to_flat), axis=0
        )


class ButterDiff(_Peer):
    """``pynumdiff.butterdiff(x, dt, filter_order, cutoff_freq, num_iterations)``: zero-phase
    Butterworth (scipy ``filtfilt``) then second-order finite differences."""

    filter_order: int = param(
        2, low=1, high=10, integer=True, tune_low=1, tune_high=8, doc="Butterworth order"
    )
    cutoff_freq: float = _cutoff(0.5)
    num_iterations: int = param(
        1,
        low=1,
        high=10,
        integer=True,
        tune_low=1,
        tune_high=4,
        doc="times the smoothing is applied",
    )
    peer_call = "pynumdiff.butterdiff"
    presets = tuned_preset("PyNumDiff", filter_order=8, cutoff_freq=0.0429, num_iterations=4)

    def min_samples(self, dt: float) -> int:
        return 3 * (self.filter_order + 1) + 1  # scipy filtfilt's default padding

    def _smooth_and_first(self, x, dt):
        return _pynumdiff().butterdiff(
            x, dt, self.filter_order, self.cutoff_freq, self.num_iterations, axis=0
        )


class SavGolDiff(_Peer):
    """``pynumdiff.savgoldiff(x, dt, degree, window_size, smoothing_win)``: Savitzky–Golay ẋ
    (scipy), then Gaussian smoothing of ẋ over ``smoothing_win`` samples (an even window is
    made odd by PyNumDiff)."""

    degree: int = param(
        3, low=1, high=11, integer=True, tune_low=1, tune_high=7, doc="polynomial degree"
    )
    window_size: int = _window(31, doc="Savitzky–Golay window, samples (> degree)")
    smoothing_win: int = _window(31, low=1, doc="Gaussian smoothing window of ẋ, samples")
    peer_call = "pynumdiff.savgoldiff"
    presets = tuned_preset("PyNumDiff", degree=6, window_size=55, smoothing_win=7)

    def min_samples(self, dt: float) -> int:
        if self.window_size <= self.degree:
            raise ValueError(
                f"`window_size` must exceed `degree` ({self.degree}), got {self.window_size}"
            )
        return max(self.window_size + 1, self.smoothing_win) + 1

    def _smooth_and_first(self, x, dt):
        return _pynumdiff().savgoldiff(
            x, dt, self.degree, self.window_size, self.smoothing_win, axis=0
        )


class PolyDiff(_Peer):
    """``pynumdiff.polydiff(x, dt, degree, window_size, kernel=kernel)``: sliding polynomial
    fits, blended with a ``kernel`` weighting."""

    degree: int = param(
        3, low=1, high=11, integer=True, tune_low=1, tune_high=7, doc="polynomial degree"
    )
    window_size: int = _window(31, doc="sliding window, samples (> degree)")
    kernel: str = param(
        "friedrichs", choices=("friedrichs", "gaussian"), doc="weighting of the overlapping fits"
    )
    peer_call = "pynumdiff.polydiff"
    presets = tuned_preset("PyNumDiff", degree=7, window_size=148, kernel="friedrichs")

    time_stamps = "native"  # PyNumDiff takes the time stamps in place of dt

    def min_samples(self, dt: float) -> int:
        if self.window_size <= self.degree:
            raise ValueError(
                f"`window_size` must exceed `degree` ({self.degree}), got {self.window_size}"
            )
        return self.window_size + 1

    def _smooth_and_first(self, x, dt):
        return _pynumdiff().polydiff(
            x, dt, self.degree, self.window_size, kernel=self.kernel, axis=0
        )


class SplineDiff(_Peer):
    """``pynumdiff.splinediff(x, dt, degree, s)``: scipy ``make_splrep`` smoothing spline
    whose residual energy is ``s`` times PyNumDiff's robust noise estimate."""

    degree: int = param(
        3, low=1, high=5, integer=True, tune_low=2, tune_high=5, doc="spline degree"
    )
    s: float = param(
        1.0,
        low=0.0,
        tune_low=0.01,
        tune_high=100.0,
        log=True,
        doc="residual energy / (N × robust noise variance)",
    )
    peer_call = "pynumdiff.splinediff"
    presets = tuned_preset("PyNumDiff", degree=5, s=1.35)

    time_stamps = "native"  # PyNumDiff takes the time stamps in place of dt

    def min_samples(self, dt: float) -> int:
        return 2 * (self.degree + 1)

    def _smooth_and_first(self, x, dt):
        return _pynumdiff().splinediff(x, dt, self.degree, self.s, axis=0)


class RtsDiff(_Peer):
    """``pynumdiff.rtsdiff(x, dt, order, log_qr_ratio, forwardbackward)``: Rauch–Tung–Striebel
    smoother of a constant-``order``-derivative model (1 in ``forwardbackward``: run forwards
    and backwards and blend)."""

    order: int = param(
        2,
        low=1,
        high=3,
        integer=True,
        tune_low=1,
        tune_high=3,
        doc="derivative held constant by the model",
    )
    log_qr_ratio: float = param(
        10.0,
        low=-50.0,
        high=80.0,
        tune_low=-10.0,
        tune_high=40.0,
        doc="ln(process noise q / measurement noise r)",
    )
    forwardbackward: int = param(
        0, choices=(0, 1), integer=True, doc="1: forwards and backwards, blended"
    )
    peer_call = "pynumdiff.rtsdiff"
    presets = tuned_preset("PyNumDiff", order=3, log_qr_ratio=14.5, forwardbackward=1)

    time_stamps = "native"  # PyNumDiff takes the time stamps in place of dt

    def _smooth_and_first(self, x, dt):
        return _pynumdiff().rtsdiff(
            x, dt, self.order, self.log_qr_ratio, forwardbackward=bool(self.forwardbackward), axis=0
        )


class TvrDiff(_Peer):
    """``pynumdiff.tvrdiff(x, dt, order, gamma)``: total-variation regularisation of the
    derivative of ``order`` (convex problem solved by cvxpy; needs cvxpy)."""

    order: int = param(
        1, choices=(1, 2, 3), integer=True, doc="derivative whose total variation is penalised"
    )
    gamma: float = param(
        0.01,
        low=0.0,
        low_open=True,
        tune_low=1e-6,
        tune_high=1e6,
        log=True,
        doc="regularisation weight",
    )
    peer_call = "pynumdiff.tvrdiff"
    presets = tuned_preset("PyNumDiff", order=3, gamma=325.0)

    def min_samples(self, dt: float) -> int:
        return self.order + 3

    def _smooth_and_first(self, x, dt):
        return _pynumdiff().tvrdiff(x, dt, self.order, self.gamma, axis=0)


class KernelDiff(_Peer):
    """``pynumdiff.kerneldiff(x, dt, kernel, window_size, num_iterations)``: kernel smoothing
    then second-order finite differences (``median`` is not linear)."""

    kernel: str = param(
        "friedrichs",
        choices=("friedrichs", "gaussian", "uniform", "median"),
        doc="smoothing kernel",
    )
    window_size: int = _window(5, doc="kernel width, samples")
    num_iterations: int = param(
        1,
        low=1,
        high=10,
        integer=True,
        tune_low=1,
        tune_high=5,
        doc="times the smoothing is applied",
    )
    peer_call = "pynumdiff.kerneldiff"
    presets = tuned_preset("PyNumDiff", kernel="friedrichs", window_size=20, num_iterations=1)

    def min_samples(self, dt: float) -> int:
        return self.window_size + 1

    def _smooth_and_first(self, x, dt):
        return _pynumdiff().kerneldiff(
            x, dt, self.kernel, self.window_size, self.num_iterations, axis=0
        )


class RbfDiff(_Peer):
    """``pynumdiff.rbfdiff(x, dt, sigma, lmbd)``: regularised fit of Gaussian radial basis
    functions, one per sample (``sigma`` in seconds, the unit of the time axis)."""

    sigma: float = param(
        1.0,
        low=0.0,
        low_open=True,
        tune_low=1e-4,
        tune_high=1.0,
        log=True,
        doc="width of the basis functions, s",
    )
    lmbd: float = param(
        0.01,
        low=0.0,
        low_open=True,
        tune_low=1e-6,
        tune_high=10.0,
        log=True,
        doc="regularisation (height of the 'towers')",
    )
    peer_call = "pynumdiff.rbfdiff"
    presets = tuned_preset("PyNumDiff", sigma=0.0399, lmbd=0.00208)
    max_samples_reason = "its basis matrix grows as N², about 2 s at 2e4 samples"

    time_stamps = "native"  # PyNumDiff takes the time stamps in place of dt

    def max_samples(self, dt: float) -> int | None:
        return 20_000

    def _smooth_and_first(self, x, dt):
        return _pynumdiff().rbfdiff(x, dt, self.sigma, self.lmbd, axis=0)


ADAPTERS = {
    "spectraldiff": SpectralDiff,
    "butterdiff": ButterDiff,
    "savgoldiff": SavGolDiff,
    "polydiff": PolyDiff,
    "splinediff": SplineDiff,
    "rtsdiff": RtsDiff,
    "tvrdiff": TvrDiff,
    "kerneldiff": KernelDiff,
    "rbfdiff": RbfDiff,
}


def _register_all() -> None:
    missing = _installed()
    if missing:
        note_missing("pynumdiff", missing)
        return
    for name, cls in ADAPTERS.items():
        if name == "tvrdiff" and importlib.util.find_spec("cvxpy") is None:
            note_missing("pynumdiff", f"pynumdiff.tvrdiff needs cvxpy ({PEERS_EXTRA})")
            continue
        register(f"pynumdiff.{name}")(cls)


_register_all()
