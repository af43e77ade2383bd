"""Tables rendered from stored rows only (never from live objects), for people and for programs.

Every table has one row per *entry*: a method, its parameters and their role (a preset, tuned
by a criterion for a derivative, a variant). The Markdown names the row by its role
(``preset (paper)``, ``oracle-tuned for ẍ``) and prints parameters rounded to 4 significant
digits; the CSV beside it keeps full precision and the role as columns.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench import methods
from diffbench.bench.core import store
from diffbench.bench.core.roles import CRITERION_LEGEND, CRITERION_NAMES, ORDER_SYMBOLS, Role
from diffbench.bench.core.stats import confidence_interval

ENTRY_KEYS = ["method", "params", "role"]
ROLE_COLUMNS = list(store.ROLE_COLUMNS)
REGION_LABELS = {
    "interior": "interior",
    "whole": "whole record (every sample estimated)",
    "valid": "whole record (own valid samples)",
}
WHOLE_COVERAGE = {"whole": 1.0, "valid": 0.99}
"""Least fraction of the record an entry must cover, on every seed, to be ranked on the whole
record: estimate every sample (region ``whole``); or, ranked on its own valid samples (region
``valid``, the studies' scenario grid), mark 99 % of them valid (below that, its RMSE leaves
out too much to stand for the whole; it is still shown, with its coverage)."""

# (column label, metric, derivative order, region)
RMSE_COLUMNS = [
    *((f"RMSE {ORDER_SYMBOLS[n]} interior", "rmse", n, "interior") for n in (1, 2, 0)),
    *((f"RMSE {ORDER_SYMBOLS[n]} whole", "rmse", n, "whole") for n in (1, 2, 0)),
    *((f"estimated {ORDER_SYMBOLS[n]}", "coverage", n, "whole") for n in (1, 2)),
    *((f"valid {ORDER_SYMBOLS[n]}", "coverage", n, "valid") for n in (1, 2)),
]
DECOMPOSITION_COLUMNS = [
    (f"{ORDER_SYMBOLS[n]} {part}", metric, n, "interior")
    for n in (1, 2)
    for part, metric in (("total", "rmse"), ("bias", "bias_rmse"), ("noise", "noise_rmse"))
]


class StoreInconsistency(RuntimeError):
    """Stored rows break an invariant of the store (an internal error, never user input)."""


# --- labels ----------------------------------------------------------------------------------
def format_value(value) -> str:
    """A parameter value for people: floats to 4 significant digits, others as they are."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    if isinstance(value, int):
        return str(value)
    return f"{value:.4g}"


def readable_params(method: str, params: str) -> str:
    """``order=6, cutoff_hz=25`` in the method's declaration order (4 significant digits),
    leaving out what the method's other choices leave unused (``Method.unused_params``)."""
    values = json.loads(params)
    try:
        order = [spec.name for spec in methods.params_of(methods.method_class(method))]
    except ValueError:  # a method no longer registered (e.g. a plugin not loaded)
        order = []
    try:
        unused = set(methods.get(method, **values).unused_params())
    except ValueError:  # ... or stored values its code no longer accepts: print them all
        unused = set()
    names = [n for n in order if n in values] + sorted(set(values) - set(order))
    names = [n for n in names if n not in unused]
    return ", ".join(f"{name}={format_value(values[name])}" for name in names)


def role_of(row) -> Role:
    """The :class:`Role` of a row, from its ``role`` column (the stored canonical JSON)."""
    return Role(**json.loads(row["role"]))


def label_entries(frame: pd.DataFrame) -> pd.DataFrame:
    """Add ``setting`` (the role's label) and ``parameters`` (readable) and sort the entries:
    by method, then presets, variants, tuned (by criterion and order)."""
    frame = frame.copy()
    roles = [role_of(row) for _, row in frame.iterrows()]
    frame.insert(1, "setting", [role.label for role in roles])
    frame.insert(
        2,
        "parameters",
        [readable_params(m, p) for m, p in zip(frame["method"], frame["params"], strict=True)],
    )
    frame["_sort"] = [role.sort_key for role in roles]
    frame = frame.sort_values(["method", "_sort", "params"], kind="stable").drop(columns="_sort")
    return frame.reset_index(drop=True)


# --- statistics over seeds -----------------------------------------------------------------
def check_unique_seeds(rows: pd.DataFrame, keys: Sequence[str] = ENTRY_KEYS) -> None:
    """Raise :class:`StoreInconsistency` if an entry has two rows for one seed and score."""
    columns = [*keys, "metric", "region", "order", "seed"]
    duplicated = rows.duplicated(columns, keep=False)
    if duplicated.any():
        first = rows[duplicated].iloc[0]
        raise StoreInconsistency(
            f"{int(duplicated.sum())} stored rows repeat a seed of an entry (e.g. "
            f"{first['method']} seed {first['seed']} {first['metric']}); the store must hold "
            "each cell once"
        )


def summarise(rows: pd.DataFrame, keys: Sequence[str] = ENTRY_KEYS) -> pd.DataFrame:
    """Mean, sample std (ddof=1), 95 % CI half-width of the mean (Student t) and seed count of
    every metric per entry, region and order. Rows are sorted first, so the same rows give the
    same sums in any stored order."""
    check_unique_seeds(rows, keys)
    keys = list(keys)
    ordered = rows.sort_values([*keys, "metric", "region", "order", "seed"], kind="stable")
    grouped = ordered.groupby([*keys, "metric", "region", "order"], sort=True)["value"]
    summary = grouped.agg(
        mean="mean",
        std=lambda v: float(np.std(v, ddof=1)) if len(v) > 1 else float("nan"),
        ci95=lambda v: confidence_interval(v.to_numpy())[1],
        seeds="count",
    )
    return summary.reset_index()


def covering_whole(
    rows: pd.DataFrame, order: int, keys: Sequence[str] = ENTRY_KEYS, region: str = "whole"
) -> pd.DataFrame:
    """``rows`` less the entries that cover under :data:`WHOLE_COVERAGE` of the record for the
    derivative of ``order`` on ``region`` on some seed (their whole-record RMSE would leave out
    their worst samples); an entry with no coverage row for ``order`` is left out too."""
    coverage = rows[
        (rows["metric"] == "coverage") & (rows["order"] == order) & (rows["region"] == region)
    ]
    least = coverage.groupby(list(keys), dropna=False)["value"].min()
    covering = least[least >= WHOLE_COVERAGE[region]].index
    index = pd.MultiIndex.from_frame(rows[list(keys)])
    return rows[index.isin(covering)]


def entries(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per entry: method, params, role and the role's columns."""
    columns = [*ENTRY_KEYS, *ROLE_COLUMNS, "package"]
    return rows[columns].drop_duplicates(ENTRY_KEYS).reset_index(drop=True)


def xddot_source(method: str) -> str:
    """How the method obtains ẍ, for a table: ``native`` or ``ẋ differentiated again``."""
    try:
        cls = methods.method_class(method)
    except ValueError:  # a plugin not loaded now
        return "?"
    return "native" if cls.second_derivative == "native" else "ẋ differentiated again"


def wide_table(rows: pd.DataFrame, columns) -> pd.DataFrame:
    """One row per entry (labelled, see :func:`label_entries`) with ``<label> mean``,
    ``<label> std`` and ``<label> ci95`` per column ``(label, metric, order, region)`` (NaN
    where an entry lacks that score) and ``seeds`` (the fewest seeds of its columns)."""
    summary = summarise(rows).set_index([*ENTRY_KEYS, "metric", "region", "order"])
    table = entries(rows)
    seeds = []
    for label, metric, order, region in columns:
        for statistic in ("mean", "std", "ci95"):
            values = []
            for _, entry in table.iterrows():
                index = (entry["method"], entry["params"], entry["role"], metric, region, order)
                values.append(summary[statistic].get(index, float("nan")))
            table[f"{label} {statistic}"] = values
        seeds.append(
            [
                summary["seeds"].get(
                    (e["method"], e["params"], e["role"], metric, region, order), np.nan
                )
                for _, e in table.iterrows()
            ]
        )
    table["seeds"] = pd.array(
        np.nanmin(np.array(seeds, dtype=float), axis=0).astype(int) if seeds and len(table) else [],
        dtype="Int64",
    )
    return label_entries(table)


# --- Markdown --------------------------------------------------------------------------------
def plus_minus(mean: float, half: float) -> str:
    """``mean ± half`` (4 and 2 significant digits); ``± 0`` for a deterministic number."""
    if not np.isfinite(mean):
        return "—"
    if not np.isfinite(half):
        return f"{mean:.4g}"
    if half <= 1e-12 * abs(mean):
        return f"{mean:.4g} ± 0"
    return f"{mean:.4g} ± {half:.2g}"


def markdown_table(frame: pd.DataFrame) -> str:
    """A frame as a GitHub Markdown table (pipes in cells escaped so columns stay aligned)."""
    escaped = frame.astype(str).apply(lambda column: column.str.replace("|", "\\|"))
    escaped.columns = [str(c).replace("|", "\\|") for c in frame.columns]
    return escaped.to_markdown(index=False, disable_numparse=True)


def display_frame(wide: pd.DataFrame, columns) -> pd.DataFrame:
    """The people's view of :func:`wide_table`: method, setting, parameters, ``mean ± CI``."""
    shown = wide[["method", "package", "setting", "parameters"]].copy()
    shown.insert(2, "ẍ", [xddot_source(m) for m in wide["method"]])
    for label, metric, _, _ in columns:
        if metric == "coverage" or metric.endswith("_coverage"):
            shown[label] = [f"{v:.3f}" if np.isfinite(v) else "—" for v in wide[f"{label} mean"]]
        else:
            shown[label] = [
                plus_minus(m, h)
                for m, h in zip(wide[f"{label} mean"], wide[f"{label} ci95"], strict=True)
            ]
    shown["seeds"] = wide["seeds"].astype(str)
    return shown


def write_text(path: Path, text: str) -> Path:
    """Write ``text`` atomically (temporary file, then rename): readers never see half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    temporary.write_text(text, encoding="utf-8")
    os.replace(temporary, path)
    return path


def write_csv(path: Path, frame: pd.DataFrame) -> Path:
    return write_text(path, frame.to_csv(index=False))


def write_report(
    directory: Path,
    stem: str,
    csv_frame: pd.DataFrame,
    shown: pd.DataFrame,
    title: str,
    legend: str = "",
) -> list[Path]:
    """``<stem>.md`` (title, table, legend) and ``<stem>.csv`` (full precision)."""
    text = f"# {title}\n\n{markdown_table(shown)}\n"
    if legend:
        text += f"\n{legend}\n"
    return [
        write_text(directory / f"{stem}.md", text),
        write_csv(directory / f"{stem}.csv", csv_frame),
    ]


def legend(rows: pd.DataFrame, extra: str = "") -> str:
    """One short legend: what each setting in these rows means (presets with their source)."""

    lines = []
    table = entries(rows)
    presets = table[table["origin"] == "preset"]
    if len(presets):
        keys = ", ".join(f"`{key}`" for key in sorted(set(presets["preset"])))
        lines.append(
            f"- **preset (paper)**: the seed paper's setting; **preset (diffbench)**: "
            f"ours where the paper has none (the methods' {keys} presets; sources: "
            "`diffbench list`)."
        )
    for criterion in sorted({c for c in table["criterion"] if c}):
        tuned = table[table["criterion"] == criterion]
        pairs = zip(tuned["tuning_seed"], tuned["tuning_seeds"], strict=True)
        spans = sorted({(int(first), int(count)) for first, count in pairs})
        seeds = ", ".join(
            str(first) if count == 1 else f"{first}–{first + count - 1}" for first, count in spans
        )
        text = (
            f"- **{CRITERION_NAMES[criterion]}-tuned for n**: {CRITERION_LEGEND[criterion]}"
            f" (noise seed {seeds}, never scored"
        )
        if any(count > 1 for _, count in spans):
            text += "; **K seeds**: the loss averaged over K consecutive seeds"
        if (tuned["tuned_region"] == "whole").any():
            text += "; **whole record**: the loss taken on every sample, edge treatments tuned too"
        if "tuned_on" in tuned and (tuned["tuned_on"] != "").any():
            text += (
                "; **on TASK**: tuned on that task's record of the same step, scored on this one"
            )
        lines.append(text + ").")
    if extra:
        lines.append(extra)
    return "\n".join(lines)


def nan_to_dash(value: float, digits: int = 4) -> str:
    return "—" if value is None or not math.isfinite(value) else f"{value:.{digits}g}"


def numbers_shown(frame: pd.DataFrame, digits: int = 4) -> pd.DataFrame:
    """``frame`` for people: its float columns to ``digits`` significant digits, +inf as ∞,
    NaN (and -inf) as a dash."""
    shown = frame.copy()
    for column in shown.columns:
        if pd.api.types.is_float_dtype(shown[column]):
            shown[column] = shown[column].map(
                lambda v: "∞" if v == math.inf else nan_to_dash(v, digits)
            )
    return shown


def seeds_phrase(rows: pd.DataFrame) -> str:
    """How many noise seeds the entries of ``rows`` were scored on, for a report's text
    ("20 noise seeds", or "5–20 noise seeds" when entries differ)."""
    counts = rows.groupby(ENTRY_KEYS)["seed"].nunique()
    low, high = int(counts.min()), int(counts.max())
    return f"{low} noise seeds" if low == high else f"{low}–{high} noise seeds"
