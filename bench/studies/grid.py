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
from diffbench.bench.core import tuning
from diffbench.bench.core.plan import Cell, TuningJob, tuned_entries
from diffbench.bench.core.roles import ORDER_SYMBOLS
from diffbench.bench.core.stats import ranking
from diffbench.bench.report import tables
from diffbench.signals.scenarios import (
    GRID_NOISE_LEVELS,
    GRID_NOISE_TYPES,
    GRID_SAMPLING_LEVEL,
    GRID_SAMPLING_STEPS_S,
    GRID_SAMPLINGS,
    GRID_STEPS_S,
    grid_sampling_name,
    grid_scenario_name,
    grid_scenario_names,
    vanishing_disturbances,
)

BUDGET = 150  # evaluations per tuning: the grid tunes 36 x 7 x 2 times


def task_names() -> list[str]:
    return grid_scenario_names()


def _grid_tasks() -> list[tuple[str, float, float, str | None]]:
    """(noise label, level, step, scenario name or None where the grid has none) per row and
    column of the winners tables: the noise kinds, then the irregular samplings (Gaussian
    noise; only at the steps they are run at)."""
    rows = [
        (kind, level, step, grid_scenario_name(kind, level, step))
        for kind in GRID_NOISE_TYPES
        for level in GRID_NOISE_LEVELS
        for step in GRID_STEPS_S
    ]
    for sampling, model in GRID_SAMPLINGS.items():
        label = f"gaussian, {model.describe()}"
        rows += [
            (
                label,
                GRID_SAMPLING_LEVEL,
                step,
                grid_sampling_name(sampling, step) if step in GRID_SAMPLING_STEPS_S else None,
            )
            for step in GRID_STEPS_S
        ]
    return rows


def tuning_jobs(
    orders: Sequence[int] = (1, 2), names: Sequence[str] | None = None
) -> list[TuningJob]:
    """Each method of ``names`` (default: every registered offline one), for each order, on
    each grid task (oracle, seed :data:`~diffbench.bench.core.tuning.TUNING_SEED`); causal
    methods only on the uniformly sampled tasks."""
    return [
        TuningJob(task, name, "oracle", int(order), tuning.TUNING_SEED, None, BUDGET)
        for task in task_names()
        for name in (names or methods.available())
        for order in orders
        if not (methods.method_class(name).causal and signals.get_scenario(task).sampling)
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


def scored_rmse(rows: pd.DataFrame, order: int, region: str) -> pd.DataFrame:
    """The RMSE rows of the derivative of ``order`` on ``region`` of the entries tuned for it:
    what :func:`winners`, :func:`regrets` and :func:`causal_price` compare. On ``"whole"``
    (every sample, as estimated, trusted or not) only the entries estimating every sample
    (``WHOLE_COVERAGE["whole"]``, :mod:`diffbench.bench.report.tables`) on every seed."""
    if region == "whole":
        rows = tables.covering_whole(rows, order, keys=("method", "params"), region="whole")
    tuned_for = (rows["tuned_order"] == order).fillna(False).astype(bool)
    return rows[
        tuned_for
        & (rows["metric"] == "rmse")
        & (rows["order"] == order)
        & (rows["region"] == region)
    ]


def noiseless(scenario) -> bool:
    """Whether every disturbance of ``scenario``'s noise aliases away at its step (200 Hz
    sampled every 10 ms): nothing to rank there."""
    return len(vanishing_disturbances(scenario)) == len(scenario.noise.models)


def winners(rows: pd.DataFrame, order: int = 2, region: str = "interior") -> pd.DataFrame:
    """Per grid task: the entry with the least mean RMSE of the derivative of ``order`` on
    ``region`` (among those tuned for it), the runner-up, the paired t-test between them and the
    smallest difference it detects 80 % of the time; ``vanishing`` names a disturbance that
    aliases away at the step (no winner is named when nothing is left of the noise).

    ``region`` is ``"interior"`` (the samples every method is scored on) or ``"whole"`` (every
    sample of the record as the entry estimates it, trusted or not; entries that leave a
    sample unestimated on some seed left out). The whole record was once ranked on each
    entry's own valid samples among the entries marking 99 % of them valid: a method that
    marks its weaker end samples honestly (``spectral``'s taper) was then left out, and one
    that marks nothing (a peer's) ranked on its worst samples as if trusted.
    """
    if region not in ("interior", "whole"):
        raise ValueError(f"`region` must be 'interior' or 'whole', got {region!r}")
    scored = scored_rmse(rows, order, region)
    records = []
    for kind, level, step, name in _grid_tasks():
        record = {
            "region": region,
            "noise": kind,
            "level": level,
            "step_ms": step * 1e3,
            "task": name,
            "vanishing": "",
            "noiseless": False,
        }
        if name is None:
            records.append(record)
            continue
        scenario = signals.get_scenario(name)
        vanishing = vanishing_disturbances(scenario)
        record["vanishing"] = "; ".join(vanishing)
        record["noiseless"] = noiseless(scenario)
        mine = scored[scored["task"] == name]
        if not mine.empty:
            # the winner's test against the runner-up is all a grid cell shows
            table = ranking(mine, "rmse", order, region, keys=("method", "params"), compared=1)
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
                    "significant": None if second is None else bool(best["significant_vs_next"]),
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


REGION_COLUMNS = {"interior": "interior", "whole": "whole"}


def _winner_text(row) -> str:
    if row["noiseless"]:
        return "no noise (200 Hz aliases to 0 Hz)"
    if pd.isna(row.get("winner")):
        return "—"
    star = "*" if row["significant"] else ""
    note = " †" if row["vanishing"] else ""
    irregular = bool(row["task"]) and bool(signals.get_scenario(row["task"]).sampling)
    winner = _with_handling(row["winner"], irregular)
    if pd.isna(row["runner_up"]):
        return f"{winner} ({row['rmse']:.3g}; the only one ranked){note}"
    return (
        f"{winner}{star} ({row['rmse']:.3g}; next "
        f"{_with_handling(row['runner_up'], irregular)} {row['runner_up_rmse']:.3g}){note}"
    )


def _with_handling(name: str, irregular: bool) -> str:
    """``name``, marked ``(resampled)`` on irregular samples when the method has no handling
    of time stamps of its own (a method no longer registered is left unmarked)."""
    if not irregular or name not in methods.available():
        return name
    return f"{name} (resampled)" if methods.method_class(name).time_stamps != "native" else name


def causal_price(rows: pd.DataFrame, order: int) -> pd.DataFrame:
    """Per uniformly sampled grid task, on the interior: the best causal entry (least mean
    RMSE of the derivative of ``order`` over the seeds, among the entries tuned for it), the
    best offline one, and ``ratio`` = causal / offline: what estimating online costs. Empty
    when no causal method was run."""
    scored = scored_rmse(rows, order, "interior")
    means = scored.groupby(["task", "method", "params"], sort=True)["value"].mean().reset_index()
    causal = set(methods.available(causal=True))
    means["causal"] = means["method"].isin(causal)
    records = []
    for kind, level, step, name in _grid_tasks():
        mine = means[means["task"] == name]
        online, offline = mine[mine["causal"]], mine[~mine["causal"]]
        if name is None or online.empty or offline.empty:
            continue
        best_online = online.loc[online["value"].idxmin()]
        best_offline = offline.loc[offline["value"].idxmin()]
        records.append(
            {
                "noise": kind,
                "level": level,
                "step_ms": step * 1e3,
                "task": name,
                "causal": best_online["method"],
                "causal_rmse": best_online["value"],
                "offline": best_offline["method"],
                "offline_rmse": best_offline["value"],
                "ratio": best_online["value"] / best_offline["value"],
            }
        )
    return pd.DataFrame(records)


def regrets(rows: pd.DataFrame, order: int, region: str) -> pd.DataFrame:
    r"""Per grid task with noise left and per method: its mean RMSE of the derivative of
    ``order`` on ``region`` (its best setting among those tuned for ``order``, mean over the
    scored seeds) over the least of any method's,

    .. math:: \rho_{m,k} = \frac{\min_\theta \overline{\mathrm{RMSE}}_k(m, \theta)}
        {\min_{m'} \min_\theta \overline{\mathrm{RMSE}}_k(m', \theta)} \ge 1

    (1 for the task's winner): how much worse than the best a method is on task k.

    Parameters
    ----------
    rows : pandas.DataFrame
        The grid's scored rows (the store's cells frame).
    order : int
        The derivative order (1 or 2).
    region : {"interior", "whole"}
        As in :func:`winners`.

    Returns
    -------
    pandas.DataFrame
        One row per task and method: ``noise``, ``level``, ``step_ms``, ``task``, ``method``,
        ``rmse`` (its best setting's mean) and ``ratio``.
    """
    scored = scored_rmse(rows, order, region)
    records = []
    for kind, level, step, name in _grid_tasks():
        if name is None or noiseless(signals.get_scenario(name)):
            continue  # not run at this step, or no noise left: nothing to choose between
        mine = scored[scored["task"] == name]
        if mine.empty:
            continue
        means = mine.groupby(["method", "params"])["value"].mean().groupby("method").min()
        for method, mean in means.items():
            record = {"noise": kind, "level": level, "step_ms": step * 1e3, "task": name}
            records.append({**record, "method": method, "rmse": mean, "ratio": mean / means.min()})
    return pd.DataFrame(records)


def which_method(rows: pd.DataFrame) -> pd.DataFrame:
    r"""Per noise kind of the grid, derivative order and region: the method whose worst
    :func:`regrets` ratio over that kind's tasks (every level and step) is least, among the
    methods scored on all of them, with its median ratio and its wins, and the runner-up by
    the same rule: the one choice that is never far from the best on such records,

    .. math:: m^* = \arg\min_m \max_k \rho_{m,k}

    over the kind's tasks k (:func:`regrets`), ties broken by the median ratio.

    Parameters
    ----------
    rows : pandas.DataFrame
        The grid's scored rows.

    Returns
    -------
    pandas.DataFrame
        One row per noise kind, order and region: ``method``, ``worst_ratio``,
        ``median_ratio``, ``wins``, ``runner_up``, ``runner_up_worst_ratio``, the number of
        ``tasks`` and of ``methods`` compared, and whether the kind's samples are
        ``irregular``.
    """
    records = []
    for order in (1, 2):
        for region, label in REGION_COLUMNS.items():
            table = regrets(rows, order, region)
            if table.empty:
                continue
            for kind, group in table.groupby("noise", sort=False):
                tasks = group["task"].nunique()
                per_method = group.groupby("method")["ratio"].agg(["max", "median", "count"])
                per_method["wins"] = group[group["ratio"] == 1.0].groupby("method").size()
                everywhere = per_method[per_method["count"] == tasks].fillna({"wins": 0})
                ranked = everywhere.sort_values(["max", "median"])
                if ranked.empty:
                    continue
                best = ranked.iloc[0]
                second = ranked.iloc[1] if len(ranked) > 1 else None
                irregular = bool(signals.get_scenario(group["task"].iloc[0]).sampling)
                records.append(
                    {
                        "noise": kind,
                        "irregular": irregular,
                        "order": order,
                        "region": label,
                        "tasks": tasks,
                        "methods": len(everywhere),
                        "method": ranked.index[0],
                        "worst_ratio": best["max"],
                        "median_ratio": best["median"],
                        "wins": int(best["wins"]),
                        "runner_up": None if second is None else ranked.index[1],
                        "runner_up_worst_ratio": None if second is None else second["max"],
                    }
                )
    return pd.DataFrame(records)


WHICH_METHOD_STEM = "which_method"
"""The report of :func:`which_method` (the README's "which differentiator" table)."""


def write_which_method(rows: pd.DataFrame, directory: Path) -> list[Path]:
    """``which_method`` (Markdown + CSV): :func:`which_method`, one row per noise kind, one
    column per derivative order and region."""
    table = which_method(rows)
    if table.empty:
        return []
    shown = []
    for kind, group in table.groupby("noise", sort=False):
        line = {"noise (levels × steps)": f"{kind} ({group['tasks'].iloc[0]})"}
        for order in (1, 2):
            for label in REGION_COLUMNS.values():
                match = group[(group["order"] == order) & (group["region"] == label)]
                column = f"{ORDER_SYMBOLS[order]}, {label}"
                if match.empty:
                    line[column] = "—"
                    continue
                row = match.iloc[0]
                line[column] = (
                    f"{_with_handling(row['method'], row['irregular'])} ≤ "
                    f"{row['worst_ratio']:.2f}× (median {row['median_ratio']:.2f}×)"
                )
        shown.append(line)
    return tables.write_report(
        directory,
        WHICH_METHOD_STEM,
        table,
        pd.DataFrame(shown),
        "Which differentiator on such records: per noise kind of the grid, the method whose "
        "RMSE is nearest the best method's on every level and step (each method oracle-tuned "
        f"on seed {tuning.TUNING_SEED}, scored on the others)",
        "Each cell: the method, then its RMSE over the best method's on that record, at worst "
        "and at the median over the kind's records (1.00×: it is the best everywhere). Among "
        "the methods scored on all of them; **whole**: every sample of the record as the "
        "method estimates it, trusted or not, among the settings that estimate all of them on "
        "every seed. The runner-up, "
        "the wins and the number of methods compared are in the CSV; each record's winner in "
        "`winners_velocity` and `winners_acceleration`; `(resampled)` as there.",
    )


def write_causal_price(rows: pd.DataFrame, directory: Path) -> list[Path]:
    """``causal_price`` (Markdown grid + CSV): per noise, level and step, the best causal
    method against the best offline one, for ẋ and ẍ (nothing when no causal method ran)."""
    frames = [causal_price(rows, order).assign(order=ORDER_SYMBOLS[order]) for order in (1, 2)]
    frames = [frame for frame in frames if not frame.empty]
    if not frames:
        return []
    table = pd.concat(frames, ignore_index=True)
    shown = []
    for (symbol, kind, level), group in table.groupby(["order", "noise", "level"], sort=False):
        line = {"n": symbol, "noise": kind, "level": f"{level:g}"}
        for step in GRID_STEPS_S:
            match = group[abs(group["step_ms"] - step * 1e3) < 1e-9]
            line[f"Ts = {step * 1e3:g} ms"] = (
                "—"
                if match.empty
                else (
                    f"{match.iloc[0]['causal']} {match.iloc[0]['causal_rmse']:.3g} = "
                    f"{match.iloc[0]['ratio']:.3g}× {match.iloc[0]['offline']}"
                )
            )
        shown.append(line)
    return tables.write_report(
        directory,
        "causal_price",
        table,
        pd.DataFrame(shown),
        "What estimating online costs: per grid task, the best causal method's interior RMSE "
        "against the best offline method's (each tuned by the oracle on seed "
        f"{tuning.TUNING_SEED}, scored on the others)",
        "Each cell: the best causal method and its RMSE, then its ratio to the best offline "
        "method (named last). Causal methods use the samples up to t only; the uniformly "
        "sampled tasks only (they take no irregular time stamps).",
    )


def errors(rows: pd.DataFrame) -> pd.DataFrame:
    """Every method's error on every grid task with noise left: :func:`regrets` for ẋ and ẍ,
    on the interior and on the whole record (``region`` named as the reports name it), one
    frame with an ``order`` column: what the explorer plots against the noise level and the
    step, per method."""
    parts = [
        regrets(rows, order, region).assign(order=order, region=label)
        for order in (1, 2)
        for region, label in REGION_COLUMNS.items()
    ]
    parts = [part for part in parts if not part.empty]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()


def write_errors(rows: pd.DataFrame, directory: Path) -> list[Path]:
    """``errors.csv`` (:func:`errors`, full precision), read by the results explorer
    (:mod:`diffbench.bench.report.explorer`); no Markdown twin: a table of every method on
    every task is for a program or the explorer's filters, not for reading."""
    table = errors(rows)
    return [] if table.empty else [tables.write_csv(directory / "errors.csv", table)]


def write_winners(rows: pd.DataFrame, directory: Path) -> list[Path]:
    """``winners_velocity`` and ``winners_acceleration`` (Markdown grid + full CSV): per task
    and step, the winner on the interior and on the whole record side by side; and
    ``causal_price`` when causal methods ran (:func:`write_causal_price`)."""
    written = []
    for order in (1, 2):
        table = pd.concat([winners(rows, order, region) for region in REGION_COLUMNS])
        if "winner" not in table:
            continue
        stem = f"winners_{'velocity' if order == 1 else 'acceleration'}"
        shown = []
        for (kind, level), group in table.groupby(["noise", "level"], sort=False):
            line = {"noise": kind, "level": f"{level:g}"}
            for step in GRID_STEPS_S:
                for region, label in REGION_COLUMNS.items():
                    row = group[
                        (abs(group["step_ms"] - step * 1e3) < 1e-9) & (group["region"] == region)
                    ].iloc[0]
                    line[f"Ts = {step * 1e3:g} ms, {label}"] = _winner_text(row)
            shown.append(line)
        title = (
            f"Winner per grid task for {ORDER_SYMBOLS[order]} (RMSE on the interior and on the "
            f"whole record; each method tuned by the oracle on the interior on seed "
            f"{tuning.TUNING_SEED}, scored on the others)"
        )
        legend = (
            "`*`: better than the runner-up by the paired t-test (p < 0.05; the CSV gives p and "
            "the smallest difference the test detects 80 % of the time). `†`: the 200 Hz "
            "component of the noise aliases to 0 Hz at this step (its samples are all zero), "
            "only the other components remain. The jitter and dropout rows: the time stamps "
            "moved by up to ±30 % of the step, or 10 % of the samples lost, scored at the "
            "measured times (`(resampled)`: a method without its own handling of time stamps, "
            "run on the record resampled to the nominal grid and back; `diffbench list`); `—`: "
            "not run at that step. **whole**: the RMSE over every sample as the setting "
            "estimates it, trusted or not, among the settings that estimate every sample on "
            "every seed. The signal: sin 2π4t + "
            "sin 2π9t + sin 2π15t over 0.93 s (not a whole number of periods).\n\nMethods and "
            "the packages that computed them: " + packages_line(rows) + "."
        )
        written += tables.write_report(directory, stem, table, pd.DataFrame(shown), title, legend)
    return (
        written
        + write_which_method(rows, directory)
        + write_causal_price(rows, directory)
        + write_errors(rows, directory)
    )
