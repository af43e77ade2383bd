"""Item studies: tasks whose unit of work is not a (method, seed) cell but an item of their own
(a scenario validated, a method's Pareto front, a method's error profile over seeds, a method's
throughput). Each item is computed by a pure function on any executor (this process, local
workers, Dask), its rows are stored at once as one record of the store's ``studies`` table
(stored whole or not at all), and the report reads every item's rows from the store. So an item
study runs through the same store and executor as any task: ``--jobs`` and Dask give the rows of
a serial run, a killed run resumes where it stopped, a rerun computes nothing.

An item study declares

* ``items(method_names, seeds)``: the :class:`Item` s a run computes;
* ``compute(item)``: the item's rows, a list of dicts of JSON values (pure: no I/O);
* ``write(rows, directory)``: the report from ``{item: rows}``, the files written.

The rows are stored under :attr:`ItemStudy.record_name` with the item's ``name`` and
``setting`` as its key (:func:`diffbench.bench.core.records.study_key`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from diffbench import methods, signals
from diffbench.bench.core import tuning
from diffbench.bench.studies import paper, pareto, ratios, recommend_check, timing
from diffbench.bench.tasks.base import Task


@dataclass(frozen=True)
class Item:
    """One unit of an item study's work: ``name`` (what it scores: a scenario, a method) and
    ``setting`` (JSON: everything else its rows depend on, e.g. the methods compared)."""

    name: str
    setting: Any = None

    def __hash__(self) -> int:
        return hash((self.name, repr(self.setting)))


class ItemStudy(Task):
    """Base of the item studies (see the module docstring)."""

    kind: ClassVar[str] = "study"
    default_seeds: ClassVar[int] = 20

    @property
    def record_name(self) -> str:
        """The study name its rows are stored under (default: its name)."""
        return self.name

    def lineup(self, method_names=None):
        raise ValueError(
            f"{self.name} is a study of its own items (`diffbench run {self.name}`), it has no "
            "lineup of presets"
        )

    def score(self, method, seed):
        raise ValueError(f"{self.name} is a study of its own items: it scores no cell")

    def items(self, method_names: Sequence[str] | None, seeds: range) -> list[Item]:
        raise NotImplementedError

    def compute(self, item: Item) -> list[dict[str, Any]]:
        raise NotImplementedError

    def write(self, rows: dict[Item, list[dict]], directory: Path) -> list[Path]:
        raise NotImplementedError


def _json(value: Any) -> Any:
    """``value`` with numpy scalars as Python numbers (what the store's JSON takes)."""
    if isinstance(value, dict):
        return {str(k): _json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_json(v) for v in value]
    return value.item() if hasattr(value, "item") else value


@dataclass(frozen=True, eq=False)
class RecommendCheck(ItemStudy):
    """The data-only recommendation checked against the truth: on each scenario (an item),
    ``recommend`` without the truth against the oracle's best, per order
    (:func:`diffbench.bench.studies.recommend_check.validate`). ``scenarios``: default
    :func:`~diffbench.bench.studies.recommend_check.validation_scenarios`."""

    scenarios: tuple[str, ...] = ()
    name: str = "recommend-check"
    description: str = (
        "the data-only recommendation against the truth, on every uniformly sampled noisy "
        "scenario: its error over the oracle's best"
    )

    def __post_init__(self) -> None:
        for scenario in self.scenarios:
            signals.get_scenario(scenario)  # ValueError naming the valid ones

    @property
    def record_name(self) -> str:
        return "recommend-validation"

    @property
    def folder(self) -> str:
        return "recommend-validation"

    def items(self, method_names, seeds):
        names = list(method_names or recommend_check.VALIDATION_METHODS)
        return [Item(s, names) for s in self.scenarios or recommend_check.validation_scenarios()]

    def compute(self, item):
        rows = recommend_check.validate(item.name, names=tuple(item.setting))
        return [_json({**row, "methods": ",".join(item.setting)}) for row in rows]

    def write(self, rows, directory):
        names = next(iter(rows)).setting
        flat = [row for found in rows.values() for row in found]
        return recommend_check.write_validation(flat, directory, names)


@dataclass(frozen=True, eq=False)
class ParetoStudy(ItemStudy):
    """The Pareto front of accuracy against smoothness without the truth, per method (an item)
    on each record of ``scenarios`` (default :data:`~diffbench.bench.studies.pareto.SCENARIOS`),
    at the tuning seed (:mod:`diffbench.bench.studies.pareto`)."""

    scenarios: tuple[str, ...] = pareto.SCENARIOS
    name: str = "pareto"
    description: str = (
        "accuracy against smoothness without the truth: each method's settings on the front of "
        "re-integration fit and roughness, the knee against the oracle (limit records)"
    )

    def __post_init__(self) -> None:
        for scenario in self.scenarios:
            signals.get_scenario(scenario)

    @property
    def folder(self) -> str:
        return "limit"

    def items(self, method_names, seeds):
        names = list(method_names or methods.available())
        return [Item(scenario, name) for scenario in self.scenarios for name in names]

    def compute(self, item):
        realisation = signals.get_scenario(item.name).realise(tuning.TUNING_SEED)
        return _json(pareto.front_rows(pareto.pareto_front(item.setting, realisation)))

    def write(self, rows, directory):
        written = []
        for scenario in dict.fromkeys(item.name for item in rows):
            fronts = [
                pareto.front_of_rows(item.setting, found)
                for item, found in rows.items()
                if item.name == scenario
            ]
            written += pareto.write_pareto(fronts, scenario, directory)
        return written


@dataclass(frozen=True, eq=False)
class PaperFigures(ItemStudy):
    """The paper's figures 1-3 and its frequency table (computed in the report: cheap,
    deterministic), and the RMS error against position in the record over the seeds, whose
    items are the methods (:mod:`diffbench.bench.studies.paper`)."""

    name: str = "paper-figures"
    description: str = (
        "the paper's figures 1-3, its frequency table, and each method's RMS error against "
        "position in the record (paper signal)"
    )

    def items(self, method_names, seeds):
        names = list(method_names or methods.available())
        return [Item(name, {"seeds": len(seeds)}) for name in names]

    def compute(self, item):
        sums = paper.squared_error_sums(item.name, item.setting["seeds"])
        return [{"order": order, "squares": _json(values)} for order, values in sums.items()]

    def write(self, rows, directory):
        directory.mkdir(parents=True, exist_ok=True)
        names = [item.name for item in rows]
        seeds = next(iter(rows)).setting["seeds"]
        sums = {
            item.name: {row["order"]: np.array(row["squares"], dtype=float) for row in found}
            for item, found in rows.items()
        }
        written = paper.write_figure1(directory, names=names)
        written += paper.write_figure2(directory, names) + paper.write_figure3(directory)
        written += paper.write_frequency_table(directory, names)
        return written + paper.write_error_profile(
            directory, paper.error_profile_frame(sums, seeds), seeds
        )


RATIOS = "speed-ratios"
"""The item of the timing study that compares speeds with the peers."""


@dataclass(frozen=True, eq=False)
class TimingStudy(ItemStudy):
    """Throughput and peak memory of each method (an item) on records up to ``largest_samples``
    long, and with ``ratios`` the speed comparisons with the peers
    (:mod:`diffbench.bench.studies.timing`, :mod:`diffbench.bench.studies.ratios`). Times
    measured on parallel workers share the machine: run it with one job for the numbers to
    quote."""

    largest_samples: int = 10_000_000
    ratios: bool = True
    name: str = "timing"
    description: str = (
        "samples per second and peak memory of every method up to 1e7 samples (and, with "
        "ratios, the speed against filterpy, scipy and PyNumDiff)"
    )

    def items(self, method_names, seeds):
        sizes = [size for size in timing.SIZES if size < self.largest_samples]
        setting = {"sizes": [*sizes, self.largest_samples]}
        names = list(method_names or methods.available(causal=None))
        return [Item(name, setting) for name in names] + ([Item(RATIOS)] if self.ratios else [])

    def compute(self, item):
        if item.name == RATIOS:
            return _json(ratios.speed_ratios().to_dict("records"))
        table = timing.throughput(sizes=item.setting["sizes"], names=[item.name])
        return _json(table.to_dict("records"))

    def write(self, rows, directory):
        table = [row for item, found in rows.items() if item.name != RATIOS for row in found]
        written = timing.write_throughput(directory, pd.DataFrame(table))
        compared = [row for item, found in rows.items() if item.name == RATIOS for row in found]
        if compared:
            written += ratios.write_ratios(directory, pd.DataFrame(compared))
        return written


def builtin_tasks() -> list:
    """The item studies at their defaults."""
    return [RecommendCheck(), ParetoStudy(), PaperFigures(), TimingStudy()]
