"""The Pareto front of accuracy against smoothness, without the truth: every setting the
oracle tuning of a method tries on a record, scored by how well its ẋ re-integrates to the data
(fit) and by its total variation (roughness), the non-dominated ones and the knee a user
without the truth would pick, against the setting of least true error (``diffbench pareto``,
beside the limit study: van Breugel, Kutz & Brunton, IEEE Access 8, 2020)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods
from diffbench.bench.core import tuning
from diffbench.bench.report import figures, tables

SCENARIOS = (
    "limit-matern52-0.01",
    "limit-matern72-0.01",
    "limit-iwn2-0.01",
    "limit-iwn3-0.01",
    "limit-band20-0.01",
)
"""The records ``diffbench run pareto`` draws the fronts on by default: one random signal of
each spectrum of the limit study, at its lower noise level."""


# --- the Pareto front of accuracy against smoothness, without the truth ---------------------
def reintegration_rmse(x: np.ndarray, derivative: np.ndarray, dt: float, keep: np.ndarray) -> float:
    r"""How well the estimated ẋ explains the data: the RMSE over the samples ``keep`` (one
    unbroken stretch) of :math:`x - (c + \int \hat{\dot x}\,dt)`, the integral by the
    trapezoidal rule from the first kept sample and c the best constant (their mean
    difference). Needs no truth (van Breugel, Kutz & Brunton 2020)."""
    from scipy.integrate import cumulative_trapezoid

    kept = np.flatnonzero(keep)
    stretch = slice(kept[0], kept[-1] + 1)
    integral = cumulative_trapezoid(derivative[stretch], dx=dt, initial=0.0)
    residual = x[stretch] - integral
    return float(np.sqrt(np.mean((residual - residual.mean()) ** 2)))


def total_variation(derivative: np.ndarray, keep: np.ndarray) -> float:
    """:math:`\\sum_i |\\hat{\\dot x}_{i+1} - \\hat{\\dot x}_i|` over the kept stretch: how
    rough the estimate is."""
    kept = np.flatnonzero(keep)
    return float(np.sum(np.abs(np.diff(derivative[kept[0] : kept[-1] + 1]))))


def non_dominated(fit: np.ndarray, roughness: np.ndarray) -> np.ndarray:
    """Mask of the points no other point beats on both ``fit`` and ``roughness`` (less is
    better; of equal points the first)."""
    order = np.lexsort((roughness, fit))
    front = np.zeros(fit.size, dtype=bool)
    lowest = np.inf
    for index in order:
        if roughness[index] < lowest:
            front[index] = True
            lowest = roughness[index]
    return front


def knee(fit: np.ndarray, roughness: np.ndarray) -> int:
    """Index of the knee of a front (the points given, sorted or not): in log-log coordinates
    scaled to the unit square, the point farthest below the chord between the front's two
    ends (the "Kneedle" rule, Satopää et al. 2011). The ends themselves when there are fewer
    than three points."""
    u, v = np.log(fit), np.log(roughness)
    span_u, span_v = np.ptp(u), np.ptp(v)
    if fit.size < 3 or span_u == 0 or span_v == 0:
        return int(np.argmin(u))
    u, v = (u - u.min()) / span_u, (v - v.min()) / span_v
    first, last = int(np.argmin(u)), int(np.argmax(u))
    # distance below the chord from (u_first, v_first) to (u_last, v_last)
    du, dv = u[last] - u[first], v[last] - v[first]
    below = (dv * (u - u[first]) - du * (v - v[first])) / np.hypot(du, dv)
    return int(np.argmax(below))


@dataclass(frozen=True)
class Front:
    """The settings of one method tried on one record (the oracle tuning's candidates), each
    with its re-integration ``fit`` RMSE, the ``roughness`` (total variation) of its ẋ and
    its true ẋ ``rmse``; ``on_front`` marks the non-dominated ones, ``knee`` the data-only
    choice among them and ``oracle`` the setting of least true RMSE."""

    method: str
    settings: tuple
    fit: np.ndarray
    roughness: np.ndarray
    rmse: np.ndarray
    on_front: np.ndarray
    knee: int
    oracle: int


def front_rows(front: Front) -> list[dict]:
    """``front`` as rows of JSON values, one per setting (params, fit, roughness, rmse,
    on_front, knee, oracle): what the store keeps (:func:`front_of_rows` reads them back)."""
    return [
        {
            "params": dict(params),
            "fit": float(front.fit[i]),
            "roughness": float(front.roughness[i]),
            "rmse": float(front.rmse[i]),
            "on_front": bool(front.on_front[i]),
            "knee": i == front.knee,
            "oracle": i == front.oracle,
        }
        for i, params in enumerate(front.settings)
    ]


def front_of_rows(method: str, rows: list[dict]) -> Front:
    """The :class:`Front` of ``method`` whose :func:`front_rows` are ``rows``."""
    return Front(
        method=method,
        settings=tuple(row["params"] for row in rows),
        fit=np.array([row["fit"] for row in rows]),
        roughness=np.array([row["roughness"] for row in rows]),
        rmse=np.array([row["rmse"] for row in rows]),
        on_front=np.array([row["on_front"] for row in rows]),
        knee=next(i for i, row in enumerate(rows) if row["knee"]),
        oracle=next(i for i, row in enumerate(rows) if row["oracle"]),
    )


def pareto_front(name: str, realisation, max_evaluations: int = 150, seed: int = 0) -> Front:
    """The :class:`Front` of method ``name`` for ẋ on ``realisation`` (its interior): every
    setting the oracle tuning tries (a spread over the method's tuning ranges, densest near
    the optimum), scored without the truth (fit, roughness) and with it (RMSE)."""

    result = tuning.tune(name, realisation, 1, "oracle", max_evaluations=max_evaluations, seed=seed)
    x, dt = np.asarray(realisation.x, dtype=float), realisation.dt_s
    inside = np.asarray(realisation.interior, dtype=bool)
    settings, fit, roughness, rmse = [], [], [], []
    for params, loss in result.history:
        if not np.isfinite(loss):
            continue
        estimate = methods.get(name, **params)(x, dt, (1,))[1]
        settings.append(params)
        fit.append(reintegration_rmse(x, estimate, dt, inside))
        roughness.append(total_variation(estimate, inside))
        rmse.append(float(np.sqrt(np.mean((estimate[inside] - realisation.truth[1][inside]) ** 2))))
    fit, roughness, rmse = np.array(fit), np.array(roughness), np.array(rmse)
    on_front = non_dominated(fit, roughness)
    members = np.flatnonzero(on_front)
    return Front(
        method=name,
        settings=tuple(settings),
        fit=fit,
        roughness=roughness,
        rmse=rmse,
        on_front=on_front,
        knee=int(members[knee(fit[members], roughness[members])]),
        oracle=int(np.argmin(rmse)),
    )


def write_pareto(fronts: list[Front], task: str, directory) -> list:
    """``pareto_<task>.md``/``.csv`` (per method: the settings tried, the front's size, the
    true ẋ RMSE of the oracle's setting and of the knee's, their ratio, whether the oracle's
    setting is on the front) and ``pareto_<task>.png`` (per method: every setting's fit
    against roughness, the front, the knee and the oracle's setting)."""
    directory = Path(directory)
    rows = [
        {
            "task": task,
            "method": f.method,
            "settings": len(f.settings),
            "front": int(f.on_front.sum()),
            "oracle_rmse": f.rmse[f.oracle],
            "knee_rmse": f.rmse[f.knee],
            "knee_over_oracle": f.rmse[f.knee] / f.rmse[f.oracle],
            "oracle_on_front": bool(f.on_front[f.oracle]),
            "knee_params": json.dumps(f.settings[f.knee], sort_keys=True),
            "oracle_params": json.dumps(f.settings[f.oracle], sort_keys=True),
        }
        for f in fronts
    ]
    table = pd.DataFrame(rows).sort_values("knee_over_oracle", kind="stable")
    shown = pd.DataFrame(
        {
            "method": table["method"],
            "settings tried": table["settings"].astype(str),
            "on the front": table["front"].astype(str),
            "oracle ẋ RMSE": [f"{v:.4g}" for v in table["oracle_rmse"]],
            "knee ẋ RMSE": [f"{v:.4g}" for v in table["knee_rmse"]],
            "knee / oracle": [f"{v:.3f}" for v in table["knee_over_oracle"]],
            "oracle on the front": ["yes" if v else "no" for v in table["oracle_on_front"]],
            "knee's setting": [
                tables.readable_params(m, p)
                for m, p in zip(table["method"], table["knee_params"], strict=True)
            ],
        }
    )
    legend = (
        "Each method's settings as its oracle tuning for ẋ tries them (seed "
        f"{tuning.TUNING_SEED}), scored without the truth by how well the integral of their ẋ fits "
        "the data (re-integration RMSE) and how rough their ẋ is (total variation), as "
        "PyNumDiff's taxonomy (van Breugel, Kutz & Brunton 2020) proposes for data without "
        "priors. The front: the settings no other beats on both; the knee: the front's point "
        "farthest below the chord between its ends in log-log coordinates (Kneedle), a "
        "data-only choice. knee / oracle: the knee's true ẋ RMSE over the best setting's."
    )
    written = tables.write_report(
        directory,
        f"pareto_{task}",
        table,
        shown,
        f"`{task}`: accuracy against smoothness, and where the knee lands",
        legend,
    )
    plt = figures.pyplot()
    columns = 3
    rows_count = (len(fronts) + columns - 1) // columns
    fig, axes = plt.subplots(rows_count, columns, figsize=(13, 3.6 * rows_count), squeeze=False)
    for axis, front in zip(axes.flat, fronts, strict=False):
        axis.scatter(front.fit, front.roughness, s=8, color="0.7", label="settings tried")
        order = np.argsort(front.fit[front.on_front])
        axis.plot(
            front.fit[front.on_front][order],
            front.roughness[front.on_front][order],
            color="C0",
            label="front",
        )
        axis.plot(
            front.fit[front.knee],
            front.roughness[front.knee],
            "*",
            color="C3",
            markersize=12,
            label="knee",
        )
        axis.plot(
            front.fit[front.oracle],
            front.roughness[front.oracle],
            "o",
            markerfacecolor="none",
            color="black",
            markersize=9,
            label="oracle",
        )
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_title(
            f"{front.method}: knee/oracle RMSE "
            f"{front.rmse[front.knee] / front.rmse[front.oracle]:.3f}"
        )
        axis.set_xlabel("re-integration RMSE")
        axis.set_ylabel("total variation of ẋ")
    for axis in list(axes.flat)[len(fronts) :]:
        axis.set_visible(False)
    axes.flat[0].legend(fontsize="small")
    fig.suptitle(f"{task}: accuracy against smoothness without the truth")
    fig.tight_layout()
    written.append(figures.save_figure(fig, directory / f"pareto_{task}.png", tight=False))
    return written
