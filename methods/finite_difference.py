"""Central finite differences of a given accuracy order (no smoothing)."""

from __future__ import annotations

from math import factorial, inf

import numpy as np

from diffbench.methods._ends import trusted_samples
from diffbench.methods._local_poly import apply_fir_with_ends, end_evaluators
from diffbench.methods._registry import FirMethod, Preset, param, register
from diffbench.methods._validation import mean_step


def fornberg_weights(nodes: np.ndarray, at: float, max_order: int) -> np.ndarray:
    """Finite-difference weights on arbitrary ``nodes`` for the derivatives of orders
    0..``max_order`` at ``at``: row n holds :math:`w_{n,j}` with
    :math:`f^{(n)}(a) \\approx \\sum_j w_{n,j} f(t_j)`, exact for polynomials of degree below
    the number of nodes (the derivatives at ``at`` of the interpolating polynomial).

    Fornberg's recursion over the nodes taken one at a time (no linear system; stable for
    the stencils used here). On uniform nodes :math:`t_j = a + j h` the weights are the
    central ones, :func:`central_difference_weights` :math:`/ h^n`.

    References: B. Fornberg, "Generation of finite difference formulas on arbitrarily spaced
    grids", Math. Comp. 51 (1988) 699-706.
    """
    nodes = np.asarray(nodes, dtype=np.float64)
    weights = np.zeros((max_order + 1, nodes.size))
    weights[0, 0] = 1.0
    previous_product, offset = 1.0, nodes[0] - at
    for i in range(1, nodes.size):
        top = min(i, max_order)
        product, previous_offset, offset = 1.0, offset, nodes[i] - at
        for j in range(i):
            gap = nodes[i] - nodes[j]
            product *= gap
            if j == i - 1:
                for k in range(top, 0, -1):
                    weights[k, i] = (
                        previous_product
                        * (k * weights[k - 1, i - 1] - previous_offset * weights[k, i - 1])
                        / product
                    )
                weights[0, i] = -previous_product * previous_offset * weights[0, i - 1] / product
            for k in range(top, 0, -1):
                weights[k, j] = (offset * weights[k, j] - k * weights[k - 1, j]) / gap
            weights[0, j] = offset * weights[0, j] / gap
        previous_product = product
    return weights


def central_difference_weights(order: int, accuracy: int) -> np.ndarray:
    """Weights of the central difference for the derivative of ``order`` with ``accuracy``.

    The stencil has ``2m + 1`` samples, ``m = (order + 1) // 2 + accuracy // 2 - 1``; the
    weights solve the moment conditions

    .. math:: \\sum_{j=-m}^{m} a_j \\, j^k = k!\\,\\delta_{k,n}, \\qquad k = 0, \\dots, 2m,

    so :math:`f^{(n)}(t) \\approx h^{-n} \\sum_j a_j f(t + j h)` with error :math:`O(h^p)`,
    ``p = accuracy`` (even). Example: ``order=1, accuracy=2`` gives ``[-1/2, 0, 1/2]``;
    ``order=2, accuracy=2`` gives ``[1, -2, 1]``.

    References: B. Fornberg, "Generation of finite difference formulas on arbitrarily spaced
    grids", Math. Comp. 51 (1988) 699-706.
    """
    if order < 1:
        raise ValueError(f"`order` must be >= 1, got {order}")
    if accuracy < 2 or accuracy % 2:
        raise ValueError(f"`accuracy` must be an even integer >= 2, got {accuracy}")
    half = (order + 1) // 2 + accuracy // 2 - 1
    offsets = np.arange(-half, half + 1, dtype=np.float64)
    moments = offsets[np.newaxis, :] ** np.arange(2 * half + 1)[:, np.newaxis]
    rhs = np.zeros(2 * half + 1)
    rhs[order] = factorial(order)
    return np.linalg.solve(moments, rhs)


@register("finite_difference")
class FiniteDifference(FirMethod):
    """Central finite differences of accuracy order 2, 4 or 6, for derivative orders 1 and 2.

    .. math:: \\hat x^{(n)}_k = \\Delta t^{-n} \\sum_{j=-m}^{m} a^{(n,p)}_j x_{k+j}

    with the weights of :func:`central_difference_weights`. The smoothed signal (order 0) is the
    input itself. On the first and last m samples, where the central stencil does not fit,
    the first (last) :math:`2m_e + 1` samples give the derivative of their least-squares
    polynomial of degree :math:`p + n - 1` at each sample's own position (for
    :math:`2m_e = p + n - 1` samples or one more: the one-sided differences of Fornberg's
    tables, e.g. :math:`(-3x_0 + 4x_1 - x_2)/(2\\Delta t)` for n = 1, p = 2),
    :math:`m_e = \\lceil (p + n - 1)/2 \\rceil`; they are kept where their response is within
    twice the interior's error over the band the interior claims (:mod:`methods._ends`), else
    masked. Exact on polynomials of degree ``p + n - 1`` everywhere (the symmetric stencil
    gains one degree for ``n = 2``: not the ends).

    Time stamps (``t=``) are handled natively: the same stencils of samples, with the weights
    of :func:`fornberg_weights` at the sample's own time, and the same one-sided least-squares
    polynomials in t at the ends; the ends are masked where the uniform record of the mean step
    masks them. Uneven spacing loses the symmetric stencil's extra degree: exact on degree
    ``p`` for ``n = 2`` (``p + 1`` on uniform times), ``p + n - 1`` otherwise.

    Parameters
    ----------
    accuracy_order : {2, 4, 6}
        The truncation error is :math:`O(\\Delta t^p)`.

    References
    ----------
    B. Fornberg, Math. Comp. 51 (1988) 699-706.

    Examples
    --------
    >>> FiniteDifference(accuracy_order=2)([0.0, 1.0, 4.0], dt=1.0)[1][1]
    2.0
    """

    accuracy_order: int = param(
        2, choices=(2, 4, 6), integer=True, doc="truncation error O(dt^p), p even"
    )

    presets = {
        "paper-signal": Preset(
            {"accuracy_order": 2},
            "the paper's central Euler differences, without the Butterworth filter",
            by="paper",
        ),
        "robot": Preset(
            {"accuracy_order": 2}, "the paper's central Euler differences, unfiltered", by="paper"
        ),
    }
    reference = "Fornberg (1988)"
    time_stamps = "native"

    def _half_width(self, order: int) -> int:
        return (order + 1) // 2 + self.accuracy_order // 2 - 1

    def exact_degree(self, order: int) -> float | None:
        return inf if order == 0 else self.accuracy_order + order - 1

    def _end_half_width(self, order: int) -> int:
        return max(self._half_width(order), -(-(self.accuracy_order + order - 1) // 2))

    def end_reach(self, dt: float) -> int | None:
        return max(self._half_width(order) for order in (1, 2))

    def min_samples(self, dt: float) -> int:
        return 2 * max(self._end_half_width(order) for order in (1, 2)) + 1

    def _estimate(self, x, dt, orders):
        values, valid = {}, {}
        for order in orders:
            if order == 0:
                values[0], valid[0] = x.copy(), np.ones(x.shape[0], dtype=bool)
                continue
            m = self._end_half_width(order)
            ends = end_evaluators(m, self.accuracy_order + order - 1, order, dt)
            values[order] = apply_fir_with_ends(x, self.taps(order, dt), ends)
            valid[order] = np.ones(x.shape[0], dtype=bool)
        return values, valid

    def taps(self, order: int, dt: float) -> np.ndarray:
        """Taps a_{-m..m} / dt^n of the derivative of ``order`` (order 0: the identity)."""
        if order == 0:
            return np.ones(1)
        return central_difference_weights(order, self.accuracy_order) / dt**order

    def _estimate_at(self, x, times, orders):
        n = times.size
        if n < self.min_samples(1.0):
            raise ValueError(
                f"`x` has {n} samples on axis 0; at least {self.min_samples(1.0)} are needed"
            )
        flat = x.reshape(n, -1)
        trusted = trusted_samples(self, n, mean_step(times), orders)
        values, valid = {}, {}
        for order in orders:
            if order == 0:
                values[0], valid[0] = x.copy(), np.ones(n, dtype=bool)
                continue
            m, m_end = self._half_width(order), self._end_half_width(order)
            degree = self.accuracy_order + order - 1
            out = np.empty_like(flat)
            for k in range(n):
                if m <= k < n - m:
                    stencil = slice(k - m, k + m + 1)
                    out[k] = (
                        fornberg_weights(times[stencil], times[k], order)[order] @ flat[stencil]
                    )
                    continue
                stencil = slice(0, 2 * m_end + 1) if k < m else slice(n - 2 * m_end - 1, n)
                span = times[stencil][-1] - times[stencil][0]
                u = (times[stencil] - times[k]) / span
                coefficients = np.linalg.lstsq(
                    np.vander(u, degree + 1, increasing=True), flat[stencil], rcond=None
                )[0]
                out[k] = coefficients[order] * factorial(order) / span**order
            values[order], valid[order] = out.reshape(x.shape), trusted[order]
        return values, valid
