"""The high-gain observer of an m-integrator chain (Khalil), of any dimension, run online."""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import signal as sps

from diffbench.methods._causal import CausalMethod, state_space_response
from diffbench.methods._registry import Preset, param, register

SOURCE_OURS = "diffbench's choice for the paper signal (4/9/15 Hz, 1 kHz), not tuned"


def binomial_gains(dimension: int) -> np.ndarray:
    """:math:`\\alpha_i = \\binom{m}{i}`, i = 1..m: the coefficients of :math:`(s+1)^m`, all
    the observer's poles at :math:`-1/\\varepsilon`."""
    return np.array([math.comb(dimension, i) for i in range(1, dimension + 1)], dtype=float)


@functools.lru_cache(maxsize=256)
def discrete_observer(dimension: int, epsilon_s: float, dt: float):
    """``(Ad, Bd, Dd)``: the observer in the scaled coordinates :math:`\\eta_i =
    \\varepsilon^{i-1} z_i` (see :class:`HighGainObserver`), discretised by the first-order
    (triangle) hold with ``scipy.signal.cont2discrete``: :math:`\\xi_{k+1} = A_d \\xi_k + B_d
    x_k`, :math:`\\eta_k = \\xi_k + D_d x_k`."""
    alpha = binomial_gains(dimension)
    shift = np.eye(dimension, k=1)
    a = (shift - np.outer(alpha, np.eye(dimension)[0])) / epsilon_s
    b = (alpha / epsilon_s)[:, None]
    ad, bd, _, dd, _ = sps.cont2discrete(
        (a, b, np.eye(dimension), np.zeros((dimension, 1))), dt, method="foh"
    )
    return ad, bd[:, 0], dd[:, 0]


@register("high_gain_observer")
class HighGainObserver(CausalMethod):
    """The high-gain observer of the chain of m integrators, its poles placed together, run on
    the samples linearly interpolated between them (first-order hold).

    .. math::
        \\dot z_i = z_{i+1} + \\frac{\\alpha_i}{\\varepsilon^i}\\,(y - z_1) \\;(i < m), \\qquad
        \\dot z_m = \\frac{\\alpha_m}{\\varepsilon^m}\\,(y - z_1), \\qquad
        \\hat x^{(n)} = z_{n+1}

    with :math:`\\alpha_i = \\binom{m}{i}`: the error dynamics have the characteristic
    polynomial :math:`(s + 1/\\varepsilon)^m` (all poles at :math:`-1/\\varepsilon`, no
    overshoot of the linear error; Khalil & Praly 2014). :math:`y(t)` is the line through the
    samples on each step, so the observer is integrated exactly between samples
    (``scipy.signal.cont2discrete``, method ``"foh"``; the triangle-hold equivalent of Franklin,
    Powell & Workman): the estimate at :math:`t_k` uses the samples up to :math:`x_k`. It
    runs in the scaled coordinates :math:`\\eta_i = \\varepsilon^{i-1} z_i`, whose matrices
    stay of order one at any ε. It follows a polynomial of degree below m with no error once
    the start transient (:math:`e^{-t/\\varepsilon}` times a polynomial in t) has decayed,
    up to the hold's interpolation error (on a parabola :math:`O(\\Delta t^2)` in x,
    :math:`O(\\Delta t^4)` in its derivatives); noise
    is amplified as :math:`\\varepsilon^{-n}` in the estimate of order n. It starts at the
    first sample with zero derivatives.

    Where the α-β-γ tracker places three poles together in discrete time, this is the
    continuous-time observer of any dimension, with ε its single knob.

    Parameters
    ----------
    observer_dimension : {3, 4, 5}
        m, the number of states (x and its first m-1 derivatives).
    epsilon_s : float > 0
        ε, the observer's time constant, seconds: small follows fast and amplifies noise.

    References
    ----------
    H. K. Khalil, L. Praly, "High-gain observers in nonlinear feedback control", Int. J.
    Robust Nonlinear Control 24 (2014) 993-1015; A. M. Dabroom, H. K. Khalil, "Discrete-time
    implementation of high-gain observers for numerical differentiation", Int. J. Control
    72 (1999) 1523-1537; G. F. Franklin, J. D. Powell, M. L. Workman, "Digital Control of
    Dynamic Systems", 3rd ed., Addison-Wesley 1998, section 6.3 (triangle-hold equivalent).
    """

    observer_dimension: int = param(3, choices=(3, 4, 5), integer=True, doc="m, states x … x^(m-1)")
    epsilon_s: float = param(
        0.01,
        low=0.0,
        low_open=True,
        tune_low=2e-4,
        tune_high=0.2,
        log=True,
        kind="duration",
        doc="ε, time constant, s",
    )

    presets = {"paper-signal": Preset({"observer_dimension": 3, "epsilon_s": 0.004}, SOURCE_OURS)}
    reference = "Khalil & Praly 2014 (binomial gains, first-order hold)"

    def _matrices(self, dt: float):
        ad, bd, dd = discrete_observer(self.observer_dimension, self.epsilon_s, dt)
        scale = self.epsilon_s ** -np.arange(self.observer_dimension)  # z_i = η_i / ε^(i-1)
        return ad, bd, dd, scale

    def _response(self, frequency_hz, dt, order):
        ad, bd, dd, scale = self._matrices(dt)
        output = np.zeros(self.observer_dimension)
        output[order] = scale[order]
        lag = np.exp(-2j * np.pi * frequency_hz * dt)  # ξ_k takes x up to x_{k-1}
        direct = dd[order] * scale[order]
        return lag * state_space_response(ad, bd, output, frequency_hz, dt) + direct

    def _start(self, first, dt, orders, samples):
        _, _, dd, _ = self._matrices(dt)
        eta = np.zeros((self.observer_dimension, *first.shape))
        eta[0] = first
        return eta - dd.reshape((-1,) + (1,) * first.ndim) * first  # ξ_0 = η_0 - D_d x_0

    def _advance(self, state, x, dt, orders):
        from diffbench.methods import _causal_loops  # numba: imported on first use

        ad, bd, dd, scale = self._matrices(dt)
        estimates, xi = _causal_loops.observe(ad, bd, dd, x, state)
        values = {order: estimates[:, order] * scale[order] for order in orders}
        return values, xi
