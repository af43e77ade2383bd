"""Tables rendered from stored result rows only (never from live objects)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

ORDER_LABELS = {0: "x", 1: "ẋ", 2: "ẍ"}
REGION_LABELS = {"interior": "interior", "valid": "full"}
KEYS = ["method", "params", "preset"]

# (column label, metric, derivative order, region)
RMSE_COLUMNS = [
    (f"RMSE {ORDER_LABELS[order]} {REGION_LABELS[region]}", "rmse", order, region)
    for region in ("interior", "valid")
    for order in (0, 1, 2)
] + [("coverage ẋ", "coverage", 1, "valid")]
DECOMPOSITION_COLUMNS = [
    (f"{ORDER_LABELS[order]} {part}", metric, order, "interior")
    for order in (1, 2)
    for part, metric in (("total", "rmse"), ("bias", "bias_rmse"), ("noise", "noise_rmse"))
]


def summarise(rows: pd.DataFrame) -> pd.DataFrame:
    """Mean, sample std (ddof=1) and seed count of every metric per method/parameters, region
    and order. Rows are sorted first, so the same rows give the same sums in any stored order.
    """
    ordered = rows.sort_values([*KEYS, "metric", "region", "order", "seed"], kind="stable")
    grouped = ordered.groupby([*KEYS, "metric", "region", "order"], sort=True)["value"]
    summary = grouped.agg(
        mean="mean",
        std=lambda v: float(np.std(v, ddof=1)) if len(v) > 1 else float("nan"),
        seeds="count",
    )
    return summary.reset_index()


def wide_table(rows: pd.DataFrame, columns) -> pd.DataFrame:
    """One row per method/parameters with ``<label> mean`` and ``<label> std`` per column
    ``(label, metric, order, region)``; methods lacking a metric get NaN there."""
    summary = summarise(rows).set_index([*KEYS, "metric", "region", "order"])
    records = []
    for keys, _ in summary.groupby(level=[0, 1, 2], sort=True):
        record = dict(zip(KEYS, keys, strict=True))
        seeds = []
        for label, metric, order, region in columns:
            index = (*keys, metric, region, order)
            if index in summary.index:
                found = summary.loc[index]
                record[f"{label} mean"], record[f"{label} std"] = found["mean"], found["std"]
                seeds.append(int(found["seeds"]))
            else:
                record[f"{label} mean"] = record[f"{label} std"] = float("nan")
        record["seeds"] = min(seeds) if seeds else 0
        records.append(record)
    return pd.DataFrame(records)


def rmse_wide(rows: pd.DataFrame) -> pd.DataFrame:
    """RMSE of x, ẋ, ẍ on the interior and on each method's valid samples, with coverage."""
    return wide_table(rows, RMSE_COLUMNS)


def _pm(mean: float, std: float) -> str:
    if not np.isfinite(mean):
        return "—"
    if not np.isfinite(std):
        return f"{mean:.4g}"
    if std <= 1e-12 * abs(mean):  # a deterministic number (e.g. a bias): rounding, not spread
        return f"{mean:.4g} ± 0"
    return f"{mean:.4g} ± {std:.2g}"


def to_markdown(wide: pd.DataFrame, title: str, notes: str = "") -> str:
    """A wide table as Markdown: ``mean ± std`` per column, then the presets' sources."""
    labels = [c[: -len(" mean")] for c in wide.columns if c.endswith(" mean")]
    header = ["method", "parameters", *labels, "seeds"]
    lines = [f"# {title}", "", "| " + " | ".join(header) + " |",
             "|" + "|".join("---" for _ in header) + "|"]  # fmt: skip
    for _, row in wide.iterrows():
        cells = [row["method"], f"`{row['params']}`"]
        cells += [
            f"{row[f'{label} mean']:.3f}" if label.startswith("coverage")
            else _pm(row[f"{label} mean"], row[f"{label} std"])
            for label in labels
        ]  # fmt: skip
        cells.append(str(row["seeds"]))
        lines.append("| " + " | ".join(cells) + " |")
    sources = "; ".join(f"{row['method']}: {row['preset']}" for _, row in wide.iterrows())
    lines += (
        ["", notes, "", f"Presets — {sources}", ""] if notes else ["", f"Presets — {sources}", ""]
    )
    return "\n".join(lines)


def write_table(wide: pd.DataFrame, directory: Path, stem: str, title: str, notes: str = ""):
    """Write ``<stem>.md`` and ``<stem>.csv`` into ``directory``; return their paths."""
    directory.mkdir(parents=True, exist_ok=True)
    markdown, csv = directory / f"{stem}.md", directory / f"{stem}.csv"
    markdown.write_text(to_markdown(wide, title, notes), encoding="utf-8")
    wide.to_csv(csv, index=False)
    return [markdown, csv]


def write_run_tables(rows: pd.DataFrame, directory: Path, scenario: str) -> list[Path]:
    """The RMSE table and, where linear methods ran, the bias/noise decomposition table."""
    written = write_table(
        rmse_wide(rows), directory, "rmse",
        f"RMSE per method on `{scenario}` (mean ± std over seeds)",
        "interior: the scenario's common interior, the same samples for every method; full: "
        "every sample the method estimates (its coverage of the signal is given for ẋ).",
    )  # fmt: skip
    if rows["metric"].isin(["bias_rmse", "noise_rmse"]).any():
        decomposition = wide_table(rows, DECOMPOSITION_COLUMNS)
        decomposition = decomposition[decomposition["ẋ bias mean"].notna()]
        written += write_table(
            decomposition, directory, "decomposition",
            f"Error decomposition on `{scenario}`: interior RMS of the total error, of the "
            "bias part and of the noise part (mean ± std over seeds)",
            "For a linear method D, D(x + e) − x⁽ⁿ⁾ = [D(x) − x⁽ⁿ⁾] + D(e): bias = the method "
            "on the clean signal minus the truth, noise = the method on the noise alone.",
        )  # fmt: skip
    return written
