"""Levant's arbitrary-order robust exact differentiator, discretised implicitly (backward Euler)
with its outputs read as backward-difference combinations of its states."""

from __future__ import annotations

import functools

import numpy as np

from diffbench.methods._causal import CausalMethod
from diffbench.methods._registry import Preset, param, register

GAINS = {
    1: (1.5, 1.1),
    2: (2.0, 2.12, 1.1),
    3: (3.0, 4.16, 3.06, 1.1),
    4: (5.0, 10.03, 9.30, 4.57, 1.1),
    5: (8.0, 26.5, 34.25, 22.57, 7.66, 1.1),
}
"""Levant's gains :math:`\\lambda_0..\\lambda_n` in the non-recursive form (λ_0 on the
estimate of x, λ_n = 1.1 on the sign), for differentiator orders n = 1..5 (Levant 2003's
recursive 1.1, 1.5, 2, 3, 5, 8 written non-recursively, as in Reichhartinger et al. 2018)."""


@functools.lru_cache(maxsize=16)
def output_weights(n: int) -> np.ndarray:
    """Matrix :math:`W` with :math:`\\hat x^{(i)} = \\sum_j W_{ij} \\Delta t^{j-i} z_j`: the
    coefficients of :math:`\\nabla^j` in :math:`(-\\ln(1-\\nabla))^i`, truncated at degree n.

    In the sliding mode :math:`z_j = \\nabla^j x_k / \\Delta t^j` (the j-th backward
    difference), and :math:`\\Delta t\\, D = -\\ln(1 - \\nabla) = \\sum_{j\\ge1} \\nabla^j/j`, so
    these combinations are exact on polynomials of degree n (whose higher differences
    vanish)."""
    series = np.zeros(n + 1)
    series[1:] = 1.0 / np.arange(1, n + 1)
    weights = np.zeros((n + 1, n + 1))
    power = np.zeros(n + 1)
    power[0] = 1.0
    for i in range(n + 1):
        weights[i] = power
        power = np.polynomial.polynomial.polymul(power, series)[: n + 1]
    return weights


@register("levant")
class Levant(CausalMethod):
    """Levant's robust exact differentiator of order n, implicit (backward Euler)
    discretisation with outputs corrected to be exact in the sliding mode.

    The continuous differentiator, :math:`e = z_0 - x`,
    :math:`\\lceil e \\rfloor^{p} = |e|^p \\operatorname{sign} e`:

    .. math::
        \\dot z_i = -\\lambda_i L^{\\frac{i+1}{n+1}} \\lceil e \\rfloor^{\\frac{n-i}{n+1}}
        + z_{i+1} \\;(i < n), \\qquad \\dot z_n \\in -\\lambda_n L \\operatorname{Sign}(e)

    converges in finite time to :math:`z_i = x^{(i)}` for any signal with
    :math:`|x^{(n+1)}| \\le L` (Levant 2003). Backward Euler on the samples,
    :math:`z^{k+1} = z^k + \\Delta t (A z^{k+1} - D(e_{k+1}))` with A the shift
    :math:`(Az)_i = z_{i+1}`, gives :math:`z^{k+1} = M (z^k - \\Delta t D(e_{k+1}))`,
    :math:`M = (I - \\Delta t A)^{-1} = \\sum_j \\Delta t^j A^j`, and one scalar equation for
    the new error:

    .. math::
        e + \\sum_{j=0}^{n} c_j \\lceil e \\rfloor^{\\frac{n-j}{n+1}} \\ni
        r = \\sum_j \\Delta t^j z^k_j - x_{k+1}, \\qquad
        c_j = \\Delta t^{j+1} \\lambda_j L^{\\frac{j+1}{n+1}}

    whose left side is increasing: e = 0 (the sliding mode, Sign(0) = r/c_n) when
    :math:`|r| \\le c_n`, else the root of the same sign as r (Brent's method). No chattering:
    the set-valued sign is resolved exactly. In the sliding mode the states are backward
    differences, :math:`z_j = \\nabla^j x_k/\\Delta t^j`, which lag; the outputs are the
    combinations :math:`\\hat x^{(i)} = \\sum_j W_{ij} \\Delta t^{j-i} z_j`
    (:func:`output_weights`) that make them exact on polynomials of degree n (Seeber 2024
    proposes outputs as such combinations). Starts from :math:`z_0` = the first sample, the
    other states 0. Nonlinear.

    Parameters
    ----------
    differentiator_order : int in [1, 5]
        n: the highest derivative estimated (orders above it are refused).
    lipschitz : float > 0
        L, the bound assumed on :math:`|x^{(n+1)}|`, in the signal's units per
        :math:`s^{n+1}`.

    References
    ----------
    A. Levant, "Higher-order sliding modes, differentiation and output-feedback control",
    Int. J. Control 76 (2003) 924-941; R. Seeber, "Proper implicit discretization of
    arbitrary-order robust exact differentiators", arXiv:2404.02770 (2024); B. Brogliato,
    A. Polyakov, "Digital implementation of sliding-mode control via the implicit method: a
    tutorial", Int. J. Robust Nonlinear Control 31 (2021) 3528-3586.
    """

    linear = False
    differentiator_order: int = param(
        2,
        low=1,
        high=5,
        integer=True,
        untuned="fixed by the orders asked for (the lowest n that gives them)",
        doc="n, the highest derivative estimated",
    )
    lipschitz: float = param(
        1e5,
        low=0.0,
        low_open=True,
        tune_low=1.0,
        tune_high=1e9,
        log=True,
        doc="L, bound on |x^(n+1)|",
    )

    presets = {
        "paper-signal": Preset(
            {"differentiator_order": 2, "lipschitz": 1.2e6},
            "the third derivative of the paper signal (unit sines at 4, 9, 15 Hz) is at most "
            "(2 pi)^3 (4^3 + 9^3 + 15^3) = 1.03e6; L a little above it, as the theory asks",
        ),
    }
    reference = "Levant 2003; implicit form after Seeber 2024"

    def _check_orders(self, orders) -> None:
        if max(orders) > self.differentiator_order:
            raise ValueError(
                f"`differentiator_order`={self.differentiator_order} gives derivatives up to "
                f"order {self.differentiator_order}, {max(orders)} was asked for; raise it"
            )

    def _start(self, first, dt, orders, samples):
        self._check_orders(orders)
        n = self.differentiator_order
        state = np.zeros((n + 1, *first.shape))
        state[0] = first
        return state

    def _advance(self, state, x, dt, orders):
        from diffbench.methods import _causal_loops  # numba: imported on first use

        self._check_orders(orders)
        n = self.differentiator_order
        constants = _step_constants(n, self.lipschitz, dt)
        states, last = _causal_loops.levant_steps(constants, dt, x, state)
        j = np.arange(n + 1)
        weights = output_weights(n)
        values = {}
        for order in orders:
            row = weights[order] * dt ** (j - order)
            # summed term by term, not by a matrix product: BLAS may sum in another order for
            # another number of samples, and a stream must equal the batch bit for bit
            total = np.zeros(states[:, 0].shape)
            for term, weight in enumerate(row):
                total += weight * states[:, term]
            values[order] = total
        return values, last


@functools.lru_cache(maxsize=64)
def _step_constants(n: int, lipschitz: float, dt: float) -> tuple[np.ndarray, ...]:
    r"""What every implicit step of :class:`Levant` uses, computed once per setting (a stream
    pushing one sample at a time would otherwise rebuild them at each push): the injection
    scales :math:`\lambda_j L^{(j+1)/(n+1)}`, the coefficients :math:`c_j`, the powers
    :math:`(n-j)/(n+1)`, the first row of M and M itself."""
    lambdas = np.array(GAINS[n])
    j = np.arange(n + 1)
    scale = lambdas * lipschitz ** ((j + 1) / (n + 1))  # λ_j L^{(j+1)/(n+1)}
    coefficients = dt ** (j + 1) * scale  # c_j
    powers = (n - j) / (n + 1)
    steps = dt**j  # first row of M
    # M = sum_j dt^j A^j: (M v)_i = sum_{l >= i} dt^(l-i) v_l
    propagate = np.array(
        [[dt ** (c - r) if c >= r else 0.0 for c in range(n + 1)] for r in range(n + 1)]
    )
    for array in (scale, coefficients, powers, steps, propagate):
        array.setflags(write=False)
    return scale, coefficients, powers, steps, propagate
