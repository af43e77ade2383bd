"""Total-variation regularised differentiation: ℓ1 trend filtering of the samples, then
differences of the fitted trend."""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import LinAlgError, solveh_banded

from diffbench.methods._registry import Method, Preset, param, register

TV_ORDERS = (1, 2)

GAP_TOLERANCE = 1e-10
"""The interior-point iteration stops once its duality gap is at most this fraction of the
primal objective (a certificate: ‖z - z*‖² <= 2 gap); the active-set finish then solves the
optimality conditions exactly, to rounding."""
MAX_INTERIOR_ITERATIONS = 100
"""Cap on interior-point (Newton) iterations; 25-50 are typical."""
MAX_ACTIVE_SET_ROUNDS = 8
"""Cap on active-set finishing rounds (one banded solve each); 1-2 are typical."""

_BACKTRACKS = 50
_ACCEPT = 1e-9  # a free dual variable may exceed the box by this fraction (rounding)
_STALL = 5  # stop once the gap has not halved in this many iterations
_CENTRING = 2.0  # the barrier parameter aims at gap / _CENTRING after each long step
_ROUNDING = 4 * np.finfo(float).eps  # below this fraction of |x| a change is rounding


def difference(z: np.ndarray, count: int) -> np.ndarray:
    """The forward difference :math:`(D^{c} z)_i = \\sum_j (-1)^{c-j}\\binom{c}{j} z_{i+j}`,
    i = 0..n-c-1 (``numpy.diff(z, count)``)."""
    return np.diff(z, count)


def difference_adjoint(nu: np.ndarray, count: int) -> np.ndarray:
    """:math:`(D^{c})^\\top \\nu`: the adjoint of :func:`difference`, of length len(nu) + c."""
    out = nu
    for _ in range(count):
        padded = np.zeros(out.shape[0] + 2)
        padded[1:-1] = out
        out = -np.diff(padded)
    return out


def _gram_bands(count: int) -> np.ndarray:
    """h_d = (D Dᵀ)_{i,i+d}, d = 0..count: the bands of :math:`D^c (D^c)^\\top`."""
    taps = np.array([(-1) ** (count - j) * math.comb(count, j) for j in range(count + 1)])
    return np.array([float(np.dot(taps[: count + 1 - d], taps[d:])) for d in range(count + 1)])


def polynomial_fit(x: np.ndarray, degree: int) -> np.ndarray:
    """Least-squares polynomial of ``degree`` through the samples ``x`` (1-D), evaluated on
    them; fitted in the Legendre basis on [-1, 1], which is well conditioned."""
    u = np.linspace(-1.0, 1.0, x.shape[0])
    basis = np.polynomial.legendre.legvander(u, degree)
    coefficients, *_ = np.linalg.lstsq(basis, x, rcond=None)
    return basis @ coefficients


def fused_penalty(x: np.ndarray, tv_order: int) -> tuple[float, np.ndarray]:
    r"""The smallest penalty λ whose trend filter (:func:`trend_filter`) is the least-squares
    polynomial p of degree ``tv_order``, and p.

    At :math:`\lambda \ge \lambda_{\max}` the optimality conditions hold with z = p and the
    dual variable :math:`\nu` solving :math:`D^\top\nu = x - p`, whence
    :math:`\lambda_{\max} = \|\nu\|_\infty`. That system is solved by k + 1 running sums
    (``x - p`` is orthogonal to the polynomials of degree k, so it is consistent).
    """
    fit = polynomial_fit(x, tv_order)
    nu = x - fit
    for _ in range(tv_order + 1):
        nu = -np.cumsum(nu)[:-1]
    return float(np.max(np.abs(nu))), fit


def _interior_point(x: np.ndarray, penalty: float, count: int):
    """Primal-dual interior-point iteration on the dual box-constrained QP (see
    :func:`trend_filter`); returns the last dual iterate ν (strictly inside the box).

    Written for memory: besides ν, μ₁, μ₂ and the Newton step it holds no array of the
    record's length from one use to the next (Dx, the slacks λ ∓ ν and the steps of μ are
    recomputed where needed, the band matrix lives only for its solve), about ten arrays
    at its peak."""
    m = x.shape[0] - count
    bands = _gram_bands(count)

    def gram_less_dx(nu):
        """D Dᵀν - Dx (a new array): the dual residual without its μ₁ - μ₂."""
        out = difference(difference_adjoint(nu, count), count)
        out -= difference(x, count)
        return out

    def slack(nu, sign):
        """λ - ν (``sign`` +1) or λ + ν (-1): the room to the box (a new array, > 0)."""
        return (penalty - nu) if sign > 0 else (penalty + nu)

    def centre(mu, nu, sign, inverse_t):
        """μ (λ ∓ ν) - 1/t (a new array)."""
        out = slack(nu, sign)
        out *= mu
        out -= inverse_t
        return out

    def mu_step(mu, nu, dnu, sign, inverse_t):
        """The Newton step of μ₁ (``sign`` +1) or μ₂ (-1): -(c ∓ μ Δν)/(λ ∓ ν)."""
        out = centre(mu, nu, sign, inverse_t)
        moved = mu * dnu
        if sign > 0:
            out -= moved
        else:
            out += moved
        del moved
        np.negative(out, out=out)
        out /= slack(nu, sign)
        return out

    def residual_norm(nu, mu1, mu2, inverse_t, move=None):
        """‖(dual residual, centring residuals)‖ at (ν, μ₁, μ₂); with ``move`` = (step, Δν,
        the current ν) at (ν, μ + step Δμ), Δμ the Newton step of μ at the current point."""
        out = gram_less_dx(nu)
        norms = []
        for mu, sign in ((mu1, 1), (mu2, -1)):
            if move is not None:
                step, dnu, current = move
                moved = mu_step(mu, current, dnu, sign, inverse_t)
                moved *= step
                moved += mu
            else:
                moved = mu
            if sign > 0:
                out += moved
            else:
                out -= moved
            residual = centre(moved, nu, sign, inverse_t)
            del moved
            norms.append(residual @ residual)
            del residual
        return math.sqrt(out @ out + norms[0] + norms[1])

    nu = np.zeros(m)
    mu1, mu2 = np.ones(m), np.ones(m)
    inverse_t, step = math.inf, 1.0
    history = []
    floor = m * (2**count * penalty) ** 2 * np.finfo(float).eps
    for _ in range(MAX_INTERIOR_ITERATIONS):
        z = x - difference_adjoint(nu, count)  # the primal estimate z = x - Dᵀν, w = Dz
        w = difference(z, count)
        terms = np.abs(w)
        terms *= penalty
        terms -= nu * w
        gap = float(np.sum(terms))  # the duality gap Σ(λ|w| - ν w) >= 0
        del terms
        z = x - z
        primal = 0.5 * float(z @ z) + penalty * float(np.sum(np.abs(w)))
        del z, w
        # (Dz)_i is a difference of numbers of size λ: rounding leaves the gap ~ m (2^c λ)² eps
        history.append(gap)
        target = max(GAP_TOLERANCE * primal, floor)
        if gap <= target:
            break
        if gap <= 1e3 * target and len(history) > _STALL and gap > 0.5 * history[-1 - _STALL]:
            break  # near the floor and no longer falling: rounding sets the gap now
        surrogate = float(mu1 @ slack(nu, 1)) + float(mu2 @ slack(nu, -1))
        if step >= 0.2:
            inverse_t = min(surrogate / (_CENTRING * 2 * m), inverse_t / 1.2)
        # the Newton system: (D Dᵀ + diag(μ₁/(λ-ν) + μ₂/(λ+ν))) Δν = -r + c₁/(λ-ν) - c₂/(λ+ν)
        rhs = centre(mu1, nu, 1, inverse_t)
        rhs /= slack(nu, 1)
        dual = gram_less_dx(nu)  # the dual residual D Dᵀν - Dx + μ₁ - μ₂
        dual += mu1
        dual -= mu2
        rhs -= dual
        del dual
        term = centre(mu2, nu, -1, inverse_t)
        term /= slack(nu, -1)
        rhs -= term
        del term
        system = np.zeros((count + 1, m), order="F")  # upper form, overwritten by its factor
        for d in range(1, count + 1):
            system[count - d, d:] = bands[d]
        np.divide(mu1, slack(nu, 1), out=system[count])
        system[count] += bands[0]
        term = slack(nu, -1)
        np.divide(mu2, term, out=term)
        system[count] += term
        del term
        try:
            dnu = solveh_banded(
                system, rhs, overwrite_ab=True, overwrite_b=True, check_finite=False
            )
        except (LinAlgError, ValueError):
            break
        del system, rhs
        step = 1.0
        # the longest step keeping μ > 0 and |ν| < λ, times 0.99
        step = _longest_step(step, mu1, mu_step(mu1, nu, dnu, 1, inverse_t))
        step = _longest_step(step, mu2, mu_step(mu2, nu, dnu, -1, inverse_t))
        step = _longest_step(step, slack(nu, 1), -dnu)
        step = _longest_step(step, slack(nu, -1), dnu)
        before = residual_norm(nu, mu1, mu2, inverse_t)
        for _ in range(_BACKTRACKS):
            trial = dnu * step
            trial += nu
            if np.all(np.abs(trial) < penalty):
                after = residual_norm(trial, mu1, mu2, inverse_t, (step, dnu, nu))
                if after <= (1 - 0.01 * step) * before:
                    break
            trial = None  # freed before the next, shorter, trial
            step *= 0.5
        else:
            break
        for mu, sign in ((mu1, 1), (mu2, -1)):  # μ += step Δμ, Δμ at the current ν
            change = mu_step(mu, nu, dnu, sign, inverse_t)
            change *= step
            mu += change
            del change
        nu, trial, dnu = trial, None, None
    return nu


def _longest_step(step: float, room: np.ndarray, change: np.ndarray) -> float:
    """The least of ``step`` and 0.99 times the longest step s keeping room + s change > 0."""
    falling = change < 0
    if falling.any():
        step = min(step, 0.99 * float(np.min(room[falling] / -change[falling])))
    return step


def _active_set_finish(x, nu, penalty, count):
    """Primal-dual active-set rounds from the dual iterate ν: fix ν_i = ±λ where ν + c·Dz
    leaves the box (c = λ / max|Dz|: there the trend bends, with the sign of (Dz)_i), solve
    the banded system D_F(x - Dᵀν) = 0 for the other ν_i, and repeat until the set no longer
    changes. If it settles with every free ν_i inside the box (to ``_ACCEPT``), the
    optimality conditions hold to rounding and that ν is returned; otherwise the iterate ν,
    unchanged."""
    bands = _gram_bands(count)
    m = nu.shape[0]
    start, previous = nu, None
    for _ in range(MAX_ACTIVE_SET_ROUNDS):
        w = difference(x, count)  # Dz = Dx - D Dᵀν
        w -= difference(difference_adjoint(nu, count), count)
        scale = penalty / max(float(np.max(np.abs(w))), np.finfo(float).tiny)
        w *= scale
        w += nu  # the predicted ν + c·Dz
        upper, lower = w > penalty, w < -penalty
        del w
        key = (upper.tobytes(), lower.tobytes())
        if key == previous:
            if np.max(np.abs(nu)) <= penalty * (1 + _ACCEPT):
                return np.clip(nu, -penalty, penalty)
            return start
        previous = key
        del nu
        nu = np.zeros(m)
        nu[upper], nu[lower] = penalty, -penalty
        upper |= lower
        del lower
        free = np.flatnonzero(~upper)
        del upper
        if free.size:
            rhs = difference(x, count)
            rhs -= difference(difference_adjoint(nu, count), count)
            rhs = rhs[free]
            system = np.zeros((count + 1, free.size), order="F")
            system[count] = bands[0]
            for d in range(1, count + 1):  # (D_F D_Fᵀ)_{i,i+d}: the band of their distance
                steps = free[d:] - free[:-d]
                apart = steps > count
                np.minimum(steps, count, out=steps)
                system[count - d, d:] = bands[steps]
                del steps
                system[count - d, d:][apart] = 0.0
                del apart
            try:
                nu[free] = solveh_banded(
                    system, rhs, overwrite_ab=True, overwrite_b=True, check_finite=False
                )
            except (LinAlgError, ValueError):
                return start
            del system, rhs
            if not np.all(np.isfinite(nu)):
                return start
        del free
    return start


def trend_filter(x: np.ndarray, penalty: float, tv_order: int) -> np.ndarray:
    r"""ℓ1 trend filter of order k = ``tv_order`` (1 or 2) of the samples ``x`` (1-D):

    .. math:: z^\star = \arg\min_z \tfrac12 \|x - z\|_2^2 + \lambda \|D^{k+1} z\|_1

    with :math:`D^{k+1}` the (k+1)-th forward difference (:func:`difference`) and λ =
    ``penalty`` > 0 (in units of x, per sample). k = 1 penalises the total variation of the
    slope (z is piecewise linear: the discrete TVRegDiff of Chartrand), k = 2 that of the
    second difference (z is piecewise quadratic). The problem is strictly convex: z* is
    unique, and a polynomial of degree <= k costs no penalty.

    Solved through its dual, a box-constrained quadratic programme with a banded
    :math:`D D^\top` (Kim et al., sec. 5):

    .. math:: \min_{\|\nu\|_\infty \le \lambda} \tfrac12 \|D^\top \nu\|^2 - \nu^\top D x,
        \qquad z = x - D^\top \nu,

    whose duality gap :math:`\sum_i \lambda |(Dz)_i| - \nu_i (Dz)_i \ge 0` certifies
    :math:`\|z - z^\star\|^2 \le 2\,\mathrm{gap}`. First a primal-dual interior-point
    iteration (one banded Cholesky solve per Newton step, O(n); at most
    :data:`MAX_INTERIOR_ITERATIONS`) to a relative gap of :data:`GAP_TOLERANCE`, then at most
    :data:`MAX_ACTIVE_SET_ROUNDS` active-set rounds that solve the optimality conditions
    :math:`x - z = D^\top\nu`, :math:`|\nu_i| \le \lambda`, :math:`\nu_i = \lambda\,
    \mathrm{sign}((Dz)_i)` where :math:`(Dz)_i \ne 0` exactly; the dual point of least gap is
    kept. Deterministic. Two cases are closed-form: :math:`\lambda \ge \lambda_{\max}` gives
    the least-squares polynomial of degree k (:func:`fused_penalty`), and :math:`\lambda
    2^{k+1}` below rounding of x gives x (always :math:`\|z^\star - x\|_\infty \le \lambda
    2^{k+1}`).

    The Newton systems grow ill-conditioned with the length L of the stretches where z is
    one polynomial (condition ~ (L/π)^{2(k+1)}): past a few hundred samples (just below
    λ_max on long records) the iteration may stop at the cap with a gap above the
    tolerance, and the best point met is returned.

    References: S.-J. Kim, K. Koh, S. Boyd, D. Gorinevsky, "ℓ1 trend filtering", SIAM Review
    51 (2009) 339-360; R. Chartrand, "Numerical differentiation of noisy, nonsmooth data",
    ISRN Applied Mathematics 2011, 164564; M. Hintermüller, K. Ito, K. Kunisch, "The
    primal-dual active set strategy as a semismooth Newton method", SIAM J. Optim. 13 (2002).

    Examples
    --------
    A kink is kept, shrunk (a straight line, which costs nothing, would be kept as it is):

    >>> trend_filter(np.array([0.0, 1.0, 2.0, 1.0, 0.0]), 0.1, 1).round(4)
    array([0.0571, 0.9857, 1.9143, 0.9857, 0.0571])
    """
    count = tv_order + 1
    largest = float(np.max(np.abs(x)))
    if penalty * 2**count <= _ROUNDING * largest or largest == 0.0:
        return x.copy()
    limit, fit = fused_penalty(x, tv_order)
    if penalty >= limit:
        return fit
    del fit
    nu = _interior_point(x, penalty, count)
    nu = _active_set_finish(x, nu, penalty, count)
    return x - difference_adjoint(nu, count)


def trend_derivatives(z: np.ndarray, dt: float, orders) -> dict[int, np.ndarray]:
    """Derivatives of ``orders`` of the samples z (time on axis 0) by second-order
    differences: central inside, one-sided at the ends,

    .. math:: \\dot z_i = \\frac{z_{i+1} - z_{i-1}}{2\\Delta t},\\
        \\dot z_0 = \\frac{-3z_0 + 4z_1 - z_2}{2\\Delta t},\\quad
        \\ddot z_i = \\frac{z_{i+1} - 2z_i + z_{i-1}}{\\Delta t^2}

    (mirrored at the last sample; the second difference at an end is its neighbour's), exact
    on quadratics. Needs at least 3 samples.
    """
    results = {}
    for order in orders:
        if order == 0:
            results[0] = z.copy()
        elif order == 1:
            slope = np.empty_like(z)
            slope[1:-1] = (z[2:] - z[:-2]) / (2 * dt)
            slope[0] = (-3 * z[0] + 4 * z[1] - z[2]) / (2 * dt)
            slope[-1] = (3 * z[-1] - 4 * z[-2] + z[-3]) / (2 * dt)
            results[1] = slope
        else:
            curvature = np.empty_like(z)
            curvature[1:-1] = (z[2:] - 2 * z[1:-1] + z[:-2]) / dt**2
            curvature[0], curvature[-1] = curvature[1], curvature[-2]
            results[2] = curvature
    return results


def total_variation_derivatives(
    x: np.ndarray, dt: float, orders, penalty: float, tv_order: int
) -> dict[int, np.ndarray]:
    r"""Derivatives of ``orders`` of samples ``x`` (time on axis 0, each channel alone) by
    ℓ1 trend filtering (:func:`trend_filter`) and differences (:func:`trend_derivatives`).

    ``penalty`` α is in physical units, x·s^{k+1}: the per-sample penalty is
    :math:`\lambda = \alpha / \Delta t^{k+1}`, for which the objective times Δt is the Riemann
    sum of

    .. math:: \tfrac12 \int (x - z)^2\, dt + \alpha\, \mathrm{TV}(z^{(k)}),

    the same functional at any sampling step. Roughly, it removes a component of amplitude
    below :math:`\alpha (2\pi f)^{k+1}` at frequency f (the residual's (k+1)-fold integral is
    bounded by α), so α scales with the amplitude of x.
    """
    count = tv_order + 1
    flat = x.reshape(x.shape[0], -1)
    with np.errstate(over="ignore", under="ignore", divide="ignore"):
        # may overflow to inf (then past λ_max: the polynomial) or underflow to 0 (then x)
        lam = float(np.float64(penalty) / np.float64(dt) ** count)
    if flat.shape[1] == 1:  # one channel: its trend is the array (no second copy)
        smooth = trend_filter(np.ascontiguousarray(flat[:, 0]), lam, tv_order)
    else:
        smooth = np.empty_like(flat)
        for channel in range(flat.shape[1]):
            column = np.ascontiguousarray(flat[:, channel])
            smooth[:, channel] = trend_filter(column, lam, tv_order)
    values = trend_derivatives(smooth.reshape(x.shape), dt, orders)
    return values


END_SAMPLES = {0: 2, 1: 4, 2: 3}
"""Samples masked at each end, per order: those whose estimate reads the trend's first (last)
two samples (ẋ_i and ẍ_i read z_{i-1..i+1}; ẍ_0 is ẍ_1), and for ẋ one more: its fourth
sample from an end had 3.1-3.4 times the interior's RMS error at 2.345 and 4.937 s (the
trend's end error decays over a few samples; at most 2.8 times from the fifth on, paper
signal over 1.0-4.937 s, 20 seeds, tests/methods/test_valid_marks.py)."""


@register("total_variation")
class TotalVariation(Method):
    """Total-variation regularised differentiation: ℓ1 trend filtering, then second-order
    differences (see :func:`total_variation_derivatives`).

    Every sample is estimated; the samples that read the trend's first or last two samples
    are masked, and ẋ's fourth (:data:`END_SAMPLES`: 2 of x, 4 of ẋ, 3 of ẍ at each end). On
    the clean paper signal at the paper-signal preset the first and last ẋ were 3.3 times the
    worst interior error; on the paper signal over 1.237 s (20 seeds) ẋ_1, ẍ_0 and ẍ_1 had
    3.2-3.6 times the interior's RMS error, ẋ's fourth sample from the end 3.1-3.4 times at
    2.345 and 4.937 s. The ends are not probed otherwise, the method not being linear. Not
    linear (the ℓ1 penalty makes it a
    shrinkage); symmetric under time reversal (the problem is, and its solution is unique).
    Exact on polynomials of degree ``tv_order`` (they cost no penalty, so the trend is the
    data, and the differences are exact on quadratics).

    Irregular time stamps are resampled (``time_stamps = "resampled"``), by measurement: the
    native form, the trend filter with divided differences on the stamps (Tibshirani 2014,
    sec. 6) and the derivatives of the quadratics through neighbouring stamps, did worse. On
    the paper signal at a 5 ms step with noise 0.01 (10 seeds, each form tuned by the truth
    on another seed) its interior ẋ RMSE was 6.80 against 3.37 resampled with 30 % of the
    samples dropped, 3.28 against 2.95 with ±45 % jitter (ẍ 1280 against 718, 1073 against
    647): the three-stamp differences across a gap, not the trend, carry the error. The same
    trend differentiated on the grid came within 1 % of resampling (7 % better on the
    jittered ẍ), not enough to be worth a second path.

    Parameters
    ----------
    penalty : float in (0, inf)
        α, the weight of the total variation of the k-th derivative, in units of x·s^{k+1}
        (λ = α/Δt^{k+1} per sample); larger is smoother.
    tv_order : {1, 2}
        k: 1 penalises the variation of ẋ (piecewise-linear trend, as Chartrand's TVRegDiff),
        2 that of ẍ (piecewise-quadratic trend, piecewise-constant ẍ).

    References
    ----------
    Kim, Koh, Boyd & Gorinevsky, SIAM Review 51 (2009); Chartrand, ISRN Appl. Math. (2011).
    """

    penalty: float = param(
        1e-8,
        low=0.0,
        low_open=True,
        tune_low=1e-11,
        tune_high=1e-2,
        log=True,
        doc="weight α of the total variation of the k-th derivative, x·s^(k+1)",
    )
    tv_order: int = param(2, integer=True, choices=TV_ORDERS, doc="k: 1 (TV of ẋ), 2 (TV of ẍ)")
    presets = {
        "paper-signal": Preset(
            {"penalty": 1.09e-8, "tv_order": 2},
            "diffbench, not in the paper: oracle tuning on the held-out noise seed 10000, "
            "least interior ẍ RMSE",
        ),
        "robot": Preset(
            {"penalty": 3e-9, "tv_order": 2},
            "diffbench, not in the paper: removes 5 Hz components (the cutoff of the paper's "
            "Butterworth, 0.1 fs/2, sec. IV) smaller than one 16-bit encoder step, "
            "α = 2π/2^16 / (2π·5)^3",
        ),
    }
    reference = "Kim et al. (2009)"
    linear = False

    def min_samples(self, dt: float) -> int:
        # the end samples masked on each side (END_SAMPLES) and one valid sample between
        return max(self.tv_order + 2, 2 * max(END_SAMPLES.values()) + 1)

    def exact_degree(self, order: int) -> float | None:
        return self.tv_order

    def _estimate(self, x, dt, orders):
        values = total_variation_derivatives(x, dt, orders, self.penalty, self.tv_order)
        valid = {order: np.ones(x.shape[0], dtype=bool) for order in orders}
        for order in orders:
            # the trend's first and last two samples each take part in one or two of the
            # penalty's k + 2-sample terms (the others in more): the freest, so the noisiest;
            # every estimate that reads them is marked not valid (ẋ_0 is one-sided besides:
            # noise gain √26/2 against the central √2/2)
            ends = END_SAMPLES[order]
            valid[order][:ends] = False
            valid[order][x.shape[0] - ends :] = False
        return values, valid
