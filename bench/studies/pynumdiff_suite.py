"""PyNumDiff's own test records (:mod:`diffbench.signals.pynumdiff_suite`): every PyNumDiff
method diffbench wraps at the parameters PyNumDiff's tests give it, every native method tuned
by the truth on a seed never scored, all scored over every sample.

An entry is a method at one setting on one record: :func:`entry_rows` gives its per-seed
scores of ẋ (the share of samples it estimates and of those it marks valid, RMSE over the
whole record when it estimates every sample, RMSE over its valid samples),
:func:`oracle_setting` its tuned setting, :func:`record_table` and
:func:`summary_table` the report.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from diffbench import methods
from diffbench.bench.core import search_space, tuning
from diffbench.bench.core.scores import estimate_on
from diffbench.bench.report import tables
from diffbench.signals import pynumdiff_suite as records

ORDER = 1
"""The derivative scored: ẋ (PyNumDiff's tests score ẋ)."""

TEST_SETTINGS: dict[str, list[dict[str, Any]]] = {
    "pynumdiff.kerneldiff": [
        {"kernel": "uniform", "window_size": 3, "num_iterations": 2},
        {"kernel": "median", "window_size": 3, "num_iterations": 2},
        {"kernel": "gaussian", "window_size": 5, "num_iterations": 1},
        {"kernel": "friedrichs", "window_size": 5, "num_iterations": 1},
    ],
    "pynumdiff.butterdiff": [{"filter_order": 3, "cutoff_freq": 0.7, "num_iterations": 1}],
    "pynumdiff.polydiff": [{"degree": 5, "window_size": 15, "kernel": "friedrichs"}],
    "pynumdiff.savgoldiff": [{"degree": 2, "window_size": 5, "smoothing_win": 5}],
    "pynumdiff.splinediff": [{"degree": 5, "s": 2.0}],
    "pynumdiff.spectraldiff": [{"cutoff_freq": 0.2, "extension": "odd", "pad_to_flat": 1}],
    "pynumdiff.rbfdiff": [{"sigma": 0.5, "lmbd": 0.001}],
    "pynumdiff.rtsdiff": [{"order": 2, "log_qr_ratio": 7.0, "forwardbackward": 1}],
    "pynumdiff.tvrdiff": [
        {"order": 1, "gamma": 0.5},
        {"order": 2, "gamma": 1.0},
        {"order": 3, "gamma": 10.0},
    ],
}
"""The parameters PyNumDiff 0.3's ``test_diff_methods.py`` runs each wrapped method at (with
PyNumDiff's defaults written out: polydiff's kernel, spectraldiff's extension,
kerneldiff's and butterdiff's one iteration)."""

SHRINK_MARGINS = (1, 2, 3, 4, 5, 7, 10)
"""Samples left out at each end, in turn, when a method covers no whole record at any
setting: it is then tuned on the samples it can cover (and marked as not covering)."""

TUNING_SEEDS = 10
"""Noise seeds every method is tuned on (from :data:`tuning.TUNING_SEED`, never scored), the
loss their mean: on 31 samples one seed's noise decides the setting. Tuned on the seed 10000
alone, the ℓ1 trend filter picked a penalty below the one that gives f2's least-squares
quadratic, 0.0295 against 0.0154 on the scored seeds."""


def is_native(name: str) -> bool:
    """Whether ``name`` is diffbench's own method (a peer's name has a dot: ``pkg.fn``)."""
    return "." not in name


def oracle_setting(record: str, name: str, max_evaluations: int | None = None) -> dict:
    """``name`` tuned by the truth for ẋ on ``record`` at the :data:`TUNING_SEEDS` seeds from
    :data:`tuning.TUNING_SEED` (never scored; the mean loss over them): on the whole record,
    or, if no setting covers it, on the widest middle part it covers
    (:data:`SHRINK_MARGINS`). Returns ``{"params", "tuned_on", "loss"}``."""
    scenario = records.get(record)
    tuned_on = [scenario.realise(tuning.TUNING_SEED + k) for k in range(TUNING_SEEDS)]
    try:
        result = tuning.tune(
            name, tuned_on, ORDER, "oracle", max_evaluations=max_evaluations, region="whole"
        )
        if math.isfinite(result.loss):
            return {"params": result.params, "tuned_on": "whole", "loss": result.loss}
    except search_space.NoRoomToTune:
        pass
    n = tuned_on[0].x.shape[0]
    for margin in SHRINK_MARGINS:
        inside = np.zeros(n, dtype=bool)
        inside[margin : n - margin] = True
        shrunk = [dataclasses.replace(r, interior=inside) for r in tuned_on]
        try:
            result = tuning.tune(name, shrunk, ORDER, "oracle", max_evaluations=max_evaluations)
        except search_space.NoRoomToTune:
            continue
        if math.isfinite(result.loss):
            return {
                "params": result.params,
                "tuned_on": f"all but {margin} at each end",
                "loss": result.loss,
            }
    raise ValueError(f"{name} covers too little of {record} at every setting to be tuned")


def entry_rows(record: str, name: str, params: dict, seeds: int) -> list[dict[str, Any]]:
    """Per seed 0..seeds-1, ``name`` at ``params`` on ``record``: ``coverage`` (fraction of
    samples estimated), ``valid`` (fraction marked valid), ``rmse_whole`` (ẋ RMSE over every
    sample; NaN unless it estimates them all) and ``rmse_valid`` (over the samples it marks
    valid); ``failure``: why it gave no estimate (a setting refused on this record), or
    empty."""
    scenario = records.get(record)
    rows = []
    for seed in range(seeds):
        realisation = scenario.realise(seed)
        try:
            estimate = estimate_on(methods.get(name, **params), realisation, orders=(ORDER,))
        except ValueError as error:  # refused at this setting or on this record: said so
            rows.append(
                {
                    "seed": seed,
                    "coverage": 0.0,
                    "valid": 0.0,
                    "rmse_whole": math.nan,
                    "rmse_valid": math.nan,
                    "failure": str(error),
                }
            )
            continue
        valid = np.asarray(estimate.valid[ORDER], dtype=bool)
        estimated = estimate.estimated(ORDER)
        error = estimate[ORDER] - realisation.truth[ORDER]
        rows.append(
            {
                "seed": seed,
                "coverage": float(np.mean(estimated)),
                "valid": float(np.mean(valid)),
                "rmse_whole": float(np.sqrt(np.mean(error**2))) if estimated.all() else math.nan,
                "rmse_valid": (
                    float(np.sqrt(np.mean(error[valid] ** 2))) if valid.any() else math.nan
                ),
                "failure": "",
            }
        )
    return rows


def setting_label(params: dict) -> str:
    """``k=v, ...`` of a setting, numbers to 3 significant digits."""
    return ", ".join(
        f"{key}={value:.3g}" if isinstance(value, float) else f"{key}={value}"
        for key, value in params.items()
    )


def _declared_order(name: str, params: dict) -> dict:
    """``params`` in the order ``name`` declares its parameters (sorted if it is not
    registered here), so a label does not depend on how the store kept the keys."""
    try:
        declared = [spec.name for spec in methods.params_of(methods.method_class(name))]
    except ValueError:
        declared = []
    rank = {key: index for index, key in enumerate(declared)}
    return dict(sorted(params.items(), key=lambda item: (rank.get(item[0], len(rank)), item[0])))


def entries_frame(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """One row per entry (record, method, setting) from the per-seed rows (each carrying
    ``record``, ``method``, ``package``, ``source``, ``params``, ``time_stamps``): the means
    over seeds, ``covers`` (every sample at every seed)."""
    frame = pd.DataFrame(rows)
    frame["setting"] = [
        setting_label(_declared_order(name, params))
        for name, params in zip(frame["method"], frame["params"], strict=True)
    ]
    keys = ["record", "method", "package", "source", "setting", "time_stamps", "tuned_on"]
    grouped = frame.groupby(keys, sort=False, dropna=False)
    table = grouped.agg(
        seeds=("seed", "nunique"),
        coverage=("coverage", "mean"),
        min_coverage=("coverage", "min"),
        valid=("valid", "mean"),
        rmse_whole=("rmse_whole", "mean"),
        rmse_valid=("rmse_valid", "mean"),
        failure=("failure", "max"),
    ).reset_index()
    table["covers"] = table["min_coverage"] >= 1.0
    table.loc[~table["covers"], "rmse_whole"] = math.nan
    return table


def record_table(entries: pd.DataFrame, record: str) -> pd.DataFrame:
    """The table of one record: every entry, best whole-record RMSE first (those not covering
    every sample last, by their RMSE on their valid samples)."""
    part = entries[entries["record"] == record].copy()
    part = part.sort_values(["covers", "rmse_whole", "rmse_valid"], ascending=[False, True, True])
    return pd.DataFrame(
        {
            "method": part["method"],
            "package": part["package"],
            "parameters": part["source"] + ": " + part["setting"],
            "time stamps": part["time_stamps"],
            "tuned on": part["tuned_on"],
            "estimated": part["coverage"].map(lambda v: f"{v:.0%}"),
            "covers all": part["covers"].map({True: "yes", False: "NO"}),
            "valid": part["valid"].map(lambda v: f"{v:.0%}"),
            "RMSE whole record": part["rmse_whole"],
            "RMSE valid samples": part["rmse_valid"],
            "failed": part["failure"].fillna(""),
        }
    )


def _best(part: pd.DataFrame) -> tuple[str, float]:
    covering = part[part["covers"] & part["rmse_whole"].notna()]
    if covering.empty:
        return "—", math.nan
    best = covering.loc[covering["rmse_whole"].idxmin()]
    return f"{best['method']} ({best['setting']})", float(best["rmse_whole"])


def _ratio(ours: float, theirs: float) -> float:
    """``ours / theirs``; inf when theirs is exact (0) and ours is not, NaN when either is
    missing."""
    if math.isnan(ours) or math.isnan(theirs):
        return math.nan
    if theirs == 0:
        return 1.0 if ours == 0 else math.inf
    return ours / theirs


def summary_table(entries: pd.DataFrame) -> pd.DataFrame:
    """Per record: diffbench's best at full coverage against PyNumDiff's best (at its tests'
    parameters; and tuned, where tuned rows exist), and their ratio (< 1: diffbench ahead)."""
    rows = []
    for record in dict.fromkeys(entries["record"]):
        part = entries[entries["record"] == record]
        native = part[part["package"] == "diffbench"]
        peers = part[part["method"].str.startswith("pynumdiff.")]
        ours, ours_rmse = _best(native)
        theirs, theirs_rmse = _best(peers[peers["source"] == "PyNumDiff tests"])
        tuned, tuned_rmse = _best(peers[peers["source"] == "oracle"])
        best_valid = native.loc[native["rmse_valid"].idxmin()] if not native.empty else None
        rows.append(
            {
                "record": record,
                "diffbench best (full coverage)": ours,
                "its RMSE": ours_rmse,
                "PyNumDiff best (its tests' parameters)": theirs,
                "its RMSE ": theirs_rmse,
                "ratio": _ratio(ours_rmse, theirs_rmse),
                "PyNumDiff tuned best": tuned,
                "its RMSE  ": tuned_rmse,
                "ratio to tuned": _ratio(ours_rmse, tuned_rmse),
                "diffbench best on its valid samples": (
                    "—"
                    if best_valid is None
                    else f"{best_valid['method']}: {best_valid['rmse_valid']:.3g} "
                    f"({best_valid['valid']:.0%} valid)"
                ),
            }
        )
    return pd.DataFrame(rows)


def write_report(rows: list[dict[str, Any]], directory: Path, seeds: int) -> list[Path]:
    """``summary.md``/``.csv``, ``entries.csv`` and ``<record>.md``/``.csv`` per record."""
    directory.mkdir(parents=True, exist_ok=True)
    entries = entries_frame(rows)
    legend = (
        f"ẋ RMSE, mean over {seeds} noise seeds (Gaussian, std {records.NOISE_STD:g}, "
        "`numpy.random.default_rng(seed)`); native methods tuned by the truth over the whole "
        f"record on the seeds {tuning.TUNING_SEED}..{tuning.TUNING_SEED + TUNING_SEEDS - 1} "
        "(the mean loss; never scored; one that covers no whole "
        "record: on the widest middle part it covers, column `tuned on`; one that covers too "
        "little to be tuned: at its defaults); "
        f"PyNumDiff's methods at its tests' parameters ({records.SOURCE}). **estimated**: the "
        "share of samples a method estimates; a method not estimating every sample at every "
        "seed has no whole-record RMSE. **valid**: the share it marks valid (trusts; the "
        "RMSE over them is beside it). Ratio: diffbench's best / PyNumDiff's best (< 1: "
        "diffbench ahead)."
    )
    summary = summary_table(entries)
    written = tables.write_report(
        directory,
        "summary",
        summary,
        tables.numbers_shown(summary),
        "PyNumDiff's test records: diffbench's best at full coverage against PyNumDiff's",
        legend,
    )
    written.append(tables.write_csv(directory / "entries.csv", entries))
    for record in dict.fromkeys(entries["record"]):
        table = record_table(entries, record)
        title = f"{record}: {records.get(record).description}"
        written += tables.write_report(
            directory, record, table, tables.numbers_shown(table), title, legend
        )
    return written
