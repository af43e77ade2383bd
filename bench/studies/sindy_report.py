"""The SINDy discovery study's report (:mod:`diffbench.bench.studies.sindy`): the entries'
scores over the seeds, the winner per system and noise level against the weak form, where
each entry stops finding the true terms, a table per system and a figure."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from diffbench.bench.core import tuning
from diffbench.bench.core.records import canonical
from diffbench.bench.core.stats import confidence_interval
from diffbench.bench.report import figures, tables
from diffbench.bench.studies import sindy as study
from diffbench.signals.dynamics import PolynomialSystem, get_system


def entry_label(source: str, method: str) -> str:
    """An entry as a table names it: ``method (source)``."""
    return method if source in ("truth", "weak form", "pysindy") else f"{method} ({source})"


def entries_frame(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """One row per entry (system, step, starts, level, source, method) from the per-seed rows
    (a row stored before records had several starts has one): the mean
    coefficient error and the half-width of its 95 % interval over the seeds (Student's t;
    NaN for one seed), the mean precision and recall,
    the share of seeds with the exact support, the median simulation error and the seeds
    whose simulations diverged; ``params`` as canonical JSON (sorted keys), so that rows just
    computed and rows read back from the store give the same table."""
    frame = pd.DataFrame(rows)
    frame["failed"] = frame["failure"].fillna("") != ""
    starts = frame["starts"] if "starts" in frame else pd.Series(1, index=frame.index)
    frame["starts"] = starts.fillna(1).astype(int)
    keys = ["system", "step_s", "starts", "level", "source", "method"]
    out = []
    for key, group in frame.groupby(keys, sort=False):
        scored = group[~group["failed"]]
        errors = scored["coefficient_error"].to_numpy(dtype=float)
        half = confidence_interval(errors)[1] if errors.size else math.nan
        out.append(
            {
                **dict(zip(keys, key, strict=True)),
                "entry": entry_label(key[4], key[5]),
                "params": canonical(group["params"].iloc[0]),  # one spelling, stored or not
                "seeds": int(group["seed"].nunique()),
                "failed": int(group["failed"].sum()),
                "coefficient_error": float(errors.mean()) if errors.size else math.nan,
                "ci_half": half,
                "precision": float(scored["precision"].mean()) if len(scored) else math.nan,
                "recall": float(scored["recall"].mean()) if len(scored) else math.nan,
                "exact_support": float(scored["exact_support"].mean()) if len(scored) else 0.0,
                "simulation_error": (
                    float(scored["simulation_error"].median()) if len(scored) else math.nan
                ),
                "diverged_seeds": int((scored["diverged"] > 0).sum()) if len(scored) else 0,
            }
        )
    return pd.DataFrame(out)


def _contenders(part: pd.DataFrame) -> pd.DataFrame:
    """The entries a winner is chosen among: every one but the truth, scored on every seed."""
    return part[(part["source"] != "truth") & (part["failed"] == 0)].dropna(
        subset=["coefficient_error"]
    )


def summary_table(entries: pd.DataFrame) -> pd.DataFrame:
    """Per system, record (sampling step and starts) and noise level: the entry with the least
    mean coefficient error, its margin over the next (their ratio), the weak form's error
    (the better of its entries), and the best pointwise differentiator's ratio to it (< 1:
    it beats the weak form)."""
    rows = []
    groups = entries.groupby(["system", "step_s", "starts", "level"], sort=False)
    for (system, step_s, starts, level), part in groups:
        ranked = _contenders(part).sort_values("coefficient_error")
        weak = part[part["source"] == "weak form"]["coefficient_error"]
        weak_error = float(weak.min()) if len(weak) else math.nan
        pointwise = ranked[ranked["source"] != "weak form"]
        best, second = (ranked.iloc[0], ranked.iloc[1]) if len(ranked) > 1 else (None, None)
        rows.append(
            {
                "system": system,
                "step": step_label(step_s),
                "starts": starts,
                "noise": f"{level:.1%}",
                "winner": "—" if best is None else best["entry"],
                "its error": math.nan if best is None else best["coefficient_error"],
                "exact support": math.nan if best is None else best["exact_support"],
                "next": "—" if second is None else second["entry"],
                "margin": (
                    math.nan
                    if best is None
                    else second["coefficient_error"] / best["coefficient_error"]
                    if best["coefficient_error"] > 0
                    else math.inf
                ),
                "weak form's error": weak_error,
                "best pointwise": "—" if pointwise.empty else pointwise.iloc[0]["entry"],
                "its error ": math.nan
                if pointwise.empty
                else pointwise.iloc[0]["coefficient_error"],
                "best pointwise / weak form": (
                    math.nan
                    if pointwise.empty or not weak_error
                    else pointwise.iloc[0]["coefficient_error"] / weak_error
                ),
            }
        )
    return pd.DataFrame(rows)


def headline_table(summary: pd.DataFrame) -> pd.DataFrame:
    """One row per number of starts from :func:`summary_table`: on how many records
    (system × step × noise) the best pointwise differentiator's coefficient error is below
    the weak form's, the median ratio of the two, and the entry that wins most records (with
    its count)."""
    rows = []
    for starts, part in summary.groupby("starts"):
        ratios = part["best pointwise / weak form"].to_numpy(dtype=float)
        compared = np.isfinite(ratios)
        wins = part["winner"].value_counts()
        rows.append(
            {
                "trajectories": (
                    "1, the whole duration" if starts == 1 else f"{starts}, each 1/{starts} of it"
                ),
                "records (systems × steps × noise levels)": len(part),
                "best pointwise differentiator beats the weak form on": int(
                    np.sum(ratios[compared] < 1)
                ),
                "its error / the weak form's, median": (
                    f"{np.median(ratios[compared]):.2f}×" if compared.any() else "—"
                ),
                "wins most records": f"{wins.index[0]} ({wins.iloc[0]} of {len(part)})",
            }
        )
    return pd.DataFrame(rows)


def support_table(entries: pd.DataFrame) -> pd.DataFrame:
    """Per system, sampling step and starts, each entry's share of seeds with the exact
    support at every noise level (columns): where it stops recovering the right equations."""
    table = entries.assign(step=entries["step_s"].map(step_label)).pivot_table(
        index=["system", "step", "starts", "entry"],
        columns="level",
        values="exact_support",
        sort=False,
    )
    table.columns = [f"{level:.1%}" for level in table.columns]
    return table.reset_index()


def step_label(step_s: float) -> str:
    """A sampling step as tables name it: ``2 ms``."""
    return f"{1000 * step_s:.3g} ms"


def system_table(entries: pd.DataFrame, system: str) -> pd.DataFrame:
    """One system: per record (sampling step and starts), every entry's mean coefficient
    error (95 % interval) and share of exact supports at each noise level (columns), the
    best at the highest level first."""
    part = entries[entries["system"] == system]
    levels = sorted(set(part["level"]))
    rows = []
    for (step_s, starts), record in part.groupby(["step_s", "starts"]):
        hardest = record[record["level"] == record["level"].max()]
        for entry in hardest.sort_values("coefficient_error")["entry"]:
            mine = record[record["entry"] == entry].set_index("level")
            row = {"step": step_label(step_s), "starts": starts, "entry": entry}
            for level in levels:
                if level not in mine.index:
                    row[f"{level:.1%}"] = "—"
                    continue
                found = mine.loc[level]
                row[f"{level:.1%}"] = (
                    f"{tables.plus_minus(found['coefficient_error'], found['ci_half'])}"
                    f" ({found['exact_support']:.0%} exact)"
                )
            rows.append(row)
    return pd.DataFrame(rows)


def equation_text(system: PolynomialSystem) -> str:
    """A system's equations as written: ``x' = -10 x + 10 y; ...`` (each equation's terms
    in decreasing order of their monomials' exponents, a coefficient of one left out, the
    others to four significant digits)."""
    equations = []
    for state, terms in zip(system.states, system.terms, strict=True):
        text = ""
        for monomial, value in sorted(terms.items(), reverse=True):
            factors = " ".join(
                name if power == 1 else f"{name}^{power}"
                for name, power in zip(system.states, monomial, strict=True)
                if power
            )
            number = f"{abs(value):.4g}"
            term = factors if factors and number == "1" else f"{number} {factors}".strip()
            sign = "-" if value < 0 else "+"
            text += f"{sign}{term}" if not text else f" {sign} {term}"
        equations.append(f"{state}' = {text.removeprefix('+')}")
    return "; ".join(equations)


def systems_table(names) -> pd.DataFrame:
    """The systems the study ran on: equations, the thresholded least squares' threshold
    and library degree, step, duration, the measured and held-out starts and the horizon."""
    rows = []
    for name in names:
        system = get_system(name)
        rows.append(
            {
                "system": name,
                "equations": equation_text(system),
                "STLSQ threshold": system.threshold,
                "library degree": system.degree,
                "step (s)": system.dt_s,
                "duration (s)": system.duration_s,
                "measured from": "; ".join(
                    str(start) for start in (system.initial, *system.starts)
                ),
                "held out": "; ".join(str(start) for start in system.held_out),
                "horizon (s)": system.horizon_s,
                "reference": system.reference,
            }
        )
    return pd.DataFrame(rows)


FIGURE_SOURCES = ("oracle", "weak form")
"""The entries the figure draws: each method oracle-tuned, the weak form, and pysindy's own
differentiation (:data:`FIGURE_PYSINDY`); every entry is in the tables."""

FIGURE_PYSINDY = ("FiniteDifference", "SmoothedFiniteDifference")


def write_figure(entries: pd.DataFrame, path: Path) -> Path:
    """Coefficient error against noise level at each system's own step from one start, one
    panel per system, one line per entry of :data:`FIGURE_SOURCES` and :data:`FIGURE_PYSINDY`
    with its 95 % interval over the seeds (log-log; the lower bar cut at a tenth of the
    mean)."""
    plt = figures.pyplot()
    own_step = entries.groupby("system")["step_s"].transform("min")
    drawn = entries[
        (entries["step_s"] == own_step)
        & (entries["starts"] == 1)
        & (
            entries["source"].isin(FIGURE_SOURCES)
            | ((entries["source"] == "pysindy") & entries["method"].isin(FIGURE_PYSINDY))
        )
    ]
    systems = list(dict.fromkeys(drawn["system"]))
    columns = min(3, len(systems))
    rows = math.ceil(len(systems) / columns)
    names = list(dict.fromkeys(drawn["entry"]))
    legend_rows = math.ceil(len(names) / 4)
    height = 3.6 * rows + 0.3 * legend_rows
    fig, axes = plt.subplots(rows, columns, figsize=(5.2 * columns, height), squeeze=False)
    styles = figures.method_styles(names)
    for axis, system in zip(axes.flat, systems, strict=False):
        for entry, group in drawn[drawn["system"] == system].groupby("entry", sort=False):
            group = group.sort_values("level")
            style = styles[entry]
            axis.errorbar(
                group["level"],
                group["coefficient_error"].clip(lower=1e-16),
                yerr=[
                    np.minimum(group["ci_half"], 0.9 * group["coefficient_error"]),
                    group["ci_half"],
                ],
                label=entry,
                color=style.color,
                linestyle=style.linestyle,
                marker=style.marker,
                capsize=2,
            )
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_title(system)
        axis.set_xlabel("noise / state's std")
        axis.set_ylabel("coefficient error")
    for axis in list(axes.flat)[len(systems) :]:
        axis.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize="small")
    fig.tight_layout(rect=(0, 0.3 * legend_rows / height + 0.02, 1, 1))
    return figures.save_figure(fig, path, tight=False)


def write_report(rows: list[dict[str, Any]], directory: Path, seeds: int) -> list[Path]:
    """``headline.md``/``.csv`` (:func:`headline_table`), ``summary.md``/``.csv`` (the winner
    per system, step, starts and noise level), ``systems.md``/``.csv`` (the systems),
    ``support.md``/``.csv``
    (where each entry stops recovering the support), ``<system>.md``/``.csv`` per system,
    ``entries.csv`` (every entry's scores) and ``coefficient_error.png``."""
    directory.mkdir(parents=True, exist_ok=True)
    entries = entries_frame(rows)
    legend = (
        f"Mean over {seeds} noise seeds (Gaussian, the level times each state's std over the "
        "samples kept, `numpy.random.default_rng(seed)`); **step**: every sample of the "
        "trajectory, at the system's own step, or every fifth, at five times it; **starts**: "
        "one trajectory over the system's duration, or three from other initial conditions, "
        "each a third as long, fitted together. "
        "**coefficient error**: "
        "‖Ξ̂ − Ξ‖_F / ‖Ξ‖_F over the system's polynomial library (STLSQ at the system's "
        "threshold, no ridge); **exact**: the share of seeds whose terms are "
        "exactly the true ones. *oracle*: tuned by the truth for ẋ on the seed "
        f"{tuning.TUNING_SEED} (never scored); *recommend*: the setting `diffbench recommend` "
        "chooses for each state from that seed's measurement alone; *preset*: the method's "
        f"{study.PRESET} preset; "
        "pysindy's classes at their defaults, derivative's methods (SINDyDerivative.*) at its "
        "README's settings; **weak form**: pysindy's WeakPDELibrary over time (no pointwise "
        "derivative), at its defaults and with its number of test functions K chosen by the "
        "truth on the tuning seed (the weak form's error: the better of the two). Margin: the "
        "next entry's error over the winner's."
    )
    summary = summary_table(entries)
    headline = headline_table(summary)
    written = tables.write_report(
        directory,
        "headline",
        headline,
        headline,
        "SINDy discovery in one line: pointwise differentiators against the weak form",
        legend,
    )
    written += tables.write_report(
        directory,
        "summary",
        summary,
        tables.numbers_shown(summary, 3),
        "SINDy discovery: the differentiator that finds the equations best, per system, "
        "sampling step, starts and noise level",
        legend,
    )
    support = support_table(entries)
    written += tables.write_report(
        directory,
        "support",
        support,
        tables.numbers_shown(support, 3),
        "Exact support: the share of seeds each entry finds exactly the true terms",
        legend,
    )
    systems = systems_table(dict.fromkeys(entries["system"]))
    written += tables.write_report(
        directory,
        "systems",
        systems,
        systems,
        "The systems: equations, SINDy's threshold, sampling and starts",
        "The threshold is below every true coefficient's magnitude, so that SINDy recovers "
        "each system's equations from the exact derivatives (tested, to rounding). "
        "**measured from**: the initial conditions of the one-start record (the first) and "
        "of the three-start one; **held out**: those the discovered model is simulated from "
        "over the horizon (never measured).",
    )
    for system in dict.fromkeys(entries["system"]):
        table = system_table(entries, system)
        title = f"{system}: coefficient error (95 % interval) and exact supports"
        written += tables.write_report(directory, system, table, table, title, legend)
    written.append(tables.write_csv(directory / "entries.csv", entries))
    written.append(write_figure(entries, directory / "coefficient_error.png"))
    return written
