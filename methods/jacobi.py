"""The central Jacobi differentiator (Liu, Gibaru, Perruquetti 2011; Guo et al. 2015)."""

from __future__ import annotations

import numpy as np
from diffbench.methods._registry import FirMethod, Preset, param, register
from diffbench.methods.jacobi_kernel import RULES, fir_weights, half_width


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
    number. The first and last M samples of each order are masked (the window does not fit).
    Exact on polynomials of degree n+q (n+q+1 for κ = μ with even q) with the
    ``least_squares`` rule; the ``trapezoid`` and ``linear`` rules approximate the continuous
    filter (O(Ts²) for ``linear``; far better for ``trapezoid`` when min(κ, μ) ≥ 2).

    Parameters
    ----------
    kappa : float > -1
        Exponent of (1 + τ): weights the past end of the window.
    mu : float > -1
        Exponent of (1 − τ): weights the future end.
    q : int >= 0
        Truncation order of the Jacobi series (odd q with κ = μ equals q − 1).
    window_s : float > 0
        Window T for orders 0 and 1, seconds.
    accel_window_s : float > 0
        Window T for order 2, seconds.
    rule : {"trapezoid", "linear", "least_squares"}
        Discretisation; only ``linear`` admits κ or μ < 0.

    References
    ----------
    D.-Y. Liu, O. Gibaru, W. Perruquetti, "Differentiation by integration with Jacobi
    polynomials", J. Comput. Appl. Math. 235 (2011) 3015-3032; Q. Guo, M. Gautier, D.-Y. Liu,
    W. Perruquetti, IEEE/ASME AIM 2015, sec. III.
    """

    kappa: float = param(
        12.0,
        low=-1.0,
        low_open=True,
        tune_low=-0.5,
        tune_high=30.0,
        doc="weight exponent at the past end (1+tau)^kappa",
    )
    mu: float = param(
        12.0,
        low=-1.0,
        low_open=True,
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
        tune_high=12,
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
    )
    accel_window_s: float = param(
        0.21,
        low=0.0,
        low_open=True,
        tune_low=0.004,
        tune_high=2.0,
        log=True,
        doc="window T = 2M*dt for order 2, seconds",
    )
    rule: str = param(
        "trapezoid", choices=RULES, doc="discretisation of the integral (linear: any kappa, mu)"
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

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.rule != "linear" and min(self.kappa, self.mu) < 0:
            raise ValueError(
                f"`rule`={self.rule!r} needs kappa, mu >= 0 (the weight is infinite at a "
                f"window end for kappa={self.kappa!r}, mu={self.mu!r}); use rule='linear'"
            )

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
        for order in (0, 1, 2):
            self.taps(order, dt)

    def min_samples(self, dt: float) -> int:
        return 2 * max(self._half_width(order, dt) for order in (0, 1, 2)) + 1

    def exact_degree(self, order: int) -> float | None:
        if self.rule != "least_squares":
            return None
        bonus = 1 if self.kappa == self.mu and self.q % 2 == 0 else 0
        return order + self.q + bonus
