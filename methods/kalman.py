"""Kalman smoothing with a polynomial (constant-acceleration or constant-jerk) model."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import fft as sp_fft

from diffbench.methods._registry import Method, Preset, param, register
from diffbench.methods._validation import check_frequency

_STATIONARY = 4 * np.finfo(float).eps  # relative change of the gains that counts as none
_SETTLED = 1e-11  # relative change accepted as converged once held for 50 m steps
_NEGLIGIBLE = 1e-18  # relative size at which the impulse responses are truncated

MIN_BANDWIDTH_STEPS = 1e-4
"""Lowest ``bandwidth_hz * dt``. The steady-state gains (which the frequency response needs)
take about 5-6 / (bandwidth_hz * dt) steps of the covariance recursion: measured 4.8e4 to
6.0e4 steps (2-3 s) at 1e-4, 1.5e5 to 2.0e5 (5-8 s) at 3e-5, 4.3e5 to 5.5e5 (19-24 s) at
1e-5, against a cap of 10^6 steps (below about 5e-6 the 'steady' gains are a truncation). The
estimate itself stays exact on polynomials at any bandwidth (it runs at most one step per
sample)."""


@dataclass(frozen=True)
class KalmanModel:
    r"""The state-space model in scaled states :math:`s_j = x^{(j)} \Delta t^j / j!`
    (j = 0..m-1): transition F, process noise Q, measurement variance R (H = [1, 0, ...]),
    and ``to_derivatives`` (:math:`j!/\Delta t^j`) mapping s_j back to :math:`x^{(j)}`."""

    F: np.ndarray
    Q: np.ndarray
    R: float
    to_derivatives: np.ndarray

    @property
    def states(self) -> int:
        return self.F.shape[0]


def polynomial_model(model_order: int, dt: float, bandwidth_hz: float) -> KalmanModel:
    """The model of ``kalman``: an (m-1)-times integrated white noise observed in noise.

    In the state :math:`(x, \\dot x, \\dots, x^{(m-1)})`, ``m = model_order + 1``, the
    transition is :math:`F_{ij} = \\Delta t^{j-i}/(j-i)!` and the process noise is
    ``filterpy.common.Q_continuous_white_noise`` of spectral density
    :math:`q = (2\\pi f_b)^{2m} R\\,\\Delta t`, R = 1. For that q the continuous Wiener smoother
    has :math:`|H| = 1/(1 + (f/f_b)^{2m})`, so ``bandwidth_hz`` (:math:`f_b`) is where it passes
    one half (-6 dB, like a forward-backward Butterworth at its cutoff). Only q/R matters for
    the smoothed means (scaling both scales every covariance and leaves the gains unchanged),
    which is why one parameter, as a bandwidth, describes the smoother.

    The model is returned in the scaled states :math:`s_j = x^{(j)}\\Delta t^j/j!` (the same
    model under a diagonal change of variables: :math:`F' = TFT^{-1}` holds binomial
    coefficients, :math:`Q' = TQT^\top`), whose covariances are far better conditioned: with
    raw derivatives at 1 kHz the entries of Q span 20 orders of magnitude.
    """
    from filterpy.common import Q_continuous_white_noise  # lazy: filterpy imports slowly

    states = model_order + 1
    density = (2 * math.pi * bandwidth_hz) ** (2 * states) * dt
    noise = np.asarray(Q_continuous_white_noise(dim=states, dt=dt, spectral_density=density))
    to_derivatives = np.array([math.factorial(j) / dt**j for j in range(states)])
    scaled_noise = noise / np.outer(to_derivatives, to_derivatives)
    transition = np.array(
        [[math.comb(j, i) if j >= i else 0 for j in range(states)] for i in range(states)],
        dtype=float,
    )
    return KalmanModel(F=transition, Q=scaled_noise, R=1.0, to_derivatives=to_derivatives)


PRIOR_SCALE = 1e6
"""How vague the prior is: its covariance is this many times that of the least-squares start.
Measured on clean sin 3t (31 samples, dt = 0.1 s, bandwidth 2 Hz, constant jerk): the L2 error
of ẋ over the record is 1.38 at 10 (the scale used until 2026-11), 0.37 at 1e3, 0.08 at 1e6,
0.06 at 1e9; the start then follows the data instead of the prior's guess."""


def initial_state(
    z: np.ndarray, states: int, steps: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    r"""Prior mean and covariance of the scaled state one step before the first sample: vague.

    A least-squares polynomial :math:`p(u) = \sum_j c_j u^j` (u in steps) of degree m-1
    through the first min(n, 4m) samples, sample j at u = j + 1: the scaled state at u = 0 is
    the coefficients c themselves; covariance ``PRIOR_SCALE`` R (VᵀV)⁻¹, so that the data, not
    the guess, decide the first estimates. A polynomial of the model's degree starts the filter
    on its exact state, so the smoother reproduces it exactly. ``steps``: the samples' times in
    steps from the prior (irregular times; default 1, 2, ...). ``z`` has shape (n, channels);
    the mean has shape (m, channels). The covariance does not depend on the data.
    """
    count = min(z.shape[0], 4 * states)
    steps = np.arange(1, count + 1, dtype=float) if steps is None else steps[:count]
    vandermonde = steps[:, None] ** np.arange(states)[None, :]
    coefficients, *_ = np.linalg.lstsq(vandermonde, z[:count], rcond=None)
    return coefficients, PRIOR_SCALE * np.linalg.inv(vandermonde.T @ vandermonde)


@dataclass(frozen=True)
class Gains:
    """Data-independent gains: per-step filter gains K_k and smoother gains C_k for the first
    ``len(filter_gains)`` steps, then their steady values."""

    filter_gains: np.ndarray  # (T, m)
    smoother_gains: np.ndarray  # (T, m, m)
    steady_filter: np.ndarray  # (m,)
    steady_smoother: np.ndarray  # (m, m)


def covariance_recursion(
    model: KalmanModel, prior_covariance: np.ndarray, n: int, stop_at_rest: bool = False
) -> Gains:
    """Run the covariance part of the filter and smoother (filterpy's equations: Joseph-form
    update, C_k = P_k Fᵀ (F P_k Fᵀ + Q)⁻¹) for n steps or until both gains are stationary
    to rounding (relative change <= 4 eps for 2m consecutive steps, or <= 1e-11 for 50m steps
    where rounding keeps the last bits moving): the recursion's own fixed point, which is what
    filterpy converges to.

    With ``stop_at_rest`` (for the steady gains alone, see :func:`_steady_gains`), also stop
    once P itself is still to 4 eps (elementwise, relative) for 50m steps: the fixed point
    too, reached while P flips in its last bits and C, computed through the ill-conditioned
    (F P Fᵀ + Q)⁻¹ at low bandwidth_hz * dt, amplifies the flips beyond 1e-11 (measured, for
    the constant-jerk model: C alternating by 1e-7 at bandwidth_hz * dt = 2.7e-4, wandering by
    1e-6 at 2.4e-4), so that the first two stops may never come (10^6 steps, 37 s, for one
    frequency response). The estimate keeps the first two stops (it runs at most n steps).
    """
    F, Q, R, m = model.F, model.Q, model.R, model.states
    F_t = F.T
    identity = np.eye(m)
    inverse = np.linalg.inv
    P = prior_covariance
    filter_gains, smoother_gains = [], []
    quiet = settled = resting = 0
    for _ in range(n):
        previous = P
        predicted = F @ P @ F_t + Q
        gain = predicted[:, 0] / (predicted[0, 0] + R)
        i_kh = identity.copy()
        i_kh[:, 0] -= gain
        P = i_kh @ predicted @ i_kh.T + R * (gain[:, None] * gain[None, :])
        smoother = P @ F_t @ inverse(F @ P @ F_t + Q)
        if filter_gains:
            # ndarray methods: this loop is the Kalman smoother's fixed cost per call
            gain_still = abs(gain - filter_gains[-1]).max() <= _STATIONARY * abs(gain).max()
            scale = _STATIONARY * abs(smoother).max()
            still = gain_still and abs(smoother - smoother_gains[-1]).max() <= scale
            quiet = quiet + 1 if still else 0
            # Where rounding keeps the last bits moving, settle for 1e-11 held for 50 m steps.
            close = abs(gain - filter_gains[-1]).max() <= _SETTLED * abs(gain).max() and (
                abs(smoother - smoother_gains[-1]).max() <= _SETTLED * abs(smoother).max()
            )
            settled = settled + 1 if close else 0
            at_rest = (abs(P - previous) <= _STATIONARY * abs(P)).all()
            resting = resting + 1 if at_rest else 0
        filter_gains.append(gain)
        smoother_gains.append(smoother)
        if quiet >= 2 * m or settled >= 50 * m or (stop_at_rest and resting >= 50 * m):
            break
    return Gains(
        filter_gains=np.array(filter_gains),
        smoother_gains=np.array(smoother_gains),
        steady_filter=filter_gains[-1],
        steady_smoother=smoother_gains[-1],
    )


def _powers_times(matrix: np.ndarray, vectors: np.ndarray, limit: int) -> np.ndarray:
    """``matrix^j @ vectors`` for j = 0.. until negligible (or ``limit``): shape (L, ...)."""
    out = [vectors]
    scale = float(abs(vectors).max()) or 1.0
    current = vectors
    while len(out) < limit:
        current = matrix @ current
        out.append(current)
        if len(out) % 8 == 0 and abs(current).max() < _NEGLIGIBLE * scale:
            break
    return np.array(out)


def _causal_filter(u: np.ndarray, kernels: np.ndarray) -> np.ndarray:
    """y_k = sum_j kernels[j] @ u_{k-j} for vector sequences: u (N, b, c), kernels (L, a, b)
    -> (N, a, c).

    Overlap-add FFT convolution with the spectra shared: each block of u is transformed once
    per input component and mixed by the kernel spectra (a x b) before one inverse transform
    per output, so the cost is that of a + b convolutions, not a x b."""
    n, inputs, channels = u.shape
    length, outputs = kernels.shape[0], kernels.shape[1]
    size = sp_fft.next_fast_len(max(4 * length, 1 << 12), real=True)
    hop = size - length + 1
    blocks = -(-n // hop)
    # time last and contiguous, each block already zero-padded to the FFT size
    padded = np.zeros((inputs, channels, blocks, size))
    series = np.zeros((inputs, channels, blocks * hop))
    series[:, :, :n] = u.transpose(1, 2, 0)
    padded[..., :hop] = series.reshape(inputs, channels, blocks, hop)
    spectra_u = sp_fft.rfft(padded, axis=-1, workers=-1)
    kernel_padded = np.zeros((outputs, inputs, size))
    kernel_padded[..., :length] = kernels.transpose(1, 2, 0)
    spectra_k = sp_fft.rfft(kernel_padded, axis=-1)  # (a, b, F)
    out = np.empty((outputs, channels, blocks, hop))
    for a in range(outputs):
        mixed = sum(spectra_k[a, b][None, None, :] * spectra_u[b] for b in range(inputs)
                    if spectra_k[a, b].any())  # fmt: skip
        pieces = sp_fft.irfft(mixed, n=size, axis=-1, workers=-1)  # (channels, blocks, size)
        out[a] = pieces[:, :, :hop]
        out[a, :, 1:, : length - 1] += pieces[:, :-1, hop : hop + length - 1]
    flat = out.reshape(outputs, channels, blocks * hop)[:, :, :n]
    return flat.transpose(2, 0, 1)


def rts_smooth(z: np.ndarray, model: KalmanModel, mean0, covariance0) -> np.ndarray:
    """Kalman filter + Rauch-Tung-Striebel smoother, equal to filterpy's ``batch_filter`` +
    ``rts_smoother`` (predict then update at every sample) for every channel at once.

    The covariances do not depend on the data, so they are run once until the gains are
    steady; the transient is stepped explicitly and the steady remainder is a linear
    time-invariant recursion, applied as a (truncated, < 1e-18 relative) impulse response by
    FFT convolution. ``z`` has shape (n, channels); returns the smoothed states (n, m, channels).
    """
    F, m = model.F, model.states
    n = z.shape[0]
    gains = covariance_recursion(model, covariance0, n)
    transient = len(gains.filter_gains)
    filtered = np.empty((n, m, z.shape[1]))
    state = mean0
    for k in range(min(n, transient)):
        predicted = F @ state
        state = predicted + np.outer(gains.filter_gains[k], z[k] - predicted[0])
        filtered[k] = state
    if n > transient:
        # x_k = A x_{k-1} + K z_k with A = (I - K H) F, from k = transient on.
        steady = gains.steady_filter
        a_matrix = F - np.outer(steady, F[0])
        impulse = _powers_times(a_matrix, steady[:, None], n - transient)  # (L, m, 1)
        tail = z[transient:][:, None, :]
        filtered[transient:] = _causal_filter(tail, impulse)
        start = _powers_times(a_matrix, filtered[transient - 1], n - transient + 1)[1:]
        filtered[transient : transient + start.shape[0]] += start
    smoothed = np.empty_like(filtered)
    smoothed[n - 1] = filtered[n - 1]
    if n - 1 > transient:
        # x~_k = C x~_{k+1} + (I - C F) x^_k for k in [transient, n-2], run in reversed time.
        c_matrix = gains.steady_smoother
        reversed_filtered = filtered[transient:][::-1].copy()  # index i <-> k = n - 1 - i
        last = reversed_filtered[0].copy()
        reversed_filtered[0] = 0.0
        powers = _powers_times(c_matrix, np.eye(m), n - transient)  # C^j
        kernels = powers @ (np.eye(m) - c_matrix @ F)  # G_j = C^j (I - C F)
        result = _causal_filter(reversed_filtered, kernels)
        ends = powers @ last  # C^i x^_{n-1}
        result[: ends.shape[0]] += ends
        smoothed[transient:] = result[::-1]
    for k in range(min(n - 2, transient - 1), -1, -1):
        c_k = gains.smoother_gains[k]
        smoothed[k] = filtered[k] + c_k @ (smoothed[k + 1] - F @ filtered[k])
    return smoothed


@functools.lru_cache(maxsize=64)
def _steady_gains(model_order: int, dt: float, bandwidth_hz: float) -> Gains:
    """The steady gains of the model (the recursion run from the usual prior until stationary;
    cached: the frequency response needs them for every frequency set)."""
    model = _cached_model(model_order, dt, bandwidth_hz)
    _, covariance0 = initial_state(np.zeros((4 * model.states, 1)), model.states)
    return covariance_recursion(model, covariance0, 10**6, stop_at_rest=True)


SETTLING = 1e-7
"""What the slowest mode of the steady filter or smoother must fall below to count as settled."""


@functools.lru_cache(maxsize=64)
def _end_reach(model_order: int, dt: float, bandwidth_hz: float) -> int:
    """Samples at each end that differ from the steady smoother: the gains' transient from the
    vague prior, plus the steps the slowest steady mode (filter :math:`(I - KH)F` or smoother
    C) takes to fall to 1e-7."""
    model = _cached_model(model_order, dt, bandwidth_hz)
    _, covariance0 = initial_state(np.zeros((4 * model.states, 1)), model.states)
    transient = len(covariance_recursion(model, covariance0, 10**6).filter_gains)
    gains = _steady_gains(model_order, dt, bandwidth_hz)
    a_matrix = model.F - np.outer(gains.steady_filter, model.F[0])
    radius = max(
        np.max(np.abs(np.linalg.eigvals(a_matrix))),
        np.max(np.abs(np.linalg.eigvals(gains.steady_smoother))),
    )
    return transient + int(np.ceil(np.log(SETTLING) / np.log(radius)))


def irregular_models(
    model_order: int, times: np.ndarray, bandwidth_hz: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Per-step transitions and process noises of :func:`polynomial_model` at irregular
    ``times``, in the states scaled by the mean step h (:math:`s_j = x^{(j)} h^j / j!`): for
    the step :math:`\Delta_k = t_k - t_{k-1}` (:math:`\Delta_0 = h`, from the prior),
    :math:`F_k = T F(\Delta_k) T^{-1}` and :math:`Q_k = T Q(\Delta_k) T`, T = diag(h^j/j!),
    with Q from filterpy's ``Q_continuous_white_noise`` at the spectral density of the
    uniform model of step h. Returns (Fs, Qs, to_derivatives)."""
    from filterpy.common import Q_continuous_white_noise

    states = model_order + 1
    step = float((times[-1] - times[0]) / (times.size - 1))
    density = (2 * math.pi * bandwidth_hz) ** (2 * states) * step
    to_derivatives = np.array([math.factorial(j) / step**j for j in range(states)])
    gaps = np.r_[step, np.diff(times)]
    Fs = np.empty((times.size, states, states))
    Qs = np.empty_like(Fs)
    for k, gap in enumerate(gaps):
        raw = np.array(
            [[gap ** (j - i) / math.factorial(j - i) if j >= i else 0.0 for j in range(states)]
             for i in range(states)]
        )  # fmt: skip
        Fs[k] = raw * to_derivatives[None, :] / to_derivatives[:, None]
        noise = np.asarray(Q_continuous_white_noise(dim=states, dt=gap, spectral_density=density))
        Qs[k] = noise / np.outer(to_derivatives, to_derivatives)
    return Fs, Qs, to_derivatives


@functools.lru_cache(maxsize=64)
def _cached_model(model_order: int, dt: float, bandwidth_hz: float) -> KalmanModel:
    return polynomial_model(model_order, dt, bandwidth_hz)


@register("kalman")
class KalmanSmoother(Method):
    """Rauch-Tung-Striebel smoother of a constant-acceleration (or constant-jerk) model.

    .. math::
        s_{k} = F s_{k-1} + w_k, \\quad z_k = s_{k,0} + v_k, \\quad
        \\hat x^{(n)}_k = E[s_{k,n} \\mid z_0, \\dots, z_{N-1}]

    with the model of :func:`polynomial_model` (filterpy's ``Q_continuous_white_noise``) and
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
    model_order : {2, 3}
        2: constant acceleration (white jerk), 3: constant jerk (white snap).

    References
    ----------
    H. E. Rauch, F. Tung, C. T. Striebel, AIAA J. 3(8) (1965) 1445-1450; R. Labbe, FilterPy.
    """

    bandwidth_hz: float = param(
        20.0, low=0.0, low_open=True, tune_low=0.5, tune_high=200.0, log=True,
        doc="-6 dB point of the steady-state smoother, Hz (sets q/R)", kind="frequency",
    )  # fmt: skip
    model_order: int = param(
        2, choices=(2, 3), integer=True, doc="2: constant acceleration, 3: constant jerk"
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
            "bandwidth_hz", self.bandwidth_hz, dt,
            lowest_hz=MIN_BANDWIDTH_STEPS / dt,
            why_low=f"the steady-state gains settle in about 6 / (bandwidth_hz * dt) steps: below "
            f"{MIN_BANDWIDTH_STEPS:g} / dt that is over 6e4 steps, and from about 5e-6 / dt "
            "beyond the 10^6-step cap",
        )  # fmt: skip

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
        gains = _steady_gains(self.model_order, float(dt), self.bandwidth_hz)
        F, m = model.F, model.states
        a_matrix = F - np.outer(gains.steady_filter, F[0])
        c_matrix = gains.steady_smoother
        theta = 2 * np.pi * frequency_hz * dt
        identity = np.eye(m)[None, :, :]
        behind = np.exp(-1j * theta)[:, None, None]
        forward = np.linalg.solve(
            identity - a_matrix[None] * behind,
            np.broadcast_to(gains.steady_filter, (theta.size, m))[..., None],
        )
        mix = (np.eye(m) - c_matrix @ F)[None] @ forward
        backward = np.linalg.solve(identity - c_matrix[None] / behind, mix)[..., 0]
        response = backward[:, order] * model.to_derivatives[order]
        return response

    def _estimate(self, x, dt, orders):
        flat = x.reshape(x.shape[0], -1)
        model = self.model(dt)
        mean0, covariance0 = initial_state(flat, model.states)
        smoothed = rts_smooth(flat, model, mean0, covariance0)
        valid = np.ones(x.shape[0], dtype=bool)
        values = {
            order: (smoothed[:, order, :] * model.to_derivatives[order]).reshape(x.shape)
            for order in orders
        }
        return values, {order: valid.copy() for order in orders}

    def _estimate_at(self, x, times, orders):
        from filterpy.kalman import KalmanFilter

        from diffbench.methods._ends import mask_untrusted, trusted_times

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
        trusted = trusted_times(self, times, step, orders)  # before the filter: may refuse
        mean0, covariance0 = initial_state(flat, states, (times - times[0]) / step + 1.0)
        smoothed = np.empty((n, states, flat.shape[1]))
        for channel in range(flat.shape[1]):
            kf = KalmanFilter(dim_x=states, dim_z=1)
            kf.x = mean0[:, channel].copy()
            kf.P = covariance0.copy()
            kf.H = np.eye(1, states)
            kf.R = np.eye(1)
            means, covariances, _, _ = kf.batch_filter(flat[:, channel], Fs=Fs, Qs=Qs)
            smoothed[:, :, channel] = kf.rts_smoother(means, covariances, Fs=Fs, Qs=Qs)[0]
        values = {}
        for order in orders:
            estimate = (smoothed[:, order, :] * to_derivatives[order]).reshape(x.shape)
            values[order] = mask_untrusted(estimate, trusted[order])
        return values, trusted
