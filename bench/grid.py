"""Where each method wins: every method tuned (oracle, for ẍ and for ẋ) on each scenario of the
noise-type x noise-level x sampling-step grid, then scored on other seeds."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from diffbench import methods, signals
from diffbench.bench import tuning
from diffbench.bench.runner import Cell
from diffbench.bench.stats import ranking
from diffbench.signals.scenarios import (
    GRID_NOISE_LEVELS,
    GRID_NOISE_TYPES,
    GRID_STEPS_S,
    grid_scenario_name,
)

TUNING_SEED = 10_000


def _tuned(job):
    name, scenario_name, order = job
    realisation = signals.get_scenario(scenario_name).realise(TUNING_SEED)
    try:
        result = tuning.tune(name, realisation, order, "oracle", max_evaluations=150)
    except ValueError:  # the method cannot cover the interior at this step at all
        return job, None
    return job, {**methods.get(name).params(), **result.params}


def grid_cells(seeds, orders=(2,), jobs: int = 1) -> list[Cell]:
    """Tune every method for each order on each grid scenario (tuning seed 10000), and return
    the cells that score the tuned methods on ``seeds``."""
    work = [(name, grid_scenario_name(kind, level, step), order)
            for kind in GRID_NOISE_TYPES for level in GRID_NOISE_LEVELS for step in GRID_STEPS_S
            for name in methods.available() for order in orders]  # fmt: skip
    if jobs > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=jobs) as pool:
            results = list(pool.map(_tuned, work))
    else:
        results = [_tuned(job) for job in work]
    cells = []
    for (name, scenario_name, order), params in results:
        if params is None:
            continue
        label = f"tuned: oracle for {'ẋ' if order == 1 else 'ẍ'} on seed {TUNING_SEED}"
        cells += [Cell(name, params, scenario_name, int(seed), preset=label) for seed in seeds]
    return cells


def winners(rows: pd.DataFrame, order: int = 2) -> pd.DataFrame:
    """Per grid scenario: the method with the least mean interior RMSE of the derivative of
    ``order`` (among those tuned for it), the runner-up, and whether the win is significant
    (paired t and Wilcoxon tests over the seeds, p < 0.05)."""
    label = "ẋ" if order == 1 else "ẍ"
    records = []
    for kind in GRID_NOISE_TYPES:
        for level in GRID_NOISE_LEVELS:
            for step in GRID_STEPS_S:
                name = grid_scenario_name(kind, level, step)
                mine = rows[(rows["scenario"] == name)
                            & rows["preset"].str.contains(f"for {label}")]  # fmt: skip
                if mine.empty:
                    continue
                table = ranking(mine, "rmse", order, "interior")
                best = table.iloc[0]
                second = table.iloc[1] if len(table) > 1 else None
                records.append({
                    "noise": kind, "level": level, "step_ms": step * 1e3,
                    "winner": best["method"], "rmse": best["mean"], "ci95": best["ci95"],
                    "runner_up": None if second is None else second["method"],
                    "runner_up_rmse": None if second is None else second["mean"],
                    "significant": bool(best["significant_vs_next"]) if second is not None
                    else None,
                })  # fmt: skip
    return pd.DataFrame(records)


def write_winners(rows: pd.DataFrame, directory: Path) -> list[Path]:
    written = []
    for order in (1, 2):
        table = winners(rows, order)
        if table.empty:
            continue
        label = "ẋ" if order == 1 else "ẍ"
        csv = directory / f"winners_{'velocity' if order == 1 else 'acceleration'}.csv"
        table.to_csv(csv, index=False)
        lines = [f"# Winner per scenario for {label} (each method tuned by the oracle on seed "
                 f"{TUNING_SEED}, scored on the others; * = significantly better than the "
                 "runner-up, paired tests p < 0.05)", "",
                 "| noise | level | " + " | ".join(f"Ts = {s * 1e3:g} ms" for s in GRID_STEPS_S)
                 + " |", "|---|---|" + "---|" * len(GRID_STEPS_S)]  # fmt: skip
        for (kind, level), group in table.groupby(["noise", "level"], sort=False):
            cells = []
            for step in GRID_STEPS_S:
                hit = group[abs(group["step_ms"] - step * 1e3) < 1e-9]
                if hit.empty:
                    cells.append("—")
                    continue
                row = hit.iloc[0]
                star = "*" if row["significant"] else ""
                cells.append(f"{row['winner']}{star} ({row['rmse']:.3g}; next "
                             f"{row['runner_up']} {row['runner_up_rmse']:.3g})")  # fmt: skip
            lines.append(f"| {kind} | {level:g} | " + " | ".join(cells) + " |")
        markdown = csv.with_suffix(".md")
        markdown.write_text("\n".join([*lines, ""]), encoding="utf-8")
        written += [markdown, csv]
    return written
