"""The causal methods' compiled recursions (methods/_causal_loops.py) against the same
recursions written in numpy (Levant's against scipy's ``brentq``), and independent of how the
channels are batched."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from diffbench.methods import _causal_loops as loops

EPS = np.finfo(float).eps


def _stable(size: int, radius: float, rng) -> np.ndarray:
    """A random matrix of spectral radius ``radius``."""
    matrix = rng.standard_normal((size, size))
    return matrix * (radius / max(abs(np.linalg.eigvals(matrix))))


def _bound(size: int, radius: float, step_scale: float) -> float:
    """The rounding of one step (S products summed, then a gain times a difference added: at
    most (S + 2) eps x ``step_scale``, the largest sum of the magnitudes it adds), carried by
    a recursion whose errors shrink by ``radius`` a step (at most 1 / (1 - radius) steps'
    worth), for each of the two implementations (they sum in different orders)."""
    return 2 * (size + 2) * EPS * step_scale / (1 - radius)


def _step_scale(transition, gains, states, x) -> float:
    """The largest sum of magnitudes a step adds up: |F| |s| and |K| (|x| + |F s|)."""
    propagated = abs(transition).sum(axis=1).max() * abs(states).max()
    return propagated + abs(gains).max() * (abs(x).max() + propagated)


@pytest.mark.parametrize("size", [3, 4, 6])
def test_track_is_the_predictor_corrector_recursion(size):
    rng = np.random.default_rng(size)
    steady = rng.standard_normal(size)
    steady[0] = 0.5
    # s_k = (I - K e_0ᵀ) F s_{k-1} + K x_k: F chosen so that this closed loop is stable
    closed = _stable(size, 0.8, rng)
    transition = np.linalg.solve(np.eye(size) - np.outer(steady, np.eye(size)[0]), closed)
    gains = steady + 1e-3 * rng.standard_normal((7, size))  # a short transient, then steady
    x = rng.standard_normal((200, 2))
    state0 = rng.standard_normal((size, 2))
    estimates, last = loops.track(transition, x, state0, steady, gains, start=0)
    mean, expected = state0.copy(), []
    for i in range(x.shape[0]):
        gain = gains[i] if i < len(gains) else steady
        predicted = transition @ mean
        mean = predicted + gain[:, None] * (x[i] - predicted[0])
        expected.append(mean)
    expected = np.array(expected)
    bound = _bound(size, 0.8, _step_scale(transition, gains, expected, x))
    assert abs(estimates - expected).max() <= bound
    assert np.array_equal(last, estimates[-1])
    # a channel alone gives the bits it gives among others; and a record cut in two pieces
    alone, _ = loops.track(transition, x[:, 1:], state0[:, 1:], steady, gains)
    assert np.array_equal(alone[..., 0], estimates[..., 1])
    head, middle = loops.track(transition, x[:50], state0, steady, gains)
    tail, _ = loops.track(transition, x[50:], middle, steady, gains, start=50)
    assert np.array_equal(np.concatenate([head, tail]), estimates)


@pytest.mark.parametrize("size", [2, 3, 5])
def test_observe_is_the_discrete_observer(size):
    rng = np.random.default_rng(10 + size)
    transition = _stable(size, 0.9, rng)
    input_gain, direct = rng.standard_normal(size), rng.standard_normal(size)
    x = rng.standard_normal((300, 3))
    xi = rng.standard_normal((size, 3))
    outputs, last = loops.observe(transition, input_gain, direct, x, xi)
    state, expected = xi.copy(), []
    for i in range(x.shape[0]):
        expected.append(state + direct[:, None] * x[i])
        state = transition @ state + input_gain[:, None] * x[i]
    expected = np.array(expected)
    bound = _bound(size, 0.9, _step_scale(transition, input_gain, expected, x))
    assert abs(outputs - expected).max() <= bound and abs(last - state).max() <= bound
    head, middle = loops.observe(transition, input_gain, direct, x[:77], xi)
    tail, end = loops.observe(transition, input_gain, direct, x[77:], middle)
    assert np.array_equal(np.concatenate([head, tail]), outputs) and np.array_equal(end, last)


def test_no_samples_leave_the_state_as_it_was():
    state = np.arange(3.0)[:, None]
    estimates, last = loops.track(np.eye(3), np.empty((0, 1)), state, np.ones(3))
    assert estimates.shape == (0, 3, 1) and np.array_equal(last, state)


def _levant_reference(constants, dt, x, state):
    """Levant's implicit steps in plain Python with scipy's ``brentq``: every sum in the
    compiled loop's order (first term first), so the two must agree bit for bit (IEEE
    arithmetic, the same libm ``pow``; no BLAS)."""
    scale, coefficients, powers, steps, propagate = constants
    size = state.shape[0]
    n = size - 1
    z = np.array(state, dtype=float).reshape(size, -1)
    samples = x.reshape(x.shape[0], -1)
    states = np.empty((x.shape[0], size, z.shape[1]))
    solved = 0  # steps outside the sliding mode
    for channel in range(z.shape[1]):
        for i in range(samples.shape[0]):
            residual = steps[0] * z[0, channel]
            for j in range(1, size):
                residual += steps[j] * z[j, channel]
            residual -= samples[i, channel]
            injection = [0.0] * size
            if abs(residual) <= coefficients[n]:
                injection[n] = scale[n] * residual / coefficients[n]
            else:
                target = abs(residual) - coefficients[n]

                def excess(u, target=target):
                    total = coefficients[0] * u ** powers[0]
                    for j in range(1, n):
                        total += coefficients[j] * u ** powers[j]
                    return (u + total) - target

                solved += 1
                root = brentq(excess, 0.0, target, xtol=1e-300, rtol=4 * EPS)
                sign = math.copysign(1.0, residual)
                injection = [scale[j] * root ** powers[j] * sign for j in range(size)]
            moved = [z[j, channel] - dt * injection[j] for j in range(size)]
            for row in range(size):
                total = propagate[row, 0] * moved[0]
                for column in range(1, size):
                    total += propagate[row, column] * moved[column]
                z[row, channel] = total
                states[i, row, channel] = total
    return states.reshape((x.shape[0], *state.shape)), z.reshape(state.shape), solved


@pytest.mark.parametrize("order", [1, 2, 3, 5])
@pytest.mark.parametrize("lipschitz", [1e3, 1.2e6, 1e9])
def test_levant_steps_are_brents_method_of_scipy_step_for_step(order, lipschitz):
    """The compiled implicit steps against the same steps with scipy's ``brentq``, bit for
    bit, on a noisy 3-sine record of 1500 samples at 0.1 ms (sliding and reaching phases,
    L below and far above the signal's third derivative: where the switching amplifies any
    rounding difference into the estimate) and two channels at once."""
    from diffbench.methods.levant import _step_constants

    dt = 1e-4
    t = np.arange(1500) * dt
    rng = np.random.default_rng(order)
    clean = sum(np.sin(2 * np.pi * f * t) for f in (4, 9, 15))
    x = np.column_stack([clean + 0.02 * rng.standard_normal(t.size), 0.5 * clean])
    constants = _step_constants(order, lipschitz, dt)
    state = np.zeros((order + 1, 2))
    state[0] = x[0]
    states, last = loops.levant_steps(constants, dt, x, state)
    expected, expected_last, solved = _levant_reference(constants, dt, x, state)
    np.testing.assert_array_equal(states, expected)
    np.testing.assert_array_equal(last, expected_last)
    if (lipschitz == 1.2e6 and order <= 2) or (lipschitz == 1e9 and order in (2, 3)):
        # here steps of both kinds alternate (elsewhere each record slides, or solves, almost
        # throughout): the sliding ones and those Brent's method solves
        assert 0 < solved < x.size - 2
