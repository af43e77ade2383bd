"""Signal tasks: a scenario with its exact derivatives (the paper signal, the grid, the limit
study's records, the Jacobi parameter study)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pandas as pd

from diffbench import methods, signals
from diffbench.bench.core.plan import Entry
from diffbench.bench.core.roles import ORDER_SYMBOLS, Role
from diffbench.bench.core.scores import estimate_on, score_estimate
from diffbench.bench.core.stats import ranking
from diffbench.bench.report import tables
from diffbench.bench.report.figures import write_error_figure
from diffbench.bench.studies import limit
from diffbench.bench.studies.frequency import decompose_error
from diffbench.bench.tasks.base import ScenarioTask
from diffbench.signals.scenarios import grid_scenario_names


@dataclass(frozen=True, eq=False)
class SignalTask(ScenarioTask):
    """A signal scenario (``diffbench.signals``): each method differentiates the noisy samples
    and is scored against the exact derivatives, on the common interior and on its own valid
    samples; linear methods also get the bias and noise parts of their error."""

    scenario: signals.Scenario
    listed: bool = True
    kind: ClassVar[str] = "signal"

    def score(self, method, seed):
        realisation = self.scenario.realise(seed)
        estimate = estimate_on(method, realisation)
        rows = score_estimate(estimate, realisation.truth, realisation.interior)
        if method.linear:
            for order in (1, 2):
                parts = decompose_error(method, realisation, order, estimate)
                rows += [
                    {"order": order, "region": "interior", "metric": metric, "value": value}
                    for metric, value in (("bias_rmse", parts.bias), ("noise_rmse", parts.noise))
                ]
        return rows

    def tuning_data(self, seed):
        return self.scenario.realise(seed)

    def longest_record(self):
        realisation = self.scenario.realise(0)
        return realisation.x.shape[0], realisation.dt_s

    def refusal(self, method):
        """Also: a causal method on irregular time stamps (it takes uniform sampling only)."""
        if method.causal and self.scenario.sampling:
            return "a causal method takes uniformly sampled records only; this one is not"
        return super().refusal(method)

    def report(self, cells, tunings, directory):
        return signal_report(self.name, self.description, cells, tunings, directory)


@dataclass(frozen=True, eq=False)
class LimitTask(SignalTask):
    """A signal task on a random signal with a known spectrum (the ``limit-*`` scenarios):
    also the efficiency of every entry against the least error any method can reach
    (:mod:`diffbench.bench.studies.limit`)."""

    listed: bool = False

    def score(self, method, seed):
        """Also the interior RMSE of the optimal estimator on the same realisation (metric
        ``optimal_rmse``; the filter's for a causal method): the efficiency is then a paired
        ratio, free of the realisation's own luck
        (:func:`diffbench.bench.studies.limit.efficiency_table`)."""
        rows = super().score(method, seed)
        return rows + limit.optimal_scores(self.scenario, seed, causal=method.causal)

    def report(self, cells, tunings, directory):
        written = super().report(cells, tunings, directory)
        return written + limit.write_efficiency_report(cells, directory)


# Table I of the paper: one parameter raised or lowered from the test-signal preset at a time.
INFLUENCE_VARIANTS = (
    ("", {}),
    ("κ = μ = 6", {"kappa": 6.0, "mu": 6.0}),
    ("κ = μ = 24", {"kappa": 24.0, "mu": 24.0}),
    ("q = 2", {"q": 2}),
    ("q = 10", {"q": 10}),
    ("T = 0.1 s", {"window_s": 0.1, "accel_window_s": 0.1}),
    ("T = 0.3 s", {"window_s": 0.3, "accel_window_s": 0.3}),
)


@dataclass(frozen=True, eq=False)
class JacobiInfluenceTask(SignalTask):
    """The paper's table I measured: the Jacobi preset with one design parameter moved at a
    time, on the paper signal: bias (truncation) and noise parts of the error."""

    listed: bool = True

    @property
    def name(self) -> str:
        return "jacobi-influence"

    @property
    def description(self) -> str:
        return (
            "Table I of the paper measured: bias and noise parts of the Jacobi error on "
            "paper-signal as κ = μ, q and T move from the paper's preset."
        )

    def lineup(self, method_names=None):
        if method_names and list(method_names) != ["jacobi"]:
            raise ValueError("jacobi-influence runs the jacobi method only")
        base = methods.preset("jacobi", "paper-signal").params()
        return [
            Entry(
                "jacobi",
                {**base, **change},
                Role(origin="variant", preset="paper-signal", by="paper", variant=label),
            )
            for label, change in INFLUENCE_VARIANTS
        ]

    def report(self, cells, tunings, directory):
        return influence_report(cells, directory)


# --- the report ------------------------------------------------------------------------------


INTERIOR_NOTE = (
    "- **interior**: the task's common interior, the same samples for every method, where it "
    "marks them valid; **whole**: every sample of the record the method estimates, valid or "
    "not (**estimated**: the fraction of the record they are); **valid**: the fraction of the "
    "record the method marks valid, its samples whose expected error is within a few times "
    "its interior's. Cells: mean ± 95 % confidence half-width over the noise seeds (std in "
    "the CSV)."
)


REGION_HEADINGS = {"interior": "interior", "whole": "whole record"}


WHOLE_RANK_NOTE = (
    "On the **whole record** an entry is ranked by its RMSE over every sample, and only if it "
    "estimates every sample on every seed (an entry that leaves out its ends would otherwise "
    "rank on its middle)."
)


def signal_report(
    task: str, description: str, cells: pd.DataFrame, tunings: pd.DataFrame, directory: Path
) -> list[Path]:
    """``rmse``, ``ranking``, ``decomposition`` (linear methods), ``tuning`` (if tuned) tables
    and the error figure of a signal task."""

    wide = tables.wide_table(cells, tables.RMSE_COLUMNS)
    title = (
        f"`{task}`: RMSE per method and setting (mean ± 95 % CI over {tables.seeds_phrase(cells)})"
    )
    written = tables.write_report(
        directory,
        "rmse",
        wide,
        tables.display_frame(wide, tables.RMSE_COLUMNS),
        title,
        f"{description}\n\n{tables.legend(cells, INTERIOR_NOTE)}",
    )
    written.append(write_error_figure(wide, directory / "errors.png", title))
    written += ranking_report(cells, directory)
    if cells["metric"].isin(["bias_rmse", "noise_rmse"]).any():
        linear = cells[
            cells.groupby(tables.ENTRY_KEYS)["metric"].transform(
                lambda m: m.isin(["bias_rmse"]).any()
            )
        ]
        parts = tables.wide_table(linear, tables.DECOMPOSITION_COLUMNS)
        written += tables.write_report(
            directory,
            "decomposition",
            parts,
            tables.display_frame(parts, tables.DECOMPOSITION_COLUMNS),
            f"`{task}`: error decomposition of the linear methods (interior RMS)",
            "For a linear method D, D(x + e) − x⁽ⁿ⁾ = [D(x) − x⁽ⁿ⁾] + D(e): **bias** = the "
            "method on the clean signal minus the truth, **noise** = the method on the noise "
            "alone; total² = bias² + noise² + 2·cross term.",
        )
    mine = tunings[tunings["task"] == task] if len(tunings) else tunings
    if len(mine):
        written += tuning_report(cells, mine, directory)
    return written


def ranking_report(cells: pd.DataFrame, directory: Path) -> list[Path]:
    """``ranking.md``/``.csv``: entries ranked by RMSE of ẋ and of ẍ, on the interior and on
    the whole record (entries that estimate every sample of it), each
    compared with the next by a paired t-test over the common seeds, with the smallest
    difference that test detects 80 % of the time."""
    frames, parts = [], []
    for order in (1, 2):
        for region in ("interior", "whole"):
            rows = cells if region == "interior" else tables.covering_whole(cells, order)
            chosen = rows[
                (rows["metric"] == "rmse") & (rows["order"] == order) & (rows["region"] == region)
            ]
            if chosen.empty:
                continue
            table = ranking(chosen, "rmse", order, region, keys=tuple(tables.ENTRY_KEYS))
            table = table.merge(tables.entries(chosen), on=tables.ENTRY_KEYS, how="left")
            labelled = tables.label_entries(table).sort_values("mean", kind="stable")
            labelled.insert(0, "derivative", ORDER_SYMBOLS[order])
            labelled.insert(1, "region", REGION_HEADINGS[region])
            frames.append(labelled)
            parts.append(
                f"## {ORDER_SYMBOLS[order]}, {REGION_HEADINGS[region]}\n\n"
                f"{tables.markdown_table(_ranking_shown(labelled))}\n"
            )
    text = (
        "# Rankings by RMSE on the interior and on the whole record\n\n"
        + "\n".join(parts)
        + "\n**better than next?**: the two-sided paired t-test over the common seeds of the "
        "difference with the next row (p < 0.05: yes). **detectable (80 %)**: the smallest true "
        "difference in mean RMSE that this test would find 80 % of the time with these seeds; a "
        "'no' next to a difference smaller than it says the run is too small to tell, not that "
        f"the methods are equal. {WHOLE_RANK_NOTE}\n"
    )
    return [
        tables.write_text(directory / "ranking.md", text),
        tables.write_csv(directory / "ranking.csv", pd.concat(frames)),
    ]


def _ranking_shown(labelled: pd.DataFrame) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "rank": range(1, len(labelled) + 1),
            "method": labelled["method"],
            "package": labelled["package"],
            "ẍ": [tables.xddot_source(m) for m in labelled["method"]],
            "setting": labelled["setting"],
            "parameters": labelled["parameters"],
            "RMSE": [
                tables.plus_minus(m, h)
                for m, h in zip(labelled["mean"], labelled["ci95"], strict=True)
            ],
            "better than next?": [_verdict(row) for _, row in labelled.iterrows()],
            "detectable (80 %)": [
                tables.nan_to_dash(v, 2) for v in labelled["detectable_difference_80"]
            ],
        }
    )


def _verdict(row) -> str:
    if pd.isna(row["significant_vs_next"]):
        return "—"
    word = "yes" if row["significant_vs_next"] else "no"
    return f"{word} (p = {row['vs_next_t_p']:.2g})" if np.isfinite(row["vs_next_t_p"]) else word


SEVERAL = "K"
"""Marks the variants of :data:`TUNING_VARIANTS` whose loss averages several tuning seeds: one
column per count stored (:func:`tuning_variants`; ten seeds of the paper's 1001 samples, two of
its 4938-sample record)."""

# The tunings a tuning table compares: (column, criterion, seeds the loss averages, region it
# is taken on).
TUNING_VARIANTS = (
    ("oracle", "oracle", 1, "interior"),
    ("oracle K seeds", "oracle", SEVERAL, "interior"),
    ("oracle K seeds whole", "oracle", SEVERAL, "whole"),
    ("oracle whole", "oracle", 1, "whole"),
    ("no-truth", "no-truth", 1, "interior"),
    ("pynumdiff", "pynumdiff", 1, "interior"),
)


def several_seed_counts(tunings: pd.DataFrame) -> list[int]:
    """The tuning seed counts above one among ``tunings`` (oracle criterion), ascending."""
    if not len(tunings):
        return []
    oracle = tunings[tunings["criterion"] == "oracle"]
    return sorted({int(k) for k in oracle["tuning_seeds"] if int(k) > 1})


def tuning_variants(tunings: pd.DataFrame) -> list[tuple[str, str, int, str]]:
    """:data:`TUNING_VARIANTS` with each several-seed variant once per count
    :func:`several_seed_counts` finds (``oracle 10 seeds``, ``oracle 2 seeds whole``...), none
    where no tuning averaged several seeds."""
    counts = several_seed_counts(tunings)
    variants = []
    for column, criterion, seeds, region in TUNING_VARIANTS:
        if seeds != SEVERAL:
            variants.append((column, criterion, seeds, region))
            continue
        for count in counts:
            variants.append((column.replace("K seeds", f"{count} seeds"), criterion, count, region))
    return variants


def tuning_table(cells: pd.DataFrame, tunings: pd.DataFrame) -> pd.DataFrame:
    """Per method, derivative n and scoring region (interior, whole record), the mean RMSE on
    the scoring seeds of the preset and of each tuned setting of :func:`tuning_variants`, the
    seconds each tuning took, the no-truth / oracle ratio, and (whole record) the least
    coverage of the record among these settings."""
    chosen = cells[cells["metric"].isin(["rmse", "coverage"])]
    group_keys = [
        "method",
        "origin",
        "criterion",
        "tuned_order",
        "tuning_seeds",
        "tuned_region",
        "tuned_on",
        "order",
        "region",
        "metric",
    ]
    means = chosen.groupby(group_keys, dropna=False)["value"].mean()
    least = chosen.groupby(group_keys, dropna=False)["value"].min()
    records = []
    variants = tuning_variants(tunings)
    for (method, order), group in tunings.groupby(["method", "order"], sort=True):
        order = int(order)
        for region in ("interior", "whole"):
            record = {
                "method": method,
                "n": ORDER_SYMBOLS[order],
                "scored on": REGION_HEADINGS[region],
            }
            presets = chosen[
                (chosen["method"] == method)
                & (chosen["origin"] == "preset")
                & (chosen["order"] == order)
                & (chosen["region"] == region)
            ]
            rmse = presets[presets["metric"] == "rmse"]["value"]
            record["preset"] = rmse.mean() if len(rmse) else float("nan")
            coverages = list(presets[presets["metric"] == "coverage"]["value"])
            for column, criterion, seeds, tuned_region in variants:
                hit = _variant(group, criterion, seeds, tuned_region)
                # the tunings on this task (a setting tuned on another has its own rows)
                key = (method, "tuned", criterion, order, seeds, tuned_region, "", order, region)
                record[column] = (
                    means.get((*key, "rmse"), float("nan")) if len(hit) else float("nan")
                )
                record[f"{column} s"] = float(hit["seconds"].iloc[0]) if len(hit) else float("nan")
                if len(hit):
                    coverages.append(least.get((*key, "coverage"), float("nan")))
            oracle = record["oracle"]
            record["no-truth / oracle"] = (
                record["no-truth"] / oracle if oracle > 0 else float("nan")
            )
            known = [c for c in coverages if np.isfinite(c)]
            record["least coverage"] = min(known) if region == "whole" and known else float("nan")
            records.append(record)
    return pd.DataFrame(records)


def tuning_report(cells: pd.DataFrame, tunings: pd.DataFrame, directory: Path) -> list[Path]:
    """``tuning.md``/``.csv``: :func:`tuning_table`, the columns no tuning filled left out; the
    seconds each tuning took in the ``.csv`` only (they change from run to run and machine to
    machine, so the tracked ``.md`` stays the same when a rerun reproduces the numbers)."""
    frame = tuning_table(cells, tunings)
    frame = frame[
        [c for c in frame.columns if c in ("method", "n", "scored on") or frame[c].notna().any()]
    ]
    shown = frame[[c for c in frame.columns if not c.endswith(" s")]].copy()
    for column in shown.columns[3:]:
        shown[column] = [tables.nan_to_dash(v, 4) for v in frame[column]]
    return tables.write_report(
        directory,
        "tuning",
        frame,
        shown,
        "Tuning: RMSE on the scoring seeds, on the interior and on the whole record, of the "
        "preset and of each tuned setting",
        "Each tuned setting is tuned for the derivative n on its tuning seeds (never scored): "
        "**oracle**, **no-truth**, **pynumdiff**: one seed, loss on the interior; "
        + "".join(
            f"**oracle {k} seeds**: the loss averaged over {k} seeds; "
            for k in several_seed_counts(tunings)
        )
        + "**whole**: the loss taken on every sample. "
        "no-truth / oracle near 1 means the data-only criterion finds what the truth would; "
        "tuning.csv also gives the seconds each tuning took. **whole record**: RMSE over every "
        "sample each setting estimates; **least coverage**: the smallest fraction of the record "
        "they estimate among the row's settings (under 1: some samples have no estimate)."
        + screening_note(tunings),
    )


def _variant(tunings: pd.DataFrame, criterion: str, seeds: int, region: str) -> pd.DataFrame:
    """The tunings of one variant of :func:`tuning_variants`."""
    return tunings[
        (tunings["criterion"] == criterion)
        & (tunings["tuning_seeds"] == seeds)
        & (tunings["region"] == region)
    ]


def screening_note(tunings: pd.DataFrame) -> str:
    """The sentence saying which columns of the tuning table were tuned with their choices
    screened (the tunings' ``screen``; empty when none was)."""
    if "screen" not in tunings:
        return ""
    columns = []
    for column, criterion, seeds, region in tuning_variants(tunings):
        hit = _variant(tunings, criterion, seeds, region)["screen"].dropna()
        columns += [f"**{column}** to the best {int(k)}" for k in sorted(hit.unique())]
    if not columns:
        return ""
    return (
        " Screened (`diffbench tune --screen K`): "
        + ", ".join(columns)
        + ": each combination of a method's choice parameters got one generation of its "
        "search and only the K best were searched in full, sharing the budget of all."
    )


def influence_report(cells: pd.DataFrame, directory: Path) -> list[Path]:
    """Table I of the paper measured: bias and noise parts of the Jacobi error per variant."""
    wide = tables.wide_table(cells, tables.DECOMPOSITION_COLUMNS)
    shown = tables.display_frame(wide, tables.DECOMPOSITION_COLUMNS)
    return tables.write_report(
        directory,
        "table1",
        wide,
        shown,
        "Table I of the paper, measured: bias and noise parts of the Jacobi error on "
        f"`paper-signal` (interior RMS, mean ± 95 % CI over {tables.seeds_phrase(cells)})",
        "Base preset κ = μ = 12, q = 6, T = 0.21 s (trapezoid rule, paper sec. III.C); each "
        "variant changes one design parameter. The paper's table I predicts: κ = μ or q up → "
        "noise up, bias down; T up → noise down, bias up.",
    )


def builtin_tasks() -> list:
    """A task per registered scenario (a limit one for the random signals of the limit study,
    the grid's unlisted) and Jacobi's influence study (table I) on the paper signal."""
    grid = set(grid_scenario_names())
    limits = set(signals.scenarios.limit_scenario_names())
    tasks = []
    for name in signals.available_scenarios():
        scenario = signals.get_scenario(name)
        listed = name not in grid
        tasks.append(LimitTask(scenario) if name in limits else SignalTask(scenario, listed))
    return [*tasks, JacobiInfluenceTask(signals.get_scenario("paper-signal"))]
