"""Tables rendered from stored result rows only (never from live objects)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

ORDER_LABELS = {0: "x", 1: "ẋ", 2: "ẍ"}
REGION_LABELS = {"interior": "interior", "valid": "full"}


def rmse_summary(rows: pd.DataFrame, metric: str = "rmse") -> pd.DataFrame:
    """Mean, std and seed count of ``metric`` per method/parameters, region and order.

    ``rows`` are stored rows (see :mod:`bench.store`). Returns a long table with columns
    method, params, preset, region, order, mean, std, seeds (std is the sample std, ddof=1).
    """
    chosen = rows[rows["metric"] == metric].sort_values(
        ["method", "params", "region", "order", "seed"], kind="stable"
    )  # a fixed order: the same rows give the same sums, whatever order they were stored in
    if chosen.empty:
        raise ValueError(f"no stored rows with metric {metric!r}")
    grouped = chosen.groupby(["method", "params", "preset", "region", "order"], sort=True)
    summary = grouped["value"].agg(
        mean="mean",
        std=lambda v: float(np.std(v, ddof=1)) if len(v) > 1 else float("nan"),
        seeds="count",
    )
    return summary.reset_index()


def rmse_wide(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per method: RMSE mean and std of x, ẋ, ẍ on the interior and on the method's
    full (valid) samples, with its coverage of the signal and of the interior."""
    summary = rmse_summary(rows)
    coverage = rmse_summary(rows, metric="coverage")
    wide = []
    for (method, params, preset), group in summary.groupby(["method", "params", "preset"]):
        record = {
            "method": method,
            "params": params,
            "preset": preset,
            "seeds": int(group["seeds"].min()),
        }
        for region in ("interior", "valid"):
            for order in sorted(group["order"].unique()):
                cell = group[(group["region"] == region) & (group["order"] == order)].iloc[0]
                label = f"{ORDER_LABELS[order]} {REGION_LABELS[region]}"
                record[f"{label} mean"] = cell["mean"]
                record[f"{label} std"] = cell["std"]
        mine = coverage[(coverage["method"] == method) & (coverage["params"] == params)]
        for region, column in (("valid", "coverage"), ("interior", "interior coverage")):
            record[column] = float(mine[mine["region"] == region]["mean"].min())
        wide.append(record)
    return pd.DataFrame(wide)


def _pm(mean: float, std: float) -> str:
    return f"{mean:.4g} ± {std:.2g}" if np.isfinite(std) else f"{mean:.4g}"


def to_markdown(wide: pd.DataFrame, title: str) -> str:
    """The wide RMSE table as Markdown: ``mean ± std`` per derivative and region."""
    labels = [c[: -len(" mean")] for c in wide.columns if c.endswith(" mean")]
    header = ["method", "parameters", *(f"RMSE {label}" for label in labels), "coverage", "seeds"]
    lines = [
        f"# {title}",
        "",
        "| " + " | ".join(header) + " |",
        "|" + "|".join("---" for _ in header) + "|",
    ]
    for _, row in wide.iterrows():
        cells = [row["method"], f"`{row['params']}`"]
        cells += [_pm(row[f"{label} mean"], row[f"{label} std"]) for label in labels]
        cells += [f"{row['coverage']:.3f}", str(row["seeds"])]
        lines.append("| " + " | ".join(cells) + " |")
    lines += [
        "",
        "Presets: " + "; ".join(f"{row['method']} ({row['preset']})" for _, row in wide.iterrows()),
        "",
    ]
    return "\n".join(lines)


def write_rmse_tables(rows: pd.DataFrame, directory: Path, title: str) -> list[Path]:
    """Write ``rmse.md`` and ``rmse.csv`` into ``directory``; return their paths."""
    wide = rmse_wide(rows)
    directory.mkdir(parents=True, exist_ok=True)
    markdown, csv = directory / "rmse.md", directory / "rmse.csv"
    markdown.write_text(to_markdown(wide, title), encoding="utf-8")
    wide.to_csv(csv, index=False)
    return [markdown, csv]
