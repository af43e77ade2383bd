r"""Which differentiator for this record, with which settings, and how wrong: from the data.

:func:`recommend` reads the record's noise floor and signal band from its periodogram
(:mod:`diffbench.bench.spectrum`; nothing typed in), draws surrogate records with the same
spectrum whose truth is known (:mod:`diffbench.bench.surrogates`), tunes every method on some
of them with the oracle criterion, scores the tuned setting on the others, and ranks the
methods by that predicted RMSE (mean ± standard deviation over the scoring surrogates). Linear
or not, native or a peer's: every method is tuned and scored the same way.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from diffbench import methods
from diffbench.bench.scores import error_metrics
from diffbench.bench.spectrum import RecordSpectrum, record_spectrum
from diffbench.bench.surrogates import surrogate_records
from diffbench.bench.tuning import tune

TUNING_SURROGATES = 2
"""Surrogates a method is tuned on (their mean loss: one draw can favour a setting by luck)."""

SCORING_SURROGATES = 4
"""Other surrogates the tuned setting is scored on: the predicted RMSE and its spread."""

COLUMNS = (
    "order", "rank", "method", "params", "predicted_rmse", "spread", "coverage", "package",
    "seconds",
)  # fmt: skip


@dataclass(frozen=True)
class Recommendation:
    """The record's spectrum and one row per (order, method): its tuned ``params``, predicted
    interior RMSE ``predicted_rmse`` ± ``spread`` (standard deviation over the scoring
    surrogates), its ``coverage`` of the record, and its ``rank`` among the methods (1: best;
    methods that failed have no rank and say why in ``params``)."""

    spectrum: RecordSpectrum
    table: pd.DataFrame

    def best(self, order: int) -> tuple[str, dict]:
        """The name and settings of the best method for the derivative of ``order``."""
        rows = self.table[(self.table["order"] == order) & (self.table["rank"] == 1)]
        if rows.empty:
            raise ValueError(f"no method was recommended for order {order}")
        row = rows.iloc[0]
        return row["method"], row["params"]


def recommend(
    x: np.ndarray,
    dt: float,
    names: list[str] | None = None,
    orders: tuple[int, ...] = (1, 2),
    seed: int = 0,
    max_evaluations: int | None = None,
) -> Recommendation:
    """Recommend a method and its settings for the derivatives of ``orders`` of the 1-D
    record ``x`` sampled every ``dt`` seconds (see the module docstring).

    ``names``: the methods to consider (default every registered one); ``max_evaluations``
    bounds each tuning (the tuner's default otherwise).
    """
    samples = np.asarray(x, dtype=np.float64)
    if samples.ndim != 1:
        raise ValueError(f"`x` must be one channel (1-D), got shape {samples.shape}")
    samples, dt = methods.check_signal(samples, dt, min_samples=16)
    spectrum = record_spectrum(samples, dt)
    drawn = surrogate_records(
        spectrum, samples.size, dt, TUNING_SURROGATES + SCORING_SURROGATES, seed=seed
    )
    tuning, scoring = drawn[:TUNING_SURROGATES], drawn[TUNING_SURROGATES:]
    rows = []
    for name in names if names is not None else methods.available():
        for order in orders:
            rows.append(_tuned_and_scored(name, order, tuning, scoring, max_evaluations, seed))
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    table["rank"] = table.groupby("order")["predicted_rmse"].rank(method="first", na_option="keep")
    table = table.sort_values(["order", "rank"], na_position="last").reset_index(drop=True)
    return Recommendation(spectrum, table)


def _tuned_and_scored(name, order, tuning, scoring, max_evaluations, seed) -> dict:
    start = time.perf_counter()
    row = {"order": order, "method": name, "package": methods.package_of(name)}
    try:
        result = tune(name, tuning, order, "oracle", max_evaluations=max_evaluations, seed=seed)
    except ValueError as error:
        return {**row, "params": f"not tuned: {error}", "predicted_rmse": math.nan,
                "spread": math.nan, "coverage": math.nan,
                "seconds": time.perf_counter() - start}  # fmt: skip
    method = methods.get(name, **result.params)
    errors, coverage = [], []
    for realisation in scoring:
        try:
            estimate = method(realisation.x, realisation.dt_s, (order,))
        except ValueError:
            errors.append(math.inf)
            continue
        valid = estimate.valid[order]
        scored = realisation.interior & valid
        if scored.sum() < realisation.interior.sum():
            errors.append(math.inf)  # the tuner's rule: every interior sample estimated
            continue
        errors.append(error_metrics(estimate[order], realisation.truth[order], scored)["rmse"])
        coverage.append(float(valid.mean()))
    finite = np.isfinite(errors)
    return {
        **row,
        "params": result.params,
        "predicted_rmse": float(np.mean(errors)) if finite.all() else math.nan,
        "spread": float(np.std(errors)) if finite.all() else math.nan,
        "coverage": float(np.mean(coverage)) if coverage else math.nan,
        "seconds": time.perf_counter() - start,
    }
