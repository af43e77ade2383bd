"""Studies: tasks made of other tasks. A study tunes every method it holds on each of its
parts (the tunings stored and reused), scores the tuned settings there (cells stored under the
part's name, computed by the part) and writes one report over all its parts' cells. It runs
through the same runner, store and executor as any task (``diffbench run grid``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

from diffbench import methods
from diffbench.bench.core.plan import Cell
from diffbench.bench.studies import grid, limit
from diffbench.bench.tasks.base import Task


@dataclass(frozen=True, eq=False)
class Study(Task):
    """Base of the studies: no lineup and no score of its own, only its parts'."""

    kind: ClassVar[str] = "study"

    def lineup(self, method_names=None):
        raise ValueError(
            f"{self.name} is a study: its settings are tuned on each of its parts first "
            f"(`diffbench run {self.name}`), it has no lineup of presets"
        )

    def score(self, method, seed):
        raise ValueError(f"{self.name} is a study: its cells are scored by its parts")

    def plan(self, found: dict, method_names, seeds: range) -> list[Cell]:
        """Each tuned setting of ``found`` on the part it was tuned on, over ``seeds``."""
        return grid.cells(found, seeds)


@dataclass(frozen=True, eq=False)
class GridStudy(Study):
    """Where each method wins: every method oracle-tuned for ẋ and for ẍ on each task of the
    scenario grid (noise kinds x levels x steps, and the irregular samplings), scored there;
    the report names the winner of each (:mod:`~diffbench.bench.studies.grid`)."""

    name: str = "grid"
    description: str = (
        "every method oracle-tuned for ẋ and ẍ on each scenario of the grid (noise kind x "
        "level x step, irregular samplings), scored there: the winner per scenario"
    )

    def parts(self) -> list[str]:
        return grid.task_names()

    def tuning_jobs(self, method_names: Sequence[str] | None, orders: Sequence[int]) -> list:
        return grid.tuning_jobs(orders, method_names or None)

    def report(self, cells, tunings, directory):
        return grid.write_winners(cells, directory)


@dataclass(frozen=True, eq=False)
class LimitStudy(Study):
    """How close to the optimum: every method tuned (oracle and data-only) on each random
    signal with a known spectrum, its efficiency against the least possible error
    (:mod:`~diffbench.bench.studies.limit`). ``scenarios``: a subset of the limit scenarios
    (default every one)."""

    scenarios: tuple[str, ...] = ()
    name: str = "limit"
    description: str = (
        "every method tuned (oracle and data-only) on random signals with known spectra: "
        "its efficiency against the least possible error"
    )

    def __post_init__(self) -> None:
        unknown = sorted(set(self.scenarios) - set(limit.task_names()))
        if unknown:
            raise ValueError(
                f"`scenarios`: not limit scenarios: {', '.join(unknown)}; "
                f"choose among {', '.join(limit.task_names())}"
            )

    def parts(self) -> list[str]:
        return list(self.scenarios) or limit.task_names()

    def tuning_jobs(self, method_names: Sequence[str] | None, orders: Sequence[int]) -> list:
        return limit.tuning_jobs(method_names or methods.available(), orders, self.parts())

    def report(self, cells, tunings, directory):
        return limit.write_study(cells, directory)


def builtin_tasks() -> list:
    """The grid study and the limit study on every limit scenario."""
    return [GridStudy(), LimitStudy()]
