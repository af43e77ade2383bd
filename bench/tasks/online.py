"""Online tasks: causal methods on the paper signal (delay, error) and in the 2R robot's loop."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pandas as pd

from diffbench import methods, signals
from diffbench.bench.core.plan import Entry
from diffbench.bench.core.roles import ORDER_SYMBOLS, Role
from diffbench.bench.report import tables
from diffbench.bench.report.figures import write_online_figure
from diffbench.bench.studies import loop, online
from diffbench.bench.studies.loop import LoopSpec, loop_scores
from diffbench.bench.studies.online import online_scores, pareto_front, sweep_settings
from diffbench.bench.tasks.base import ScenarioTask, Task


def sweep_lineup(task: str, method_names=None) -> list[Entry]:
    """The online tasks' entries: each causal method of ``method_names`` (default: all) at
    every setting of its sweep (:func:`diffbench.bench.studies.online.sweep_settings`); an offline
    method is refused by name."""
    names = list(method_names) if method_names else methods.available(causal=True)
    entries = []
    for name in names:
        if not methods.method_class(name).causal:
            raise ValueError(
                f"{task} runs causal methods only; {name} is not causal (see `diffbench list`)"
            )
        for label, params in sweep_settings(name):
            full = methods.get(name, **params).params()
            entries.append(
                Entry(
                    name,
                    full,
                    Role(origin="variant", preset="default", by="defaults", variant=label),
                )
            )
    return entries


@dataclass(frozen=True, eq=False)
class OnlineTask(ScenarioTask):
    """The online track on a signal scenario: each causal method at the settings of its sweep
    (:func:`diffbench.bench.studies.online.sweep_settings`), scored by the error of its estimate at
    the time it is made, its delay, the error once that delay is compensated and its noise
    gain (:func:`diffbench.bench.studies.online.online_scores`); the report draws each method's
    error against its delay."""

    scenario: signals.Scenario
    listed: bool = True
    kind: ClassVar[str] = "online"
    default_seeds: ClassVar[int] = 5

    @property
    def name(self) -> str:
        return f"online-{self.scenario.name}"

    @property
    def folder(self) -> str:
        """``online``: the online track's reports live together."""
        return "online"

    @property
    def description(self) -> str:
        return (
            f"The online track on `{self.scenario.name}`: the causal methods at sweeps of "
            "their settings, scored on delay and on the error at the time of the "
            "estimate."
        )

    def lineup(self, method_names=None):
        return sweep_lineup(self.name, method_names)

    def score(self, method, seed):
        return online_scores(method, self.scenario.realise(seed))

    def longest_record(self):
        realisation = self.scenario.realise(0)
        return realisation.x.shape[0], realisation.dt_s

    def report(self, cells, tunings, directory):
        return online_report(self.name, self.description, cells, directory)


@dataclass(frozen=True, eq=False)
class LoopTask(Task):
    """In the loop: the simulated 2R robot's PD controller at 1 kHz fed the velocity each
    causal method estimates online from the encoder, at the settings of its sweep, against the
    exact-velocity controller (:mod:`~diffbench.bench.studies.loop`); a setting that loses the
    loop is reported as unstable."""

    listed: bool = True
    kind: ClassVar[str] = "online (in the loop)"
    default_seeds: ClassVar[int] = 3
    name: str = "online-2r-loop"
    loop: object = None

    @property
    def spec(self):
        """The experiment (:class:`~diffbench.bench.studies.loop.LoopSpec`; its defaults unless
        ``loop`` gives one)."""
        return LoopSpec() if self.loop is None else self.loop

    @property
    def folder(self) -> str:
        return "online"

    @property
    def description(self) -> str:
        return (
            f"In the loop: {self.spec.name}; each causal method estimates q̇ online for "
            "the velocity term, against the same controller fed the exact q̇."
        )

    def lineup(self, method_names=None):
        return sweep_lineup(self.name, method_names)

    def score(self, method, seed):
        return loop_scores(self.spec, method, seed)

    def report(self, cells, tunings, directory):
        return loop_report(self.name, self.description, cells, directory)


# --- the report ------------------------------------------------------------------------------


ONLINE_COLUMNS = (
    ("delay (ms)", "delay_s", 1e3),
    ("phase delay (ms)", "phase_delay_s", 1e3),
    ("RMSE at the time", "rmse", 1.0),
    ("RMSE delay-compensated", "aligned_rmse", 1.0),
    ("noise gain", "noise_gain", 1.0),
    ("interior estimated", "coverage", 1.0),
)


ONLINE_LEGEND = (
    "**RMSE at the time**: the online estimate at t_k against x⁽ⁿ⁾(t_k) on the interior; "
    "**delay**: the shift of the truth that best matches the estimate (whole steps within "
    f"±{online.MAX_SHIFT_S:g} s, refined by a parabola); **RMSE delay-compensated**: the error "
    f"at that shift; **phase delay** (linear methods): the lag at "
    f"{online.PHASE_FREQUENCY_FRACTION * 100:g} % of Nyquist, from the frequency "
    "response; **noise gain**: RMS of (method on the noisy record − method on the clean "
    "one) / RMS of the noise. A **front** point is one that no other setting of the same "
    "method beats in both delay and delay-compensated RMSE. Means over the seeds."
)


def online_table(cells: pd.DataFrame) -> pd.DataFrame:
    """One row per entry and derivative order (1, 2): the means over seeds of the online
    scores, and ``front`` (on its method's Pareto front of |delay| and compensated RMSE)."""

    summary = tables.summarise(cells)
    labelled = tables.label_entries(tables.entries(cells))
    records = []
    for order in (1, 2):
        mine = summary[summary["order"] == order].set_index([*tables.ENTRY_KEYS, "metric"])
        for _, entry in labelled.iterrows():
            key = (entry["method"], entry["params"], entry["role"])
            record = {
                "method": entry["method"],
                "setting": entry["setting"].removeprefix("variant: "),
                "order": ORDER_SYMBOLS[order],
            }
            for label, metric, scale in ONLINE_COLUMNS:
                row = (*key, metric)
                record[label] = (
                    float(mine.loc[row, "mean"]) * scale if row in mine.index else (float("nan"))
                )
            record["seeds"] = (
                int(mine.loc[(*key, "rmse"), "seeds"]) if (*key, "rmse") in (mine.index) else 0
            )
            records.append(record)
    table = pd.DataFrame(records)
    table["front"] = False
    for _, group in table.groupby(["method", "order"]):
        scored = group.dropna(subset=["delay (ms)", "RMSE delay-compensated"])
        front = pareto_front(scored["delay (ms)"], scored["RMSE delay-compensated"])
        table.loc[scored.index[front], "front"] = True
    return table


def _shown(table: pd.DataFrame, keys: list[str], columns) -> pd.DataFrame:
    """``keys`` as they are, then each of ``columns`` (its label first) to 3 significant
    digits, ``—`` where there is no number."""
    shown = table[keys].copy()
    for label, *_ in columns:
        shown[label] = [f"{v:.3g}" if np.isfinite(v) else "—" for v in table[label]]
    return shown


def _online_shown(table: pd.DataFrame) -> pd.DataFrame:
    return _shown(table, ["method", "setting", "order"], ONLINE_COLUMNS)


def online_report(task: str, description: str, cells: pd.DataFrame, directory: Path) -> list[Path]:
    """``sweep`` (every setting), ``front`` (each method's Pareto front), ``best`` (each
    method's least RMSE at the time) and the error-against-delay figure of an online task."""

    table = online_table(cells)
    seeds = tables.seeds_phrase(cells)
    written = tables.write_report(
        directory,
        "sweep",
        table,
        _online_shown(table),
        f"`{task}`: every setting of each causal method (means over {seeds})",
        f"{description}\n\n{ONLINE_LEGEND}",
    )
    front = table[table["front"]].sort_values(["order", "method", "delay (ms)"])
    written += tables.write_report(
        directory,
        "front",
        front,
        _online_shown(front),
        f"`{task}`: the error-against-delay front of each causal method (means over {seeds})",
        ONLINE_LEGEND,
    )
    scored = table.dropna(subset=["RMSE at the time"])
    best = scored.loc[scored.groupby(["order", "method"])["RMSE at the time"].idxmin()]
    best = best.sort_values(["order", "RMSE at the time"])
    written += tables.write_report(
        directory,
        "best",
        best,
        _online_shown(best),
        f"`{task}`: each causal method at its setting of least error at the time of the "
        f"estimate (means over {seeds})",
        "The online choice: a controller acts on the estimate when it is made, so its error "
        f"then is what counts. {ONLINE_LEGEND}",
    )
    written.append(
        write_online_figure(
            table, directory / "error_vs_delay.png", f"`{task}`: error against delay ({seeds})"
        )
    )
    return written


LOOP_COLUMNS = (
    ("q₁ tracking RMSE (rad)", "tracking_rmse", 1),
    ("q₂ tracking RMSE (rad)", "tracking_rmse", 2),
    ("q₁ tracking / exact", "tracking_ratio", 1),
    ("q₂ tracking / exact", "tracking_ratio", 2),
    ("τ₁ noise (N·m)", "torque_noise_rms", 1),
    ("τ₂ noise (N·m)", "torque_noise_rms", 2),
)


LOOP_TRACKING_MARGIN = 0.1
"""A loop's best setting tracks within this fraction of the exact controller on both joints."""


LOOP_LEGEND = (
    f"**tracking RMSE**: q − q_d after the first {loop.LoopSpec.settle_s:g} s; **/ exact**: "
    "over the same controller fed the exact q̇ (same encoder readings); **τ noise**: RMS of "
    "the torque less that controller's. **loop**: stable on every seed, or lost (tracking "
    f"error past {loop.LoopSpec.lost_rad:g} rad) on k of n seeds at the times given; the scores "
    "of a lost loop are left out. **best**: per method, the setting stable on every seed "
    f"whose tracking is within {LOOP_TRACKING_MARGIN * 100:g} % of the exact controller's on both "
    "joints, of least τ₁ noise."
)


def loop_table(cells: pd.DataFrame) -> pd.DataFrame:
    """One row per entry: stability over the seeds and the means of the loop scores."""
    summary = tables.summarise(cells).set_index([*tables.ENTRY_KEYS, "metric", "order"])
    labelled = tables.label_entries(tables.entries(cells))
    records = []
    for _, entry in labelled.iterrows():
        key = (entry["method"], entry["params"], entry["role"])
        mine = cells[
            (cells["method"] == key[0]) & (cells["params"] == key[1]) & (cells["role"] == key[2])
        ]
        stable = mine[(mine["metric"] == "stable") & (mine["order"] == 1)]
        lost = mine[(mine["metric"] == "lost_at_s") & (mine["order"] == 1)]["value"].dropna()
        record = {
            "method": entry["method"],
            "setting": entry["setting"].removeprefix("variant: "),
            "seeds": len(stable),
        }
        if lost.empty:
            record["loop"] = "stable"
        else:
            times = ", ".join(f"{v:.2f}" for v in sorted(lost))
            record["loop"] = f"lost on {len(lost)} of {len(stable)} seeds (at {times} s)"
        for label, metric, joint in LOOP_COLUMNS:
            row = (*key, metric, joint)
            record[label] = float(summary.loc[row, "mean"]) if row in summary.index else np.nan
        records.append(record)
    return pd.DataFrame(records)


def _loop_shown(table: pd.DataFrame) -> pd.DataFrame:
    return _shown(table, ["method", "setting", "loop"], LOOP_COLUMNS)


def loop_report(task: str, description: str, cells: pd.DataFrame, directory: Path) -> list[Path]:
    """``loop`` (every setting, stable or not) and ``loop_best`` (each method's best stable
    setting, or why it has none) of the in-the-loop task."""
    table = loop_table(cells)
    seeds = tables.seeds_phrase(cells)
    written = tables.write_report(
        directory,
        "loop",
        table,
        _loop_shown(table),
        f"`{task}`: every setting of each causal method in the loop ({seeds})",
        f"{description}\n\n{LOOP_LEGEND}",
    )
    best = []
    for name, group in table.groupby("method", sort=True):
        limit = 1 + LOOP_TRACKING_MARGIN
        usable = group[
            (group["loop"] == "stable")
            & (group["q₁ tracking / exact"] <= limit)
            & (group["q₂ tracking / exact"] <= limit)
        ]
        if len(usable):
            best.append(usable.loc[usable["τ₁ noise (N·m)"].idxmin()])
        else:
            stable = int((group["loop"] == "stable").sum())
            best.append(
                pd.Series(
                    {
                        "method": name,
                        "setting": "—",
                        "seeds": group["seeds"].max(),
                        "loop": f"no usable setting: {stable} of {len(group)} "
                        "settings stable, none tracking within "
                        f"{LOOP_TRACKING_MARGIN * 100:g} %"
                        if stable
                        else f"unstable at all {len(group)} settings",
                    }
                )
            )
    best = pd.DataFrame(best).sort_values("τ₁ noise (N·m)", na_position="last")
    written += tables.write_report(
        directory,
        "loop_best",
        best,
        _loop_shown(best),
        f"`{task}`: each causal method at its best setting in the loop ({seeds})",
        LOOP_LEGEND,
    )
    return written


def builtin_tasks() -> list:
    """The online paper-signal task and the simulated robot's control loop."""
    return [OnlineTask(signals.get_scenario("paper-signal")), LoopTask()]
