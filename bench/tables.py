"""Tables rendered from stored result rows only (never from live objects)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from diffbench.bench.stats import confidence_interval, ranking

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
    """Mean, sample std (ddof=1), 95 % CI half-width of the mean (Student t) and seed count of
    every metric per method/parameters, region and order. Rows are sorted first, so the same
    rows give the same sums in any stored order.
    """
    ordered = rows.sort_values([*KEYS, "metric", "region", "order", "seed"], kind="stable")
    grouped = ordered.groupby([*KEYS, "metric", "region", "order"], sort=True)["value"]
    summary = grouped.agg(
        mean="mean",
        std=lambda v: float(np.std(v, ddof=1)) if len(v) > 1 else float("nan"),
        ci95=lambda v: confidence_interval(v.to_numpy())[1],
        seeds="count",
    )
    return summary.reset_index()


def wide_table(rows: pd.DataFrame, columns) -> pd.DataFrame:
    """One row per method/parameters with ``<label> mean``, ``<label> std`` and ``<label> ci95``
    per column ``(label, metric, order, region)``; methods lacking a metric get NaN there."""
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
                record[f"{label} ci95"] = found["ci95"]
                seeds.append(int(found["seeds"]))
            else:
                record[f"{label} mean"] = record[f"{label} std"] = float("nan")
                record[f"{label} ci95"] = float("nan")
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
    """A wide table as Markdown: ``mean ± h`` per column (h the 95 % confidence half-width of
    the mean over seeds; the std is in the CSV), then the presets' sources."""
    labels = [c[: -len(" mean")] for c in wide.columns if c.endswith(" mean")]
    header = ["method", "parameters", *labels, "seeds"]
    lines = [f"# {title}", "", "| " + " | ".join(header) + " |",
             "|" + "|".join("---" for _ in header) + "|"]  # fmt: skip
    for _, row in wide.iterrows():
        cells = [row["method"], f"`{row['params']}`"]
        cells += [
            f"{row[f'{label} mean']:.3f}" if label.startswith("coverage")
            else _pm(row[f"{label} mean"], row[f"{label} ci95"])
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
        f"RMSE per method on `{scenario}` (mean ± 95 % CI of the mean over seeds)",
        "interior: the scenario's common interior, the same samples for every method; full: "
        "every sample the method estimates (its coverage of the signal is given for ẋ).",
    )  # fmt: skip
    written += write_ranking(rows, directory)
    if rows["metric"].isin(["bias_rmse", "noise_rmse"]).any():
        decomposition = wide_table(rows, DECOMPOSITION_COLUMNS)
        decomposition = decomposition[decomposition["ẋ bias mean"].notna()]
        written += write_table(
            decomposition, directory, "decomposition",
            f"Error decomposition on `{scenario}`: interior RMS of the total error, of the "
            "bias part and of the noise part (mean ± 95 % CI of the mean over seeds)",
            "For a linear method D, D(x + e) − x⁽ⁿ⁾ = [D(x) − x⁽ⁿ⁾] + D(e): bias = the method "
            "on the clean signal minus the truth, noise = the method on the noise alone.",
        )  # fmt: skip
    return written


IDENTIFICATION_SUMMARY = [
    ("‖X̂−X‖/‖X‖ (well excited)", "param_error_norm", 0, "identification"),
    ("τ RMSE joint 1 (N·m)", "torque_rmse.joint1", 0, "identification"),
    ("τ RMSE joint 2 (N·m)", "torque_rmse.joint2", 0, "identification"),
    ("q̇ RMSE (rad/s)", "derivative_rmse", 1, "identification"),
    ("q̈ RMSE (rad/s²)", "derivative_rmse", 2, "identification"),
    ("σ_ρ (N·m)", "sigma_rho", 0, "identification"),
    ("cond(W)", "cond_W", 0, "identification"),
    ("equations", "equations", 0, "identification"),
]


def identification_table(rows: pd.DataFrame, names, truth=None) -> pd.DataFrame:
    """The paper's table II layout: one row per parameter; per method the mean over seeds of
    X̂, of its one-sigma σ_X and of %σ_Xr, and (with ``truth``) the relative error in %
    (mean ± 95 % CI of the mean over seeds)."""
    indexed = summarise(rows).set_index([*KEYS, "metric", "region", "order"])
    summary, spread = indexed["mean"], indexed["std"]
    methods_run = sorted({(m, p, s) for m, p, s, *_ in summary.index})
    records = []
    for index, name in enumerate(names):
        record = {"parameter": name}
        if truth is not None:
            record["true"] = float(truth[index])
        for method, params, preset in methods_run:

            def value(metric, method=method, params=params, preset=preset):
                return summary.get((method, params, preset, metric, "identification", 0))

            record[f"{method} X̂"] = value(f"estimate.{name}")
            record[f"{method} σ"] = value(f"sigma.{name}")
            record[f"{method} %σXr"] = value(f"rel_sigma_pct.{name}")
            if truth is not None:
                key = (method, params, preset, f"rel_error.{name}", "identification", 0)
                record[f"{method} error % mean"] = 100 * summary.get(key)
                record[f"{method} error % std"] = 100 * spread.get(key)
        records.append(record)
    return pd.DataFrame(records)


def identification_markdown(table: pd.DataFrame, title: str, notes: str,
                            reference: str = "true") -> str:  # fmt: skip
    """Markdown of :func:`identification_table`: the ``reference`` column if present (the
    truth, or a published model), then one column per method with X̂, σ, %σ_Xr and the
    error."""
    methods_run = [c[: -len(" X̂")] for c in table.columns if c.endswith(" X̂")]
    shown = [reference] if reference in table else []
    header = ["parameter", *shown, *methods_run]
    lines = [f"# {title}", "", "| " + " | ".join(header) + " |",
             "|" + "|".join("---" for _ in header) + "|"]  # fmt: skip
    for _, row in table.iterrows():
        cells = [row["parameter"]] + [f"{row[column]:.4g}" for column in shown]
        for method in methods_run:
            text = (f"{row[f'{method} X̂']:.4g} (σ {row[f'{method} σ']:.2g}, "
                    f"{row[f'{method} %σXr']:.3g} %)")  # fmt: skip
            if f"{method} error % mean" in table:
                mean, std = row[f"{method} error % mean"], row[f"{method} error % std"]
                text += f"; err {mean:+.2f} ± {std:.2f} %"
            cells.append(text)
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join([*lines, "", notes, ""])


def write_identification_table(table: pd.DataFrame, directory: Path, title: str, notes: str,
                               reference: str = "true") -> list[Path]:  # fmt: skip
    """Write ``table2.csv`` and ``table2.md`` (see :func:`identification_markdown`)."""
    directory.mkdir(parents=True, exist_ok=True)
    csv, markdown = directory / "table2.csv", directory / "table2.md"
    table.to_csv(csv, index=False)
    markdown.write_text(identification_markdown(table, title, notes, reference), encoding="utf-8")
    return [markdown, csv]


DFKI_SUMMARY = [
    ("τ RMSE joint 1 (N·m)", "torque_rmse.joint1", 0, "identification"),
    ("lab τ RMSE joint 1", "lab_torque_rmse.joint1", 0, "identification"),
    ("τ RMSE joint 2 (N·m)", "torque_rmse.joint2", 0, "identification"),
    ("lab τ RMSE joint 2", "lab_torque_rmse.joint2", 0, "identification"),
    ("q̇ vs driver (rad/s)", "velocity_rmse_vs_driver", 1, "identification"),
    ("cond(W)", "cond_W", 0, "identification"),
]


def write_ranking(rows: pd.DataFrame, directory: Path) -> list[Path]:
    """``ranking.md``/``.csv``: methods ranked by interior RMSE of ẋ and of ẍ, each with its
    95 % CI and a paired test (t and Wilcoxon over the common seeds) against the next one."""
    frames, lines = [], ["# Rankings by interior RMSE (paired tests over the same seeds)", ""]
    for order in (1, 2):
        table = ranking(rows, "rmse", order, "interior")
        table.insert(0, "derivative", ORDER_LABELS[order])
        frames.append(table)
        lines += [f"## {ORDER_LABELS[order]}", "",
                  "| rank | method | RMSE mean ± 95 % CI | seeds | better than next? (t p, "
                  "Wilcoxon p) |", "|---|---|---|---|---|"]  # fmt: skip
        for rank, row in table.iterrows():
            verdict = "—"
            if pd.notna(row["significant_vs_next"]):
                word = "yes" if row["significant_vs_next"] else "not significant"
                verdict = f"{word} ({row['vs_next_t_p']:.2g}, {row['vs_next_wilcoxon_p']:.2g})"
            name = row["method"]
            if str(row["preset"]).startswith("tuned"):
                name += f" ({row['preset'].split(' on seed')[0]})"
            lines.append(f"| {rank + 1} | {name} | {_pm(row['mean'], row['ci95'])} | "
                         f"{row['seeds']} | {verdict} |")  # fmt: skip
        lines.append("")
    directory.mkdir(parents=True, exist_ok=True)
    markdown, csv = directory / "ranking.md", directory / "ranking.csv"
    markdown.write_text("\n".join(lines), encoding="utf-8")
    pd.concat(frames).to_csv(csv, index=False)
    return [markdown, csv]


def write_tuning_summary(rows: pd.DataFrame, log: pd.DataFrame, directory: Path) -> list[Path]:
    """``tuning.md``: per method and derivative, the interior RMSE on the scoring seeds of the
    preset and of each tuned parameter set (looked up by its parameters, so a tuning that lands
    on the preset is still found), the no-truth / oracle ratio, and the tuning time."""
    import json

    from diffbench.bench.store import canonical_params

    chosen = rows[(rows["metric"] == "rmse") & (rows["region"] == "interior")]
    means = chosen.groupby(["method", "params", "order"])["value"].mean()
    presets = chosen[~chosen["preset"].astype(str).str.startswith("tuned")]
    lines = ["# Tuning: preset vs tuned (interior RMSE on the scoring seeds, never the tuning "
             "seed)", "",
             "| method | n | preset | oracle-tuned | no-truth-tuned | no-truth / oracle | "
             "pynumdiff-tuned | tuning s (oracle, no-truth, pynumdiff) |",
             "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    records = []
    for method in sorted(log["method"].unique()):
        for order in sorted(log[log["method"] == method]["order"].unique()):
            found = {}
            for criterion in ("oracle", "no-truth", "pynumdiff"):
                hit = log[(log["method"] == method) & (log["order"] == order)
                          & (log["criterion"] == criterion)]  # fmt: skip
                if len(hit):
                    params = canonical_params(json.loads(hit["params"].iloc[-1]))
                    found[criterion] = (means.get((method, params, order), float("nan")),
                                        float(hit["seconds"].iloc[-1]))  # fmt: skip
                else:
                    found[criterion] = (float("nan"), float("nan"))
            mine = presets[(presets["method"] == method) & (presets["order"] == order)]
            preset = float(mine.groupby("params")["value"].mean().iloc[0]) if len(mine) else (
                float("nan"))  # fmt: skip
            oracle, no_truth, pynumdiff = (found[c][0] for c in ("oracle", "no-truth",
                                                                 "pynumdiff"))  # fmt: skip
            ratio = no_truth / oracle if oracle > 0 else float("nan")
            times = ", ".join(f"{found[c][1]:.2f}" for c in ("oracle", "no-truth", "pynumdiff"))
            records.append({"method": method, "order": int(order), "preset": preset,
                            "oracle": oracle, "no_truth": no_truth,
                            "no_truth_over_oracle": ratio, "pynumdiff": pynumdiff,
                            "seconds": times})  # fmt: skip
            lines.append(f"| {method} | {ORDER_LABELS[int(order)]} | {preset:.4g} | "
                         f"{oracle:.4g} | {no_truth:.4g} | {ratio:.3f} | {pynumdiff:.4g} | "
                         f"{times} |")  # fmt: skip
    markdown, csv = directory / "tuning.md", directory / "tuning_summary.csv"
    markdown.write_text("\n".join([*lines, ""]), encoding="utf-8")
    pd.DataFrame(records).to_csv(csv, index=False)
    return [markdown, csv]
