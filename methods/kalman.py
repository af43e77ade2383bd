"""Kalman smoothing with a polynomial (constant-acceleration or constant-jerk) model."""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy import linalg, signal

from diffbench.methods._registry import Method, Preset, param, register
from diffbench.methods._validation import check_frequency, mean_step

CONVERGED = 1e-12
"""How close (relative) the covariance recursion's gain and covariance must come to the
steady state before the rest of a record is filtered with the steady gains; at low
``bandwidth_hz * dt`` the recursion's rounding keeps it farther (measured: within 5e-11 at
best at 1e-4, 2e-12 at 1e-3, 1e-14 at 1e-2), so the tolerance is also at least
:data:`ROUNDING` / (ω_b Δt)² (2.2e-9 at 1e-4, 2.2e-11 at 1e-3)."""

ROUNDING = 4 * np.finfo(float).eps

MIN_BANDWIDTH_STEPS = 1e-4
"""Lowest ``bandwidth_hz * dt``. From the vague prior the covariance recursion takes about
6 / (bandwidth_hz * dt) steps to reach the steady state (to :data:`CONVERGED`), a Python loop of
some 20 us a step: 6e4 steps (1-2 s) at 1e-4, and ten times as many at ten times less. The
steady state itself is solved directly at any bandwidth (:func:`steady_state`)."""


@dataclass(frozen=True)
class KalmanModel:
    r"""The state-space model in states scaled by the bandwidth,
    :math:`s_j = x^{(j)} / \omega_b^j` (j = 0..m-1, :math:`\omega_b = 2\pi f_b`): transition
    F, process noise Q, measurement variance R (H = [1, 0, ...]), ``to_derivatives``
    (:math:`\omega_b^j`) mapping s_j back to :math:`x^{(j)}`, and ``per_step_coefficient``
    (:math:`j!/(\omega_b \Delta t)^j`): the state of the polynomial :math:`\sum_j c_j u^j` in
    u = t / Δt is :math:`c_j` times it."""

    F: np.ndarray
    Q: np.ndarray
    R: float
    to_derivatives: np.ndarray
    per_step_coefficient: np.ndarray

    @property
    def states(self) -> int:
        return self.F.shape[0]


def integrated_white_noise(states: int, dt: float, spectral_density: float) -> np.ndarray:
    r"""Process-noise covariance over a step ``dt`` of a (``states`` - 1)-times integrated
    white noise of ``spectral_density`` q, in the state :math:`(x, \dot x, \dots)`:

    .. math:: Q_{ij} = q\, \frac{\Delta t^{p}}{(m-1-i)!\,(m-1-j)!\; p}, \qquad
        p = 2m - 1 - i - j,

    m = ``states`` (C. F. Van Loan, "Computing integrals involving the matrix exponential",
    IEEE Trans. Automat. Control 23 (1978) 395-404, for the integral of :math:`e^{Ft} G G^\top
    e^{F^\top t}`). filterpy's ``Q_continuous_white_noise`` gives the same for 2 to 4 states
    (its limit; the tests hold it to it); this one serves any number."""
    m = int(states)
    q = np.empty((m, m))
    for i in range(m):
        for j in range(m):
            power = 2 * m - 1 - i - j
            q[i, j] = dt**power / (math.factorial(m - 1 - i) * math.factorial(m - 1 - j) * power)
    return spectral_density * q


def polynomial_model(model_order: int, dt: float, bandwidth_hz: float) -> KalmanModel:
    """The model of ``kalman``: an (m-1)-times integrated white noise observed in noise.

    In the state :math:`(x, \\dot x, \\dots, x^{(m-1)})`, ``m = model_order + 1``, the
    transition is :math:`F_{ij} = \\Delta t^{j-i}/(j-i)!` and the process noise is
    :func:`integrated_white_noise` (filterpy's ``Q_continuous_white_noise``) of density
    :math:`q = (2\\pi f_b)^{2m} R\\,\\Delta t`, R = 1. For that q the continuous Wiener smoother
    has :math:`|H| = 1/(1 + (f/f_b)^{2m})`, so ``bandwidth_hz`` (:math:`f_b`) is where it passes
    one half (-6 dB, like a forward-backward Butterworth at its cutoff). Only q/R matters for
    the smoothed means (scaling both scales every covariance and leaves the gains unchanged),
    which is why one parameter, as a bandwidth, describes the smoother.

    The model is returned in the states scaled by the bandwidth,
    :math:`s_j = x^{(j)}/\\omega_b^j` (the same model under a diagonal change of variables:
    :math:`F' = TFT^{-1}`, :math:`F'_{ij} = (\\omega_b \\Delta t)^{j-i}/(j-i)!`,
    :math:`Q' = TQT^\top`), in which the steady covariance is well conditioned at any
    bandwidth (its error variances are all about :math:`R\\,\\omega_b \\Delta t`: condition
    number 30-1e4 for ``bandwidth_hz * dt`` from 1e-4 to 0.45, against up to 4e21 in states
    scaled by :math:`\\Delta t^j/j!`, and beyond any precision in raw derivatives).
    """
    states = model_order + 1
    omega = 2 * math.pi * bandwidth_hz
    density = omega ** (2 * states) * dt
    noise = integrated_white_noise(states, dt, density)
    to_derivatives = omega ** np.arange(states, dtype=float)
    scaled_noise = noise / np.outer(to_derivatives, to_derivatives)
    reach = omega * dt
    transition = np.array(
        [
            [reach ** (j - i) / math.factorial(j - i) if j >= i else 0.0 for j in range(states)]
            for i in range(states)
        ]
    )
    per_step = np.array([math.factorial(j) / reach**j for j in range(states)])
    return KalmanModel(
        F=transition,
        Q=scaled_noise,
        R=1.0,
        to_derivatives=to_derivatives,
        per_step_coefficient=per_step,
    )


PRIOR_SCALE = 1e6
"""How vague the prior is: its covariance is this many times that of the least-squares start.
Measured on clean sin 3t (31 samples, dt = 0.1 s, bandwidth 2 Hz, constant jerk): the L2 error
of ẋ over the record is 1.38 at 10 (the scale used until 2026-11), 0.37 at 1e3, 0.08 at 1e6,
0.06 at 1e9; the start then follows the data instead of the prior's guess."""


def initial_state(
    z: np.ndarray, per_step_coefficient: np.ndarray, steps: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    r"""Prior mean and covariance of the scaled state one step before the first sample: vague.

    A least-squares polynomial :math:`p(u) = \sum_j c_j u^j` (u in steps) of degree m-1
    through the first min(n, 4m) samples, sample j at u = j + 1: the scaled state at u = 0 is
    :math:`D c`, D = diag(``per_step_coefficient``) (the model's, see :class:`KalmanModel`);
    covariance ``PRIOR_SCALE`` R D (VᵀV)⁻¹ D, so that the data, not the guess, decide the first
    estimates. A polynomial of the model's degree starts the filter on its exact state, so the
    smoother reproduces it exactly. ``steps``: the samples' times in steps from the prior
    (irregular times; default 1, 2, ...). ``z`` has shape (n, channels); the mean has shape
    (m, channels). The covariance does not depend on the data.
    """
    states = per_step_coefficient.size
    count = min(z.shape[0], 4 * states)
    steps = np.arange(1, count + 1, dtype=float) if steps is None else steps[:count]
    vandermonde = steps[:, None] ** np.arange(states)[None, :]
    coefficients, *_ = np.linalg.lstsq(vandermonde, z[:count], rcond=None)
    covariance = np.linalg.inv(vandermonde.T @ vandermonde)
    scale = np.outer(per_step_coefficient, per_step_coefficient)
    return coefficients * per_step_coefficient[:, None], PRIOR_SCALE * covariance * scale


@dataclass(frozen=True)
class SteadyState:
    """The steady state of the filter and smoother: filter gain K (m,), smoother gain C
    (m, m), and the filtered covariance P (m, m)."""

    filter_gain: np.ndarray
    smoother_gain: np.ndarray
    covariance: np.ndarray


def steady_state(F: np.ndarray, Q: np.ndarray, R: float) -> SteadyState:
    r"""The steady state, solved directly: the predicted covariance :math:`P^-` is the
    stabilising solution of the discrete algebraic Riccati equation

    .. math::
        P^- = F P^- F^\\top - F P^- H^\\top (H P^- H^\\top + R)^{-1} H P^- F^\\top + Q

    (``scipy.linalg.solve_discrete_are``, the filtering problem as the dual of the control
    one); then :math:`K = P^- H^\\top / (H P^- H^\\top + R)`, the filtered covariance
    :math:`P = (I - KH) P^- (I - KH)^\\top + R K K^\\top` and the smoother gain
    :math:`C = P F^\\top (F P F^\\top + Q)^{-1}`, by the recursion's own formulas.

    References
    ----------
    B. D. O. Anderson, J. B. Moore, "Optimal Filtering", Prentice-Hall 1979, ch. 4 and 7.
    """
    m = F.shape[0]
    observation = np.eye(m, 1)
    predicted = linalg.solve_discrete_are(F.T, observation, Q, np.array([[R]]))
    gain = predicted[:, 0] / (predicted[0, 0] + R)
    i_kh = np.eye(m)
    i_kh[:, 0] -= gain
    covariance = i_kh @ predicted @ i_kh.T + R * np.outer(gain, gain)
    smoother = covariance @ F.T @ np.linalg.inv(F @ covariance @ F.T + Q)
    return SteadyState(filter_gain=gain, smoother_gain=smoother, covariance=covariance)


@dataclass(frozen=True)
class Gains:
    """Data-independent gains: per-step filter gains K_k and smoother gains C_k for the first
    ``len(filter_gains)`` steps (until the steady state), then the steady ones."""

    filter_gains: np.ndarray  # (T, m)
    smoother_gains: np.ndarray  # (T, m, m)
    steady: SteadyState
    transient: TransientMaps | None = None  # the transient's block maps, when prepared
    modes: _SmootherModes | None = None  # the steady passes' modes, when prepared
    # the key of prior_gains' cache (model order, step, bandwidth): cached gains
    key: tuple | None = None


MAPS_MAX_CHANNELS = 8
"""The most channels a call may have to run the transient by the block maps of cached gains
(:func:`_cached_maps`): with a hundred channels (the ends check's probes) one step of the
recursion costs what a channel does and the maps' products cost a hundred times more. A rule
on the call alone, never on what was called before, so that a run's numbers do not depend on
its order (serial, on workers, on Dask)."""

MAPS_MAX_STEPS = 512
"""The longest transient run by block maps. The maps hold about 34 times the gains (the
backward ones a (B m)² matrix a block): 2 MB for a transient of 512 steps at order 3, but
94 MB at order 5 and 1 Hz (8276 steps), where building them also costs twice stepping (109
ms against 56 ms on 9301 samples). Up to 512 steps building costs less than stepping once
(0.5 ms against 1.8 ms for the paper preset's 262), so even a setting called once gains."""

TRANSIENT_BLOCK = 32
"""Steps of the transient each block map of :class:`TransientMaps` covers."""


@dataclass(frozen=True)
class TransientMaps:
    r"""The transient of the filter and smoother as affine maps over blocks of
    :data:`TRANSIENT_BLOCK` steps (data-independent; :func:`transient_maps`), so that a call
    steps through a block with two array products instead of one per sample.

    Forward, over a block of steps a..e-1, the filter
    :math:`\hat s_k = A_k \hat s_{k-1} + K_k z_k` with :math:`A_k = F - K_k F_{0\cdot}`
    (predict, then update at every sample) is

    .. math:: \hat s_{a+i} = \Phi_i \hat s_{a-1} + \sum_{j \le i} \Psi_{ij} z_{a+j},
       \quad \Phi_i = A_{a+i} \Phi_{i-1}, \quad \Psi_{ij} = A_{a+i} \Psi_{i-1,j},
       \quad \Psi_{ii} = K_{a+i};

    backward, the smoother :math:`\tilde s_k = \hat s_k + C_k(\tilde s_{k+1} - F\hat s_k)`
    is

    .. math:: \tilde s_{a+i} = \Gamma_i \tilde s_e + \sum_{j \ge i} \Omega_{ij}
       \hat s_{a+j}, \quad \Gamma_i = C_{a+i} \Gamma_{i+1}, \quad
       \Omega_{ij} = C_{a+i} \Omega_{i+1,j}, \quad \Omega_{ii} = I - C_{a+i} F.

    Each list holds one array per block: ``forward_state`` (B, m, m), ``forward_data``
    (B, m, B), ``backward_state`` (B, m, m), ``backward_data`` (B, m, B, m)."""

    forward_state: list
    forward_data: list
    backward_state: list
    backward_data: list


def transient_maps(filter_gains: np.ndarray, smoother_gains: np.ndarray, F: np.ndarray):
    """:class:`TransientMaps` of the transient gains K_k (T, m) and C_k (T, m, m) of the model
    with transition ``F``, by the recursions of :class:`TransientMaps` run on every block at
    once (a step of all blocks one batched product: B steps in all, not T). Forward, each
    block's step i holds :math:`[\\Phi_i \\mid \\Psi_{i\\cdot}]` from :math:`[I \\mid 0]`;
    backward :math:`[\\Gamma_i \\mid \\Omega_{i\\cdot}]` from :math:`[I \\mid 0]` at the block's
    end. The last block is padded to B steps with A = I, K = 0 (after its end, unused) and
    C = I, I - CF = 0 (before its backward start: they leave :math:`[I \\mid 0]` as it is)."""
    m, steps = F.shape[0], filter_gains.shape[0]
    size = TRANSIENT_BLOCK
    blocks = -(-steps // size)
    padded = blocks * size
    transitions = np.broadcast_to(np.eye(m), (padded, m, m)).copy()
    transitions[:steps] = F[None] - filter_gains[:, :, None] * F[0][None, None, :]  # A_k
    gains = np.zeros((padded, m))
    gains[:steps] = filter_gains
    smoothers = np.broadcast_to(np.eye(m), (padded, m, m)).copy()
    smoothers[:steps] = smoother_gains
    to_smoothed = np.zeros((padded, m, m))
    to_smoothed[:steps] = np.eye(m)[None] - smoother_gains @ F  # I - C_k F
    transitions = transitions.reshape(blocks, size, m, m)
    gains = gains.reshape(blocks, size, m)
    smoothers = smoothers.reshape(blocks, size, m, m)
    to_smoothed = to_smoothed.reshape(blocks, size, m, m)
    forward = np.empty((blocks, size, m, m + size))
    current = np.zeros((blocks, m, m + size))
    current[:, :, :m] = np.eye(m)
    for i in range(size):
        current = transitions[:, i] @ current
        current[:, :, m + i] += gains[:, i]
        forward[:, i] = current
    backward = np.empty((blocks, size, m, m + size * m))
    current = np.zeros((blocks, m, m + size * m))
    current[:, :, :m] = np.eye(m)
    for i in range(size - 1, -1, -1):
        current = smoothers[:, i] @ current
        current[:, :, m + i * m : m + (i + 1) * m] += to_smoothed[:, i]
        backward[:, i] = current
    maps = TransientMaps([], [], [], [])
    for block in range(blocks):
        length = min(size, steps - block * size)
        maps.forward_state.append(forward[block, :length, :, :m].copy())
        maps.forward_data.append(forward[block, :length, :, m : m + length].copy())
        maps.backward_state.append(backward[block, :length, :, :m].copy())
        columns = backward[block, :length, :, m : m + length * m]
        maps.backward_data.append(columns.reshape(length, m, length, m).copy())
    return maps


CONVERGENCE_BLOCK = 16
"""Steps of :func:`covariance_recursion` tested for convergence at once (one vectorised test
instead of one per step: the loop's cost is its numpy calls)."""


def covariance_recursion(model: KalmanModel, prior_covariance: np.ndarray, n: int) -> Gains:
    """Run the covariance part of the filter and smoother (filterpy's equations: Joseph-form
    update, C_k = P_k Fᵀ (F P_k Fᵀ + Q)⁻¹) for n steps or until the gain and the covariance
    are within :data:`CONVERGED` (or the rounding floor) of the steady state
    (:func:`steady_state`; the covariance compared entry by entry on the scale
    :math:`\\sqrt{P_{ii} P_{jj}}`), from which on the steady gains hold."""
    F, Q, R, m = model.F, model.Q, model.R, model.states
    steady = _steady_state(model)
    target_gain, target = steady.filter_gain, steady.covariance
    reach = model.F[0, 1]  # ω_b Δt
    relative = max(CONVERGED, ROUNDING / reach**2)
    gain_tolerance = relative * abs(target_gain).max()
    tolerance = relative * np.sqrt(np.outer(np.diag(target), np.diag(target)))
    F_t = F.T
    identity = np.eye(m)
    P = prior_covariance
    predicted = F @ P @ F_t + Q
    filter_gains, covariances, predictions = [], [], []
    # ndarray methods and the fewest calls a step: this loop is the Kalman smoother's fixed
    # cost per call. F P_k Fᵀ + Q is the next step's prediction and the smoother gain's
    # denominator both: computed once. The smoother gains are taken after the loop, all at
    # once (numpy's inv and matmul run the same LAPACK and BLAS calls on each matrix of a
    # stack as on one: the same bits).
    # The convergence test runs on blocks of CONVERGENCE_BLOCK steps at once, and the
    # recursion stops at the first converged step of the block: the steps after it, computed
    # ahead, are dropped (each step is computed as it would be alone: the same bits).
    done = 0
    while done < n:
        block = min(CONVERGENCE_BLOCK, n - done)
        for _ in range(block):
            gain = predicted[:, 0] / (predicted[0, 0] + R)
            i_kh = identity.copy()
            i_kh[:, 0] -= gain
            P = i_kh @ predicted @ i_kh.T + R * (gain[:, None] * gain[None, :])
            predicted = F @ P @ F_t + Q
            filter_gains.append(gain)
            covariances.append(P)
            predictions.append(predicted)
        gain_errors = np.abs(np.array(filter_gains[done:]) - target_gain).max(axis=1)
        covariance_fits = (np.abs(np.array(covariances[done:]) - target) <= tolerance).all(
            axis=(1, 2)
        )
        converged = np.flatnonzero((gain_errors <= gain_tolerance) & covariance_fits)
        if converged.size:
            last = done + int(converged[0]) + 1
            del filter_gains[last:], covariances[last:], predictions[last:]
            break
        done += block
    smoother_gains = np.array(covariances) @ F_t @ np.linalg.inv(np.array(predictions))
    return Gains(
        filter_gains=np.array(filter_gains),
        smoother_gains=smoother_gains.reshape(-1, m, m),
        steady=steady,
    )


def _steady_state(model: KalmanModel) -> SteadyState:
    """:func:`steady_state` of ``model``, cached by its matrices' contents."""
    return _cached_steady_state(model.F.tobytes(), model.Q.tobytes(), model.R, model.states)


@functools.lru_cache(maxsize=64)
def _cached_steady_state(f_bytes: bytes, q_bytes: bytes, r: float, states: int) -> SteadyState:
    shape = (states, states)
    return steady_state(
        np.frombuffer(f_bytes).reshape(shape), np.frombuffer(q_bytes).reshape(shape), r
    )


def _modes(matrix: np.ndarray):
    """Eigenvalues λ and eigenvectors V (columns) of a real matrix, V⁻¹, and the modes to
    run: one of each complex-conjugate pair (its twin is its conjugate) and each real one."""
    eigenvalues, vectors = np.linalg.eig(matrix)
    return eigenvalues, vectors, np.linalg.inv(vectors), np.flatnonzero(eigenvalues.imag >= 0)


def _mode_twins(poles: np.ndarray, values: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """Values of every mode from those of the ``kept`` ones (each complex pair's twin: its
    conjugate)."""
    full = np.zeros(poles.size, dtype=complex)
    full[kept] = values
    for mode in kept:
        if poles[mode].imag > 0:
            full[int(np.argmin(abs(poles - np.conj(poles[mode]))))] = np.conj(full[mode])
    return full


class _SmootherModes(NamedTuple):
    """The steady filter and smoother in their eigenbases (:func:`_smoother_modes`)."""

    poles: np.ndarray  # λ, of A = (I - KH)F
    vectors: np.ndarray  # V
    inverse: np.ndarray  # V⁻¹
    forward: np.ndarray  # the modes of A run (one of each conjugate pair)
    drive: np.ndarray  # d = V⁻¹K
    poles_c: np.ndarray  # μ, of C
    vectors_c: np.ndarray  # W
    inverse_c: np.ndarray  # W⁻¹
    backward: np.ndarray  # the modes of C run
    coupling: np.ndarray  # c_il = (W⁻¹(I - CF)V)_il / (1 - λ_l μ_i)
    scale: np.ndarray  # b_i μ_i, b = c d


def _smoother_modes(steady: SteadyState, F: np.ndarray) -> _SmootherModes:
    """The eigendecompositions and partial-fraction coefficients both steady passes
    (:func:`_steady_passes`, :func:`_blocked_steady_passes`) run on."""
    m = F.shape[0]
    transition = F - np.outer(steady.filter_gain, F[0])
    poles, vectors, inverse, forward = _modes(transition)
    drive = inverse @ steady.filter_gain
    poles_c, vectors_c, inverse_c, backward = _modes(steady.smoother_gain)
    mixing = inverse_c @ (np.eye(m) - steady.smoother_gain @ F) @ vectors
    coupling = mixing / (1 - poles_c[:, None] * poles[None, :])
    scale = (coupling @ drive) * poles_c
    return _SmootherModes(
        poles,
        vectors,
        inverse,
        forward,
        drive,
        poles_c,
        vectors_c,
        inverse_c,
        backward,
        coupling,
        scale,
    )


def _first_order(pole: complex, x: np.ndarray, before: np.ndarray, out: np.ndarray, backward):
    r""":math:`f_k = \lambda f_{k-1} + x_k` along axis 0 (k = 0..L-1) from :math:`f_{-1}` =
    ``before``, written as real signals s_r into the rows of ``out`` (each of length L + 1,
    :math:`f_{-1}` first, or reversed where ``backward``), with coefficients :math:`a_r`
    (returned) such that :math:`f = \sum_r a_r s_r`: any :math:`\mathrm{Re}(\alpha f)` is
    the real combination :math:`\sum_r \mathrm{Re}(\alpha a_r) s_r`.

    A real λ: f itself (one row). A complex one: :math:`f = (1 - \bar\lambda q^{-1}) w` with
    w the real all-pole recursion :math:`w_k = 2\mathrm{Re}\lambda\, w_{k-1} - |\lambda|^2
    w_{k-2} + x_k` (``scipy.signal.lfilter``, from :math:`w_{-2} = \mathrm{Im} f_{-1} /
    \mathrm{Im}\lambda`, :math:`w_{-1} = \mathrm{Re} f_{-1} + \mathrm{Re}\lambda\,
    w_{-2}`): two rows, w and w delayed one step, coefficients 1 and :math:`-\bar\lambda`.
    Real arithmetic, one pass either way (a complex ``lfilter`` costs 3-4 times more)."""
    order = slice(None, None, -1) if backward else slice(None)
    if pole.imag == 0:
        f = signal.lfilter([1.0], [1.0, -pole.real], x, axis=0, zi=(pole.real * before.real)[None])[
            0
        ]
        out[0][order] = np.concatenate([before.real[None], f])
        return [1.0]
    a1, a2 = -2 * pole.real, abs(pole) ** 2
    older = before.imag / pole.imag  # w_{-2}
    old = before.real + pole.real * older  # w_{-1}
    state = np.stack([-a1 * old - a2 * older, -a2 * old])  # lfilter's, from w_{-1}, w_{-2}
    w = signal.lfilter([1.0], [1.0, a1, a2], x, axis=0, zi=state)[0]
    current, delayed = out[0][order], out[1][order]
    current[0], current[1:] = old, w
    delayed[0], delayed[1:2], delayed[2:] = older, old, w[:-1]  # rows of 1 sample: older
    return [1.0, -np.conj(pole)]


def _steady_passes(
    z: np.ndarray,
    steady: SteadyState,
    F: np.ndarray,
    before: np.ndarray,
    components,
    modes: _SmootherModes | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The steady filter and smoother over a record z (N, channels) whose filter starts from
    the filtered state ``before`` (m, channels):

    .. math::
        \\hat s_k = A \\hat s_{k-1} + K z_k, \\quad A = (I - KH)F; \\qquad
        \\tilde s_{N-1} = \\hat s_{N-1}, \\quad \\tilde s_k = C \\tilde s_{k+1} + (I - CF)\\hat s_k

    In the eigenbases :math:`A = V\\Lambda V^{-1}`, :math:`C = WMW^{-1}` (well conditioned in
    the bandwidth-scaled states: cond(V), cond(W) <= 40 for ``bandwidth_hz * dt`` in [1e-4,
    0.45]) the filter is first-order recursions :math:`y_{l,k} = \\lambda_l y_{l,k-1} + d_l z_k`
    (:math:`y = V^{-1}\\hat s`, d = V⁻¹K), and the smoother's modes :math:`u = W^{-1}\\tilde s`
    are, exactly (the partial fractions of :math:`1/((1-\\mu q)(1-\\lambda q^{-1}))`, summed
    over the finite record),

    .. math::
        u_{i,k} = \\sum_l c_{il}\\, y_{l,k} + \\sigma_{i,k}, \\quad
        c_{il} = \\frac{(W^{-1}(I - CF)V)_{il}}{1 - \\lambda_l \\mu_i}, \\quad
        \\sigma_{i,k} = \\mu_i \\sigma_{i,k+1} + \\mu_i b_i z_{k+1}, \\quad
        \\sigma_{i,N-1} = u_{i,N-1} - \\sum_l c_{il}\\, y_{l,N-1}

    with :math:`b = c\\, d`: one recursion forward per mode of A and one backward per mode of
    C, each on z itself, one per conjugate pair (its twin is its conjugate) in real arithmetic
    (:func:`_first_order`), and each smoothed component a real combination of their outputs
    (one matrix product). Returns the smoothed ``components`` (len(components), N, channels)
    and the whole smoothed state at k = 0 (m, channels). ``modes``: :func:`_smoother_modes`
    of ``steady`` and F, if the caller has them."""
    m = F.shape[0]
    (
        poles,
        vectors,
        inverse,
        forward,
        drive,
        poles_c,
        vectors_c,
        inverse_c,
        backward,
        coupling,
        scale,
    ) = _smoother_modes(steady, F) if modes is None else modes
    start = inverse @ before
    wanted = np.r_[np.asarray(components, dtype=int), np.arange(m)]  # then the state at k = 0
    # s̃_j = Re( Σ_l (W c)_jl y_l + Σ_i W_ji σ_i ), each pair's twin its conjugate
    n, channels = z.shape
    rows = sum(2 if poles[mode].imag else 1 for mode in forward)
    rows += sum(2 if poles_c[i].imag else 1 for i in backward)
    basis = np.empty((rows, n + 1, channels))  # forward rows from k = -1, backward to k = N-1
    weights, row = [], 0
    last_modes = np.zeros((m, channels), dtype=complex)  # y_{l,N-1}
    for mode in forward:
        pole, d = poles[mode], drive[mode]
        coefficients = _first_order(pole, z, start[mode] / d, basis[row:], False)
        parts = basis[row : row + len(coefficients), -1]
        last_modes[mode] = d * sum(a * s for a, s in zip(coefficients, parts, strict=True))
        last_modes[int(np.argmin(abs(poles - np.conj(pole))))] = np.conj(last_modes[mode])
        alpha = (2.0 if pole.imag > 0 else 1.0) * d * (vectors_c @ coupling[:, mode])
        weights += [(alpha[wanted] * a).real for a in coefficients]
        row += len(coefficients)
    last = (vectors @ last_modes).real  # ŝ_{N-1}
    end = inverse_c @ last - coupling @ last_modes  # σ_{N-1}
    reversed_z = z[:0:-1]  # z_{N-1}, ..., z_1
    for i in backward:
        # σ_{i,k} = b_i μ_i χ_{N-1-k}: χ_κ = μ_i χ_{κ-1} + z_{N-κ} from χ_0 = σ_{i,N-1} / (b_i μ_i),
        # written reversed into the rows' samples 1..N (k = 0..N-1)
        coefficients = _first_order(
            poles_c[i], reversed_z, end[i] / scale[i], basis[row:, 1:], True
        )
        alpha = (2.0 if poles_c[i].imag > 0 else 1.0) * scale[i] * vectors_c[:, i]
        weights += [(alpha[wanted] * a).real for a in coefficients]
        row += len(coefficients)
    mix = np.stack(weights, axis=1)  # (len(wanted), rows)
    count = len(wanted) - m
    if channels == 1:  # one BLAS product
        out = (mix[:count] @ basis[:, 1:, 0])[..., None]
    else:
        out = np.einsum("jp,pkc->jkc", mix[:count], basis[:, 1:])
    return out, mix[count:] @ basis[:, 1]


BLOCK_STEPS = 32
"""Samples a block of :func:`_blocked_steady_passes` (the fastest of 16-128 at 1e6 samples
here: 24 ms against 38 ms at 16 and 33 ms at 128)."""

BLOCKED_FROM = 2**16
"""Steady samples from which :func:`rts_smooth` runs the steady part by blocks
(:func:`_blocked_steady_passes`) rather than by recursions (:func:`_steady_passes`): beyond
every record the studies use (9301 samples at most), and beyond the ends check's probes of
any setting with ``bandwidth_hz * dt`` >= 2e-4, whose results thus keep their bits."""


def _blocked_steady_passes(
    z: np.ndarray,
    steady: SteadyState,
    F: np.ndarray,
    before: np.ndarray,
    components,
    out,
    modes: _SmootherModes | None = None,
) -> np.ndarray:
    r""":func:`_steady_passes` by blocks of B = :data:`BLOCK_STEPS` samples, the smoothed
    ``components`` written into ``out`` (len(components), N, channels); returns the whole
    smoothed state at k = 0. The same recursions, driven by z alone (unit drive), forward
    :math:`f_{l,k} = \lambda_l f_{l,k-1} + z_k` and backward
    :math:`\rho_{i,k} = \mu_i \rho_{i,k+1} + z_{k+1}`, give each component as
    :math:`\tilde s_{j,k} = \mathrm{Re}(\sum_l a_{jl} f_{l,k} + \sum_i c_{ji} \rho_{i,k})`
    (:math:`a = W c\, \mathrm{diag}(d)`, :math:`c_{ji} = W_{ji} b_i \mu_i`, twice for one of
    a complex pair). Within block b (samples bB + i, i = 0..B-1)

    .. math::
        f_{l,bB+i} = \lambda_l^{i+1} f_{l,bB-1} + \sum_{t \le i} \lambda_l^{i-t} z_{bB+t},
        \quad \rho_{i,bB+i'} = \mu_i^{B-1-i'} \rho_{i,bB+B-1}
        + \sum_{t > i'} \mu_i^{t-i'-1} z_{bB+t},

    so a block of every component is one product of the block's samples and the 2m carries
    (the recursions' values at the block's edges) with a (B + 2m) × B matrix: one matrix
    product a component for the whole record (BLAS) instead of a recursion a mode. The
    carries are themselves first-order recursions over blocks, with poles
    :math:`\lambda^B`, :math:`\mu^B` (``lfilter`` on N/B values). The last 1..B samples are
    run by :func:`_steady_passes`, from the filtered state the blocks end on; its smoothed
    state at their first sample starts the backward carries. The same values to rounding
    (tested against eps cond(V) cond(W) (B + g²) of the output, g = 1/(1 - max|pole|); seen
    about 1e-14 relative), in a third of the time at 1e6 samples (C. S. Burrus, "Block
    realization of digital filters", IEEE Trans. Audio Electroacoust. 20 (1972) 230-235).
    ``modes``: :func:`_smoother_modes` of ``steady`` and F, if the caller has them."""
    m = F.shape[0]
    n, channels = z.shape
    block = BLOCK_STEPS
    count = (n - 1) // block  # whole blocks; the tail keeps 1..B samples
    head = count * block
    modes = _smoother_modes(steady, F) if modes is None else modes
    (
        poles,
        vectors,
        inverse,
        forward,
        drive,
        poles_c,
        vectors_c,
        inverse_c,
        backward,
        coupling,
        scale,
    ) = modes
    lam, mu = poles[forward], poles_c[backward]
    twice_f = np.where(lam.imag > 0, 2.0, 1.0)
    twice_b = np.where(mu.imag > 0, 2.0, 1.0)
    a = (vectors_c @ coupling[:, forward]) * (twice_f * drive[forward])  # (m, modes of A)
    c = vectors_c[:, backward] * (twice_b * scale[backward])  # (m, modes of C)
    steps = np.arange(block)
    lag = steps[None, :] - steps[:, None]  # i - t: row t (the sample), column i (the output)
    causal = np.where(lag >= 0, 1.0, 0.0)
    within_f = lam[:, None, None] ** np.maximum(lag, 0)[None] * causal  # (L, B, B)
    within_b = mu[:, None, None] ** np.maximum(-lag - 1, 0)[None] * (1 - causal)
    carry_f = lam[:, None] ** (steps + 1)[None, :]  # f_{bB-1} into sample bB + i
    carry_b = mu[:, None] ** (block - 1 - steps)[None, :]  # rho_{bB+B-1} into bB + i
    # the recursions' values at block ends, from each block's samples: f_{bB+B-1} gains
    # sum_t lam^(B-1-t) z_{bB+t}; rho_{bB-1} gains sum_t mu^t z_{bB+t}
    sums = np.concatenate(
        [lam[:, None] ** (block - 1 - steps)[None, :], mu[:, None] ** steps[None, :]]
    ).T
    sums = np.concatenate([sums.real, sums.imag], axis=1)  # (B, 2(L + I)), real products
    matrices = []
    for j in components:
        inner = np.einsum("l,lti->ti", a[j], within_f) + np.einsum("k,kti->ti", c[j], within_b)
        edges = np.concatenate([a[j][:, None] * carry_f, c[j][:, None] * carry_b])
        matrices.append(np.vstack([inner.real, edges.real, -edges.imag]))
    start = inverse @ before
    state0 = np.empty((m, channels))
    design = np.empty((count, block + 2 * (lam.size + mu.size)))
    for channel in range(channels):
        samples = z[:, channel]
        blocks = samples[:head].reshape(count, block)
        totals = blocks @ sums
        half = lam.size + mu.size
        totals = totals[:, :half] + 1j * totals[:, half:]
        first = start[forward, channel] / drive[forward]  # f_{l,-1}
        ends_f = np.empty((count, lam.size), dtype=complex)  # f at each block's last sample
        for mode, pole in enumerate(lam):
            power = pole**block
            ends_f[:, mode] = signal.lfilter(
                [1.0], [1.0, -power], totals[:, mode], zi=[power * first[mode]]
            )[0]
        # the tail, filtered on from the blocks' last filtered state
        last = _mode_twins(poles, drive[forward] * ends_f[-1], forward)
        filtered = (vectors @ last).real[:, None]
        tail_out, following = _steady_passes(
            samples[head:, None], steady, F, filtered, components, modes
        )
        out[:, head:, channel] = tail_out[:, :, 0]
        # backward: rho at the tail's first sample from its smoothed state
        at_head = _mode_twins(poles, drive[forward] * (lam * ends_f[-1] + samples[head]), forward)
        sigma = inverse_c @ following[:, 0] - coupling @ at_head
        rho = sigma[backward] / scale[backward]
        ends_b = np.empty((count, mu.size), dtype=complex)  # rho at each block's last sample
        for i, pole in enumerate(mu):
            power = pole**block
            top = pole * rho[i] + samples[head]  # rho_{head-1}
            ends_b[-1, i] = top
            if count > 1:
                ends_b[-2::-1, i] = signal.lfilter(
                    [1.0], [1.0, -power], totals[:0:-1, lam.size + i], zi=[power * top]
                )[0]
        into_f = np.vstack([first[None, :], ends_f[:-1]])
        design[:, :block] = blocks
        design[:, block:] = np.concatenate(
            [into_f.real, ends_b.real, into_f.imag, ends_b.imag], axis=1
        )
        for row, matrix in enumerate(matrices):
            target = out[row, :head, channel]
            if target.flags.c_contiguous:
                np.matmul(design, matrix, out=target.reshape(count, block))
            else:
                target[:] = (design @ matrix).reshape(-1)
        f0 = lam * first + samples[0]
        rho0 = mu ** (block - 1) * ends_b[0] + (mu[:, None] ** steps[None, :-1]) @ samples[1:block]
        state0[:, channel] = (a @ f0 + c @ rho0).real
    return state0


def rts_smooth(
    z: np.ndarray, model: KalmanModel, mean0, covariance0, components=None, gains=None
) -> np.ndarray:
    """Kalman filter + Rauch-Tung-Striebel smoother, equal to filterpy's ``batch_filter`` +
    ``rts_smoother`` (predict then update at every sample) for every channel at once.

    The covariances do not depend on the data, so they are run once until the steady state;
    the transient is stepped explicitly, or (``gains.transient``, or cached gains on a call
    of few channels: :func:`_cached_maps`) by block maps, and the steady remainder, a linear
    time-invariant recursion forward and one backward, is run mode by mode
    (:func:`_steady_passes`), or from
    :data:`BLOCKED_FROM` steady samples on by blocks (:func:`_blocked_steady_passes`). ``z``
    has shape (n, channels); returns the smoothed states (n, m, channels), or only the state
    ``components`` given (n, len(components), channels). ``gains``: the recursion from
    ``covariance0`` already run (to n steps or more), as :func:`prior_gains` keeps them."""
    F, m = model.F, model.states
    components = list(range(m)) if components is None else list(components)
    n = z.shape[0]
    gains = covariance_recursion(model, covariance0, n) if gains is None else gains
    transient = min(n, len(gains.filter_gains))
    # by block maps when they are prepared and the whole transient is run (a record longer
    # than it), else step by step
    maps = None
    if n > transient:
        maps = gains.transient
        if maps is None and gains.key is not None:
            maps = _cached_maps(gains, z.shape[1])
    blocked = maps is not None
    if blocked:
        filtered = _blocked_filter(z, maps, mean0)
    else:
        filtered = np.empty((transient, m, z.shape[1]))
        state = mean0
        gain_columns = gains.filter_gains[:transient, :, None]
        for k in range(transient):  # s_k = F s_{k-1} + K_k (z_k - (F s_{k-1})_0), in place
            state = np.matmul(F, state, out=filtered[k])
            state += gain_columns[k] * (z[k] - state[0])
    smoothed = np.empty((len(components), n, z.shape[1]))  # component by component
    if n - transient >= max(BLOCKED_FROM, BLOCK_STEPS + 1):
        following = _blocked_steady_passes(
            z[transient:],
            gains.steady,
            F,
            filtered[-1],
            components,
            smoothed[:, transient:],
            gains.modes,
        )
    elif n > transient:
        smoothed[:, transient:], following = _steady_passes(
            z[transient:], gains.steady, F, filtered[-1], components, gains.modes
        )
    else:
        following = filtered[-1]
        smoothed[:, -1] = following[components]
    if blocked:
        _blocked_smoother(filtered, maps, following, components, smoothed)
        return smoothed.transpose(1, 0, 2)
    predicted = F @ filtered  # F s_k for every transient k at once (the same bits)
    for k in range(min(n - 2, transient - 1), -1, -1):
        following = filtered[k] + gains.smoother_gains[k] @ (following - predicted[k])
        smoothed[:, k] = following[components]
    return smoothed.transpose(1, 0, 2)


def _blocked_filter(z: np.ndarray, maps: TransientMaps, mean0: np.ndarray) -> np.ndarray:
    """The filtered states of the transient (T, m, channels) by :class:`TransientMaps`, from
    the prior mean ``mean0`` (m, channels)."""
    blocks = []
    state, a = mean0, 0
    for transition, data in zip(maps.forward_state, maps.forward_data, strict=True):
        size = transition.shape[0]
        driven = (data.reshape(size * data.shape[1], size) @ z[a : a + size]).reshape(
            size, data.shape[1], -1
        )
        block = transition @ state + driven
        blocks.append(block)
        state, a = block[-1], a + size
    return np.concatenate(blocks)


def _blocked_smoother(filtered, maps: TransientMaps, following, components, smoothed) -> None:
    """The smoothed ``components`` of the transient written into ``smoothed`` (components,
    n, channels) by :class:`TransientMaps`, from the smoothed state ``following`` (m,
    channels) just after it and its filtered states (T, m, channels)."""
    a = filtered.shape[0]
    for transition, data in zip(maps.backward_state[::-1], maps.backward_data[::-1], strict=True):
        size = transition.shape[0]
        a -= size
        flat = size * data.shape[1]
        driven = (data.reshape(flat, flat) @ filtered[a : a + size].reshape(flat, -1)).reshape(
            size, data.shape[1], -1
        )
        block = transition @ following + driven
        smoothed[:, a : a + size] = block[:, components].transpose(1, 0, 2)
        following = block[0]


SETTLING = 1e-7
"""What the slowest mode of the steady filter or smoother must fall below to count as settled."""


@functools.lru_cache(maxsize=64)
def prior_gains(model_order: int, dt: float, bandwidth_hz: float) -> Gains:
    """The covariance recursion of ``kalman``'s model from its vague prior (that of any record
    of 4m samples or more: it depends on no data), run to the steady state; cached, as a
    record of n samples needs its first n steps and the same model is called again and again
    (tuning, the ends' probes)."""
    model = _cached_model(model_order, dt, bandwidth_hz)
    _, covariance0 = initial_state(np.zeros((4 * model.states, 1)), model.per_step_coefficient)
    gains = covariance_recursion(model, covariance0, 10**6)
    modes = _smoother_modes(gains.steady, model.F)
    return dataclasses.replace(gains, modes=modes, key=(model_order, dt, bandwidth_hz))


def _cached_maps(gains: Gains, channels: int) -> TransientMaps | None:
    """The block maps of the cached ``gains`` (:func:`prior_gains`', whose ``key`` they hold)
    for a call on ``channels`` channels: None (step) beyond :data:`MAPS_MAX_CHANNELS` channels
    or :data:`MAPS_MAX_STEPS` steps of transient, else built once and kept
    (:func:`_maps_of_prior`)."""
    if channels > MAPS_MAX_CHANNELS or len(gains.filter_gains) > MAPS_MAX_STEPS:
        return None
    return _maps_of_prior(*gains.key)


@functools.lru_cache(maxsize=16)
def _maps_of_prior(model_order: int, dt: float, bandwidth_hz: float) -> TransientMaps:
    """:func:`transient_maps` of :func:`prior_gains`' gains; cached apart from them, for the
    last 16 settings (at most a few MB each, :data:`MAPS_MAX_STEPS`)."""
    gains = prior_gains(model_order, dt, bandwidth_hz)
    model = _cached_model(model_order, dt, bandwidth_hz)
    return transient_maps(gains.filter_gains, gains.smoother_gains, model.F)


@functools.lru_cache(maxsize=64)
def _end_reach(model_order: int, dt: float, bandwidth_hz: float) -> int:
    """Samples at each end that differ from the steady smoother: the gains' transient from the
    vague prior, plus the steps the slowest steady mode (filter :math:`(I - KH)F` or smoother
    C) takes to fall to 1e-7."""
    model = _cached_model(model_order, dt, bandwidth_hz)
    transient = len(prior_gains(model_order, dt, bandwidth_hz).filter_gains)
    steady = _steady_state(model)
    a_matrix = model.F - np.outer(steady.filter_gain, model.F[0])
    radius = max(
        np.max(np.abs(np.linalg.eigvals(a_matrix))),
        np.max(np.abs(np.linalg.eigvals(steady.smoother_gain))),
    )
    return transient + int(np.ceil(np.log(SETTLING) / np.log(radius)))


def irregular_models(
    model_order: int, times: np.ndarray, bandwidth_hz: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Per-step transitions and process noises of :func:`polynomial_model` at irregular
    ``times``, in the states scaled by the mean step h (:math:`s_j = x^{(j)} h^j / j!`): for
    the step :math:`\Delta_k = t_k - t_{k-1}` (:math:`\Delta_0 = h`, from the prior),
    :math:`F_k = T F(\Delta_k) T^{-1}` and :math:`Q_k = T Q(\Delta_k) T`, T = diag(h^j/j!),
    with Q from :func:`integrated_white_noise` at the spectral density of the uniform model
    of step h. Returns (Fs, Qs, to_derivatives)."""
    states = model_order + 1
    step = mean_step(times)
    density = (2 * math.pi * bandwidth_hz) ** (2 * states) * step
    to_derivatives = np.array([math.factorial(j) / step**j for j in range(states)])
    gaps = np.r_[step, np.diff(times)]
    Fs = np.empty((times.size, states, states))
    Qs = np.empty_like(Fs)
    for k, gap in enumerate(gaps):
        raw = np.array(
            [
                [gap ** (j - i) / math.factorial(j - i) if j >= i else 0.0 for j in range(states)]
                for i in range(states)
            ]
        )
        Fs[k] = raw * to_derivatives[None, :] / to_derivatives[:, None]
        noise = integrated_white_noise(states, gap, density)
        Qs[k] = noise / np.outer(to_derivatives, to_derivatives)
    return Fs, Qs, to_derivatives


@functools.lru_cache(maxsize=64)
def _cached_model(model_order: int, dt: float, bandwidth_hz: float) -> KalmanModel:
    return polynomial_model(model_order, dt, bandwidth_hz)


@register("kalman")
class KalmanSmoother(Method):
    """Rauch-Tung-Striebel smoother of a polynomial model (constant acceleration, jerk, or a
    constant 4th or 5th derivative).

    .. math::
        s_{k} = F s_{k-1} + w_k, \\quad z_k = s_{k,0} + v_k, \\quad
        \\hat x^{(n)}_k = E[s_{k,n} \\mid z_0, \\dots, z_{N-1}]

    with the model of :func:`polynomial_model` (:func:`integrated_white_noise`) and
    the vague prior of :func:`initial_state`. Equal to filterpy's ``KalmanFilter.batch_filter`` +
    ``rts_smoother`` (tested to 1e-9), computed by :func:`rts_smooth` over all channels at
    once. Linear in the data; estimates every sample; an end sample stays valid only where its
    response is within twice the interior's error over the band the interior claims
    (:mod:`methods._ends`; the others are masked). Exact on polynomials of degree
    ``model_order`` (the model's own signals).

    Time stamps (``t=``) are native: the same model with each step's own transition and
    process noise (:func:`irregular_models`), run by filterpy's ``batch_filter`` +
    ``rts_smoother`` themselves (per channel), q set by the mean step; the ends are trusted
    over the same spans of time as on the uniform record of the mean step.

    Parameters
    ----------
    bandwidth_hz : float in [1e-4/dt, 1/(2 dt))
        Where the steady-state smoother passes one half; below Nyquist, and at least
        ``1e-4 / dt`` (lower bandwidths take over 6e4 steps to reach the steady state: see
        ``MIN_BANDWIDTH_STEPS``). Checked against the step by ``check_step``.
    model_order : {2, 3, 4, 5}
        2: constant acceleration (white jerk), 3: constant jerk (white snap), 4 and 5: a
        constant 4th or 5th derivative. The higher the order, the steeper the smoother's
        roll-off past its bandwidth (:math:`|H| = 1/(1 + (f/f_b)^{2m})`, m = order + 1): on
        the paper signal, oracle-tuned for ẍ, interior RMSE 559 / 425 / 354 / 309 for
        orders 2 / 3 / 4 / 5 (20 seeds).

    References
    ----------
    H. E. Rauch, F. Tung, C. T. Striebel, AIAA J. 3(8) (1965) 1445-1450; R. Labbe, FilterPy.
    """

    bandwidth_hz: float = param(
        20.0,
        low=0.0,
        low_open=True,
        tune_low=0.5,
        tune_high=200.0,
        log=True,
        doc="-6 dB point of the steady-state smoother, Hz (sets q/R)",
        kind="frequency",
    )
    model_order: int = param(
        2,
        choices=(2, 3, 4, 5),
        integer=True,
        doc="2: constant acceleration, 3: constant jerk, 4, 5: constant 4th, 5th derivative",
    )

    presets = {
        "paper-signal": Preset(
            {"bandwidth_hz": 24.0, "model_order": 3},
            "diffbench, not in the paper: grid over bandwidth 5-80 Hz (40 log-spaced) x model "
            "order 2, 3 on the held-out noise seed 10000, least interior ẍ RMSE",
        ),
        "robot": Preset(
            {"bandwidth_hz": 8.75, "model_order": 2},
            "diffbench, not in the paper: grid on robot-sim, held-out noise seed 10000, least "
            "interior q̈ RMSE",
        ),
    }
    reference = "Rauch, Tung, Striebel (1965); filterpy"
    time_stamps = "native"
    time_symmetric = False  # the prior and the transients differ at the two ends

    def check_step(self, dt: float) -> None:
        check_frequency(
            "bandwidth_hz",
            self.bandwidth_hz,
            dt,
            lowest_hz=MIN_BANDWIDTH_STEPS / dt,
            why_low=f"the steady-state gains settle in about 6 / (bandwidth_hz * dt) steps: below "
            f"{MIN_BANDWIDTH_STEPS:g} / dt that is over 6e4 steps, and from about 5e-6 / dt "
            "beyond the 10^6-step cap",
        )

    def min_samples(self, dt: float) -> int:
        return 2 * (self.model_order + 1)

    def exact_degree(self, order: int) -> float | None:
        return self.model_order

    def end_reach(self, dt: float) -> int | None:
        return _end_reach(self.model_order, float(dt), self.bandwidth_hz)

    def model(self, dt: float) -> KalmanModel:
        return _cached_model(self.model_order, float(dt), self.bandwidth_hz)

    def _response(self, frequency_hz, dt: float, order: int) -> np.ndarray:
        """Response of the steady-state smoother (away from the ends):
        :math:`v = (I - A e^{-i\\theta})^{-1} K`, :math:`w = (I - C e^{i\\theta})^{-1}(I - CF) v`,
        :math:`H = w_n\\, n!/\\Delta t^n`, with A = (I - KH)F and the steady gains K, C."""
        model = self.model(dt)
        steady = _steady_state(model)
        F, m = model.F, model.states
        a_matrix = F - np.outer(steady.filter_gain, F[0])
        c_matrix = steady.smoother_gain
        theta = 2 * np.pi * frequency_hz * dt
        identity = np.eye(m)[None, :, :]
        behind = np.exp(-1j * theta)[:, None, None]
        forward = np.linalg.solve(
            identity - a_matrix[None] * behind,
            np.broadcast_to(steady.filter_gain, (theta.size, m))[..., None],
        )
        mix = (np.eye(m) - c_matrix @ F)[None] @ forward
        backward = np.linalg.solve(identity - c_matrix[None] / behind, mix)[..., 0]
        response = backward[:, order] * model.to_derivatives[order]
        return response

    def _estimate(self, x, dt, orders):
        flat = x.reshape(x.shape[0], -1)
        model = self.model(dt)
        mean0, covariance0 = initial_state(flat, model.per_step_coefficient)
        known = flat.shape[0] >= 4 * model.states  # the prior of prior_gains
        gains = prior_gains(self.model_order, float(dt), self.bandwidth_hz) if known else None
        smoothed = rts_smooth(flat, model, mean0, covariance0, components=orders, gains=gains)
        valid = np.ones(x.shape[0], dtype=bool)
        values = {
            order: (smoothed[:, c, :] * model.to_derivatives[order]).reshape(x.shape)
            for c, order in enumerate(orders)
        }
        return values, {order: valid.copy() for order in orders}

    def _estimate_at(self, x, times, orders):
        from filterpy.kalman import KalmanFilter

        from diffbench.methods._ends import trusted_times

        n = times.size
        if n < self.min_samples(1.0):
            raise ValueError(
                f"`x` has {n} samples on axis 0; at least {self.min_samples(1.0)} are needed"
            )
        step = float((times[-1] - times[0]) / (n - 1))
        self.check_step(step)
        flat = x.reshape(n, -1)
        Fs, Qs, to_derivatives = irregular_models(self.model_order, times, self.bandwidth_hz)
        states = self.model_order + 1
        trusted = trusted_times(self, times, step, orders)
        # states scaled by the mean step h (s_j = x^(j) h^j / j!): the polynomial's coefficients
        steps = (times - times[0]) / step + 1.0
        mean0, covariance0 = initial_state(flat, np.ones(states), steps)
        smoothed = np.empty((n, states, flat.shape[1]))
        for channel in range(flat.shape[1]):
            kf = KalmanFilter(dim_x=states, dim_z=1)
            kf.x = mean0[:, channel].copy()
            kf.P = covariance0.copy()
            kf.H = np.eye(1, states)
            kf.R = np.eye(1)
            means, covariances, _, _ = kf.batch_filter(flat[:, channel], Fs=Fs, Qs=Qs)
            smoothed[:, :, channel] = kf.rts_smoother(means, covariances, Fs=Fs, Qs=Qs)[0]
        values = {
            order: (smoothed[:, order, :] * to_derivatives[order]).reshape(x.shape)
            for order in orders
        }
        return values, trusted
