"""The registry's base: :class:`Task` and :class:`ScenarioTask`, and where tasks are registered."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import ClassVar

import pandas as pd

from diffbench import methods
from diffbench.bench.core.plan import Cell, Entry, preset_entry
from diffbench.bench.core.roles import Role

_TASKS: dict[str, Task] = {}


class Task:
    """Base of every task (see the module docstring)."""

    name: str
    description: str
    preset: str = methods.DEFAULT_PRESET
    default_seeds: ClassVar[int] = 10
    max_seeds: ClassVar[int | None] = None
    kind: ClassVar[str] = "task"
    listed: bool = True

    def lineup(self, method_names: Sequence[str] | None = None) -> list[Entry]:
        """Every method named (default: every registered one) at this task's preset, less
        those whose preset refuses records as long as this task's (see :meth:`refusal`)."""
        names = list(method_names) if method_names else methods.available()
        entries = []
        for name in names:
            entry = preset_entry(name, self.preset)
            why = self.refusal(methods.get(name, **entry.params))
            if why:
                print(f"{name}: not run on {self.name}: {why}", file=sys.stderr)
                continue
            entries.append(entry)
        return entries

    def parts(self) -> list[str]:
        """The tasks whose cells this one's report reads: itself (a study: its parts)."""
        return [self.name]

    def tuning_jobs(self, method_names: Sequence[str] | None, orders: Sequence[int]) -> list:
        """The tunings ``diffbench run`` does before it plans the cells (a study tunes every
        method on each of its parts; a task at its presets tunes nothing)."""
        return []

    def plan(self, found: dict, method_names: Sequence[str] | None, seeds: range) -> list[Cell]:
        """The cells ``diffbench run`` computes, given the tunings ``found`` of
        :meth:`tuning_jobs`: the :meth:`lineup` over ``seeds``."""
        return [
            cell for entry in self.lineup(method_names) for cell in entry.cells(self.name, seeds)
        ]

    @property
    def folder(self) -> str:
        """The folder under the output directory its report is written to (its name)."""
        return self.name

    def longest_record(self) -> tuple[int, float] | None:
        """``(samples, dt_s)`` of the longest record a method is handed (None: unknown)."""
        return None

    def refusal(self, method: methods.Method) -> str | None:
        """Why ``method`` cannot run this task (a record longer than its ``max_samples``, e.g.
        a dense O(N³) peer), or None."""
        record = self.longest_record()
        if record is None:
            return None
        samples, dt = record
        longest = method.max_samples(dt)
        if longest is not None and samples > longest:
            return f"{samples} samples, it accepts at most {longest} ({method.max_samples_reason})"
        return None

    def seeds(self, count: int | None) -> range:
        """The seeds 0..count-1 (``default_seeds`` if None); ValueError past ``max_seeds``."""
        count = self.default_seeds if count is None else count
        if self.max_seeds is not None and count > self.max_seeds:
            raise ValueError(
                f"{self.name} has {self.max_seeds} seeds (fixed); "
                f"--seeds must be at most {self.max_seeds}, got {count}"
            )
        return range(count)

    def score(self, method: methods.Method, seed: int) -> list[dict]:
        raise NotImplementedError

    def score_cell(self, method: methods.Method, seed: int, role: Role) -> list[dict]:
        """The rows of a cell: :meth:`score`, unless the role changes what is computed (a task
        whose variants are procedures, not parameters, overrides this)."""
        return self.score(method, seed)

    def report(self, cells: pd.DataFrame, tunings: pd.DataFrame, directory: Path) -> list[Path]:
        raise NotImplementedError

    def tuning_data(self, seed: int):
        raise ValueError(
            f"task {self.name!r} cannot be tuned (tuning needs a signal task with "
            "its truth, e.g. paper-signal)"
        )


class ScenarioTask(Task):
    """A task on a registered scenario (its ``scenario`` field): named, described and preset
    by it."""

    scenario: object

    @property
    def name(self) -> str:
        return self.scenario.name

    @property
    def description(self) -> str:
        return self.scenario.description

    @property
    def preset(self) -> str:
        return self.scenario.preset


def register_task(task: Task) -> Task:
    """Add ``task`` under its name; ``ValueError`` if the name is taken."""
    if task.name in _TASKS:
        raise ValueError(f"a task named {task.name!r} is already registered")
    _TASKS[task.name] = task
    return task
