"""Kalman smoothing with a polynomial (constant-acceleration or constant-jerk) model."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import linalg

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
    ``len(filter_gains)`` steps (until the steady state), then the steady ones; ``tables``:
    the steps' matrices as the compiled loops take them (:func:`step_tables`)."""

    filter_gains: np.ndarray  # (T, m)
    smoother_gains: np.ndarray  # (T, m, m)
    steady: SteadyState
    tables: tuple


def step_tables(
    F: np.ndarray, filter_gains: np.ndarray, smoother_gains: np.ndarray, steady: SteadyState
) -> tuple:
    """The filter's and smoother's matrices of every step, the transient's T and then the
    steady one (T + 1 entries), padded for :func:`diffbench.methods._kalman_loops.smooth`:
    :math:`A_k = (I - K_k H) F`, :math:`K_k`, :math:`C_k` and :math:`I - C_k F`."""
    from diffbench.methods import _kalman_loops as loops

    m = F.shape[0]
    width = loops.width(m)
    gains = np.vstack([filter_gains.reshape(-1, m), steady.filter_gain[None]])
    smoothers = np.concatenate([smoother_gains.reshape(-1, m, m), steady.smoother_gain[None]])
    transitions = F[None] - gains[:, :, None] * F[0][None, None, :]
    mixes = np.eye(m)[None] - smoothers @ F
    return loops.padded_tables(transitions, gains, smoothers, mixes, width)


RECURSION_CHUNK = 256
"""Steps of :func:`covariance_recursion` a compiled call runs at most (the arrays it fills
grow by as many, whatever the number of steps asked)."""


def covariance_recursion(model: KalmanModel, prior_covariance: np.ndarray, n: int) -> Gains:
    """Run the covariance part of the filter and smoother (filterpy's equations: Joseph-form
    update, C_k = P_k Fᵀ (F P_k Fᵀ + Q)⁻¹) for n steps or until the gain and the covariance
    are within :data:`CONVERGED` (or the rounding floor) of the steady state
    (:func:`steady_state`; the covariance compared entry by entry on the scale
    :math:`\\sqrt{P_{ii} P_{jj}}`), from which on the steady gains hold. The steps run
    compiled (:func:`diffbench.methods._kalman_loops.covariance_steps`), by chunks of
    :data:`RECURSION_CHUNK`; the smoother gains are taken after them, all at once."""
    from diffbench.methods import _kalman_loops as loops

    F, Q, R, m = model.F, model.Q, model.R, model.states
    steady = _steady_state(model)
    target_gain, target = steady.filter_gain, steady.covariance
    reach = model.F[0, 1]  # ω_b Δt
    relative = max(CONVERGED, ROUNDING / reach**2)
    gain_tolerance = relative * abs(target_gain).max()
    tolerance = relative * np.sqrt(np.outer(np.diag(target), np.diag(target)))
    predicted = F @ prior_covariance @ F.T + Q
    chunks, done = [], 0
    while done < n:
        size = min(RECURSION_CHUNK, n - done)
        chunk = (np.empty((size, m)), np.empty((size, m, m)), np.empty((size, m, m)))
        steps, converged = loops.covariance_steps(
            F, Q, R, predicted, target_gain, target, gain_tolerance, tolerance, *chunk
        )
        chunks.append([part[:steps] for part in chunk])
        done += steps
        if converged:
            break
    parts = zip(*chunks, strict=True)
    filter_gains, covariances, predictions = (np.concatenate(part) for part in parts)
    smoother_gains = (covariances @ F.T @ np.linalg.inv(predictions)).reshape(-1, m, m)
    return Gains(
        filter_gains=filter_gains,
        smoother_gains=smoother_gains,
        steady=steady,
        tables=step_tables(F, filter_gains, smoother_gains, steady),
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


def rts_smooth(
    z: np.ndarray, model: KalmanModel, mean0, covariance0, components=None, gains=None
) -> np.ndarray:
    """Kalman filter + Rauch-Tung-Striebel smoother, equal to filterpy's ``batch_filter`` +
    ``rts_smoother`` (predict then update at every sample) for every channel at once.

    The covariances do not depend on the data, so they are run once until the steady state
    (:func:`covariance_recursion`); the states' recursions, forward and backward, with each
    step's gains (the transient's, then the steady ones) run as one compiled loop a channel
    (:func:`diffbench.methods._kalman_loops.smooth`). ``z`` has shape (n, channels); returns
    the smoothed states (n, m, channels), or only the state ``components`` given (n,
    len(components), channels). ``gains``: the recursion from ``covariance0`` already run
    (to n steps or more), as :func:`prior_gains` keeps them."""
    from diffbench.methods import _kalman_loops as loops

    m = model.states
    components = list(range(m)) if components is None else list(components)
    gains = covariance_recursion(model, covariance0, z.shape[0]) if gains is None else gains
    start = loops.padded(np.asarray(mean0, dtype=float).T, 1, gains.tables[1].shape[1])
    states = loops.smooth(z.T, start, *gains.tables)  # (channels, n, width)
    return states[:, :, components].transpose(1, 2, 0)


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
    return covariance_recursion(model, covariance0, 10**6)


@functools.lru_cache(maxsize=8)
def _steady_response(
    model_order: int, dt: float, bandwidth_hz: float, frequencies: bytes
) -> np.ndarray:
    """The steady smoother's state response w (frequencies, m) of
    :meth:`KalmanSmoother._response` at the ``frequencies`` (their float64 bytes), for every
    state at once; cached, as the ends check asks each order at the same frequencies."""
    model = _cached_model(model_order, dt, bandwidth_hz)
    steady = _steady_state(model)
    F, m = model.F, model.states
    a_matrix = F - np.outer(steady.filter_gain, F[0])
    c_matrix = steady.smoother_gain
    theta = 2 * np.pi * np.frombuffer(frequencies) * dt
    identity = np.eye(m)[None, :, :]
    behind = np.exp(-1j * theta)[:, None, None]
    forward = np.linalg.solve(
        identity - a_matrix[None] * behind,
        np.broadcast_to(steady.filter_gain, (theta.size, m))[..., None],
    )
    mix = (np.eye(m) - c_matrix @ F)[None] @ forward
    states = np.linalg.solve(identity - c_matrix[None] / behind, mix)[..., 0]
    states.flags.writeable = False
    return states


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
    with F's entries :math:`\Delta_k^{j-i}/(j-i)!` and Q :func:`integrated_white_noise`'s
    at the spectral density of the uniform model of step h, for every step at once. Returns
    (Fs, Qs, to_derivatives)."""
    states = model_order + 1
    step = mean_step(times)
    density = (2 * math.pi * bandwidth_hz) ** (2 * states) * step
    to_derivatives = np.array([math.factorial(j) / step**j for j in range(states)])
    gaps = np.r_[step, np.diff(times)][:, None, None]
    index = np.arange(states)
    ahead = index[None, :] - index[:, None]  # j - i
    factorials = np.array([float(math.factorial(k)) for k in range(2 * states)])
    raw = np.where(ahead >= 0, gaps ** np.maximum(ahead, 0) / factorials[np.abs(ahead)], 0.0)
    Fs = raw * to_derivatives[None, None, :] / to_derivatives[None, :, None]
    power = 2 * states - 1 - index[:, None] - index[None, :]
    below = factorials[states - 1 - index]
    noise = density * (gaps**power / (np.outer(below, below) * power))
    Qs = noise / np.outer(to_derivatives, to_derivatives)
    return Fs, Qs, to_derivatives


def irregular_smooth(
    z: np.ndarray, Fs: np.ndarray, Qs: np.ndarray, R: float, mean0, covariance0
) -> np.ndarray:
    r"""Kalman filter + Rauch-Tung-Striebel smoother with each step's own model (``Fs``,
    ``Qs``: (n, m, m), :func:`irregular_models`), equal to filterpy's ``batch_filter`` +
    ``rts_smoother`` given ``Fs=Fs, Qs=Qs`` (predict with step k's model, then update; the
    smoother's :math:`C_k = P_k F_{k+1}^\top (F_{k+1} P_k F_{k+1}^\top + Q_{k+1})^{-1}`,
    :math:`\tilde s_k = C_k \tilde s_{k+1} + (I - C_k F_{k+1}) \hat s_k`), for every channel
    at once. The covariances do not depend on the data: their recursion runs once, compiled
    (:func:`diffbench.methods._kalman_loops.varying_covariance_steps`), and the states' with
    each step's tables (:func:`diffbench.methods._kalman_loops.smooth`). ``z``: (n, channels);
    returns the smoothed states (n, m, channels)."""
    from diffbench.methods import _kalman_loops as loops

    n, m = Fs.shape[0], Fs.shape[1]
    predicted = Fs[0] @ covariance0 @ Fs[0].T + Qs[0]
    gains = np.empty((n, m))
    covariances = np.empty((n, m, m))
    predictions = np.empty((n, m, m))
    predictions[-1] = np.eye(m)  # no step after the last: its smoother gain is never used
    loops.varying_covariance_steps(Fs, Qs, float(R), predicted, gains, covariances, predictions)
    smoothers = np.zeros((n, m, m))
    smoothers[:-1] = covariances[:-1] @ np.swapaxes(Fs[1:], 1, 2) @ np.linalg.inv(predictions[:-1])
    mixes = np.broadcast_to(np.eye(m), (n, m, m)).copy()
    mixes[:-1] -= smoothers[:-1] @ Fs[1:]
    transitions = Fs - gains[:, :, None] * Fs[:, 0][:, None, :]
    width = loops.width(m)
    tables = loops.padded_tables(transitions, gains, smoothers, mixes, width)
    start = loops.padded(np.asarray(mean0, dtype=float).T, 1, width)
    states = loops.smooth(np.asarray(z, dtype=float).T, start, *tables)  # (channels, n, width)
    return states[:, :, :m].transpose(1, 2, 0)


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
    process noise (:func:`irregular_models`), filtered and smoothed by
    :func:`irregular_smooth` (filterpy's ``batch_filter`` + ``rts_smoother`` with per-step
    models, its tests' oracle), q set by the mean step; the ends are trusted
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
        :math:`H = w_n\\, n!/\\Delta t^n`, with A = (I - KH)F and the steady gains K, C
        (:func:`_steady_response`: the solves shared by the orders asked at the same
        frequencies)."""
        frequencies = np.ascontiguousarray(frequency_hz, dtype=float)
        states = _steady_response(
            self.model_order, float(dt), self.bandwidth_hz, frequencies.tobytes()
        )
        return states[:, order] * self.model(dt).to_derivatives[order]

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
        smoothed = irregular_smooth(flat, Fs, Qs, 1.0, mean0, covariance0)
        values = {
            order: (smoothed[:, order, :] * to_derivatives[order]).reshape(x.shape)
            for order in orders
        }
        return values, trusted
