r"""Random signals with a known spectrum and exact derivatives, and the least error any
differentiator can reach on them.

Each family is a linear stochastic differential equation (a Gauss–Markov process) whose state
holds the signal and its derivatives,

.. math:: dz = F z\,dt + L\,dW, \qquad z = (x, \dot x, \ddot x, \dots), \qquad
    \mathrm E[dW^2] = q_c\,dt,

so a realisation is drawn exactly on any grid from the discretised model
:math:`z_{j+1} = A z_j + w_j`, :math:`w_j \sim \mathcal N(0, Q)` (Van Loan's method), and the
derivatives are the state itself: no finite differences anywhere.

* :class:`IntegratedWhiteNoise`: :math:`x^{(k)} = w` (white), k = 2 (the constant-velocity
  model: ẍ does not exist, it is NaN) or 3 (constant acceleration), spectrum
  :math:`q_c / (2\pi f)^{2k}`; it starts at rest at 0 (it has no stationary law).
* :class:`Matern`: the stationary Matérn process of smoothness ν = 5/2 or 7/2 (mean-square
  differentiable ⌈ν⌉ - 1 times: ẍ exists for both), length scale ℓ and standard deviation σ,
  started from its stationary law.
* :class:`BandLimited`: a stationary Gaussian process with a flat spectrum over [-B, B], drawn
  exactly on K lines (every derivative exists). It has no finite state: its bound is its exact
  posterior on the record (:func:`gaussian_posterior`, below).

**The bound.** For samples :math:`y_j = x(j\Delta t) + e_j` with white noise of standard
deviation σ_n, no estimator of :math:`x^{(n)}(t_j)` from the whole record has a smaller mean
squared error than the Wiener smoother's, which for these models is the Rauch–Tung–Striebel
smoother with the true model. Far from the ends of a record (its error there is the infinite
record's) the bound is computed two independent ways:

* from the spectra (:func:`smoother_bound_spectral`): the error spectrum of the state given
  every sample, in information form,

  .. math:: \mathrm{MMSE}_n = \int_{-1/2\Delta t}^{1/2\Delta t} c_n^\top
      \left[\frac{G(f)^{-H} Q^{-1} G(f)^{-1}}{\Delta t}
      + \frac{h h^\top}{\sigma_n^2 \Delta t}\right]^{-1} c_n\,df,
      \qquad G(f)^{-1} = I - A e^{-i 2\pi f \Delta t},

  with :math:`h` picking x and :math:`c_n` picking :math:`x^{(n)}`. The sampled model is exact,
  so everything the grid aliases is accounted for; for a spectrum negligible above Nyquist it
  is :math:`\int (2\pi f)^{2n} S N/(S + N)\,df`, :math:`N = \sigma_n^2\Delta t`.
* from the steady state of the smoother (:func:`smoother_bound`): the filter's predicted
  covariance from the discrete algebraic Riccati equation, the smoother's from a discrete
  Lyapunov equation. The same function gives the **causal bound** (the filter's covariance:
  the least error of any estimate of :math:`x^{(n)}(t_j)` from samples up to :math:`t_j`).

For any stationary signal with a covariance function, :func:`gaussian_posterior` gives the
optimal estimate and its error on the finite record itself (dense, O(n³)): for a Gauss–Markov
signal it equals the RTS smoother (tested), for a band-limited one it is the bound.

References
----------
C. E. Rasmussen, C. K. I. Williams, *Gaussian Processes for Machine Learning*, MIT Press (2006),
ch. 4 (Matérn); J. Hartikainen, S. Särkkä, "Kalman filtering and smoothing solutions to temporal
Gaussian process regression models", IEEE MLSP (2010) (the state-space form); C. F. Van Loan,
"Computing integrals involving the matrix exponential", IEEE TAC 23 (1978); B. D. O. Anderson,
J. B. Moore, *Optimal Filtering*, Prentice-Hall (1979), ch. 7 (the steady-state smoother);
N. Wiener, *Extrapolation, Interpolation, and Smoothing of Stationary Time Series*, MIT (1949).
"""

from __future__ import annotations

import abc
import functools
import math
import warnings
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import integrate, linalg

from diffbench.signals._checks import check_real, check_rng, check_times
from diffbench.signals.clean import MAX_ORDER, Signal, Truth, register_signal


class RandomSignal(Signal):
    """A signal drawn at random: :meth:`draw` gives a realisation with its exact derivatives
    (a scenario draws it from its seed); :meth:`evaluate` is refused (there is no one signal
    to evaluate)."""

    random: ClassVar[bool] = True
    derivative_orders: ClassVar[tuple[int, ...]] = (1, 2)
    """The derivative orders (1..2) that exist and are drawn."""

    @abc.abstractmethod
    def draw(self, t: np.ndarray, rng: np.random.Generator) -> Truth:
        """A realisation at the times ``t`` with its exact derivatives, from ``rng``."""

    def _derivatives(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise ValueError(
            f"{self.name} is a random signal: draw a realisation with `draw(t, rng)` (or realise "
            "a scenario built on it), there is no one signal to evaluate"
        )


@dataclass(frozen=True)
class Model:
    """The state-space model :math:`dz = Fz\\,dt + L\\,dW`, :math:`E[dW^2] = q_c dt`, of a
    :class:`GaussMarkov` signal; ``stationary``: it starts from its stationary law (else at
    rest at 0)."""

    F: np.ndarray
    L: np.ndarray
    q_c: float
    stationary: bool

    @property
    def states(self) -> int:
        return self.F.shape[0]

    def discretise(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(A, Q)``: the exact transition over ``dt`` and the covariance of the noise it
        adds (Van Loan 1978; see :func:`_discretise`)."""
        scaled_a, scaled_q, _, scale = self._discretised(dt)
        return scaled_a * np.outer(1 / scale, scale), scaled_q / np.outer(scale, scale)

    def transition_and_root(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(A, R)``: the transition over ``dt`` and a square root R of the noise covariance
        (R Rᵀ = Q), each entry to its own relative precision (see :func:`_discretise`)."""
        scaled_a, _, scaled_root, scale = self._discretised(dt)
        return scaled_a * np.outer(1 / scale, scale), scaled_root / scale[:, None]

    def scaled_discretisation(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r"""``(A', Q', s)``: the model over ``dt`` in the state :math:`z'_k = s_k z_k`,
        :math:`s_k = \Delta t^k` (each derivative times the step to its order), where
        :func:`_discretise` computes it: its entries are of one size, so Riccati and
        Lyapunov equations on it are well conditioned (read-only arrays)."""
        scaled_a, scaled_q, _, scale = self._discretised(dt)
        return scaled_a, scaled_q, scale

    def _discretised(self, dt: float):
        return _discretise(self.F.tobytes(), self.L.tobytes(), self.q_c, self.states, float(dt))

    def stationary_covariance(self) -> np.ndarray:
        """:math:`P_\\infty`, solving :math:`F P + P F^\\top + q_c L L^\\top = 0`."""
        if not self.stationary:
            raise ValueError("an integrated white noise has no stationary law")
        return linalg.solve_continuous_lyapunov(self.F, -self.q_c * np.outer(self.L, self.L))


@functools.lru_cache(maxsize=256)
def _discretise(f_bytes: bytes, l_bytes: bytes, q_c: float, states: int, dt: float):
    r"""``(A', Q', R', s)``: the model over ``dt`` by Van Loan's block exponential, in the
    state :math:`z'_k = \Delta t^k z_k` and the time :math:`u = t/\Delta t`
    (:math:`F' = \Delta t\, S F S^{-1}`, :math:`L' = S L`, :math:`q'_c = q_c \Delta t`,
    S = diag(s), :math:`s_k = \Delta t^k`, a unit step), with :math:`R' R'^\top = Q'`
    (:func:`_root`). :class:`Model` brings them back: :math:`A = S^{-1} A' S`,
    :math:`Q = S^{-1} Q' S^{-1}`, :math:`R = S^{-1} R'`.

    In the original state the entries of Q span :math:`q_c \Delta t^{2k+1}` down to
    :math:`q_c \Delta t^{2(k-i)+1}`: rounding relative to the largest swamps the smallest
    and an eigendecomposition of Q resolves its small eigenvalues only to that rounding: at
    10 µs a drawn Matérn 7/2's ẋ differentiated to its ẍ only to 1.7e-3 (RMS, relative) on
    one machine, and to within 3e-4 on another. In the scaled state the entries are of one
    size, so every entry of Q and of its root keeps its own relative precision (4.6e-6 there,
    the finite difference's own error). The root is not the one of the unscaled Q: the same
    seed draws another realisation of the same law (records drawn before differ).

    Reference: C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE
    Trans. Automatic Control 23 (1978) 395-404.
    """
    F = np.frombuffer(f_bytes).reshape(states, states)
    L = np.frombuffer(l_bytes)
    scale = dt ** np.arange(states)
    scaled_f = dt * F * np.outer(scale, 1 / scale)
    scaled_l = scale * L
    block = np.zeros((2 * states, 2 * states))
    block[:states, :states] = -scaled_f
    block[:states, states:] = q_c * dt * np.outer(scaled_l, scaled_l)
    block[states:, states:] = scaled_f.T
    exponential = linalg.expm(block)
    scaled_a = exponential[states:, states:].T
    scaled_q = scaled_a @ exponential[:states, states:]
    scaled_q = 0.5 * (scaled_q + scaled_q.T)
    scaled_root = _root(scaled_q)
    for array in (scaled_a, scaled_q, scaled_root, scale):
        array.flags.writeable = False
    return scaled_a, scaled_q, scaled_root, scale


class GaussMarkov(RandomSignal):
    """A random signal whose state :math:`(x, \\dot x, \\dots)` follows a linear SDE
    (:class:`Model`); drawn exactly on any grid (see the module docstring)."""

    @abc.abstractmethod
    def model(self) -> Model:
        """The state-space model."""

    @property
    def derivative_orders(self) -> tuple[int, ...]:
        """The orders 1..2 the state holds."""
        return tuple(range(1, min(self.model().states, MAX_ORDER + 1)))

    @abc.abstractmethod
    def spectral_density(self, frequency_hz) -> np.ndarray:
        """Two-sided power spectral density of x at ``frequency_hz`` (unit² / Hz): its
        integral over all frequencies is the variance (where it is finite)."""

    def draw(self, t, rng) -> Truth:
        r"""A realisation at the times ``t`` (any increasing times): :math:`z_0` from the
        stationary law (or 0), then :math:`z_{j+1} = A(\Delta_j) z_j + Q(\Delta_j)^{1/2}
        \varepsilon_j` with :math:`\varepsilon_j` standard normal from ``rng`` (one block of
        ``(n, states)`` draws, after the initial state's)."""
        t = check_times(t)
        rng = check_rng(rng)
        steps = np.diff(t)
        if np.any(steps <= 0):
            raise ValueError("`t` must be strictly increasing to draw a random signal on it")
        model = self.model()
        states = model.states
        first = rng.standard_normal(states)
        if model.stationary:
            z = np.linalg.cholesky(model.stationary_covariance()) @ first
        else:
            z = np.zeros(states)
        shocks = rng.standard_normal((t.size, states))
        path = np.empty((t.size, states))
        path[0] = z
        factors: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        for j, step in enumerate(steps):
            if step not in factors:
                factors[step] = model.transition_and_root(step)
            A, root = factors[step]
            z = A @ z + root @ shocks[j + 1]
            path[j + 1] = z
        columns = [
            path[:, k] if k < states else np.full(t.size, np.nan) for k in range(MAX_ORDER + 1)
        ]
        return Truth(t=t, derivatives=tuple(columns))

    def cross_covariance(self, lag_s, order: int, other: int) -> np.ndarray:
        r""":math:`\mathrm{Cov}(x^{(a)}(t + \tau), x^{(b)}(t))` at the lags τ = ``lag_s``
        (a = ``order``, b = ``other``, both held in the state) of the stationary law:
        :math:`[e^{F\tau} P_\infty]_{ab}` for τ ≥ 0, :math:`[e^{F|\tau|} P_\infty]_{ba}`
        for τ < 0 (one matrix exponential per lag)."""
        model = self.model()
        stationary = model.stationary_covariance()  # refuses a process without one
        lag = np.atleast_1d(np.asarray(lag_s, dtype=float))
        values = np.empty(lag.size)
        for index, value in enumerate(lag):
            covariance = linalg.expm(model.F * abs(value)) @ stationary
            values[index] = covariance[order, other] if value >= 0 else covariance[other, order]
        return values


def _root(Q: np.ndarray) -> np.ndarray:
    """A square root R of the covariance Q (R Rᵀ = Q), by eigenvalues: Q of a short step is
    nearly singular, which Cholesky refuses."""
    values, vectors = np.linalg.eigh(Q)
    return vectors * np.sqrt(np.clip(values, 0.0, None))


@register_signal("integrated_white_noise")
@dataclass(frozen=True, kw_only=True)
class IntegratedWhiteNoise(GaussMarkov):
    r"""White noise integrated ``times`` times: :math:`x^{(k)}(t) = w(t)`, the
    constant-velocity (k = 2) and constant-acceleration (k = 3) models of tracking.

    .. math:: S_x(f) = \frac{q_c}{(2\pi f)^{2k}}

    State :math:`(x, \dots, x^{(k-1)})`, at rest at 0 at the first sample. With k = 2, ẍ is
    white noise and does not exist as a function: it is NaN.

    Parameters
    ----------
    times : int, 2 or 3
        k, how many times the white noise is integrated.
    intensity : float
        :math:`q_c` > 0, the spectral density of the white noise (unit² s^(1-2k)).

    References
    ----------
    Y. Bar-Shalom, X. R. Li, T. Kirubarajan, *Estimation with Applications to Tracking and
    Navigation*, Wiley (2001), sec. 6.2.
    """

    times: int = 3
    intensity: float = 1.0

    def __post_init__(self) -> None:
        if self.times not in (2, 3) or isinstance(self.times, bool):
            raise ValueError(f"`times` must be 2 or 3, got {self.times!r}")
        object.__setattr__(self, "intensity", check_real("intensity", self.intensity, gt=0))

    def model(self) -> Model:
        k = self.times
        F = np.eye(k, k, 1)
        L = np.zeros(k)
        L[-1] = 1.0
        return Model(F=F, L=L, q_c=self.intensity, stationary=False)

    def spectral_density(self, frequency_hz) -> np.ndarray:
        omega = 2 * np.pi * np.asarray(frequency_hz, dtype=float)
        with np.errstate(divide="ignore"):
            return self.intensity / omega ** (2 * self.times)


@register_signal("matern")
@dataclass(frozen=True, kw_only=True)
class Matern(GaussMarkov):
    r"""The stationary Matérn process of smoothness :math:`\nu = p + 1/2` (5/2 or 7/2), length
    scale ℓ and standard deviation σ:

    .. math:: S_x(f) = \sigma^2 \frac{2\sqrt\pi\,\Gamma(\nu + 1/2)}{\Gamma(\nu)}
        \frac{\lambda^{2\nu}}{(\lambda^2 + (2\pi f)^2)^{\nu + 1/2}},
        \qquad \lambda = \sqrt{2\nu}/\ell,

    the state :math:`(x, \dots, x^{(p)})` with :math:`F` the companion matrix of
    :math:`(s + \lambda)^{p+1}` (Hartikainen & Särkkä 2010). ν = 5/2 has x, ẋ and ẍ; ν = 7/2
    also a continuous third derivative.

    Parameters
    ----------
    smoothness : float, 2.5 or 3.5
        ν.
    length_scale_s : float
        ℓ > 0, seconds.
    std : float
        σ > 0, the standard deviation of x.

    References
    ----------
    Rasmussen & Williams (2006), sec. 4.2.1; Hartikainen & Särkkä (2010).
    """

    smoothness: float = 2.5
    length_scale_s: float = 0.1
    std: float = 1.0

    def __post_init__(self) -> None:
        if self.smoothness not in (2.5, 3.5):
            raise ValueError(f"`smoothness` must be 2.5 or 3.5, got {self.smoothness!r}")
        for name in ("length_scale_s", "std"):
            object.__setattr__(self, name, check_real(name, getattr(self, name), gt=0))

    @property
    def rate(self) -> float:
        """λ = √(2ν)/ℓ, 1/s."""
        return math.sqrt(2 * self.smoothness) / self.length_scale_s

    def _white_intensity(self) -> float:
        nu = self.smoothness
        return (
            self.std**2
            * 2
            * math.sqrt(math.pi)
            * math.gamma(nu + 0.5)
            / math.gamma(nu)
            * self.rate ** (2 * nu)
        )

    def model(self) -> Model:
        m = int(self.smoothness + 0.5)  # p + 1 states
        F = np.eye(m, m, 1)
        F[-1] = [-math.comb(m, k) * self.rate ** (m - k) for k in range(m)]
        L = np.zeros(m)
        L[-1] = 1.0
        return Model(F=F, L=L, q_c=self._white_intensity(), stationary=True)

    def spectral_density(self, frequency_hz) -> np.ndarray:
        omega = 2 * np.pi * np.asarray(frequency_hz, dtype=float)
        return self._white_intensity() / (self.rate**2 + omega**2) ** (self.smoothness + 0.5)


@register_signal("band_limited")
@dataclass(frozen=True, kw_only=True)
class BandLimited(RandomSignal):
    r"""A stationary Gaussian process whose spectrum is flat over the band [-B, B] and zero
    outside it, drawn exactly by its spectral representation on K lines,

    .. math:: x(t) = \sum_{k<K} a_k\cos\omega_k t + b_k \sin\omega_k t, \qquad
        \omega_k = 2\pi\,\frac{(k + 1/2) B}{K}, \quad a_k, b_k \sim \mathcal N(0, \sigma^2/K),

    so that its covariance is :math:`r(\tau) = \frac{\sigma^2}{K}\sum_k \cos\omega_k\tau`
    (:meth:`cross_covariance`), the flat band's :math:`\sigma^2\,\mathrm{sinc}(2B\tau)` to
    within the lines' spacing B/K (r is antiperiodic over K/B seconds: the default's 30 s,
    ten times the limit scenarios' records). The process is Gaussian (a sum of independent
    Gaussian terms), every derivative exists and is drawn exactly (each term differentiated),
    and the least error of any estimate is that of its exact posterior given the record
    (:func:`gaussian_posterior`): it has no finite state, no Kalman form.

    Parameters
    ----------
    band_hz : float
        B > 0, the band's edge, Hz.
    std : float
        σ > 0, the standard deviation of x.
    lines : int
        K ≥ 1, the lines the band is drawn on.

    References
    ----------
    M. Shinozuka, G. Deodatis, "Simulation of stochastic processes by spectral representation",
    Appl. Mech. Rev. 44 (1991) 191-204 (here with Gaussian amplitudes, so exactly Gaussian);
    A. Papoulis, *Probability, Random Variables and Stochastic Processes* (1991), ch. 11 and 13
    (band-limited processes, derivatives).
    """

    band_hz: float = 20.0
    std: float = 1.0
    lines: int = 600

    def __post_init__(self) -> None:
        for name in ("band_hz", "std"):
            object.__setattr__(self, name, check_real(name, getattr(self, name), gt=0))
        if (
            not isinstance(self.lines, (int, np.integer))
            or isinstance(self.lines, bool)
            or self.lines < 1
        ):
            raise ValueError(f"`lines` must be an integer >= 1, got {self.lines!r}")

    @property
    def angular_frequencies(self) -> np.ndarray:
        """ω_k, rad/s."""
        return 2 * np.pi * (np.arange(self.lines) + 0.5) * self.band_hz / self.lines

    def spectral_density(self, frequency_hz) -> np.ndarray:
        """The flat band's two-sided density σ²/(2B) inside [-B, B] (the K lines' limit)."""
        frequency = np.abs(np.asarray(frequency_hz, dtype=float))
        return np.where(frequency <= self.band_hz, self.std**2 / (2 * self.band_hz), 0.0)

    def cross_covariance(self, lag_s, order: int, other: int) -> np.ndarray:
        r""":math:`\mathrm{Cov}(x^{(a)}(t + \tau), x^{(b)}(t)) = \frac{\sigma^2}{K}\sum_k
        \omega_k^{a+b}\cos(\omega_k\tau + (a - b)\pi/2)` at the lags τ = ``lag_s``
        (a = ``order``, b = ``other``)."""
        lag = np.atleast_1d(np.asarray(lag_s, dtype=float))
        omega = self.angular_frequencies
        phase = np.outer(lag, omega) + (order - other) * np.pi / 2
        return np.cos(phase) @ (omega ** (order + other)) * self.std**2 / self.lines

    def draw(self, t, rng) -> Truth:
        """A realisation at the times ``t`` (any times): the 2K amplitudes drawn from ``rng``
        (cosines' then sines'), x and its derivatives summed term by term."""
        t = check_times(t)
        rng = check_rng(rng)
        amplitudes = rng.standard_normal((2, self.lines)) * (self.std / math.sqrt(self.lines))
        omega = self.angular_frequencies
        cosine, sine = np.cos(np.outer(t, omega)), np.sin(np.outer(t, omega))
        # d/dt (a cos ωt + b sin ωt) = ω (b cos ωt - a sin ωt)
        a, b = amplitudes
        columns = []
        for order in range(MAX_ORDER + 1):
            columns.append(cosine @ (omega**order * a) + sine @ (omega**order * b))
            a, b = b, -a
        return Truth(t=t, derivatives=tuple(columns))


# --- the bound ------------------------------------------------------------------------------
def _check_bound_args(signal, dt: float, noise_std: float, order: int) -> tuple[float, float]:
    if not isinstance(signal, GaussMarkov):
        raise ValueError(f"`signal` must be a Gauss–Markov random signal, got {signal!r}")
    dt = check_real("dt", dt, gt=0)
    noise_std = check_real("noise_std", noise_std, gt=0)
    states = signal.model().states
    if order not in range(states):
        raise ValueError(
            f"`order` must be in 0..{states - 1}: {signal.name} has no derivative of order "
            f"{order!r} (its state holds x and its first {states - 1})"
        )
    return dt, noise_std


@dataclass(frozen=True)
class SteadyBounds:
    """The steady-state error covariances of the state: ``filtered`` (samples up to t: the
    causal bound) and ``smoothed`` (every sample: the bound)."""

    filtered: np.ndarray
    smoothed: np.ndarray


def steady_bounds(signal: GaussMarkov, dt: float, noise_std: float) -> SteadyBounds:
    r"""The steady-state covariances of the Kalman filter and of the RTS smoother of
    ``signal`` sampled every ``dt`` in white noise of standard deviation ``noise_std``.

    The predicted covariance :math:`P^-` solves the discrete algebraic Riccati equation
    :math:`P^- = A P A^\top + Q`, :math:`P = P^- - P^- h (h^\top P^- h + \sigma_n^2)^{-1}
    h^\top P^-`; the smoother gain is :math:`J = P A^\top (P^-)^{-1}` and its covariance
    :math:`P_s` solves :math:`P_s - J P_s J^\top = P - J P^- J^\top` (Anderson & Moore 1979,
    ch. 7)."""
    A, Q, scale = signal.model().scaled_discretisation(dt)
    h = np.zeros((A.shape[0], 1))
    h[0, 0] = 1.0
    R = np.array([[noise_std**2]])
    predicted = linalg.solve_discrete_are(A.T, h, Q, R)
    gain = predicted @ h / (h.T @ predicted @ h + R)
    filtered = predicted - gain @ h.T @ predicted
    smoother = filtered @ A.T @ np.linalg.inv(predicted)
    residual = filtered - smoother @ predicted @ smoother.T
    smoothed = linalg.solve_discrete_lyapunov(smoother, residual)
    unscale = np.outer(scale, scale)
    return SteadyBounds(
        filtered=0.5 * (filtered + filtered.T) / unscale,
        smoothed=0.5 * (smoothed + smoothed.T) / unscale,
    )


def smoother_bound(
    signal: GaussMarkov, dt: float, noise_std: float, order: int, causal: bool = False
) -> float:
    """The least mean squared error of :math:`x^{(n)}(t)` (``order`` n) from every sample
    (``causal``: from the samples up to t), far from the record's ends, by the steady-state
    smoother (filter) covariance (:func:`steady_bounds`)."""
    dt, noise_std = _check_bound_args(signal, dt, noise_std, order)
    bounds = steady_bounds(signal, dt, noise_std)
    return float((bounds.filtered if causal else bounds.smoothed)[order, order])


def smoother_bound_spectral(signal: GaussMarkov, dt: float, noise_std: float, order: int) -> float:
    """The same bound as :func:`smoother_bound` (not causal), from the spectra: the integral of
    the module docstring, by adaptive quadrature over [0, 1/(2 dt)] (the integrand is even in
    f), in the variable f / Nyquist."""
    dt, noise_std = _check_bound_args(signal, dt, noise_std, order)
    A, Q, scale = signal.model().scaled_discretisation(dt)
    states = A.shape[0]
    inverse_q = np.linalg.inv(Q)
    h = np.zeros(states)
    h[0] = 1.0
    observation = np.outer(h, h) / (noise_std**2 * dt)
    nyquist = 0.5 / dt

    def density(fraction: float) -> float:
        inverse_g = np.eye(states) - A * np.exp(-2j * np.pi * fraction * nyquist * dt)
        information = inverse_g.conj().T @ inverse_q @ inverse_g / dt + observation
        return float(np.linalg.solve(information, np.eye(states)[:, order])[order].real)

    # near 0 Hz the information matrix of a smooth process is ill conditioned, which limits
    # the integrand to about 1e-9 relative: quad says so for ν = 7/2 (agreement with
    # smoother_bound, tested: 1e-7)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        value, _ = integrate.quad(density, 0.0, 1.0, limit=400, epsabs=0.0, epsrel=1e-8)
    return 2 * nyquist * value / scale[order] ** 2


# --- the exact posterior of a stationary process on a finite record ---------------------------
@dataclass(frozen=True)
class Posterior:
    """The optimal linear estimates of :math:`x^{(n)}` on a uniform record of n samples:
    ``weights[n]`` (n x n, the estimate is ``weights[n] @ y``) and ``variance[n]`` (the error
    variance at each sample, which no estimator from the same samples beats)."""

    weights: dict
    variance: dict


def gaussian_posterior(
    signal, dt: float, samples: int, noise_std: float, causal: bool = False
) -> Posterior:
    r"""The exact posterior of the derivatives of a stationary Gaussian ``signal`` (with a
    ``cross_covariance``) given ``samples`` samples every ``dt`` in white noise of
    standard deviation ``noise_std``, for each order 1..2 the signal has.

    With :math:`K_{yy} = R + \sigma_n^2 I = L L^\top` (R: the Toeplitz covariance of the
    samples) and :math:`C_{ik} = \mathrm{Cov}(x(t_i), x^{(n)}(t_k))`, let :math:`W = L^{-1}C`
    and :math:`e = L^{-1}y` (the innovations: :math:`e_j` depends on :math:`y_{\le j}` only).
    The posterior mean from every sample is :math:`\hat x^{(n)}_k = \sum_j W_{jk} e_j`, with
    error variance :math:`\mathrm{Var}\,x^{(n)} - \sum_j W_{jk}^2`; from the samples up to
    :math:`t_k` (``causal``) the same sums over :math:`j \le k` (L is lower triangular, so
    the first k + 1 rows of W are those of the record cut at k). No estimate of
    :math:`x^{(n)}(t_k)` from the same samples has a smaller mean squared error (it is the
    conditional mean of a Gaussian vector). Costs O(n³): a few seconds at n = 3001.

    References: Rasmussen & Williams (2006), sec. 2.2 and 9.4 (derivative observations);
    T. Kailath, A. H. Sayed, B. Hassibi, *Linear Estimation*, Prentice Hall (2000), ch. 4
    (innovations).
    """
    dt = check_real("dt", dt, gt=0)
    noise_std = check_real("noise_std", noise_std, gt=0)
    if not isinstance(samples, (int, np.integer)) or samples < 2:
        raise ValueError(f"`samples` must be an integer >= 2, got {samples!r}")
    if not callable(getattr(signal, "cross_covariance", None)):
        raise ValueError(f"`signal` must be a stationary random signal, got {signal!r}")
    return _posterior(signal, float(dt), int(samples), float(noise_std), bool(causal))


@functools.lru_cache(maxsize=2)
def _posterior(signal, dt: float, samples: int, noise_std: float, causal: bool) -> Posterior:
    lags = np.arange(samples) * dt
    covariance = linalg.toeplitz(signal.cross_covariance(lags, 0, 0))
    covariance[np.diag_indices(samples)] += noise_std**2
    root = linalg.cholesky(covariance, lower=True, overwrite_a=True)
    del covariance
    weights, variance = {}, {}
    for order in signal.derivative_orders:
        prior = float(signal.cross_covariance(0.0, order, order)[0])
        # C[i, k] = Cov(x^(n)(t_k), x(t_i)): lag t_k - t_i
        cross = linalg.toeplitz(
            signal.cross_covariance(-lags, order, 0), signal.cross_covariance(lags, order, 0)
        )
        whitened = linalg.solve_triangular(root, cross, lower=True, overwrite_b=True)
        if causal:
            whitened = np.triu(whitened)
        variance[order] = prior - np.einsum("jk,jk->k", whitened, whitened)
        # the estimate W^T L^{-1} y, as one matrix: (L^{-T} W)^T
        weights[order] = linalg.solve_triangular(
            root, whitened, lower=True, trans="T", overwrite_b=True
        ).T
        weights[order].flags.writeable = variance[order].flags.writeable = False
    return Posterior(weights=weights, variance=variance)
