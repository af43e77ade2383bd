"""The base class of the peer adapters: call the peer, return its result as an Estimate."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from diffbench.methods._registry import Method, Preset
from diffbench.methods._validation import finite_samples


def tuned_preset(peer: str, **values) -> dict[str, Preset]:
    """The ``paper-signal`` preset of a ``peer`` adapter: the peer tuned by the oracle for ẍ."""
    source = (
        f"diffbench, not {peer}'s: oracle tuning (differential evolution) on the held-out "
        "noise seed 10000, least interior ẍ RMSE"
    )
    return {"paper-signal": Preset(values, source)}


APPLIED_TWICE = "the peer's ẋ differentiated again by the same method and parameters"


class PeerMethod(Method):
    """A peer library's differentiator behind diffbench's call contract.

    Subclasses implement ``_smooth_and_first(x, dt) -> (smoothed x, ẋ)`` with one call of the
    peer. The second derivative is :data:`APPLIED_TWICE` unless a subclass overrides
    ``_second``. Samples where the peer returns NaN or inf are marked invalid (all channels of
    a time step together), never hidden. Declared non-linear: diffbench computes no frequency
    response for a peer (its data-only spectral criterion needs one), even where the peer's
    method is linear.
    """

    linear: ClassVar[bool] = False
    time_symmetric: ClassVar[bool] = False
    second_derivative: ClassVar[str] = APPLIED_TWICE
    peer_call: ClassVar[str] = ""
    """The peer's function or class that runs, as its users write it."""

    def _estimate_at(self, x, times, orders):
        # a peer whose function takes the time stamps in place of the step (its
        # ``time_stamps`` is "native") is handed them as they are
        return self._estimate(x, times, orders)

    def min_samples(self, dt: float) -> int:
        # second-order differences of ẋ need three samples; one more keeps ends off each other
        return 4

    def _smooth_and_first(self, x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _second(self, first: np.ndarray, dt: float) -> np.ndarray:
        return self._smooth_and_first(first, dt)[1]

    def _estimate(self, x, dt, orders):
        try:
            smoothed, first = self._smooth_and_first(x, dt)
            computed = {0: smoothed, 1: first}
            if 2 in orders:
                computed[2] = self._second(np.asarray(first, dtype=float), dt)
        except Exception as error:
            if not _peer_refusal(error):
                raise  # a TypeError or the like: a bug of the adapter, shown as it is
            setting = ", ".join(f"`{k}`={v!r}" for k, v in self.params().items())
            raise ValueError(
                f"{self.peer_call} failed at {setting} with {_step_text(dt)} "
                f"({type(error).__name__}: {error}); choose other parameters"
            ) from error
        values, valid = {}, {}
        for order in orders:
            value = np.array(computed[order], dtype=float).reshape(x.shape)
            finite = finite_samples(value)
            value[~finite] = np.nan
            if not finite.any():
                setting = ", ".join(f"`{k}`={v!r}" for k, v in self.params().items())
                raise ValueError(
                    f"{self.peer_call} returned no finite value of order {order} at {setting} "
                    f"with {_step_text(dt)}; choose other parameters"
                )
            values[order], valid[order] = value, finite
        return values, valid


def _step_text(dt) -> str:
    if np.ndim(dt):
        return f"time stamps t ({np.size(dt)} of them)"
    return f"dt={dt!r}"


def _peer_refusal(error: Exception) -> bool:
    """Whether an exception raised inside a peer means "not at this setting": its own
    ValueError, a numerical failure (singular matrix, overflow, division by zero) or a failed
    convex solve (cvxpy's SolverError)."""
    numerical = (ValueError, ArithmeticError, np.linalg.LinAlgError)
    return isinstance(error, numerical) or type(error).__module__.startswith("cvxpy")
