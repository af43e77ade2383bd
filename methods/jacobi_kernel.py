"""The central Jacobi differentiator's kernel and its discrete FIR weights (pure math).

Notation (Guo et al., AIM 2015, eq. (11)-(12); Liu, Gibaru, Perruquetti, J. Comput. Appl.
Math. 235 (2011) 3015-3032): window :math:`[t_0 - h, t_0 + h]`, :math:`h = T/2`,
:math:`y(\\tau) = x(t_0 + h\\tau)`, weight :math:`w_{\\mu,\\kappa}(\\tau) =
(1-\\tau)^{\\mu}(1+\\tau)^{\\kappa}` — **μ weights the future end** (:math:`\\tau = +1`,
:math:`t_0 + h`), κ the past end. :math:`P_k^{(a,b)}` are the standard Jacobi polynomials,
orthogonal for :math:`w_{a,b}`, with squared norms :math:`h_k^{(a,b)}`.

Integrating eq. (11) by parts n times gives the kernel in a single sum that stays at rounding
level for large κ, μ, q (the paper's eq. (12) double sum does not):

.. math::
    D^{(n)}x(t_0) = h^{-n} \\int_{-1}^{1} Q(\\tau)\\, y(\\tau)\\, d\\tau, \\qquad
    Q(\\tau) = w_{\\mu,\\kappa}(\\tau) \\sum_{i=0}^{q} c_i P_{i+n}^{(\\mu,\\kappa)}(\\tau),
    \\qquad c_i = 2^n \\frac{(i+n)!}{i!}
    \\frac{P_i^{(\\mu+n,\\kappa+n)}(0)}{h_i^{(\\mu+n,\\kappa+n)}}

It is the n-th derivative at 0 of the degree-(n+q) polynomial fitted to y by least squares with
weight :math:`w_{\\mu,\\kappa}`; exact on polynomials of degree n+q (n+q+1 when κ = μ and q is
even). Three discretisations on the 2M+1 nodes :math:`\\tau_j = j/M` (node convention:
T = 2M·Ts, the outer samples lie on the window's ends) give FIR taps :math:`a_j` with
:math:`D^{(n)}x(t_k) \\approx \\sum_{j=-M}^{M} a_j x_{k+j}`:

``trapezoid``
    trapezoid rule on the nodes (κ, μ ≥ 0; very accurate when min(κ, μ) ≥ 2, where Q vanishes
    at the ends with its first derivatives).
``linear``
    exact integration of Q against the piecewise-linear interpolant of the samples (any
    κ, μ > −1; error O(Ts²)): Gauss–Legendre on inner cells, Gauss–Jacobi on the two end
    cells, which carry the (possibly singular) end factors.
``least_squares``
    the discrete weighted least-squares filter with sample weights w(τ_j) (κ, μ ≥ 0): exact on
    sampled polynomials of degree n+q for any Ts.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import special

RULES = ("trapezoid", "linear", "least_squares")
_QUADRATURE_POINTS = 24
_LINEAR_RULE_CELLS = 4096  # inner cells evaluated at once by the linear rule (bounds memory)

MIN_EXPONENT = -0.999
"""Smallest κ, μ a method admits (the mathematics admits any > -1). Measured with the linear
rule (the only one for negative exponents) at κ = μ = -1 + ε, q = 6, 101 samples: its taps
miss their moment conditions by a steady 2e-2 for ε from 0.1 down to 1e-5 (and the
amplification stays 2.1 to 2.3), by 4e-2 at 1e-6, by 2e2 at 1e-8 and 2e10 at 1e-12; at 1e-13
the Gauss–Jacobi weights are NaN. -0.999 keeps two decades from the first degradation."""

MAX_EXPONENT = 400.0
"""Largest κ, μ admitted. Measured for n ≤ 2, q ≤ 40: up to κ, μ = 440 the kernel is finite
and equals exact rational arithmetic to 1e-12 of its size (and the weighted least-squares fit
to 1e-10); beyond, the single-sum form overflows: NaN from κ = μ ≈ 460 (q = 40) or
κ + μ ≈ 900, OverflowError from κ + μ ≈ 1000."""

RULE_TOLERANCE = {"trapezoid": 1e-2, "linear": 1e-2, "least_squares": 1e-6}
"""How far each rule's taps may be off on the polynomials of degree <= n+q that the continuous
kernel differentiates exactly (:func:`moment_error`). ``least_squares`` claims exactness, so
only rounding is allowed (measured <= 1e-8 within :data:`MAX_AMPLIFICATION`; on short windows
underflowing sample weights make the fit singular instead); ``trapezoid`` and ``linear``
approximate the continuous filter and must stay within 1 % of it. Measured misses: the
trapezoid rule by 90 % on 5 samples at κ = μ = 0 and by 46 % on 7 samples at κ = μ = 30, by
46 % on 211 samples at κ = 1e-9 (the end weight jumps from 0 to 1), and by 6.6e4 for κ = 0,
μ = 47, q = 12 on any window up to 10^5 steps; presets and tuned settings miss by <= 2e-5."""

SEARCH_HALF_WIDTH = 2**13
"""Longest half-window M searched for the shortest window a rule works on (a refusal's
message; the linear rule at q = 40 costs about 0.2 s per tap set at this M)."""

MAX_AMPLIFICATION = 1e8
"""Largest :func:`amplification` admitted: rounding of the samples (and noise) enters the
estimate multiplied by it, so at 1e8 an estimate of exact data keeps about 8 digits (the
least-squares rule then misses its exactness claim by ~1e-8); lopsided weights with long
series reach 1e15 and more (κ = 0, μ = 100, q = 12), where nothing is left."""


def check_design(order: int, kappa: float, mu: float, q: int) -> None:
    """Raise ``ValueError`` naming the argument if (n, κ, μ, q) is not admissible
    (κ, μ in (-1, :data:`MAX_EXPONENT`])."""
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 0:
        raise ValueError(f"`order` must be an integer >= 0, got {order!r}")
    for name, value in (("kappa", kappa), ("mu", mu)):
        if not (
            isinstance(value, (int, float, np.integer, np.floating))
            and math.isfinite(value)
            and value > -1
        ):
            raise ValueError(f"`{name}` must be a finite number > -1, got {value!r}")
        if value > MAX_EXPONENT:
            raise ValueError(
                f"`{name}` must be in (-1, {MAX_EXPONENT:g}] (beyond, the kernel overflows), "
                f"got {value!r}"
            )
    if isinstance(q, bool) or not isinstance(q, (int, np.integer)) or q < 0:
        raise ValueError(f"`q` must be an integer >= 0, got {q!r}")


def jacobi_polynomials(max_degree: int, a: float, b: float, x: np.ndarray) -> np.ndarray:
    """Values :math:`P_k^{(a,b)}(x)` for k = 0..max_degree, shape ``(max_degree + 1,) + x.shape``.

    Three-term recurrence (Abramowitz & Stegun 22.7.1):

    .. math::
        2k(k+a+b)(2k+a+b-2) P_k = (2k+a+b-1)\\left[(2k+a+b)(2k+a+b-2)x + a^2 - b^2\\right]
        P_{k-1} - 2(k+a-1)(k+b-1)(2k+a+b) P_{k-2}
    """
    x = np.asarray(x, dtype=np.float64)
    values = np.empty((max_degree + 1, *x.shape))
    values[0] = 1.0
    if max_degree >= 1:
        values[1] = (a + 1) + (a + b + 2) * (x - 1) / 2
    for k in range(2, max_degree + 1):
        s = 2 * k + a + b
        first = (s - 1) * (s * (s - 2) * x + a * a - b * b)
        second = 2 * (k + a - 1) * (k + b - 1) * s
        values[k] = (first * values[k - 1] - second * values[k - 2]) / (
            2 * k * (k + a + b) * (s - 2)
        )
    return values


def log_norm(k: int, a: float, b: float) -> float:
    """:math:`\\ln h_k^{(a,b)}`, :math:`h_k = \\int_{-1}^{1} w_{a,b} (P_k^{(a,b)})^2 =
    \\frac{2^{a+b+1}\\Gamma(k+a+1)\\Gamma(k+b+1)}{(2k+a+b+1)\\,k!\\,\\Gamma(k+a+b+1)}`."""
    value = (a + b + 1) * math.log(2) + special.gammaln(k + a + 1) + special.gammaln(k + b + 1)
    if k == 0:
        return float(value - special.gammaln(a + b + 2))
    return float(
        value
        - math.log(2 * k + a + b + 1)
        - special.gammaln(k + 1)
        - special.gammaln(k + a + b + 1)
    )


def _sum_coefficients(order: int, kappa: float, mu: float, q: int) -> np.ndarray:
    """:math:`2^{\\mu+\\kappa} c_i`, i = 0..q (the power of 2 moved from the weight, in logs)."""
    a, b = mu + order, kappa + order
    at_zero = jacobi_polynomials(q, a, b, np.array(0.0))
    coefficients = np.zeros(q + 1)
    for i in range(q + 1):
        if at_zero[i] == 0.0:
            continue
        log_value = (
            (order + mu + kappa) * math.log(2)
            + special.gammaln(i + order + 1)
            - special.gammaln(i + 1)
            + math.log(abs(at_zero[i]))
            - log_norm(i, a, b)
        )
        coefficients[i] = math.copysign(math.exp(log_value), at_zero[i])
    return coefficients


def _kernel_parts(tau, order, kappa, mu, q):
    """S(τ) with Q(τ) = ((1−τ)/2)^μ ((1+τ)/2)^κ · S(τ)."""
    tau = np.asarray(tau, dtype=np.float64)
    polys = jacobi_polynomials(q + order, mu, kappa, tau)[order:]
    return np.tensordot(_sum_coefficients(order, kappa, mu, q), polys, axes=1)


def kernel(tau, order: int, kappa: float, mu: float, q: int) -> np.ndarray:
    """The continuous kernel :math:`Q(\\tau)` on :math:`[-1, 1]` (0 outside).

    Examples
    --------
    κ = μ = 0, q = 0, n = 0 is the moving average: Q = 1/2.

    >>> float(kernel(0.3, 0, 0.0, 0.0, 0))
    0.5
    """
    check_design(order, kappa, mu, q)
    tau = np.asarray(tau, dtype=np.float64)
    inside = np.abs(tau) <= 1
    clipped = np.clip(tau, -1, 1)
    with np.errstate(divide="ignore"):
        weight = ((1 - clipped) / 2) ** mu * ((1 + clipped) / 2) ** kappa
    values = weight * _kernel_parts(clipped, order, kappa, mu, q)
    return np.where(inside, values, 0.0)


@functools.lru_cache(maxsize=256)
def _quadrature(rule, points: int, *exponents: float) -> tuple[np.ndarray, np.ndarray]:
    """``rule(points, *exponents)`` (a ``scipy.special`` Gauss rule: nodes and weights,
    read-only), cached: the taps of orders 0-2 and their amplification bounds share one
    design's rules, and computing a rule (an eigenvalue problem) was a fifth of a Jacobi
    tuning."""
    nodes, weights = rule(points, *exponents)
    nodes.setflags(write=False)
    weights.setflags(write=False)
    return nodes, weights


def half_width(window_s: float, dt: float, name: str = "window_s") -> int:
    """M such that ``window_s = 2M·dt`` (node convention); ``ValueError`` naming ``name`` if
    ``window_s / dt`` is not an even whole number within 1e-9 relative."""
    from diffbench.methods._validation import samples_in_span

    return samples_in_span(name, window_s, dt, odd=True) // 2


def fir_weights(
    order: int, kappa: float, mu: float, q: int, half_width: int, dt: float, rule: str
) -> np.ndarray:
    """FIR taps :math:`a_{-M..M}` of the discretised differentiator, read-only and cached.

    :math:`\\hat x^{(n)}_k = \\sum_{j=-M}^{M} a_j x_{k+j}`; ``half_width`` is M, the window is
    T = 2M·dt, h = M·dt. Raises ``ValueError`` for an inadmissible design, an unknown rule, a
    rule that cannot handle negative κ or μ, or a window with fewer than n+q+2 samples.
    """
    check_design(order, kappa, mu, q)
    if rule not in RULES:
        raise ValueError(f"`rule` must be one of {', '.join(RULES)}, got {rule!r}")
    if rule in ("trapezoid", "least_squares") and min(kappa, mu) < 0:
        raise ValueError(
            f"`rule`={rule!r} needs kappa, mu >= 0 (the weight is infinite at a window end "
            f"for kappa={kappa!r}, mu={mu!r}); use rule='linear'"
        )
    if isinstance(half_width, bool) or not isinstance(half_width, (int, np.integer)):
        raise ValueError(f"`half_width` must be an integer >= 1, got {half_width!r}")
    if 2 * half_width + 1 < order + q + 2:
        raise ValueError(
            f"the window holds {2 * half_width + 1} samples; a Jacobi estimate with n + q = "
            f"{order + q} needs at least {order + q + 2}: lengthen the window or lower q"
        )
    return _fir_weights(
        int(order), float(kappa), float(mu), int(q), int(half_width), float(dt), rule
    )


def _compute_fir_weights(order, kappa, mu, q, m, dt, rule):
    scale = 1.0 / (m * dt) ** order  # h^{-n}
    nodes = np.arange(-m, m + 1) / m
    if rule == "trapezoid":
        taps = kernel(nodes, order, kappa, mu, q) / m
        taps[[0, -1]] *= 0.5
    elif rule == "linear":
        taps = _linear_rule(order, kappa, mu, q, m)
    else:
        from diffbench.methods._local_poly import local_polynomial_weights

        with np.errstate(divide="ignore"):
            sample_weights = (1 - nodes) ** mu * (1 + nodes) ** kappa
        taps = local_polynomial_weights(
            m, order + q, order, np.array([0.0]), 1.0 / m, sample_weights=sample_weights
        )[0]
    taps = taps * scale
    taps.setflags(write=False)
    return taps


_fir_weights = functools.lru_cache(maxsize=256)(_compute_fir_weights)


def moment_error(taps: np.ndarray, order: int, degree: int, dt: float) -> float:
    r"""How far FIR taps ``a_{-M..M}`` are from differentiating polynomials up to ``degree``.

    .. math::
        \max_{0 \le k \le d} \left| \frac{h^n}{n!} \sum_{j=-M}^{M} a_j (j/M)^k
        - \delta_{kn} \right|, \qquad h = M\,\Delta t

    the error on the monomials :math:`(t/h)^k` relative to the natural size :math:`n!/h^n` of
    the n-th derivative (0 for taps exact on degree d; inf for non-finite taps).
    """
    taps = np.asarray(taps, dtype=np.float64)
    if not np.all(np.isfinite(taps)):
        return math.inf
    m = taps.size // 2
    # subnormal taps (a steep weight's ends) make every product 100x slower; they add nothing
    taps = np.where(np.abs(taps) < np.finfo(float).tiny, 0.0, taps)
    u = np.arange(-m, m + 1) / max(m, 1)
    scale = (m * dt) ** order / math.factorial(order)
    power = np.ones_like(u)
    worst = 0.0
    for k in range(degree + 1):
        moment = float(np.dot(taps, power)) * scale
        worst = max(worst, abs(moment - (1.0 if k == order else 0.0)))
        power = power * u
    return worst if math.isfinite(worst) else math.inf


@functools.lru_cache(maxsize=1024)
def discretisation_error(
    order: int,
    kappa: float,
    mu: float,
    q: int,
    half_width: int,
    dt: float,
    rule: str,
    keep_taps: bool = True,
) -> float:
    """:func:`moment_error` of the taps of ``rule`` on degrees up to n+q (where the continuous
    kernel is exact); inf if the taps cannot be computed (a singular weighted fit) or are not
    finite. With ``keep_taps`` the taps go to the cache :func:`fir_weights` reads."""
    degree = order + q
    compute = _fir_weights if keep_taps else _compute_fir_weights
    try:
        with np.errstate(all="ignore"):
            taps = compute(order, float(kappa), float(mu), int(q), int(half_width), float(dt), rule)
    except np.linalg.LinAlgError:
        return math.inf
    return moment_error(taps, order, degree, dt)


def shortest_half_width(
    orders: tuple[int, ...],
    kappa: float,
    mu: float,
    q: int,
    dt: float,
    rule: str,
    start: int,
    limit: int,
) -> int | None:
    """A least M in [``start``, ``limit``], to 2 %, whose taps for every order of ``orders``
    meet :data:`RULE_TOLERANCE` (doubling, then bisection: the discretisation error falls as
    the window grows); None if even ``limit`` does not. The 2 % keep the search to a few
    tap computations near the answer (the linear rule costs 0.1 s per 10^4 steps)."""
    tolerance = RULE_TOLERANCE[rule]

    def works(m: int) -> bool:
        return all(
            discretisation_error(order, kappa, mu, q, m, dt, rule, keep_taps=False) <= tolerance
            for order in orders
        )

    failing, candidate = start - 1, start
    while not works(candidate):
        if candidate >= limit:
            return None
        failing, candidate = candidate, min(2 * candidate, limit)
    while candidate - failing > max(1, candidate // 50):
        middle = (failing + candidate) // 2
        failing, candidate = (failing, middle) if works(middle) else (middle, candidate)
    return candidate


@functools.lru_cache(maxsize=1024)
def amplification(order: int, kappa: float, mu: float, q: int) -> float:
    r""":math:`\int_{-1}^{1} |Q(\tau)|\, d\tau`: the factor by which the differentiator
    multiplies rounding errors and noise of the samples, in units of :math:`h^{-n}`.

    About 1 for the moving average, a few hundred for the paper's kernels, and beyond 1e15 for
    lopsided weights with long series (κ = 0, μ = 100, q = 12), which extrapolate from the
    heavily weighted end. Computed by Gauss–Jacobi quadrature (the kernel is the weight times
    a polynomial; its modulus is integrated to about 1e-3, ample for a bound).
    """
    check_design(order, kappa, mu, q)
    nodes, weights = _quadrature(special.roots_jacobi, 64, float(mu), float(kappa))
    # Q = ((1-τ)/2)^μ ((1+τ)/2)^κ S(τ) and the quadrature weights carry (1-τ)^μ (1+τ)^κ.
    values = np.abs(_kernel_parts(nodes, order, kappa, mu, q))
    total = float(np.sum(weights * values)) * 2.0 ** -(kappa + mu)
    return total if math.isfinite(total) else math.inf


def _linear_rule(order, kappa, mu, q, m):
    """Taps of ∫ Q(τ) ŷ(τ) dτ with ŷ the piecewise-linear interpolant of the samples."""
    step = 1.0 / m
    left_nodes = np.arange(-m, m) * step  # cell j spans [left_j, left_j + step]
    taps = np.zeros(2 * m + 1)
    # Inner cells: Gauss–Legendre (the integrand is smooth there), in blocks of cells so that
    # memory stays bounded for long windows.
    s, weights = _quadrature(special.roots_legendre, _QUADRATURE_POINTS)
    fraction = (1 + s[None, :]) / 2  # hat of the right node
    for start in range(1, 2 * m - 1, _LINEAR_RULE_CELLS):
        inner = np.arange(start, min(start + _LINEAR_RULE_CELLS, 2 * m - 1))
        tau = left_nodes[inner, None] + step * (1 + s[None, :]) / 2
        values = kernel(tau, order, kappa, mu, q) * (step / 2) * weights[None, :]
        taps[inner] += np.sum(values * (1 - fraction), axis=1)
        taps[inner + 1] += np.sum(values * fraction, axis=1)
    # End cells: Gauss–Jacobi absorbs (1+τ)^κ on the left cell and (1−τ)^μ on the right.
    s, weights = _quadrature(special.roots_jacobi, _QUADRATURE_POINTS, 0.0, float(kappa))
    tau = -1 + step * (1 + s) / 2  # 1 + τ = step (1 + s) / 2
    rest = ((1 - tau) / 2) ** mu * _kernel_parts(tau, order, kappa, mu, q)
    # ((1+τ)/2)^κ = (step/4)^κ (1+s)^κ; the small factor goes on the weights first, or rest times
    # weights overflows for κ, μ near 400 (it is the kernel without its vanishing end factor)
    values = rest * (weights * (step / 2) * (step / 4) ** kappa)
    fraction = (1 + s) / 2
    taps[0] += np.sum(values * (1 - fraction))
    taps[1] += np.sum(values * fraction)
    s, weights = _quadrature(special.roots_jacobi, _QUADRATURE_POINTS, float(mu), 0.0)
    tau = 1 - step * (1 - s) / 2  # 1 − τ = step (1 − s) / 2
    rest = ((1 + tau) / 2) ** kappa * _kernel_parts(tau, order, kappa, mu, q)
    values = rest * (weights * (step / 2) * (step / 4) ** mu)
    fraction = (1 + s) / 2
    taps[-2] += np.sum(values * (1 - fraction))
    taps[-1] += np.sum(values * fraction)
    return taps


def continuous_response(
    order: int, kappa: float, mu: float, q: int, window_s: float, frequency_hz
) -> np.ndarray:
    r"""Frequency response of the continuous differentiator divided by the ideal
    :math:`(i\omega)^n`: 1 means a perfect differentiator at that frequency.

    .. math:: G(\omega) = \frac{h^{-n} \int_{-1}^{1} Q(\tau) e^{i\omega h\tau} d\tau}
              {(i\omega)^n}

    computed by Gauss–Jacobi quadrature (Q / w is a polynomial). ``frequency_hz`` > 0.
    """
    check_design(order, kappa, mu, q)
    frequencies = np.atleast_1d(np.asarray(frequency_hz, dtype=np.float64))
    h = window_s / 2
    nodes, weights = special.roots_jacobi(200, mu, kappa)
    weight = (1 - nodes) ** mu * (1 + nodes) ** kappa
    polynomial = kernel(nodes, order, kappa, mu, q) / weight
    omega = 2 * math.pi * frequencies
    phases = np.exp(1j * np.outer(omega * h, nodes))
    response = phases @ (weights * polynomial) / h**order
    return response / (1j * omega) ** order
