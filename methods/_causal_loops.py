"""The causal methods' per-sample recursions as compiled loops (numba).

The Kalman filter (``kalman_filter``), the α-β-γ tracker (``alpha_beta_gamma``), the
high-gain observer (``high_gain_observer``) and Levant's differentiator (``levant``, whose
implicit step solves one scalar equation by Brent's method) each update a state of a few
entries once a sample. In numpy a step costs a few array calls: about 10 µs a sample (0.1 s
on the grid's 9301-sample records, evaluated hundreds of times by each tuning). Compiled, a
step costs nanoseconds. Each matrix row is summed in a fixed order, first column first, so that the
bits depend on neither the CPU's BLAS kernel nor how a record is cut into the chunks a
stream pushes: a stream equals the batch bit for bit.

Loaded on first use (numba takes about 0.2 s to import); the loops are compiled once and
cached beside this file.

References
----------
S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", LLVM-HPC
workshop (2015); R. P. Brent, *Algorithms for Minimization without Derivatives*,
Prentice-Hall (1973), ch. 4.
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


BRENT_MAX_ITERATIONS = 100
"""Iterations of Brent's method in Levant's implicit step before it gives up (scipy's
``brentq`` default)."""


@numba.njit(cache=True)
def _levant_excess(u, coefficients, powers, target):  # pragma: no cover (compiled)
    total = coefficients[0] * u ** powers[0]
    for j in range(1, coefficients.shape[0] - 1):  # c_j u^p_j, j < n, first first
        total += coefficients[j] * u ** powers[j]
    return (u + total) - target


@numba.njit(cache=True)
def _levant_root(coefficients, powers, target, xtol, rtol):  # pragma: no cover (compiled)
    previous, current = 0.0, target
    f_previous = _levant_excess(previous, coefficients, powers, target)
    f_current = _levant_excess(current, coefficients, powers, target)
    if f_previous == 0.0:
        return previous
    if f_current == 0.0:
        return current
    if (f_previous > 0.0) == (f_current > 0.0):
        raise ValueError("the root of Levant's implicit step is not bracketed")
    block = f_block = step_previous = step_current = 0.0
    for _ in range(BRENT_MAX_ITERATIONS):
        if f_previous != 0.0 and f_current != 0.0 and ((f_previous < 0.0) != (f_current < 0.0)):
            block, f_block = previous, f_previous
            step_previous = step_current = current - previous
        if abs(f_block) < abs(f_current):  # the best guess is kept in `current`
            previous, current, block = current, block, current
            f_previous, f_current, f_block = f_current, f_block, f_current
        tolerance = (xtol + rtol * abs(current)) / 2
        bisection = (block - current) / 2
        if f_current == 0.0 or abs(bisection) < tolerance:
            return current
        if abs(step_previous) > tolerance and abs(f_current) < abs(f_previous):
            if previous == block:  # secant
                trial = -f_current * (current - previous) / (f_current - f_previous)
            else:  # inverse quadratic interpolation
                slope_previous = (f_previous - f_current) / (previous - current)
                slope_block = (f_block - f_current) / (block - current)
                trial = (
                    -f_current
                    * (f_block * slope_block - f_previous * slope_previous)
                    / (slope_block * slope_previous * (f_block - f_previous))
                )
            if 2 * abs(trial) < min(abs(step_previous), 3 * abs(bisection) - tolerance):
                step_previous, step_current = step_current, trial
            else:
                step_previous = step_current = bisection
        else:
            step_previous = step_current = bisection
        previous, f_previous = current, f_current
        if abs(step_current) > tolerance:
            current += step_current
        else:
            current += tolerance if bisection > 0 else -tolerance
        f_current = _levant_excess(current, coefficients, powers, target)
    raise ValueError("the root of Levant's implicit step did not converge")


@numba.njit(cache=True)
def _levant(scale, coefficients, powers, steps, propagate, dt, x, state):  # pragma: no cover
    samples, channels = x.shape
    size = state.shape[0]
    n = size - 1
    states = np.empty((samples, size, channels))
    injection = np.empty(size)
    moved = np.empty(size)
    sign_limit = coefficients[n]
    rtol = 4 * np.finfo(np.float64).eps
    for channel in range(channels):
        for i in range(samples):
            residual = steps[0] * state[0, channel]
            for j in range(1, size):
                residual += steps[j] * state[j, channel]
            residual -= x[i, channel]
            if abs(residual) <= sign_limit:  # sliding: e = 0, Sign(0) = r / c_n
                injection[:] = 0.0
                injection[n] = scale[n] * residual / sign_limit
            else:
                target = abs(residual) - sign_limit
                magnitude = _levant_root(coefficients, powers, target, 1e-300, rtol)
                sign = 1.0 if residual > 0 else -1.0
                for j in range(size):
                    injection[j] = scale[j] * magnitude ** powers[j] * sign
            for j in range(size):
                moved[j] = state[j, channel] - dt * injection[j]
            for row in range(size):
                total = propagate[row, 0] * moved[0]
                for column in range(1, size):
                    total += propagate[row, column] * moved[column]
                state[row, channel] = total
                states[i, row, channel] = total
    return states


def levant_steps(
    constants: tuple[np.ndarray, ...], dt: float, x: np.ndarray, state: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    r"""The implicit (backward Euler) steps of Levant's differentiator over the samples ``x``
    (:class:`~diffbench.methods.levant.Levant`): with :math:`r = \sum_j \Delta t^j z_j - x`,
    the error e = 0 when :math:`|r| \le c_n` (the sliding mode), else the root of
    :math:`u + \sum_{j<n} c_j u^{(n-j)/(n+1)} = |r| - c_n` on :math:`[0, |r| - c_n]`, by
    Brent's method to 4 eps relative (scipy's ``brentq``, step for step: its test oracle);
    then :math:`z \leftarrow M(z - \Delta t D(e))`.

    ``constants``: the injection scales, the c_j, the powers, M's first row and M
    (``levant._step_constants``). ``x`` has shape (n, *channels), ``state`` (N+1,
    *channels). Returns the states after each sample, shape (n, N+1, *channels), and the
    last one."""
    scale, coefficients, powers, steps, propagate = (
        np.ascontiguousarray(c, dtype=np.float64) for c in constants
    )
    x = np.asarray(x, dtype=np.float64)
    flat = np.array(state, dtype=np.float64).reshape(state.shape[0], -1)
    states = _levant(
        scale,
        coefficients,
        powers,
        steps,
        propagate,
        float(dt),
        np.ascontiguousarray(x.reshape(x.shape[0], flat.shape[1])),
        flat,
    )
    return states.reshape((x.shape[0], *state.shape)), flat.reshape(state.shape)
