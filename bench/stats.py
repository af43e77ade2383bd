"""Monte Carlo statistics over noise seeds: confidence intervals and paired comparisons."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy import stats


def confidence_interval(values, level: float = 0.95) -> tuple[float, float]:
    """Mean and half-width of the two-sided Student-t confidence interval of the mean.

    .. math:: \\bar v \\pm t_{(1+\\ell)/2,\\,N-1}\\; s / \\sqrt{N}

    (s the sample standard deviation). NaN half-width for fewer than 2 values.
    """
    values = np.asarray(values, dtype=float)
    if values.size == 0:
        raise ValueError("`values` is empty")
    if not 0 < level < 1:
        raise ValueError(f"`level` must be in (0, 1), got {level}")
    mean = float(np.mean(values))
    if values.size < 2:
        return mean, float("nan")
    half = stats.t.ppf((1 + level) / 2, values.size - 1) * np.std(values, ddof=1)
    return mean, float(half / math.sqrt(values.size))


def paired_comparison(first, second) -> dict[str, float]:
    """Paired comparison of two methods' scores over the same seeds: mean difference
    (first − second), paired t-test and Wilcoxon signed-rank p-values (two-sided)."""
    first, second = np.asarray(first, dtype=float), np.asarray(second, dtype=float)
    if first.shape != second.shape or first.ndim != 1:
        raise ValueError("paired scores must be 1-D arrays over the same seeds")
    difference = first - second
    if first.size < 2 or np.all(difference == 0):
        return {"mean_difference": float(np.mean(difference)), "t_p": float("nan"),
                "wilcoxon_p": float("nan")}  # fmt: skip
    if np.ptp(difference) == 0:  # the same nonzero difference on every seed: no doubt left
        t_p = 0.0
    else:
        t_p = float(stats.ttest_rel(first, second).pvalue)
    wilcoxon_p = float(stats.wilcoxon(first, second).pvalue)
    return {"mean_difference": float(np.mean(difference)), "t_p": t_p, "wilcoxon_p": wilcoxon_p}


def ranking(rows: pd.DataFrame, metric: str, order: int, region: str,
            level: float = 0.05) -> pd.DataFrame:  # fmt: skip
    """Methods ranked by the mean of ``metric`` (smaller is better) with a 95 % CI each, and for
    each method the paired comparison with the next one down the ranking over their common
    seeds: ``significant`` when both the t-test and the Wilcoxon test give p < ``level``."""
    chosen = rows[(rows["metric"] == metric) & (rows["order"] == order)
                  & (rows["region"] == region)]  # fmt: skip
    if chosen.empty:
        raise ValueError(f"no stored rows for {metric!r}, order {order}, region {region!r}")
    series, labels = {}, {}
    for (method, params), group in chosen.groupby(["method", "params"], sort=True):
        series[(method, params)] = group.set_index("seed")["value"].sort_index()
        labels[(method, params)] = str(group["preset"].iloc[0]) if "preset" in group else ""
    records = []
    for key, values in series.items():
        mean, half = confidence_interval(values.to_numpy())
        records.append({"method": key[0], "params": key[1], "preset": labels[key], "mean": mean,
                        "ci95": half, "seeds": int(values.size)})  # fmt: skip
    table = pd.DataFrame(records).sort_values("mean", kind="stable").reset_index(drop=True)
    for column in ("vs_next_mean_difference", "vs_next_t_p", "vs_next_wilcoxon_p"):
        table[column] = np.nan
    table["significant_vs_next"] = pd.Series([pd.NA] * len(table), dtype="boolean")
    for index in range(len(table) - 1):
        a = series[(table.loc[index, "method"], table.loc[index, "params"])]
        b = series[(table.loc[index + 1, "method"], table.loc[index + 1, "params"])]
        common = a.index.intersection(b.index)
        result = paired_comparison(a[common].to_numpy(), b[common].to_numpy())
        table.loc[index, "vs_next_mean_difference"] = result["mean_difference"]
        table.loc[index, "vs_next_t_p"] = result["t_p"]
        table.loc[index, "vs_next_wilcoxon_p"] = result["wilcoxon_p"]
        table.loc[index, "significant_vs_next"] = bool(
            result["t_p"] < level and result["wilcoxon_p"] < level
        )
    return table
