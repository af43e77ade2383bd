"""Where each method wins: every method tuned (oracle, for ẋ and for ẍ) on each task of the
noise-type x noise-level x sampling-step grid, then scored on other seeds.

Tunings and cells live in the store like any other, so a rerun re-tunes and recomputes
nothing. A grid scenario whose sinusoidal disturbance aliases to 0 Hz at its step (200 Hz
sampled every 10 ms lands on its own zeros) has no such disturbance: the winners table says so
instead of ranking noise-free cells as if they were noisy.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import pandas as pd

from diffbench import methods, signals
from diffbench.bench import tables
from diffbench.bench.roles import ORDER_SYMBOLS
from diffbench.bench.runner import Cell, TuningJob, tuned_entries
from diffbench.bench.stats import ranking
from diffbench.signals.scenarios import (
    GRID_NOISE_LEVELS,
    GRID_NOISE_TYPES,
    GRID_STEPS_S,
    grid_scenario_name,
    grid_scenario_names,
    vanishing_disturbances,
)

TUNING_SEED = 10_000
BUDGET = 150  # evaluations per tuning: the grid tunes 36 x 7 x 2 times


def task_names() -> list[str]:
    return grid_scenario_names()


def tuning_jobs(
    orders: Sequence[int] = (1, 2), names: Sequence[str] | None = None
) -> list[TuningJob]:
    """Each method of ``names`` (default: every registered one), for each order, on each grid
    task (oracle, seed 10000)."""
    return [
        TuningJob(task, name, "oracle", int(order), TUNING_SEED, None, BUDGET)
        for task in task_names()
        for name in (names or methods.available())
        for order in orders
    ]


def cells(found: Mapping[TuningJob, dict], seeds) -> list[Cell]:
    """The cells scoring each tuned setting on ``seeds``."""
    return [
        cell
        for entry, job in zip(tuned_entries(found), _tuned_jobs(found), strict=True)
        for cell in entry.cells(job.task, seeds)
    ]


def _tuned_jobs(found: Mapping[TuningJob, dict]) -> list[TuningJob]:
    return [job for job, record in found.items() if record["params"]]


def winners(rows: pd.DataFrame, order: int = 2) -> pd.DataFrame:
    """Per grid task: the entry with the least mean interior RMSE of the derivative of
    ``order`` (among those tuned for it), the runner-up, the paired t-test between them and the
    smallest difference it detects 80 % of the time; ``vanishing`` names a disturbance that
    aliases away at the step (no winner is named when nothing is left of the noise)."""
    records = []
    for kind in GRID_NOISE_TYPES:
        for level in GRID_NOISE_LEVELS:
            for step in GRID_STEPS_S:
                name = grid_scenario_name(kind, level, step)
                vanishing = vanishing_disturbances(signals.get_scenario(name))
                noiseless = len(vanishing) == len(signals.get_scenario(name).noise.models)
                tuned_for = (rows["tuned_order"] == order).fillna(False).astype(bool)
                mine = rows[
                    (rows["task"] == name)
                    & tuned_for
                    & (rows["metric"] == "rmse")
                    & (rows["order"] == order)
                    & (rows["region"] == "interior")
                ]
                record = {
                    "noise": kind,
                    "level": level,
                    "step_ms": step * 1e3,
                    "vanishing": "; ".join(vanishing),
                    "noiseless": noiseless,
                }
                if not mine.empty:
                    table = ranking(mine, "rmse", order, "interior", keys=("method", "params"))
                    best = table.iloc[0]
                    second = table.iloc[1] if len(table) > 1 else None
                    record.update(
                        {
                            "winner": best["method"],
                            "rmse": best["mean"],
                            "ci95": best["ci95"],
                            "runner_up": None if second is None else second["method"],
                            "runner_up_rmse": None if second is None else second["mean"],
                            "t_p": best["vs_next_t_p"],
                            "detectable_difference_80": best["detectable_difference_80"],
                            "significant": None
                            if second is None
                            else bool(best["significant_vs_next"]),
                        }
                    )
                records.append(record)
    return pd.DataFrame(records)


def packages_line(rows: pd.DataFrame) -> str:
    """``butterworth (diffbench 0.1.0), pynumdiff.spectraldiff (pynumdiff 0.3), ...``: each
    method in the rows with the package and version stored with its cells."""
    if "package" not in rows:
        rows = rows.assign(package="unknown")
    pairs = rows[["method", "package"]].drop_duplicates().sort_values(["method", "package"])
    return ", ".join(f"{m} ({p})" for m, p in zip(pairs["method"], pairs["package"], strict=True))


def write_winners(rows: pd.DataFrame, directory: Path) -> list[Path]:
    """``winners_velocity`` and ``winners_acceleration`` (Markdown grid + full CSV)."""
    written = []
    for order in (1, 2):
        table = winners(rows, order)
        if "winner" not in table:
            continue
        stem = f"winners_{'velocity' if order == 1 else 'acceleration'}"
        shown = []
        for (kind, level), group in table.groupby(["noise", "level"], sort=False):
            line = {"noise": kind, "level": f"{level:g}"}
            for step in GRID_STEPS_S:
                row = group[abs(group["step_ms"] - step * 1e3) < 1e-9].iloc[0]
                column = f"Ts = {step * 1e3:g} ms"
                if row["noiseless"]:
                    line[column] = "no noise (200 Hz aliases to 0 Hz)"
                elif pd.isna(row.get("winner")):
                    line[column] = "—"
                else:
                    star = "*" if row["significant"] else ""
                    note = " †" if row["vanishing"] else ""
                    line[column] = (
                        f"{row['winner']}{star} ({row['rmse']:.3g}; next "
                        f"{row['runner_up']} {row['runner_up_rmse']:.3g}){note}"
                    )
            shown.append(line)
        title = (
            f"Winner per grid task for {ORDER_SYMBOLS[order]} (interior RMSE; each method "
            f"tuned by the oracle on seed {TUNING_SEED}, scored on the others)"
        )
        legend = (
            "`*`: better than the runner-up by the paired t-test (p < 0.05; the CSV gives p and "
            "the smallest difference the test detects 80 % of the time). `†`: the 200 Hz "
            "component of the noise aliases to 0 Hz at this step (its samples are all zero), "
            "only the other components remain. The signal: sin 2π4t + sin 2π9t + sin 2π15t "
            "over 0.93 s (not a whole number of periods).\n\nMethods and the packages that "
            "computed them: " + packages_line(rows) + "."
        )
        written += tables.write_report(directory, stem, table, pd.DataFrame(shown), title, legend)
    return written
