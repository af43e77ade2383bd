"""The causal methods' linear recursions as compiled loops (numba).

The Kalman filter (``kalman_filter``), the α-β-γ tracker (``alpha_beta_gamma``) and the
high-gain observer (``high_gain_observer``) each update a state of a few entries once a
sample. In numpy a step costs a few array calls: about 10 µs a sample (0.1 s on the grid's
9301-sample records, evaluated hundreds of times by each tuning). Compiled, a step costs
nanoseconds. Each matrix row is summed in a fixed order, first column first, so that the
bits depend on neither the CPU's BLAS kernel nor how a record is cut into the chunks a
stream pushes: a stream equals the batch bit for bit.

Loaded on first use (numba takes about 0.2 s to import); the loops are compiled once and
cached beside this file.

References
----------
S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", LLVM-HPC
workshop (2015).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def _track(transition, gains, steady, x, state, start):  # pragma: no cover (compiled)
    samples, channels = x.shape
    size = state.shape[0]
    estimates = np.empty((samples, size, channels))
    predicted = np.empty(size)
    for channel in range(channels):
        for i in range(samples):
            for row in range(size):
                total = transition[row, 0] * state[0, channel]
                for column in range(1, size):
                    total += transition[row, column] * state[column, channel]
                predicted[row] = total
            innovation = x[i, channel] - predicted[0]
            step = start + i
            for row in range(size):
                gain = gains[step, row] if step < gains.shape[0] else steady[row]
                state[row, channel] = predicted[row] + gain * innovation
                estimates[i, row, channel] = state[row, channel]
    return estimates


def track(
    transition: np.ndarray,
    x: np.ndarray,
    state: np.ndarray,
    steady: np.ndarray,
    gains: np.ndarray | None = None,
    start: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    r"""The predictor-corrector recursion of a tracking filter over the samples ``x``:

    .. math::
        s^-_k = F s_{k-1}, \qquad s_k = s^-_k + K_k \left(x_k - (s^-_k)_0\right)

    with gain :math:`K_k` = ``gains[start + k]`` while there is one, ``steady`` after.
    ``x`` has shape (n, *channels), ``state`` (S, *channels): the state before the first
    sample. Returns the states after each sample, shape (n, S, *channels), and the last one.
    """
    x = np.asarray(x, dtype=np.float64)
    flat = np.array(state, dtype=np.float64).reshape(state.shape[0], -1)
    gains = np.zeros((0, flat.shape[0])) if gains is None else gains
    estimates = _track(
        np.ascontiguousarray(transition, dtype=np.float64),
        np.ascontiguousarray(gains, dtype=np.float64),
        np.ascontiguousarray(steady, dtype=np.float64).reshape(-1),
        np.ascontiguousarray(x.reshape(x.shape[0], flat.shape[1])),
        flat,
        int(start),
    )
    return estimates.reshape((x.shape[0], *state.shape)), flat.reshape(state.shape)


@numba.njit(cache=True)
def _observe(transition, input_gain, direct, x, state):  # pragma: no cover (compiled)
    samples, channels = x.shape
    size = state.shape[0]
    estimates = np.empty((samples, size, channels))
    following = np.empty(size)
    for channel in range(channels):
        for i in range(samples):
            sample = x[i, channel]
            for row in range(size):
                estimates[i, row, channel] = state[row, channel] + direct[row] * sample
                total = transition[row, 0] * state[0, channel]
                for column in range(1, size):
                    total += transition[row, column] * state[column, channel]
                following[row] = total + input_gain[row] * sample
            for row in range(size):
                state[row, channel] = following[row]
    return estimates


def observe(
    transition: np.ndarray,
    input_gain: np.ndarray,
    direct: np.ndarray,
    x: np.ndarray,
    state: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    r"""A discrete linear observer over the samples ``x``:

    .. math::
        y_k = \xi_k + D x_k, \qquad \xi_{k+1} = A \xi_k + B x_k

    ``x`` has shape (n, *channels), ``state`` (S, *channels): :math:`\xi_0`. Returns the
    outputs :math:`y_k`, shape (n, S, *channels), and the state after the last sample."""
    x = np.asarray(x, dtype=np.float64)
    flat = np.array(state, dtype=np.float64).reshape(state.shape[0], -1)
    estimates = _observe(
        np.ascontiguousarray(transition, dtype=np.float64),
        np.ascontiguousarray(input_gain, dtype=np.float64).reshape(-1),
        np.ascontiguousarray(direct, dtype=np.float64).reshape(-1),
        np.ascontiguousarray(x.reshape(x.shape[0], flat.shape[1])),
        flat,
    )
    return estimates.reshape((x.shape[0], *state.shape)), flat.reshape(state.shape)
