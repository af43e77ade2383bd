"""The central Jacobi differentiator (Liu, Gibaru, Perruquetti 2011; Guo et al. 2015)."""

from __future__ import annotations

import collections
import dataclasses
import functools
import hashlib
import math

import numpy as np

from diffbench.methods._ends import trusted_times
from diffbench.methods._fir import apply_central_firs
from diffbench.methods._local_poly import (
    apply_fir_with_ends,
    end_evaluators,
    kernel_weighted_fit_at,
    kernel_weighted_weights_at,
)
from diffbench.methods._registry import FirMethod, Preset, param, register
from diffbench.methods._validation import (
    MAX_WINDOW_STEPS,
    DeferredValueError,
    finite_samples,
    mean_step,
)
from diffbench.methods.jacobi_kernel import (
    MAX_AMPLIFICATION,
    MAX_EXPONENT,
    MIN_EXPONENT,
    RULE_TOLERANCE,
    RULES,
    SEARCH_HALF_WIDTH,
    amplification,
    discretisation_error,
    fir_weights,
    half_width,
    shortest_half_width,
)

ENDS = ("boundary", "shifted", "central")
"""Edge treatments: the weight centred on each end sample and cut by the record, shifted
windows (both checked, see :mod:`methods._ends`), or none."""

WEIGHT_FLOOR = 1e-30
"""Sample weights below this fraction of the largest do not count towards the samples a
shifted end fit needs (they change no digit of it)."""


@register("jacobi")
class Jacobi(FirMethod):
    """Central Jacobi differentiator: a FIR filter from truncated Jacobi series.

    .. math::
        \\hat x^{(n)}(t_0) = h^{-n} \\int_{-1}^{1} Q_{\\kappa,\\mu,n,q}(\\tau)\\,
        x(t_0 + h\\tau)\\, d\\tau, \\qquad h = T/2

    discretised on the samples of the window (see :mod:`methods.jacobi_kernel` for the kernel
    and the three rules). ``window_s`` is T for the smoothed signal and the first derivative,
    ``accel_window_s`` is T for the second derivative (the paper's robot uses 0.6 s and 1.1 s).
    Windows follow the node convention T = 2M·Ts (2M+1 taps), so T/Ts must be an even whole
    number. The central window does not fit on the first and last M samples of each order.
    With ``ends="boundary"`` (the default) each of them gets the boundary-corrected local
    polynomial (Fan & Gijbels 1996, sec. 3.2.5): the window centred on the sample and cut by
    the record, its samples weighted by
    :math:`(1-\\tau_j)^{\\mu+s}(1+\\tau_j)^{\\kappa+s}` of their offset :math:`\\tau_j =
    (t_j - t_0)/h`, the polynomial of degree ``end_degree`` (at least n, at most the interior's
    n+q) fitted by weighted least squares and differentiated at the sample
    (:func:`~diffbench.methods._local_poly.kernel_weighted_fit_at`); the degree rises linearly
    from ``end_degree`` at the record's first sample to the interior's n+q next to the first
    central window, where the fits join the interior's. Exact on polynomials of
    ``end_degree``. The extra exponent s (``end_exponent``; 0, the interior's weight, by
    default) concentrates the end fits' weight near their sample: a cut window sees only one
    side, so a fit as wide as the interior's trades variance for bias there, and a local
    bandwidth of its own is the usual cure (Fan & Gijbels 1996, sec. 3.2.5 and ch. 4); a
    truth-tuned whole-record loss chooses it with ``end_degree``. On the paper signal (1 s,
    its noise, 10 seeds, the paper's preset) the whole-record RMSE of ẋ is 5.7 (7.2 at degree
    5 throughout, and 2172 with shifted windows, whose fit extrapolates towards the window's
    edge where the weight vanishes). With
    ``ends="shifted"`` they are estimated from the first (last) full window with the expansion
    point moved to their own position (Mboup, Join, Fliess 2009):

    .. math::
        \\hat x^{(n)}(t_0 + h\\xi_0) = h^{-n} \\frac{d^n}{d\\xi^n} p^*(\\xi_0), \\qquad
        \\xi_0 = -1, -1 + 1/M, \\dots, -1/M

    with :math:`p^*` the least-squares polynomial of degree n+q (n+q+1 for κ = μ with even q,
    the same fit at the centre) on the window's samples with weights
    :math:`(1-\\tau_j)^{\\mu}(1+\\tau_j)^{\\kappa}` (exponents below 0 taken as 0): exact on the
    same degree as the ``least_squares`` rule (lower where fewer samples carry weight than
    that degree needs, as with κ = μ = 139 on 5 taps; the check below then decides). Either
    way an end sample stays valid only where its response is within twice the interior's error
    over the band the interior claims (:mod:`methods._ends`); the others are estimated but
    marked not valid. ``ends="central"`` leaves all of them unestimated (NaN: the paper's
    figures).
    Exact on polynomials of degree n+q (n+q+1 for κ = μ with even q) with the
    ``least_squares`` rule (at the ends of ``"boundary"``, of ``end_degree``); the
    ``trapezoid`` and ``linear`` rules approximate the continuous filter (O(Ts²) for
    ``linear``; far better for ``trapezoid`` when min(κ, μ) ≥ 2).

    Time stamps (``t=``) are handled natively, whatever the rule: at each sample the weighted
    least-squares polynomial on the actual stamps within half a window, each weighted by
    :math:`(1-\\tau_j)^{\\mu}(1+\\tau_j)^{\\kappa}` times the span of time it stands for (the
    ``least_squares`` rule on the stamps,
    :func:`~diffbench.methods._local_poly.kernel_weighted_fit_at`), the ends as ``ends`` says
    (the window cut by the record, moved inside it, or none), trusted over the spans of time
    the uniform grid nearest the mean step trusts. The windows need not be whole numbers of
    steps there. Measured on the paper's 4, 9, 15 Hz signal at 5 ms with 30 % of the samples
    dropped (κ = μ = 8, q = 10, 0.25 s, noise 0.01, 10 seeds, interior RMSE): ẋ 1.29 and ẍ 95
    natively against 1.94 and 143 resampled; with ±45 % jitter and no gap, 1-3 % better.

    Limits, measured (see :mod:`methods.jacobi_kernel`): κ, μ in [-0.999, 400] (beyond 400
    the kernel overflows; nearer -1 the quadratures lose accuracy, NaN from -1 + 1e-13); the
    design may not amplify rounding by more than 1e8 (lopsided weights with long series, e.g.
    κ = 0, μ = 100, q = 12, reach 1e14: refused on construction, with the range of μ or q that
    works); and at a given step each window must hold enough samples for its rule to
    differentiate the polynomials of degree n+q as the continuous kernel does
    (``least_squares`` to 1e-6, the others to 1 %; refused by ``check_step`` with the shortest
    window that works).

    Parameters
    ----------
    kappa : float in [-0.999, 400]
        Exponent of (1 + τ): weights the past end of the window.
    mu : float in [-0.999, 400]
        Exponent of (1 − τ): weights the future end.
    q : int in [0, 40]
        Truncation order of the Jacobi series (odd q with κ = μ equals q − 1).
    window_s : float > 0
        Window T for orders 0 and 1, seconds.
    accel_window_s : float > 0
        Window T for order 2, seconds.
    rule : {"trapezoid", "linear", "least_squares"}
        Discretisation; only ``linear`` admits κ or μ < 0.
    ends : {"boundary", "shifted", "central"}
        Edge treatment: the weight cut by the record, shifted windows (both checked, see
        above) or none (NaN).
    end_degree : int in [1, 8]
        Degree of the boundary fits (``ends="boundary"``; at least n, at most n+q). Tuned only
        on the whole record: on the paper signal degree 5-7 beat both fewer (more bias) and
        more (more noise at the first samples).

    References
    ----------
    M. Mboup, C. Join, M. Fliess, "Numerical differentiation with annihilators in noisy
    environment", Numer. Algorithms 50 (2009) 439-467 (shifted windows); J. Fan, I. Gijbels,
    *Local Polynomial Modelling and Its Applications*, Chapman & Hall, 1996 (boundary fits);
    D.-Y. Liu, O. Gibaru, W. Perruquetti, "Differentiation by integration with Jacobi
    polynomials", J. Comput. Appl. Math. 235 (2011) 3015-3032; Q. Guo, M. Gautier, D.-Y. Liu,
    W. Perruquetti, IEEE/ASME AIM 2015, sec. III.
    """

    kappa: float = param(
        12.0,
        low=MIN_EXPONENT,
        high=MAX_EXPONENT,
        tune_low=-0.5,
        tune_high=30.0,
        doc="weight exponent at the past end (1+tau)^kappa",
    )
    mu: float = param(
        12.0,
        low=MIN_EXPONENT,
        high=MAX_EXPONENT,
        tune_low=-0.5,
        tune_high=30.0,
        doc="weight exponent at the future end (1-tau)^mu",
    )
    q: int = param(
        6,
        low=0,
        high=40,
        integer=True,
        tune_low=0,
        tune_high=16,
        doc="truncation order of the Jacobi series",
    )
    window_s: float = param(
        0.21,
        low=0.0,
        low_open=True,
        tune_low=0.004,
        tune_high=2.0,
        log=True,
        doc="window T = 2M*dt for orders 0 and 1, seconds",
        kind="window",
    )
    accel_window_s: float = param(
        0.21,
        low=0.0,
        low_open=True,
        tune_low=0.004,
        tune_high=2.0,
        log=True,
        doc="window T = 2M*dt for order 2, seconds",
        kind="window",
    )
    rule: str = param(
        "trapezoid", choices=RULES, doc="discretisation of the integral (linear: any kappa, mu)"
    )
    ends: str = param(
        "boundary",
        choices=ENDS,
        doc=(
            "boundary: the weight centred on each end sample, cut by the record; shifted: the "
            "first/last window at the sample's offset; central: none (NaN)"
        ),
        ends_only=True,
    )
    end_degree: int = param(
        5,
        low=1,
        high=8,
        integer=True,
        tune_low=1,
        tune_high=8,
        doc="degree of the boundary fits at the ends (at least n, at most n+q)",
        ends_only=True,
    )
    end_exponent: float = param(
        0.0,
        low=0.0,
        high=MAX_EXPONENT,
        tune_low=0.0,
        tune_high=8.0,
        doc=(
            "extra exponent s of the boundary fits' weight at the ends, "
            "(1-tau)^(mu+s) (1+tau)^(kappa+s) (exponents below 0 taken as 0 first): 0 is the "
            "interior's weight"
        ),
        ends_only=True,
    )

    presets = {
        "paper-signal": Preset(
            {
                "kappa": 12.0,
                "mu": 12.0,
                "q": 6,
                "window_s": 0.21,
                "accel_window_s": 0.21,
                "rule": "trapezoid",
            },
            "paper, sec. III.C",
            by="paper",
        ),
        "robot": Preset(
            {
                "kappa": 6.0,
                "mu": 6.0,
                "q": 2,
                "window_s": 0.6,
                "accel_window_s": 1.1,
                "rule": "trapezoid",
            },
            "paper, sec. IV (velocity T = 0.6 s, acceleration T = 1.1 s)",
            by="paper",
        ),
    }
    reference = "Liu et al. (2011); Guo et al., AIM 2015"
    time_stamps = "native"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.rule != "linear" and min(self.kappa, self.mu) < 0:
            raise ValueError(
                f"`rule`={self.rule!r} needs kappa, mu >= 0 (the weight is infinite at a "
                f"window end for kappa={self.kappa!r}, mu={self.mu!r}); use rule='linear'"
            )
        self._check_amplification()

    def _worst_amplification(self, kappa: float, mu: float, q: int) -> tuple[float, int]:
        return max((amplification(order, kappa, mu, q), order) for order in (0, 1, 2))

    def _check_amplification(self) -> None:
        """Refuse a design that multiplies rounding by more than ``MAX_AMPLIFICATION``, naming
        the range of the larger exponent (and of ``q``) that works with the others fixed."""
        worst, order = self._worst_amplification(self.kappa, self.mu, self.q)
        if worst <= MAX_AMPLIFICATION:
            return
        raise DeferredValueError(lambda: self._amplification_message(worst, order))

    def _amplification_message(self, worst: float, order: int) -> str:
        """The refusal of :meth:`_check_amplification`, with the range of the larger exponent
        that works (searched: composed only when read)."""
        name, other_name = ("mu", "kappa") if self.mu >= self.kappa else ("kappa", "mu")
        value, other = getattr(self, name), getattr(self, other_name)

        def works(candidate: float) -> bool:
            pair = {name: candidate, other_name: other}
            return self._worst_amplification(pair["kappa"], pair["mu"], self.q)[0] <= (
                MAX_AMPLIFICATION
            )

        floor = MIN_EXPONENT if self.rule == "linear" else 0.0
        low, high = _edge(works, inside=other, outside=floor), _edge(works, other, value)
        lower_q = next(
            (
                candidate
                for candidate in range(self.q - 1, -1, -1)
                if self._worst_amplification(self.kappa, self.mu, candidate)[0] <= MAX_AMPLIFICATION
            ),
            None,
        )
        or_q = "" if lower_q is None else f"; or lower `q` to at most {lower_q}"
        return (
            f"`{name}` must be in [{low:g}, {high:g}] with {other_name}={other!r} and "
            f"q={self.q} (the weight is so lopsided that the order-{order} kernel multiplies "
            f"rounding and noise by {worst:.3g}, more than {MAX_AMPLIFICATION:.0e}: the "
            f"estimate extrapolates from one end), got {value!r}{or_q}"
        )

    def at_record(self, n_samples: int, dt: float):
        """:meth:`Method.at_record`; where the default windows cannot shrink to the record
        under the default ``rule`` (too few samples to resolve the kernel: 16 samples of
        10 ms), the same with ``rule="least_squares"``, which needs only n + q + 2 samples a
        window and stays exact on polynomials of degree n + q."""
        adapted = super().at_record(n_samples, dt)
        given = getattr(self, "_given", frozenset())
        if given & {"rule", "window_s", "accel_window_s"} or adapted._takes_record(n_samples, dt):
            return adapted
        if not self.at_step(dt)._takes_step(dt):  # the rule fails at this step, not the record
            return adapted
        least_squares = type(self)(
            **{name: getattr(self, name) for name in given}, rule="least_squares"
        )
        return least_squares.at_record(n_samples, dt)

    @property
    def time_symmetric(self) -> bool:  # type: ignore[override]
        """Reversing time flips odd derivatives only for a symmetric weight (κ = μ)."""
        return self.kappa == self.mu

    @classmethod
    def irrelevant_params(cls, order: int) -> tuple[str, ...]:
        return ("window_s",) if order == 2 else ("accel_window_s",)

    def _window(self, order: int) -> tuple[str, float]:
        if order == 2:
            return "accel_window_s", self.accel_window_s
        return "window_s", self.window_s

    def _half_width(self, order: int, dt: float) -> int:
        name, window = self._window(order)
        return half_width(window, dt, name)

    def taps(self, order: int, dt: float) -> np.ndarray:
        """The FIR taps a_{-M..M} of the derivative of ``order`` at step ``dt``."""
        return fir_weights(
            order, self.kappa, self.mu, self.q, self._half_width(order, dt), dt, self.rule
        )

    def check_step(self, dt: float) -> None:
        """Each window must be a whole even number of steps (at most ``MAX_WINDOW_STEPS``),
        hold n + q + 2 samples, and be long enough for the rule to differentiate polynomials
        of degree n + q as the continuous kernel does (``RULE_TOLERANCE``) for every order it
        serves; the error names the window and the shortest one that works (found to 2 %)."""
        self._check_window("window_s", (0, 1), dt)
        self._check_window("accel_window_s", (2,), dt)

    def _check_window(self, name: str, orders: tuple[int, ...], dt: float) -> None:
        window = getattr(self, name)
        m = half_width(window, dt, name)
        longest = f"{2 * (MAX_WINDOW_STEPS // 2) * dt:.6g}"
        fewest = (max(orders) + self.q + 2) // 2  # the least M with 2M + 1 >= n + q + 2
        for order in orders:
            needed = order + self.q + 2
            if 2 * m + 1 < needed:
                raise ValueError(
                    f"`{name}` must be in [{2 * fewest * dt:.6g}, {longest}] s at dt={dt!r} s: "
                    f"the window holds {2 * m + 1} samples; a Jacobi estimate with n + q = "
                    f"{order + self.q} needs at least {needed} (or lower `q`), got {window!r}"
                )
        design = (self.kappa, self.mu, self.q)
        tolerance = RULE_TOLERANCE[self.rule]
        errors = {order: discretisation_error(order, *design, m, dt, self.rule) for order in orders}
        failing = [order for order in orders if errors[order] > tolerance]
        if not failing:
            return
        worst = max(failing, key=errors.get)

        def message() -> str:
            # the shortest window that works for this rule and the others, searched by
            # computing taps: only when the refusal is read (DeferredValueError)
            missed = (
                f"on {window!r} s the order-{worst} taps are off by {errors[worst]:.2g} on "
                f"polynomials up to degree {worst + self.q}, more than {tolerance:g}"
            )
            limit = min(MAX_WINDOW_STEPS // 2, SEARCH_HALF_WIDTH)
            # orders that pass at m pass on longer windows too (the error falls as M grows)
            this_rule = shortest_half_width(orders, *design, dt, self.rule, m + 1, limit)
            others = {
                rule: shortest_half_width(orders, *design, dt, rule, fewest, limit)
                for rule in RULES
                if rule != self.rule and (rule == "linear" or min(self.kappa, self.mu) >= 0)
            }
            alternatives = "; ".join(
                f"rule={rule!r} works from {2 * other * dt:.6g} s"
                for rule, other in others.items()
                if other is not None
            )
            settings = f"kappa={self.kappa!r}, mu={self.mu!r}, q={self.q}"
            if this_rule is None:
                return (
                    f"`rule`={self.rule!r} fails for {settings} at dt={dt!r} s on every `{name}` "
                    f"up to {2 * limit * dt:.6g} s ({missed}): {alternatives or 'no rule works'}"
                )
            return (
                f"`{name}` must be in [{2 * this_rule * dt:.6g}, {longest}] s at dt={dt!r} s for "
                f"rule={self.rule!r} with {settings} (shorter, too few samples resolve the kernel: "
                f"{missed}), got {window!r}" + (f"; {alternatives}" if alternatives else "")
            )

        raise DeferredValueError(message)

    def min_samples(self, dt: float) -> int:
        return 2 * max(self._half_width(order, dt) for order in (0, 1, 2)) + 1

    def end_reach(self, dt: float) -> int | None:
        if self.ends == "central":
            return None
        return max(self._half_width(order, dt) for order in (0, 1, 2))

    def _fit_degree(self, order: int) -> int:
        """Degree of the weighted fit whose derivative the estimate is: n + q, plus one for
        κ = μ with even q (the same fit at the centre, by symmetry)."""
        bonus = 1 if self.kappa == self.mu and self.q % 2 == 0 else 0
        return order + self.q + bonus

    def unused_params(self) -> tuple[str, ...]:
        return () if self.ends == "boundary" else ("end_degree", "end_exponent")

    def _end_degree(self, order: int, carrying: int) -> int:
        """The boundary fits' degree: ``end_degree`` within [n, n+q], and below ``carrying``,
        the samples of half a window whose end weight counts (the first sample's fit has only
        those)."""
        return min(max(order, self.end_degree), self._fit_degree(order), carrying - 1)

    def _carrying(self, m: int, weight=None) -> int:
        """Samples of half a window (the first sample's fit) whose ``weight`` (by default the
        interior's, :meth:`_weight`) counts."""
        half = (weight or self._weight)(np.arange(-m, m + 1) / m)[m:]
        return int(np.count_nonzero(half > half.max() * WEIGHT_FLOOR))

    def _weights(self, m: int) -> np.ndarray:
        """The weight at the window's 2m + 1 nodes (:meth:`_weight`)."""
        return self._weight(np.arange(-m, m + 1) / m)

    def _weight(self, tau: np.ndarray) -> np.ndarray:
        """:math:`(1-\\tau)^{\\mu}(1+\\tau)^{\\kappa}` at offsets ``tau`` (window half-widths,
        clipped to [-1, 1]; negative exponents taken as 0)."""
        tau = np.clip(tau, -1.0, 1.0)
        return (1 - tau) ** max(self.mu, 0.0) * (1 + tau) ** max(self.kappa, 0.0)

    def _end_weight(self, tau: np.ndarray) -> np.ndarray:
        """The boundary fits' weight :math:`(1-\\tau)^{\\mu+s}(1+\\tau)^{\\kappa+s}`, the
        interior's :meth:`_weight` times :math:`(1-\\tau^2)^s` for ``end_exponent`` s (the
        interior's itself for s = 0)."""
        if self.end_exponent == 0:
            return self._weight(tau)
        tau = np.clip(tau, -1.0, 1.0)
        return self._weight(tau) * (1 - tau * tau) ** self.end_exponent

    def _boundary_degrees(self, order: int, m: int) -> np.ndarray:
        """The boundary fits' degree at end samples 0..m-1 (0 at the record's edge): from
        :meth:`_end_degree` at the edge rising linearly to the interior's n+q next to the first
        central window, so that the fits join the interior's. Below ``order`` where too few
        samples carry weight (those samples get no estimate)."""
        carrying = self._carrying(m, self._end_weight)
        edge, inside = self._end_degree(order, carrying), self._fit_degree(order)
        inside = min(inside, max(edge, carrying - 1))
        return np.round(edge + (inside - edge) * np.arange(m) / m).astype(int)

    def _boundary_ends(
        self, x, dt, order: int, m: int, filtered: np.ndarray, skip: int = 0
    ) -> np.ndarray:
        """``filtered`` (the central filter's output) with its first and last ``m`` samples the
        boundary fits of ``ends="boundary"``, at :meth:`_boundary_degrees`; the first and last
        ``skip`` of them NaN, not fitted (each fit is its own: the others are unchanged)."""
        n = x.shape[0]
        size = min(n, 2 * m + 1)
        skip = min(skip, m)
        out = np.array(filtered, dtype=np.float64).reshape(n, -1)
        if m * size <= LAST_END_WEIGHTS:
            starts, ends = _boundary_weights(self, order, m, size, skip)
            scale = 1.0 / dt**order
            out[:m] = scale * (starts @ x[:size].reshape(size, -1))
            out[n - m :] = scale * (ends @ x[n - size :].reshape(size, -1))
            return out.reshape(filtered.shape)

        def weight(offset_s):
            return self._end_weight(offset_s / (m * dt))

        degrees = self._boundary_degrees(order, m)
        times = np.arange(size) * dt
        out[:skip] = out[n - skip :] = np.nan
        for degree in np.unique(degrees):
            at = np.flatnonzero(degrees == degree)
            at = at[at >= skip]
            if degree < order:  # too few samples carry weight to fit a derivative of order
                out[at] = out[n - 1 - at] = np.nan
                continue
            if not at.size:
                continue
            fit = (m * dt, int(degree), order, weight)
            out[at] = kernel_weighted_fit_at(x[:size], times, at, *fit)
            out[n - 1 - at] = kernel_weighted_fit_at(x[n - size :], times, size - 1 - at, *fit)
        return out.reshape(filtered.shape)

    def _estimate_away_from_ends(self, x, dt, orders):
        # the central filter alone (the ends NaN): what a tuning's interior loss reads; the
        # boundary fits cost O(M^2) a record (seconds at M in the thousands, 0.1 ms steps)
        return super()._estimate(x, dt, orders)

    skips_unread_ends = True

    def _estimate(self, x, dt, orders):
        return self._estimate_skipping_ends(x, dt, orders, 0)

    def _estimate_skipping_ends(self, x, dt, orders, skip):
        # the boundary fits cost O(m^2) a setting (QRs); each end sample's is its own
        if self.ends == "central":
            return super()._estimate(x, dt, orders)
        values, valid = {}, {}
        taps = {order: self.taps(order, dt) for order in orders}
        # all orders share one FFT; a window longer than the record fails below, with its message
        central = dict(zip(taps, apply_central_firs(x, list(taps.values())), strict=True))
        for order in orders:
            m = self._half_width(order, dt)
            if self.ends == "boundary":
                if x.shape[0] < 2 * m + 1:
                    raise ValueError(
                        f"`x` has {x.shape[0]} samples, fewer than the window's {2 * m + 1}"
                    )
                values[order] = self._boundary_ends(x, dt, order, m, central[order][0], skip)
            else:
                weights = self._weights(m)
                # a fit needs degree + 1 samples that carry weight: the end nodes carry none
                # for κ, μ > 0, and large κ, μ leave few more (κ = μ = 139 on 5 taps: 1 in 1e17)
                carrying = np.count_nonzero(weights > weights.max() * WEIGHT_FLOOR)
                degree = min(self._fit_degree(order), carrying - 1)
                ends = end_evaluators(m, degree, order, dt, sample_weights=weights)
                values[order] = apply_fir_with_ends(x, taps[order], ends, central[order][0])
            valid[order] = finite_samples(values[order])
        return values, valid

    def _estimate_at(self, x, times, orders):
        values, valid = {}, {}
        mean = mean_step(times)
        for order in orders:
            name, window = self._window(order)
            if times[-1] - times[0] < window:
                raise ValueError(
                    f"`t` spans {times[-1] - times[0]!r} s, shorter than `{name}`={window!r} s; "
                    "use a shorter window or a longer record"
                )
            values[order] = self._fits_at(x, times, order, window / 2, mean)
            if self.ends == "central":  # the ends not estimated: nothing else to mark
                valid[order] = finite_samples(values[order])
                continue
            # the ends trusted over the spans of time the uniform grid nearest the mean step
            # trusts (that order's window a whole even number of its steps)
            grid_step = window / max(2, 2 * round(window / (2 * mean)))
            alike = dataclasses.replace(self, window_s=window, accel_window_s=window)
            trusted = trusted_times(alike, times, grid_step, (order,))[order]
            valid[order] = trusted & finite_samples(values[order])
        return values, valid

    def _fits_at(self, x, times, order: int, reach_s: float, mean_step: float) -> np.ndarray:
        """The estimates of ``order`` at irregular ``times`` (see :meth:`_estimate_at`)."""
        n = times.size
        flat = x.reshape(n, -1)
        out = np.full(flat.shape, np.nan)
        inside = (times - times[0] >= reach_s * (1 - 1e-9)) & (
            times[-1] - times >= reach_s * (1 - 1e-9)
        )
        m = max(1, round(reach_s / mean_step))  # the half width in mean steps, for the degrees

        def weight(offset_s):
            return self._weight(offset_s / reach_s)

        def end_weight(offset_s):
            return self._end_weight(offset_s / reach_s)

        def fit(at, degree, centres_s=None, kernel=weight):
            if at.size:
                out[at] = kernel_weighted_fit_at(
                    flat, times, at, reach_s, int(degree), order, kernel, centres_s
                )

        # the central fits depend on the weight's exponents and the degree alone (not the
        # rule, nor the end treatment): kept for the settings a tuning tries with each
        design = (max(self.kappa, 0.0), max(self.mu, 0.0), self._fit_degree(order))
        key = (_record_key(flat, times), order, float(reach_s), *design)
        central = _kept_central_fits.get(key)
        if central is None:
            at = np.flatnonzero(inside)
            fit(at, design[2])
            _kept_central_fits.put(key, out[at])  # a copy (fancy indexing)
        else:
            out[inside] = central
        edge = np.flatnonzero(~inside)
        if self.ends == "boundary":
            # the degree rises with the distance to the nearest end, as on the uniform grid
            distance = np.minimum(times[edge] - times[0], times[-1] - times[edge])
            degrees = self._boundary_degrees(order, m)
            steps = np.minimum(np.floor(distance / reach_s * m + 1e-9).astype(int), m - 1)
            for degree in np.unique(degrees[steps]):
                if degree >= order:  # else too few samples carry weight: no estimate
                    fit(edge[degrees[steps] == degree], degree, kernel=end_weight)
        elif self.ends == "shifted":
            centres = np.clip(times[edge], times[0] + reach_s, times[-1] - reach_s)
            degree = min(self._fit_degree(order), self._carrying(m) - 1)
            fit(edge, degree, centres)
        return out.reshape(x.shape)

    def exact_degree(self, order: int) -> float | None:
        if self.rule != "least_squares":
            return None
        if self.ends == "boundary":
            return min(self._fit_degree(order), max(order, self.end_degree))
        return self._fit_degree(order)


KEPT_CENTRAL_FITS_BYTES = 64 * 2**20
"""The most bytes of central fits at time stamps kept (:data:`_kept_central_fits`), the least
recently used dropped first: 64 MiB, e.g. 840 settings' fits of a 10^4-sample channel."""


def _record_key(flat: np.ndarray, times: np.ndarray) -> tuple:
    """A record's samples and time stamps as a key: their shapes and a BLAKE2b digest of
    their bytes (a collision would need about 2^80 records)."""
    digest = hashlib.blake2b(digest_size=20)
    digest.update(np.ascontiguousarray(flat, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(times, dtype=np.float64).tobytes())
    return (flat.shape, times.shape, digest.digest())


class _Kept:
    """Read-only arrays (or tuples of them) by key, the least recently used dropped beyond
    ``maxsize`` bytes; ``cache_clear`` and ``cache_parameters`` as ``functools.lru_cache``
    has them (so that what empties the methods' bounded caches empties these too)."""

    def __init__(self, maxsize: int) -> None:
        self._values: collections.OrderedDict[tuple, tuple] = collections.OrderedDict()
        self._bytes = 0
        self._maxsize = maxsize

    def get(self, key: tuple):
        found = self._values.get(key)
        if found is None:
            return None
        self._values.move_to_end(key)
        return found[0]

    def put(self, key: tuple, value) -> None:
        arrays = value if isinstance(value, tuple) else (value,)
        for array in arrays:
            array.flags.writeable = False
        size = sum(array.nbytes for array in arrays)
        if key in self._values:
            self._bytes -= self._values.pop(key)[1]
        self._values[key] = (value, size)
        self._bytes += size
        while self._bytes > self._maxsize and len(self._values) > 1:
            self._bytes -= self._values.popitem(last=False)[1][1]

    def __len__(self) -> int:
        return len(self._values)

    def cache_clear(self) -> None:
        self._values.clear()
        self._bytes = 0

    def cache_parameters(self) -> dict:
        return {"maxsize": self._maxsize, "typed": False}


_kept_central_fits = _Kept(KEPT_CENTRAL_FITS_BYTES)
"""The central fits of :meth:`Jacobi._fits_at` by record, order, reach and design. On
irregular records a Jacobi tuning tries each setting of its numbers once per rule and end
treatment (nine combinations): their central fits, a QR for every sample's window, are the
same, computed once and read eight times."""


CACHED_END_WEIGHTS = 4_000_000
"""The most weights (end samples times window samples, per end) of Jacobi's boundary fits
kept for reuse among many settings (:data:`KEPT_END_WEIGHTS_BYTES` in all): 32 MB an end,
windows up to 2827 samples."""

KEPT_END_WEIGHTS_BYTES = 256 * 2**20
"""The most bytes of boundary weights kept (:data:`_kept_end_weights`), the least recently
used dropped first: a tuning tries each setting of its numbers once per rule, whose boundary
fits are the same (the rule discretises the central kernel only), and its differential
evolutions start from the same Sobol points."""

LAST_END_WEIGHTS = 25_000_000
"""The most weights of the boundary fits kept for the last setting only (200 MB an end,
windows up to 7071 samples): a scored cell estimates one setting's record seven times (the
estimate, then its bias and noise parts for each order), 0.3 s windows at 0.1 ms steps
(the grid's) are 2963 samples wide. Wider ones are fitted record by record."""


def _boundary_weights(method: Jacobi, order: int, m: int, size: int, skip: int = 0):
    """:func:`_fitted_boundary_weights`, kept by the parameters they depend on (not the rule,
    nor the windows in seconds: :func:`_end_design`) up to ``CACHED_END_WEIGHTS`` a setting,
    for the last setting only up to ``LAST_END_WEIGHTS``."""
    if m * size > CACHED_END_WEIGHTS:
        return _last_boundary_weights(method, order, m, size, skip)
    key = (_end_design(method), order, m, size, skip)
    found = _kept_end_weights.get(key)
    if found is None:
        found = _fitted_boundary_weights(method, order, m, size, skip)
        _kept_end_weights.put(key, found)
    return found


def _end_design(method: Jacobi) -> tuple:
    """What the boundary fits depend on besides the order and the sizes: the weight's
    exponents, q, and the end degree and exponent (:meth:`Jacobi._boundary_degrees`,
    :meth:`Jacobi._end_weight`)."""
    return (
        float(method.kappa),
        float(method.mu),
        int(method.q),
        int(method.end_degree),
        float(method.end_exponent),
    )


def _fitted_boundary_weights(method: Jacobi, order: int, m: int, size: int, skip: int = 0):
    """The boundary fits of ``ends="boundary"`` as weights, in steps (dt = 1): the matrices
    (m by ``size``) giving end samples 0..m-1 from the first ``size`` samples and samples
    n-m..n-1 from the last ``size``, at :meth:`Jacobi._boundary_degrees` (rows of NaN where
    the degree is below ``order``, and for the first and last ``skip`` samples, not fitted:
    each row is its own fit, the same bits with or without the others). The same for every
    record of a length at least ``size`` and every step (the fit scales as 1/dt^order), so
    computed once per setting: the QR factorisations cost O(m^2 d^2), the product O(m^2) a
    record."""

    def weight(offset_steps):
        return method._end_weight(offset_steps / m)

    degrees = method._boundary_degrees(order, m)
    times = np.arange(size, dtype=float)
    starts = np.full((m, size), np.nan)
    ends = np.full((m, size), np.nan)
    for degree in np.unique(degrees):
        at = np.flatnonzero(degrees == degree)
        at = at[at >= skip]
        if degree < order or not at.size:  # too few samples carry weight, or none read
            continue
        fit = (float(m), int(degree), order, weight)
        starts[at] = kernel_weighted_weights_at(times, at, *fit)
        # the last samples' fits, in the order n-m..n-1: the last sample is row m-1
        ends[m - 1 - at] = kernel_weighted_weights_at(times, size - 1 - at, *fit)
    starts.flags.writeable = ends.flags.writeable = False
    return starts, ends


_kept_end_weights = _Kept(KEPT_END_WEIGHTS_BYTES)
_last_boundary_weights = functools.lru_cache(maxsize=1)(_fitted_boundary_weights)


def _edge(works, inside: float, outside: float) -> float:
    """The value nearest ``outside`` on the segment from ``inside`` (which works) up to which
    everything works: ``outside`` itself if it works, else bisection to 1e-3 (assuming one
    crossing), rounded to 1e-3 towards ``inside`` so that the value returned works."""
    if works(outside):
        return outside
    good, bad = inside, outside
    while abs(good - bad) > 1e-3:
        middle = (good + bad) / 2
        good, bad = (middle, bad) if works(middle) else (good, middle)
    return math.floor(good * 1e3) / 1e3 if good < bad else math.ceil(good * 1e3) / 1e3
