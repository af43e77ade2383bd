"""Causal (online) methods: the estimate at a sample uses that sample and earlier ones only,
and every method runs on a stream, its state carried from one chunk of samples to the next.

A causal method implements three pure pieces:

- ``_start(first, dt, orders, samples)``: the state before any sample, from the first
  sample alone (the only one known when the stream starts); ``samples`` is the record's
  length in a batch call, None on a stream (a method may prepare data-independent parts,
  such as gains, for that many samples, or once for all);
- ``_advance(state, x, dt, orders) -> (values, state)``: the estimates of ``orders`` at the
  samples ``x`` (time on axis 0) and the state after them;
- ``warmup(order, dt)``: how many samples pass before the estimate of ``order`` is valid (a
  window still filling; 0 for recursive filters, whose start transient is part of their
  score).

The batch call is ``_start`` then one ``_advance`` over the whole record, and a
:class:`Stream` calls the same two on each chunk, every sample computed by the same
operations in the same order: feeding a record in chunks of any size gives the batch result
bit for bit. FIR filters run as ``scipy.signal.lfilter`` in its direct form II transposed
(denominator ``[1, 0]``: scipy convolves directly when the denominator has one coefficient,
and a convolution split across chunks sums in another order).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from scipy import signal as sps

from diffbench.methods._registry import Estimate, Method
from diffbench.methods._validation import check_dt, check_orders

FIR_DENOMINATOR = np.array([1.0, 0.0])
"""``lfilter``'s denominator for a FIR filter run in direct form II transposed (see above)."""


class CausalMethod(Method):
    """Base of the causal methods (see the module docstring): batch and stream share
    ``_start`` and ``_advance``."""

    causal: ClassVar[bool] = True
    time_symmetric: ClassVar[bool] = False

    time_stamps: ClassVar[str] = "uniform"
    uniform_only_reason: ClassVar[str] = (
        "is causal and takes uniformly sampled records only (resampling irregular time stamps "
        "onto a grid reads the next sample: not causal)"
    )

    def warmup(self, order: int, dt: float) -> int:
        """Samples at the start of a stream whose estimate of ``order`` is not valid (NaN)."""
        return 0

    def stream(
        self, dt: float, orders=(0, 1, 2), channels: tuple[int, ...] | None = None
    ) -> Stream:
        """A :class:`Stream` of this method at step ``dt`` for the derivatives of ``orders``
        (``channels``: the shape of one sample, e.g. ``(3,)``; by default the first chunk's).

        >>> stream = methods.get("kalman_filter").stream(dt=0.001)  # doctest: +SKIP
        >>> for chunk in chunks:                                     # doctest: +SKIP
        ...     estimate = stream.push(chunk)   # estimate[1]: ẋ at the chunk's samples
        """
        return Stream(self, dt, orders, channels)

    def _estimate(self, x, dt, orders):
        state = self._start(x[0], dt, orders, x.shape[0])
        values, _ = self._advance(state, x, dt, orders)
        return _masked(self, values, 0, dt)

    def _start(
        self, first: np.ndarray, dt: float, orders: tuple[int, ...], samples: int | None
    ) -> Any:
        raise NotImplementedError

    def _advance(self, state: Any, x: np.ndarray, dt: float, orders: tuple[int, ...]):
        raise NotImplementedError


class CausalFirMethod(CausalMethod):
    r"""A causal method that is one FIR filter per derivative order: ``taps(order, dt)``,
    :math:`\hat x^{(n)}_k = \sum_j b_j x_{k-j}` (lag 0 first); the first ``len(taps) - 1``
    samples have no estimate."""

    def taps(self, order: int, dt: float) -> np.ndarray:
        raise NotImplementedError

    def warmup(self, order: int, dt: float) -> int:
        return self.taps(order, dt).size - 1

    def _response(self, frequency_hz, dt, order):
        return causal_fir_response(self.taps(order, dt), frequency_hz, dt)

    def _start(self, first, dt, orders, samples):
        return {order: fir_state(self.taps(order, dt), first.shape) for order in orders}

    def _advance(self, state, x, dt, orders):
        values, after = {}, {}
        for order in orders:
            values[order], after[order] = run_fir(self.taps(order, dt), x, state[order])
        return values, after


def _masked(method: CausalMethod, values: dict, seen: int, dt: float) -> tuple[dict, dict]:
    """NaN on the samples still inside each order's warm-up (``seen`` samples came before)."""
    valid = {}
    for order, value in values.items():
        n = value.shape[0]
        mask = np.arange(seen, seen + n) >= method.warmup(order, dt)
        if not mask.all():
            value[~mask] = np.nan
        valid[order] = mask
    return values, valid


class Stream:
    """A causal method run online: :meth:`push` the samples as they come, in chunks of any
    size, and get the estimates at those samples; the result equals the batch call on the
    whole record bit for bit.

    ``channels`` is the shape of one sample (``()`` for a single channel); when not given,
    the first chunk fixes it (a first chunk of shape ``(k,)`` is k samples of one channel).
    Every chunk is checked (real, finite, that shape). ``samples`` counts the samples pushed
    so far.
    """

    def __init__(
        self,
        method: CausalMethod,
        dt: float,
        orders=(0, 1, 2),
        channels: tuple[int, ...] | None = None,
    ):
        self.dt = check_dt(dt)
        self.orders = check_orders(orders)
        method = method.at_step(self.dt)
        method.check_step(self.dt)
        self.method = method
        self.samples = 0
        self._state = None
        self._channels = None if channels is None else tuple(int(c) for c in channels)

    def push(self, x) -> Estimate:
        """Estimates of ``orders`` at the samples ``x`` (shape ``(k,)`` or ``(k, channels)``,
        k >= 1; a single sample may be given as a scalar or a ``(channels,)`` row when the
        stream has channels)."""
        chunk = self._check(x)
        if self._state is None:
            self._state = self.method._start(chunk[0], self.dt, self.orders, None)
        values, self._state = self.method._advance(self._state, chunk, self.dt, self.orders)
        values, valid = _masked(self.method, values, self.samples, self.dt)
        self.samples += chunk.shape[0]
        return Estimate(values=values, valid=valid)

    def _check(self, x) -> np.ndarray:
        try:
            chunk = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"`x` must be real numbers, got {type(x).__name__}") from None
        if self._channels is not None and chunk.shape == self._channels:
            chunk = chunk[np.newaxis]  # one sample
        elif chunk.ndim == 0:
            chunk = chunk.reshape(1)
        if chunk.shape[0] == 0:
            raise ValueError("`x` holds no sample; push at least one")
        if self._channels is None:
            self._channels = chunk.shape[1:]
        elif chunk.shape[1:] != self._channels:
            raise ValueError(
                f"`x` has samples of shape {chunk.shape[1:]}, the stream's are "
                f"{self._channels}; push one stream per channel layout"
            )
        if not np.all(np.isfinite(chunk)):
            raise ValueError("`x` holds NaN or inf; a stream takes finite samples only")
        return chunk


# --- shared math -----------------------------------------------------------------------------
def fir_state(taps: np.ndarray, channels: tuple[int, ...], past: np.ndarray | None = None):
    """``lfilter``'s direct-form-II-transposed state for the FIR ``taps`` (lag 0 first):
    zeros, or the state after a constant past equal to ``past`` (shape ``channels``):
    :math:`z_i = c \\sum_{j > i} b_j`."""
    tails = np.cumsum(taps[::-1])[::-1][1:]  # sum_{j > i} b_j, i = 0..L-2
    state = np.zeros((taps.size - 1, *channels))
    if past is not None:
        state += tails.reshape((-1,) + (1,) * len(channels)) * past
    return state


def run_fir(taps: np.ndarray, x: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:math:`y_k = \\sum_j b_j x_{k-j}` along axis 0 from ``state`` (see :func:`fir_state`):
    ``(y, state after)``."""
    if taps.size == 1:
        return taps[0] * x, state
    return sps.lfilter(taps, FIR_DENOMINATOR, x, axis=0, zi=state)


def causal_fir_response(taps: np.ndarray, frequency_hz: np.ndarray, dt: float) -> np.ndarray:
    """:math:`H(f) = \\sum_j b_j e^{-i 2\\pi f j \\Delta t}` for the causal taps ``b`` (lag 0
    first)."""
    unit = np.exp(-2j * np.pi * np.asarray(frequency_hz, dtype=np.float64) * dt)
    return np.polynomial.polynomial.polyval(unit, taps)


def state_space_response(
    transition: np.ndarray, gain: np.ndarray, output: np.ndarray, frequency_hz, dt: float
) -> np.ndarray:
    """Response of :math:`s_k = A s_{k-1} + g\\, x_k`, :math:`y_k = c^\\top s_k`:

    .. math:: H(f) = c^\\top (I - A e^{-i\\omega})^{-1} g, \\qquad \\omega = 2\\pi f \\Delta t
    """
    unit = np.exp(-2j * np.pi * np.asarray(frequency_hz, dtype=np.float64) * dt)
    identity = np.eye(transition.shape[0])
    systems = identity[None] - unit[:, None, None] * transition[None]
    gains = np.broadcast_to(gain[:, None], (unit.size, gain.size, 1))
    return np.linalg.solve(systems, gains)[..., 0] @ output
