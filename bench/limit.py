"""How close to the optimum: the exact optimal estimator of a Gauss–Markov signal
(:mod:`diffbench.signals.stochastic`), which reaches the bound, for the Monte Carlo that checks
the bound and for efficiencies.

The optimal estimate of the state from every sample is the Rauch–Tung–Striebel smoother with
the true model (and from the samples up to t, the Kalman filter). Its gains do not depend on
the data, so many realisations (columns) are filtered at once.

References: H. E. Rauch, F. Tung, C. T. Striebel, "Maximum likelihood estimates of linear
dynamic systems", AIAA J. 3 (1965); Anderson & Moore, *Optimal Filtering* (1979), ch. 7.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from diffbench.signals.noise import Gaussian
from diffbench.signals.stochastic import GaussMarkov, smoother_bound


def optimal_states(
    signal: GaussMarkov, dt: float, noise_std: float, y: np.ndarray, causal: bool = False
) -> np.ndarray:
    r"""The posterior mean of the state :math:`(x, \dot x, \dots)` at every sample of each
    column of ``y`` (shape ``(n,)`` or ``(n, realisations)``, samples every ``dt`` of
    ``signal`` in white noise of standard deviation ``noise_std``) given every sample (the
    RTS smoother) or, ``causal``, the samples up to each one (the Kalman filter).

    The prior is the signal's own: its stationary law, or for an integrated white noise the
    state known to be 0 at the first sample. Returns shape ``(n, states)`` or
    ``(n, states, realisations)``."""
    y = np.asarray(y, dtype=float)
    columns = y.reshape(y.shape[0], -1)
    n, count = columns.shape
    model = signal.model()
    A, Q = model.discretise(dt)
    states = A.shape[0]
    variance = noise_std**2
    prior_mean = np.zeros((states, count))
    prior = model.stationary_covariance() if model.stationary else np.zeros((states, states))
    means = np.empty((n, states, count))
    covariances = np.empty((n, states, states))
    predicted_covariances = np.empty((n, states, states))
    mean, covariance = prior_mean, prior
    for j in range(n):
        if j:
            mean = A @ mean
            covariance = A @ covariance @ A.T + Q
        predicted_covariances[j] = covariance
        gain = covariance[:, 0] / (covariance[0, 0] + variance)
        mean = mean + np.outer(gain, columns[j] - mean[0])
        covariance = covariance - np.outer(gain, covariance[0])
        means[j], covariances[j] = mean, covariance
    if not causal:
        smoothed = means[-1]
        for j in range(n - 2, -1, -1):
            smoother = covariances[j] @ A.T @ np.linalg.inv(predicted_covariances[j + 1])
            smoothed = means[j] + smoother @ (smoothed - A @ means[j])
            means[j] = smoothed
    return means[:, :, 0] if y.ndim == 1 else means


def scenario_bound(scenario, order: int, causal: bool = False) -> float:
    """The least mean squared error of the derivative of ``order`` any method can reach on
    the interior of ``scenario`` (a Gauss–Markov signal in white Gaussian noise, uniformly
    sampled): :func:`diffbench.signals.stochastic.smoother_bound` (``causal``: from past
    samples only)."""
    models = scenario.noise.models
    if not (isinstance(scenario.signal, GaussMarkov) and len(models) == 1
            and isinstance(models[0], Gaussian) and not scenario.sampling):  # fmt: skip
        raise ValueError(
            f"scenario {scenario.name!r} has no known bound: it needs a Gauss–Markov signal "
            "(diffbench.signals.stochastic) in white Gaussian noise, uniformly sampled"
        )
    return smoother_bound(scenario.signal, scenario.dt_s, models[0].std, order, causal)


EFFICIENCY_CONFIDENCE = 0.95


def efficiency_table(cells: pd.DataFrame, causal_methods=frozenset()) -> pd.DataFrame:
    r"""Per task, entry (method, setting, role) and derivative order: the mean squared error
    on the interior over the seeds, :math:`\overline{\mathrm{MSE}} = \frac1S\sum_s
    \mathrm{RMSE}_s^2`, and the **efficiency** :math:`\eta = \mathrm{MMSE}/\overline{\mathrm{MSE}}`
    (1: optimal), with a 95 % interval from the seeds' spread (the delta method:
    :math:`\eta \pm t\,\eta\,\mathrm{SE}/\overline{\mathrm{MSE}}`). The bound is the smoother's,
    or the filter's for the methods named in ``causal_methods``. Only tasks on scenarios with a
    bound (:func:`scenario_bound`)."""
    from scipy import stats

    from diffbench import signals

    rows = cells[(cells["region"] == "interior") & (cells["metric"] == "rmse")
                 & (cells["order"] >= 1)]  # fmt: skip
    records = []
    keys = ["task", "method", "params", "role", "order"]
    for (task, method, params, role, order), group in rows.groupby(keys, sort=True):
        squares = group["value"].to_numpy(dtype=float) ** 2
        if not np.isfinite(squares).all() or squares.size < 2:
            continue
        scenario = signals.get_scenario(task)
        causal = method in causal_methods
        bound = scenario_bound(scenario, int(order), causal)
        mse = float(squares.mean())
        standard_error = float(squares.std(ddof=1) / np.sqrt(squares.size))
        efficiency = bound / mse
        half = float(stats.t.ppf(0.5 + EFFICIENCY_CONFIDENCE / 2, squares.size - 1)
                     * efficiency * standard_error / mse)  # fmt: skip
        records.append({"task": task, "method": method, "params": params, "role": role,
                        "order": int(order), "seeds": int(squares.size), "mse": mse,
                        "mse_se": standard_error, "bound": bound, "causal_bound": causal,
                        "efficiency": efficiency, "efficiency_half_width": half})  # fmt: skip
    return pd.DataFrame(records)


def write_efficiency_report(cells: pd.DataFrame, directory) -> list:
    """``efficiency.md``/``.csv``: :func:`efficiency_table` of the cells, one row per entry and
    order, best first within each order."""
    from diffbench.bench import tables

    table = efficiency_table(cells)
    if table.empty:
        return []
    table = tables.label_entries(table).sort_values(
        ["task", "order", "efficiency"], ascending=[True, True, False], kind="stable"
    )
    shown = pd.DataFrame({
        "n": ["ẋ" if order == 1 else "ẍ" for order in table["order"]],
        "method": table["method"], "setting": table["setting"],
        "parameters": table["parameters"],
        "efficiency": [tables.plus_minus(e, h) for e, h in
                       zip(table["efficiency"], table["efficiency_half_width"], strict=True)],
        "RMSE": [f"{np.sqrt(m):.4g}" for m in table["mse"]],
        "least RMSE": [f"{np.sqrt(b):.4g}" for b in table["bound"]],
        "seeds": table["seeds"].astype(str),
    })  # fmt: skip
    task = table["task"].iloc[0]
    return tables.write_report(
        directory, "efficiency", table, shown,
        f"`{task}`: efficiency = least possible MSE / the method's MSE (1 = optimal)",
        "Least possible MSE: the Wiener (RTS) smoother's with the true model, far from the "
        "ends (diffbench.signals.stochastic.smoother_bound); the method's: the mean over the "
        "seeds of its squared interior RMSE, each seed a new realisation of the signal and "
        "the noise; ± the 95 % interval over the seeds (delta method). An efficiency above 1 "
        "beyond its interval would be a bug.",
    )  # fmt: skip
