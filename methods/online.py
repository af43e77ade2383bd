"""Causal differentiators for online use: backward differences, a causal Butterworth filter with
backward differences, the causal Jacobi differentiator, the Kalman filter (forward pass) and
the α-β-γ tracker. Each runs on a stream (:mod:`methods._causal`)."""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import signal as sps

from diffbench.methods._causal import (
    CausalFirMethod,
    CausalMethod,
    causal_fir_response,
    fir_state,
    run_fir,
    state_space_response,
)
from diffbench.methods._local_poly import local_polynomial_weights
from diffbench.methods._registry import Preset, param, register
from diffbench.methods._validation import check_frequency
from diffbench.methods.butterworth import _butter_sos
from diffbench.methods.finite_difference import fornberg_weights
from diffbench.methods.jacobi_kernel import half_width
from diffbench.methods.kalman import (
    _steady_state,
    covariance_recursion,
    initial_state,
    polynomial_model,
)

SOURCE_OURS = "diffbench's choice for the paper signal (4/9/15 Hz, 1 kHz), not tuned"


@functools.lru_cache(maxsize=256)
def backward_difference_weights(order: int, accuracy: int) -> np.ndarray:
    """Taps :math:`b_j`, lag 0 first, of the backward difference
    :math:`x^{(n)}_k \\approx \\Delta t^{-n} \\sum_{j=0}^{n+p-1} b_j x_{k-j}` of accuracy
    :math:`p`: the n-th derivative at the newest node of the polynomial through the last
    n + p samples (Fornberg's weights on the nodes 0, -1, ..., -(n+p-1)); exact on
    polynomials of degree n + p - 1, error :math:`O(\\Delta t^p)`. Order 0 is the sample."""
    if order == 0:
        return np.ones(1)
    nodes = -np.arange(order + accuracy, dtype=np.float64)
    return fornberg_weights(nodes, 0.0, order)[order]


@register("backward_difference")
class BackwardDifference(CausalFirMethod):
    """Backward finite differences: the derivative at the newest sample of the polynomial
    through the last n + p samples (no smoothing).

    .. math:: \\hat x^{(n)}_k = \\Delta t^{-n} \\sum_{j=0}^{n+p-1} b^{(n,p)}_j x_{k-j}

    with :math:`b^{(n,p)}` from Fornberg's recursion (:func:`backward_difference_weights`):
    exact on polynomials of degree n + p - 1, error :math:`O(\\Delta t^p)`; p = 1 is Euler's
    backward difference. The first n + p - 1 samples have no estimate of order n.

    Parameters
    ----------
    accuracy : int in [1, 6]
        Accuracy order p of the formula.

    References
    ----------
    B. Fornberg, "Generation of finite difference formulas on arbitrarily spaced grids",
    Math. Comp. 51 (1988) 699-706.
    """

    accuracy: int = param(
        1,
        low=1,
        high=6,
        integer=True,
        tune_low=1,
        tune_high=4,
        doc="accuracy order p (n + p samples per estimate)",
    )

    presets = {"euler": Preset({"accuracy": 1}, "Euler's backward difference", by="defaults")}
    reference = "Fornberg 1988 (backward stencils)"

    def taps(self, order: int, dt: float) -> np.ndarray:
        return backward_difference_weights(order, self.accuracy) / dt**order

    def min_samples(self, dt: float) -> int:
        return self.accuracy + 2

    def exact_degree(self, order: int) -> float | None:
        return order + self.accuracy - 1 if order else math.inf


@register("causal_butterworth")
class CausalButterworth(CausalMethod):
    """Butterworth low-pass run forward only, then backward differences: the paper's baseline
    as a controller would run it.

    .. math::
        \\tilde x = B_{N,f_c} * x, \\qquad
        \\hat{\\dot x}_k = \\frac{\\tilde x_k - \\tilde x_{k-1}}{\\Delta t}, \\qquad
        \\hat{\\ddot x}_k = \\frac{\\tilde x_k - 2\\tilde x_{k-1} + \\tilde x_{k-2}}{\\Delta t^2}

    :math:`B_{N,f_c}` is ``scipy.signal.butter(order, cutoff_hz, output="sos", fs=1/dt)`` run
    by ``sosfilt``; before the first sample the signal is taken at rest at that sample (the
    filter starts in its steady state for it, ``sosfilt_zi``, and the differences see a
    constant past). Response :math:`B(f)` (-3 dB at ``cutoff_hz``, a phase lag) times the
    backward difference's. Exact on constants only.

    Parameters
    ----------
    order : int in [1, 20]
        Order of the filter.
    cutoff_hz : float > 0
        Cutoff (-3 dB) frequency in Hz, below Nyquist.
    difference_accuracy : int in [1, 4]
        Accuracy order of the backward differences (1: Euler).

    References
    ----------
    S. Butterworth, "On the theory of filter amplifiers", Wireless Engineer 7 (1930) 536-541;
    Q. Guo, M. Gautier, D.-Y. Liu, W. Perruquetti, IEEE/ASME AIM 2015 (the offline baseline).
    """

    order: int = param(2, low=1, high=20, integer=True, tune_low=1, tune_high=8, doc="filter order")
    cutoff_hz: float = param(
        20.0,
        low=0.0,
        low_open=True,
        tune_low=1.0,
        tune_high=200.0,
        log=True,
        kind="frequency",
        doc="cutoff frequency, Hz",
    )
    difference_accuracy: int = param(
        1,
        low=1,
        high=4,
        integer=True,
        tune_low=1,
        tune_high=2,
        doc="accuracy order of the backward differences",
    )

    presets = {
        "paper-signal": Preset(
            {"order": 2, "cutoff_hz": 20.0, "difference_accuracy": 1}, SOURCE_OURS
        ),
    }
    reference = "Butterworth 1930; causal form of Guo et al. 2015's baseline"

    def check_step(self, dt: float) -> None:
        check_frequency("cutoff_hz", self.cutoff_hz, dt)

    def _sos(self, dt: float) -> np.ndarray:
        return _butter_sos(self.order, self.cutoff_hz, dt)

    def _difference(self, order: int, dt: float) -> np.ndarray:
        return backward_difference_weights(order, self.difference_accuracy) / dt**order

    def exact_degree(self, order: int) -> float | None:
        return 0 if order == 0 else None

    def _response(self, frequency_hz, dt, order):
        _, gain = sps.sosfreqz(self._sos(dt), worN=frequency_hz, fs=1.0 / dt)
        return gain * causal_fir_response(self._difference(order, dt), frequency_hz, dt)

    def _start(self, first, dt, orders, samples):
        zi = sps.sosfilt_zi(self._sos(dt))  # (sections, 2): steady state for a unit input
        filter_state = zi.reshape(zi.shape + (1,) * first.ndim) * first
        differences = {
            order: fir_state(self._difference(order, dt), first.shape, past=first)
            for order in orders
        }
        return filter_state, differences

    def _advance(self, state, x, dt, orders):
        filter_state, differences = state
        smoothed, filter_state = sps.sosfilt(self._sos(dt), x, axis=0, zi=filter_state)
        values, after = {}, {}
        for order in orders:
            values[order], after[order] = run_fir(
                self._difference(order, dt), smoothed, differences[order]
            )
        return values, (filter_state, after)


@register("causal_jacobi")
class CausalJacobi(CausalFirMethod):
    """Causal Jacobi differentiator: the weighted least-squares polynomial on the window of
    the last T seconds, differentiated at :math:`t - \\delta`.

    On the window :math:`[t - T, t]`, :math:`\\tau = 1 + 2(s - t)/T \\in [-1, 1]`
    (:math:`\\tau = 1` the newest sample), the polynomial :math:`p^*` of degree n + q
    minimising :math:`\\sum_j w(\\tau_j)(x_j - p(\\tau_j))^2`,
    :math:`w(\\tau) = (1 - \\tau)^{\\mu}(1 + \\tau)^{\\kappa}`, gives

    .. math::
        \\hat x^{(n)}(t) = \\frac{d^n p^*}{ds^n}\\Big|_{s = t - \\delta}
        = \\sum_{j=0}^{2M} b_j x_{k-j}

    the discrete (``least_squares`` rule) form of the Jacobi estimator with the expansion
    point moved off the window's centre (Mboup, Join, Fliess 2009: at the window's end for
    :math:`\\delta = 0`, the delay-free estimate; a delay :math:`\\delta` > 0 trades lag for
    less noise and truncation error). μ weights the newest end, κ the oldest (as in the
    central ``jacobi``, μ the later end; with μ > 0 the newest sample has weight 0, so the
    estimate at a sample uses the earlier ones only). With :math:`\\delta = 0` exact on
    polynomials of
    degree n + q; with :math:`\\delta > 0` the estimate is that of :math:`x^{(n)}(t-\\delta)`,
    exactly for the same polynomials. Windows follow the node convention T = 2M·Δt (2M + 1
    taps); the first 2M samples have no estimate.

    Parameters
    ----------
    kappa : float in [0, 400]
        Exponent of (1 + τ): weights the oldest end of the window.
    mu : float in [0, 400]
        Exponent of (1 − τ): weights the newest end.
    q : int in [0, 20]
        Degree of the fit above the derivative's order.
    window_s : float > 0
        Window T for orders 0 and 1, seconds.
    accel_window_s : float > 0
        Window T for order 2, seconds.
    delay_s : float >= 0
        δ, at most the shorter window.

    References
    ----------
    M. Mboup, C. Join, M. Fliess, "Numerical differentiation with annihilators in noisy
    environment", Numer. Algorithms 50 (2009) 439-467; D.-Y. Liu, O. Gibaru, W. Perruquetti,
    "Differentiation by integration with Jacobi polynomials", J. Comput. Appl. Math. 235 (2011)
    3015-3032.
    """

    kappa: float = param(
        1.0,
        low=0.0,
        high=400.0,
        tune_low=0.0,
        tune_high=10.0,
        doc="weight exponent at the oldest end (1+tau)^kappa",
    )
    mu: float = param(
        1.0,
        low=0.0,
        high=400.0,
        tune_low=0.0,
        tune_high=10.0,
        doc="weight exponent at the newest end (1-tau)^mu",
    )
    q: int = param(
        1,
        low=0,
        high=20,
        integer=True,
        tune_low=0,
        tune_high=4,
        doc="fit degree above the derivative order",
    )
    window_s: float = param(
        0.05,
        low=0.0,
        low_open=True,
        tune_low=0.004,
        tune_high=0.5,
        log=True,
        kind="window",
        doc="window T for x and ẋ, s",
    )
    accel_window_s: float = param(
        0.1,
        low=0.0,
        low_open=True,
        tune_low=0.008,
        tune_high=0.8,
        log=True,
        kind="window",
        doc="window T for ẍ, s",
    )
    delay_s: float = param(
        0.0, low=0.0, tune_low=0.0, tune_high=0.05, doc="delay δ of the estimate, s"
    )

    presets = {
        "paper-signal": Preset(
            {
                "kappa": 1.0,
                "mu": 1.0,
                "q": 1,
                "window_s": 0.05,
                "accel_window_s": 0.1,
                "delay_s": 0.0,
            },
            SOURCE_OURS,
        ),
    }
    reference = "Mboup, Join, Fliess 2009; Liu, Gibaru, Perruquetti 2011"

    @classmethod
    def irrelevant_params(cls, order: int) -> tuple[str, ...]:
        return ("window_s",) if order == 2 else ("accel_window_s",)

    def _window(self, order: int) -> tuple[str, float]:
        return (
            ("accel_window_s", self.accel_window_s) if order == 2 else ("window_s", self.window_s)
        )

    def check_step(self, dt: float) -> None:
        for order in (0, 1, 2):
            name, window = self._window(order)
            if self.delay_s > window:
                raise ValueError(
                    f"`delay_s`={self.delay_s!r} s must not exceed `{name}`={window!r} s "
                    "(the estimate is taken inside the window)"
                )
            self.taps(order, dt)

    def min_samples(self, dt: float) -> int:
        return 2 * half_width(max(self.window_s, self.accel_window_s), dt, "window_s") + 1

    def taps(self, order: int, dt: float) -> np.ndarray:
        """Taps :math:`b_j`, lag 0 first (see the class docstring)."""
        name, window = self._window(order)
        half = half_width(window, dt, name)
        return _causal_jacobi_taps(
            order, self.kappa, self.mu, self.q, half, self.delay_s / dt, dt, name
        )

    def exact_degree(self, order: int) -> float | None:
        return order + self.q if self.delay_s == 0 else None


@functools.lru_cache(maxsize=256)
def _causal_jacobi_taps(order, kappa, mu, q, half, delay_steps, dt, name) -> np.ndarray:
    tau = np.arange(-half, half + 1) / half
    with np.errstate(divide="ignore"):
        weights = (1 - tau) ** mu * (1 + tau) ** kappa
    degree = order + q
    carrying = int(np.count_nonzero(weights > 0))
    if carrying <= degree:
        raise ValueError(
            f"`{name}` holds {2 * half + 1} samples, {carrying} of them weighted: too few for "
            f"a fit of degree {degree} (n + q); lengthen `{name}` or lower `q`"
        )
    at = np.array([half - delay_steps])
    taps = local_polynomial_weights(half, degree, order, at, dt, weights)[0, ::-1].copy()
    taps.setflags(write=False)
    return taps


MIN_GAIN_STEPS = 1024
"""Fewest steps of the covariance recursion run at once for the Kalman filter's gains."""

STREAM_GAIN_STEPS = 10**6
"""Steps of the covariance recursion a stream runs at its start (it stops once steady)."""


def _power_of_two(samples: int) -> int:
    return max(MIN_GAIN_STEPS, 1 << (samples - 1).bit_length())


@functools.lru_cache(maxsize=64)
def _kalman_gains(model_order: int, dt: float, bandwidth_hz: float, steps: int):
    """The model and the filter's gains for the first ``steps`` samples (fewer when they turn
    steady before: then the last is the steady gain). The recursion depends on no data, so
    its first steps are the same for any ``steps``: a stream that outgrows them recomputes
    with more and gets the same gains."""
    model = polynomial_model(model_order, dt, bandwidth_hz)
    _, covariance0 = initial_state(np.zeros((4 * model.states, 1)), model.per_step_coefficient)
    return model, covariance_recursion(model, covariance0, steps)


@register("kalman_filter")
class KalmanFilter(CausalMethod):
    """The Kalman filter of ``kalman``'s model, forward pass only (no smoother): the estimate at
    a sample from that sample and the earlier ones.

    .. math::
        \\hat s_{k|k-1} = F \\hat s_{k-1}, \\qquad
        \\hat s_k = \\hat s_{k|k-1} + K_k (x_k - H \\hat s_{k|k-1})

    with the (m-1)-times integrated white-noise model of ``kalman``
    (:func:`~diffbench.methods.kalman.polynomial_model`: F, Q from filterpy, R = 1, the
    process noise set by ``bandwidth_hz``) and gains :math:`K_k` from the covariance recursion
    (data-independent: run once, then steady). The prior, one step before the first sample,
    has the first sample as its level, zero derivatives, and the vague covariance of
    ``kalman``'s start (:data:`~diffbench.methods.kalman.PRIOR_SCALE` times that of a
    least-squares polynomial through 4m samples): the filter follows the data from the first
    samples on. Equal to filterpy's ``KalmanFilter.batch_filter`` from that prior.

    Parameters
    ----------
    model_order : {2, 3}
        2: constant acceleration (state x, ẋ, ẍ); 3: constant jerk.
    bandwidth_hz : float > 0
        Sets the process noise (see ``kalman``); the filter's bandwidth grows with it.

    References
    ----------
    R. E. Kalman, "A new approach to linear filtering and prediction problems", J. Basic Eng.
    82 (1960) 35-45; R. Labbe, FilterPy (the model and the filter's equations).
    """

    model_order: int = param(
        2, choices=(2, 3), integer=True, doc="2: constant acceleration, 3: constant jerk"
    )
    bandwidth_hz: float = param(
        5.0,
        low=0.0,
        low_open=True,
        tune_low=0.5,
        tune_high=100.0,
        log=True,
        kind="frequency",
        doc="model bandwidth, Hz",
    )

    presets = {"paper-signal": Preset({"model_order": 2, "bandwidth_hz": 10.0}, SOURCE_OURS)}
    reference = "Kalman 1960; filterpy's model"

    def check_step(self, dt: float) -> None:
        check_frequency("bandwidth_hz", self.bandwidth_hz, dt)

    def _gains(self, dt: float, steps: int):
        """The model and the gains for the first ``steps`` samples (or until steady: at low
        ``bandwidth_hz * dt`` the recursion takes 10^5 steps and more to settle, which a short
        record never needs; the streams ask for powers of two)."""
        return _kalman_gains(self.model_order, dt, self.bandwidth_hz, steps)

    def _response(self, frequency_hz, dt, order):
        model = polynomial_model(self.model_order, dt, self.bandwidth_hz)
        steady = _steady_state(model).filter_gain
        transition = model.F - np.outer(steady, model.F[0])
        output = np.zeros(model.states)
        output[order] = model.to_derivatives[order]
        return state_space_response(transition, steady, output, frequency_hz, dt)

    def _start(self, first, dt, orders, samples):
        mean = np.zeros((self.model_order + 1, *first.shape))
        mean[0] = first
        # a record's gains as far as it goes; a stream's until steady, once, before its first
        # sample (no push then stalls on the recursion)
        steps = STREAM_GAIN_STEPS if samples is None else _power_of_two(samples)
        return mean, 0, (*self._gains(dt, steps), steps)

    def _advance(self, state, x, dt, orders):
        from diffbench.methods import _causal_loops  # numba: imported on first use

        mean, k, known = state  # known: (model, gains, the steps they were asked for)
        model, gains, steps = known
        if k + x.shape[0] > len(gains.filter_gains) == steps:  # not steady yet: more
            steps = _power_of_two(k + x.shape[0])
            known = (*self._gains(dt, steps), steps)
            model, gains, _ = known
        estimates, mean = _causal_loops.track(
            model.F, x, mean, gains.steady.filter_gain, gains.filter_gains, start=k
        )
        scale = model.to_derivatives
        values = {order: estimates[:, order] * scale[order] for order in orders}
        return values, (mean, k + x.shape[0], known)


@register("alpha_beta_gamma")
class AlphaBetaGamma(CausalMethod):
    """The α-β-γ tracker with critically damped (fading-memory) gains.

    .. math::
        x^-_k = x_{k-1} + \\Delta t\\, v_{k-1} + \\tfrac{\\Delta t^2}{2} a_{k-1}, \\quad
        v^-_k = v_{k-1} + \\Delta t\\, a_{k-1}, \\quad r_k = x_k - x^-_k

        \\hat x_k = x^-_k + \\alpha r_k, \\quad \\hat v_k = v^-_k + \\frac{\\beta}{\\Delta t}
        r_k, \\quad \\hat a_k = a_{k-1} + \\frac{2\\gamma}{\\Delta t^2} r_k

    with :math:`\\alpha = 1 - \\theta^3`, :math:`\\beta = \\tfrac32 (1-\\theta)^2(1+\\theta)`,
    :math:`\\gamma = \\tfrac12 (1-\\theta)^3` and :math:`\\theta = e^{-\\Delta t/T_m}`: the
    steady gains of least squares with the past discounted by θ per step (memory
    :math:`T_m` = ``memory_s``), all three closed-loop poles at θ: the discrete-time
    high-gain observer of the chain of three integrators with its poles placed together at
    :math:`e^{-\\Delta t/T_m}`. A constant acceleration is
    followed with no steady-state error (the start transient decays as θ^k); it starts at the
    first sample with zero velocity and acceleration.

    Parameters
    ----------
    memory_s : float > 0
        Memory time :math:`T_m` of the fading weights, seconds.

    References
    ----------
    E. Brookner, "Tracking and Kalman Filtering Made Easy", Wiley 1998, ch. 1 (the g-h-k
    filter, critically damped gains); N. Morrison, "Introduction to Sequential Smoothing and
    Prediction", McGraw-Hill 1969 (fading-memory polynomial filters).
    """

    memory_s: float = param(
        0.02,
        low=0.0,
        low_open=True,
        tune_low=0.001,
        tune_high=1.0,
        log=True,
        kind="duration",
        doc="fading memory time, s",
    )

    presets = {"paper-signal": Preset({"memory_s": 0.02}, SOURCE_OURS)}
    reference = "Brookner 1998 (critically damped g-h-k)"

    def gains(self, dt: float) -> tuple[float, float, float]:
        """(α, β, γ) at step ``dt``."""
        theta = math.exp(-dt / self.memory_s)
        return 1 - theta**3, 1.5 * (1 - theta) ** 2 * (1 + theta), 0.5 * (1 - theta) ** 3

    def _model(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        alpha, beta, gamma = self.gains(dt)
        transition = np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        return transition, np.array([alpha, beta / dt, 2 * gamma / dt**2])

    def _response(self, frequency_hz, dt, order):
        transition, gain = self._model(dt)
        closed = transition - np.outer(gain, transition[0])
        output = np.zeros(3)
        output[order] = 1.0
        return state_space_response(closed, gain, output, frequency_hz, dt)

    def _start(self, first, dt, orders, samples):
        state = np.zeros((3, *first.shape))
        state[0] = first
        return state, True

    def _advance(self, state, x, dt, orders):
        from diffbench.methods import _causal_loops  # numba: imported on first use

        transition, gain = self._model(dt)
        current, first = state
        starts = first and x.shape[0] > 0
        if starts:  # the first sample is the state (zero velocity and acceleration)
            head, x = current[None], x[1:]
        estimates, current = _causal_loops.track(transition, x, current, gain)
        if starts:
            estimates, first = np.concatenate([head, estimates]), False
        return {order: estimates[:, order] for order in orders}, (current, first)
