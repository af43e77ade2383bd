"""Scores for online use: the error of a causal estimate at the time it is made, its delay, the
error left once that delay is compensated, its noise gain; the sweeps of settings whose
(delay, error) points give each method's Pareto front.

A causal estimate :math:`\\hat y_k` of :math:`x^{(n)}(t_k)` is scored

- **at the same time**: :math:`\\mathrm{rmse} = \\sqrt{\\mathrm{mean}_k (\\hat y_k -
  x^{(n)}(t_k))^2}` over the scenario's interior (what a controller acting on it at
  :math:`t_k` suffers);
- **delay** :math:`d = s^*\\Delta t`, :math:`s^* = \\arg\\min_s \\mathrm{mean}_k (\\hat y_k -
  x^{(n)}(t_{k-s}))^2` over whole steps :math:`|s| \\le` :data:`MAX_SHIFT_S`, refined between
  steps by the parabola through the three losses around the least; and the **aligned RMSE**,
  that least loss's root (the error a delay-compensating user would see);
- **phase delay** (linear methods): :math:`-\\arg[H(f)/(i2\\pi f)^n] / (2\\pi f)` at
  :data:`PHASE_FREQUENCY_FRACTION` of Nyquist, the low-frequency limit of the lag;
- **noise gain**: the RMS of the method on the noisy record less the method on the clean
  one, over the RMS of the noise (for a linear method, its white-noise gain on this noise).
"""

from __future__ import annotations

import numpy as np

from diffbench import methods

MAX_SHIFT_S = 0.1
"""Largest delay searched for, seconds (either sign)."""

PHASE_FREQUENCY_FRACTION = 1e-3
"""Where the phase delay is read, as a fraction of the Nyquist frequency."""

ONLINE_METRICS = (
    "rmse",
    "rel_rmse",
    "delay_s",
    "aligned_rmse",
    "phase_delay_s",
    "noise_gain",
    "coverage",
)


def aligning_delay(
    estimate: np.ndarray, truth: np.ndarray, mask: np.ndarray, dt: float, max_shift_s: float
) -> tuple[float, float]:
    """``(delay_s, aligned_rmse)``: the shift of the truth that best matches the estimate on
    the ``mask`` samples (see the module docstring); samples whose shifted truth falls off
    the record are left out of that shift's loss."""
    n = estimate.shape[0]
    limit = max(1, round(max_shift_s / dt))
    shifts = np.arange(-limit, limit + 1)
    losses = np.full(shifts.size, np.inf)
    indices = np.flatnonzero(mask)
    for i, shift in enumerate(shifts):
        keep = indices[(indices - shift >= 0) & (indices - shift < n)]
        if keep.size:
            losses[i] = float(np.mean((estimate[keep] - truth[keep - shift]) ** 2))
    best = int(np.argmin(losses))
    offset = 0.0
    if 0 < best < shifts.size - 1 and np.isfinite(losses[best - 1 : best + 2]).all():
        left, centre, right = losses[best - 1 : best + 2]
        curvature = left - 2 * centre + right
        if curvature > 0:
            offset = 0.5 * (left - right) / curvature
    return float((shifts[best] + offset) * dt), float(np.sqrt(losses[best]))


def phase_delay_s(method: methods.Method, dt: float, order: int) -> float:
    """Low-frequency phase delay of a linear method's estimate of ``order`` (seconds)."""
    frequency = PHASE_FREQUENCY_FRACTION * 0.5 / dt
    response = method.frequency_response(frequency, dt, order)[0]
    relative = response / (2j * np.pi * frequency) ** order
    return float(-np.angle(relative) / (2 * np.pi * frequency))


def online_scores(method: methods.Method, realisation, orders=(1, 2)) -> list[dict]:
    """Tidy rows (order, region "interior", metric, value) of :data:`ONLINE_METRICS` for a
    causal ``method`` on a uniformly sampled ``realisation`` (``x``, ``dt_s``, ``truth``,
    ``interior``)."""
    if not method.causal:
        raise ValueError(f"{method.name} is not causal; the online scores are for causal methods")
    dt = realisation.dt_s
    estimate = method(realisation.x, dt, orders)
    clean = method(realisation.truth[0], dt, orders)
    noise = realisation.x - realisation.truth[0]
    noise_rms = float(np.sqrt(np.mean(noise**2)))
    rows = []
    for order in orders:
        mask = realisation.interior & estimate.valid[order]
        truth = realisation.truth[order]
        values = {"coverage": float(np.count_nonzero(mask) / realisation.interior.sum())}
        if mask.any():
            error = estimate[order][mask] - truth[mask]
            values["rmse"] = float(np.sqrt(np.mean(error**2)))
            values["rel_rmse"] = values["rmse"] / float(np.sqrt(np.mean(truth[mask] ** 2)))
            values["delay_s"], values["aligned_rmse"] = aligning_delay(
                estimate[order], truth, mask, dt, MAX_SHIFT_S
            )
            difference = estimate[order][mask] - clean[order][mask]
            values["noise_gain"] = float(np.sqrt(np.mean(difference**2))) / noise_rms
        if method.linear:
            values["phase_delay_s"] = phase_delay_s(method, dt, order)
        rows += [
            {"order": order, "region": "interior", "metric": metric, "value": value}
            for metric, value in values.items()
        ]
    return rows


def _log_grid(low: float, high: float, count: int) -> list[float]:
    return [float(f"{value:.3g}") for value in np.geomspace(low, high, count)]


def sweep_settings(name: str) -> list[tuple[str, dict]]:
    """The settings each causal method is run at for the error-against-delay trade-off:
    ``(label, params)``, the method's own knob of smoothing (hence of delay) swept over its
    range, the other parameters at their defaults. A method not listed here runs at its
    defaults only."""
    if name == "backward_difference":
        return [(f"p = {p}", {"accuracy": p}) for p in (1, 2, 3, 4)]
    if name == "causal_butterworth":
        return [
            (f"N = {n}, f_c = {f:g} Hz", {"order": n, "cutoff_hz": f})
            for n in (2, 4)
            for f in _log_grid(5.0, 150.0, 8)
        ]
    if name == "causal_jacobi":
        return [
            (
                f"T = {w:g} s, δ = {fraction:g} T",
                {"window_s": w, "accel_window_s": 2 * w, "delay_s": round(fraction * w, 6)},
            )
            for w in (0.01, 0.02, 0.04, 0.08)
            for fraction in (0.0, 0.25, 0.5)
        ]
    if name == "kalman_filter":
        return [
            (f"m = {m}, f_b = {f:g} Hz", {"model_order": m, "bandwidth_hz": f})
            for m in (2, 3)
            for f in _log_grid(2.0, 100.0, 8)
        ]
    if name == "alpha_beta_gamma":
        return [(f"T_m = {w:g} s", {"memory_s": w}) for w in _log_grid(0.002, 0.2, 8)]
    if name == "high_gain_observer":
        return [
            (f"m = {m}, ε = {e:g} s", {"observer_dimension": m, "epsilon_s": e})
            for m in (3, 4, 5)
            for e in _log_grid(0.001, 0.05, 8)
        ]
    if name == "levant":
        return [
            (f"n = 2, L = {v:g}", {"differentiator_order": 2, "lipschitz": v})
            for v in _log_grid(1e5, 1e8, 8)
        ]
    return [("defaults", {})]


def pareto_front(delays: np.ndarray, errors: np.ndarray) -> np.ndarray:
    """Mask of the points no other point beats in both |delay| and error (ties kept)."""
    delays, errors = np.abs(np.asarray(delays, float)), np.asarray(errors, float)
    front = np.ones(delays.size, dtype=bool)
    for i in range(delays.size):
        better = (delays <= delays[i]) & (errors <= errors[i])
        strictly = (delays < delays[i]) | (errors < errors[i])
        front[i] = not np.any(better & strictly)
    return front
