"""How close to the optimum: the exact optimal estimator of a random signal with a known
spectrum (:mod:`diffbench.signals.stochastic`), which reaches the bound, for the Monte Carlo
that checks the bound and for efficiencies.

For a Gauss–Markov signal the optimal estimate of the state from every sample is the
Rauch–Tung–Striebel smoother with the true model (and from the samples up to t, the Kalman
filter). Its gains do not depend on the data, so many realisations (columns) are filtered at
once. A band-limited signal has no finite state: its optimal estimate is its exact Gaussian
posterior on the record (:func:`diffbench.signals.stochastic.gaussian_posterior`).

References: H. E. Rauch, F. Tung, C. T. Striebel, "Maximum likelihood estimates of linear
dynamic systems", AIAA J. 3 (1965); Anderson & Moore, *Optimal Filtering* (1979), ch. 7.
"""

from __future__ import annotations

import functools
import json

import numpy as np
import pandas as pd

from diffbench import methods, signals
from diffbench.bench.core import tuning
from diffbench.bench.core.plan import TuningJob
from diffbench.bench.core.roles import ORDER_SYMBOLS
from diffbench.bench.report import figures, tables
from diffbench.signals.noise import Gaussian
from diffbench.signals.scenarios import limit_scenario_names
from diffbench.signals.stochastic import (
    BandLimited,
    GaussMarkov,
    gaussian_posterior,
    smoother_bound,
)


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
    the interior of ``scenario`` (a random signal with a known spectrum in white Gaussian
    noise, uniformly sampled; ``causal``: from past samples only): for a Gauss–Markov signal
    the infinite record's (:func:`diffbench.signals.stochastic.smoother_bound`, which the
    interior's error reaches far from the ends), for a band-limited one the exact posterior
    variance on this record, averaged over its interior (the infinite record's is not
    reached within a few seconds: tested)."""
    _check_bounded(scenario)
    if isinstance(scenario.signal, GaussMarkov):
        noise_std = scenario.noise.models[0].std
        return smoother_bound(scenario.signal, scenario.dt_s, noise_std, order, causal)
    return _record_bound(scenario, int(order), bool(causal))


def _check_bounded(scenario) -> None:
    """ValueError unless ``scenario`` has a known bound (see :func:`scenario_bound`)."""
    models = scenario.noise.models
    if not (
        isinstance(scenario.signal, (GaussMarkov, BandLimited))
        and len(models) == 1
        and isinstance(models[0], Gaussian)
        and not scenario.sampling
    ):
        raise ValueError(
            f"scenario {scenario.name!r} has no known bound: it needs a Gauss–Markov or "
            "band-limited signal (diffbench.signals.stochastic) in white Gaussian noise, "
            "uniformly sampled"
        )


@functools.lru_cache(maxsize=64)
def _record_bound(scenario, order: int, causal: bool) -> float:
    if order not in scenario.signal.derivative_orders:
        raise ValueError(
            f"`order` must be one of {scenario.signal.derivative_orders}, got {order!r}"
        )
    posterior = gaussian_posterior(
        scenario.signal, scenario.dt_s, scenario.n_samples, scenario.noise.models[0].std, causal
    )
    return float(np.mean(posterior.variance[order][scenario.interior]))


EFFICIENCY_CONFIDENCE = 0.95


def optimal_scores(scenario, seed: int, causal: bool = False) -> list[dict]:
    """Score rows (metric ``optimal_rmse``, region ``interior``) of the optimal estimator
    (:func:`optimal_states`; ``causal``: the filter) on ``scenario``'s realisation ``seed``,
    for each derivative order 1..2 the signal has. Every method's cell on that seed needs the
    same rows: they are kept for the last few (scenario, seed, causal) of the process."""
    _check_bounded(scenario)  # refuses a scenario without a bound
    return [dict(row) for row in _optimal_scores(scenario, int(seed), bool(causal))]


@functools.lru_cache(maxsize=64)
def _optimal_scores(scenario, seed: int, causal: bool) -> tuple[dict, ...]:
    realisation = scenario.realise(seed)
    signal, x = scenario.signal, realisation.x
    noise_std = scenario.noise.models[0].std
    if isinstance(signal, GaussMarkov):
        states = optimal_states(signal, scenario.dt_s, noise_std, x, causal)
        estimates = {order: states[:, order] for order in signal.derivative_orders}
    else:
        posterior = gaussian_posterior(signal, scenario.dt_s, x.size, noise_std, causal)
        estimates = {order: posterior.weights[order] @ x for order in signal.derivative_orders}
    inside = realisation.interior
    return tuple(
        {
            "order": order,
            "region": "interior",
            "metric": "optimal_rmse",
            "value": float(
                np.sqrt(np.mean((estimate[inside] - realisation.truth[order][inside]) ** 2))
            ),
        }
        for order, estimate in estimates.items()
    )


def efficiency_table(cells: pd.DataFrame) -> pd.DataFrame:
    r"""Per task, entry (method, setting, role) and derivative order: the method's mean squared
    error on the interior over the seeds, :math:`\bar m = \frac1S\sum_s m_s`
    (:math:`m_s = \mathrm{RMSE}_s^2`), and its **efficiency** (1: optimal)

    .. math:: \eta = \frac{\bar a}{\bar m}, \qquad a_s = \text{the optimal estimator's MSE
        on the same realisation}

    (``optimal_rmse`` rows: the RTS smoother with the true model, or the Kalman filter for a
    causal method, whose bound is the causal one; a band-limited signal's exact posterior
    from every sample or from the past ones). Its expectation is the bound over the
    method's MSE; pairing each seed's realisation with itself cancels how hard that
    realisation happened to be, so the interval is narrow where the method is near optimal
    (exactly 0 for a method that *is* the optimal estimator). The 95 % interval is the delta
    method's for a ratio of means, :math:`\eta \pm t\,\eta\,\sqrt{(s_a^2/\bar a^2 + s_m^2/\bar m^2
    - 2 s_{am}/(\bar a \bar m))/S}`. Also ``bound`` (:func:`scenario_bound`) and
    ``efficiency_unpaired`` = bound / :math:`\bar m`. Only tasks on scenarios with a bound."""
    from scipy import stats

    rows = cells[
        (cells["region"] == "interior")
        & cells["metric"].isin(["rmse", "optimal_rmse"])
        & (cells["order"] >= 1)
    ]
    records = []
    keys = ["task", "method", "params", "role", "order"]
    for (task, method, params, role, order), group in rows.groupby(keys, sort=True):
        wide = group.pivot_table(index="seed", columns="metric", values="value")
        if "optimal_rmse" not in wide or "rmse" not in wide:
            continue
        squares = wide[["optimal_rmse", "rmse"]].to_numpy(dtype=float) ** 2
        if not np.isfinite(squares).all() or len(squares) < 2:
            continue
        count = len(squares)
        optimal, mse = squares.mean(axis=0)
        covariance = np.cov(squares, rowvar=False)
        efficiency = optimal / mse
        relative = (
            covariance[0, 0] / optimal**2
            + covariance[1, 1] / mse**2
            - 2 * covariance[0, 1] / (optimal * mse)
        ) / count
        half = float(
            stats.t.ppf(0.5 + EFFICIENCY_CONFIDENCE / 2, count - 1)
            * efficiency
            * np.sqrt(max(relative, 0.0))
        )
        causal = _is_causal(method)
        bound = scenario_bound(signals.get_scenario(task), int(order), causal)
        records.append(
            {
                "task": task,
                "method": method,
                "params": params,
                "role": role,
                "order": int(order),
                "seeds": count,
                "mse": mse,
                "optimal_mse": optimal,
                "bound": bound,
                "causal_bound": causal,
                "efficiency": efficiency,
                "efficiency_half_width": half,
                "efficiency_unpaired": bound / mse,
            }
        )
    return pd.DataFrame(records)


def _is_causal(name: str) -> bool:

    return name in methods.available(causal=None) and methods.method_class(name).causal


EFFICIENCY_LEGEND = (
    "Efficiency = the optimal estimator's MSE / the method's, summed over the same "
    "realisations (1 = optimal; its expectation is the least possible MSE over the method's); "
    "the optimal estimator is the RTS smoother with the true model, the Kalman filter for "
    "causal methods (bound: causal); for a band-limited signal its exact posterior mean from "
    "every sample or from the past ones. ± the 95 % interval over the seeds (delta method, "
    "paired). RMSE: the method's over these seeds (below the least RMSE where the realisations "
    "happened to be easy: the efficiency pairs them). Least RMSE: the square root of the "
    "least possible MSE far from the ends (diffbench.signals.stochastic.smoother_bound), or "
    "for a band-limited signal on this record's interior (gaussian_posterior). An efficiency "
    "above 1 beyond its interval is a bug, or a 1-in-40 chance."
)


def _efficiency_columns(table: pd.DataFrame) -> dict[str, list[str]]:
    """The people's columns of an efficiency table: efficiency ± its interval, the method's
    RMSE and the least RMSE."""

    return {
        "efficiency": [
            tables.plus_minus(e, h)
            for e, h in zip(table["efficiency"], table["efficiency_half_width"], strict=True)
        ],
        "RMSE": [f"{np.sqrt(m):.4g}" for m in table["mse"]],
        "least RMSE": [f"{np.sqrt(b):.4g}" for b in table["bound"]],
    }


def write_efficiency_report(cells: pd.DataFrame, directory) -> list:
    """``efficiency.md``/``.csv``: :func:`efficiency_table` of the cells, one row per entry and
    order, best first within each order."""

    table = efficiency_table(cells)
    if table.empty:
        return []
    table = tables.label_entries(table).sort_values(
        ["task", "order", "efficiency"], ascending=[True, True, False], kind="stable"
    )
    shown = pd.DataFrame(
        {
            "n": [ORDER_SYMBOLS[order] for order in table["order"]],
            "method": table["method"],
            "setting": table["setting"],
            "parameters": table["parameters"],
            **_efficiency_columns(table),
            "seeds": table["seeds"].astype(str),
        }
    )
    task = table["task"].iloc[0]
    return tables.write_report(
        directory,
        "efficiency",
        table,
        shown,
        f"`{task}`: efficiency = least possible MSE / the method's MSE (1 = optimal)",
        EFFICIENCY_LEGEND,
    )


# --- the study: every method oracle-tuned on every limit scenario ----------------------------
BUDGET = 150  # evaluations per tuning, as the grid's


def task_names() -> list[str]:
    """The limit scenarios (:func:`diffbench.signals.scenarios.limit_scenario_names`)."""

    return limit_scenario_names()


CRITERIA = ("oracle", "surrogate")
"""How the study tunes each method: against the truth (the best the method can do) and from
the data alone (:func:`diffbench.bench.core.tuning.tune`'s surrogate criterion, the procedure of
``diffbench recommend``: what a user without the truth would get)."""


def tuning_jobs(names, orders=(1, 2), tasks=None, criteria=CRITERIA) -> list:
    """Each method of ``names`` tuned by each of ``criteria`` for each order the task's signal
    has (``tasks``: default every limit scenario) on seed :data:`tuning.TUNING_SEED`."""

    return [
        TuningJob(task, name, criterion, int(order), tuning.TUNING_SEED, None, BUDGET)
        for task in (tasks or task_names())
        for criterion in criteria
        for name in names
        for order in orders
        if order in signals.get_scenario(task).signal.derivative_orders
    ]


def study_table(cells: pd.DataFrame) -> pd.DataFrame:
    """:func:`efficiency_table` of the entries tuned for the order they are scored on, with
    the causal methods against the causal bound, and each task's ``family`` and
    ``noise_std``."""

    tuned = cells[cells["origin"] == "tuned"]
    tuned = tuned[tuned["tuned_order"].astype(float) == tuned["order"].astype(float)]
    table = efficiency_table(tuned)
    if table.empty:
        return table
    table.insert(1, "criterion", [json.loads(role)["criterion"] for role in table["role"]])
    table.insert(1, "family", [task.split("-")[1] for task in table["task"]])
    table.insert(
        2, "noise_std", [signals.get_scenario(t).noise.models[0].std for t in table["task"]]
    )
    return table


def write_study(cells: pd.DataFrame, directory) -> list:
    """``results/limit/``: ``efficiency.md``/``.csv`` (every tuned method on every limit
    scenario and order, oracle- and data-only-tuned, with the least RMSE), ``best.md`` (the
    best efficiency per scenario, order and criterion, and who reaches it, offline and causal
    methods apart) and
    ``efficiency.png`` (efficiency of the oracle-tuned methods against noise level, one line
    per method, a panel per signal family and order)."""
    from pathlib import Path

    directory = Path(directory)
    table = study_table(cells)
    if table.empty:
        raise ValueError(
            "no tuned cells of the limit scenarios in the store: run `diffbench limit` first"
        )
    table = table.sort_values(
        ["family", "order", "noise_std", "criterion", "efficiency"],
        ascending=[True, True, True, True, False],
        kind="stable",
    )
    shown = pd.DataFrame(
        {
            "signal": table["family"],
            "noise": [f"{v:g}" for v in table["noise_std"]],
            "n": [ORDER_SYMBOLS[o] for o in table["order"]],
            "tuned by": table["criterion"],
            "method": table["method"],
            "bound": ["causal" if c else "smoother" for c in table["causal_bound"]],
            **_efficiency_columns(table),
            "parameters": [
                tables.readable_params(m, p)
                for m, p in zip(table["method"], table["params"], strict=True)
            ],
        }
    )
    legend = (
        "Each method tuned for the derivative it is scored on (seed "
        f"{tuning.TUNING_SEED}, {BUDGET} evaluations) by the oracle (against the truth) and "
        "from the data alone (surrogate: the truth of surrogate records drawn from the record's "
        "own spectrum, as `diffbench recommend` does), scored on new realisations (seeds 0..S-1) "
        "of the signal and the noise, on the middle second of each 3 s record. "
        f"{EFFICIENCY_LEGEND}"
    )
    written = tables.write_report(
        directory, "efficiency", table, shown, "Efficiency against the least possible error", legend
    )
    # offline methods against the smoother's bound, causal ones against the filter's: apart
    best = table.loc[
        table.groupby(["task", "order", "causal_bound", "criterion"])["efficiency"].idxmax()
    ]
    best = best.sort_values(
        ["family", "order", "noise_std", "causal_bound", "criterion"], kind="stable"
    )
    best_shown = pd.DataFrame(
        {
            "signal": best["family"],
            "noise": [f"{v:g}" for v in best["noise_std"]],
            "n": [ORDER_SYMBOLS[o] for o in best["order"]],
            "bound": ["causal" if c else "smoother" for c in best["causal_bound"]],
            "tuned by": best["criterion"],
            "best method": best["method"],
            "efficiency": _efficiency_columns(best)["efficiency"],
        }
    )
    written += tables.write_report(
        directory,
        "best",
        best,
        best_shown,
        "The best efficiency per scenario and who reaches it",
        legend,
    )
    oracle = table[table["criterion"] == "oracle"]
    if len(oracle):
        written.append(_efficiency_figure(oracle, directory / "efficiency.png", figures))
    return written


def _efficiency_figure(table: pd.DataFrame, path, figures):
    panels = sorted({(f, o) for f, o in zip(table["family"], table["order"], strict=True)})
    styles = figures.method_styles(sorted(table["method"].unique()))
    plt = figures.pyplot()
    columns = 2
    rows = (len(panels) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(12, 3.6 * rows), squeeze=False)
    for axis, (family, order) in zip(axes.flat, panels, strict=False):
        part = table[(table["family"] == family) & (table["order"] == order)]
        for method, lines in part.groupby("method"):
            lines = lines.sort_values("noise_std")
            style = styles[method]
            axis.errorbar(
                lines["noise_std"],
                lines["efficiency"],
                yerr=lines["efficiency_half_width"],
                label=method,
                color=style.color,
                linestyle=style.linestyle,
                marker=style.marker,
                capsize=2,
            )
        axis.axhline(1.0, color="black", linewidth=0.8)
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_title(f"{family}, {ORDER_SYMBOLS[order]}")
        axis.set_xlabel("noise standard deviation")
        axis.set_ylabel("efficiency (1 = optimal)")
    for axis in list(axes.flat)[len(panels) :]:
        axis.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=6, fontsize="small")
    fig.suptitle("Efficiency = least possible MSE / method's MSE, oracle-tuned methods")
    fig.tight_layout(rect=(0, 0.06, 1, 0.97))
    return figures.save_figure(fig, path, tight=False)
