"""What a benchmark computes, as data: cells (a method with its parameters on a task for one
seed), entries (a row of a comparison: cells over seeds) and tuning jobs. Keys come from the
store (:func:`~diffbench.bench.core.store.cell_key`), so a cell is found again wherever it was
stored; nothing here computes or writes anything."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from diffbench import methods
from diffbench.bench.core.roles import Role
from diffbench.bench.core.store import cell_key, computation_key


@dataclass(frozen=True, eq=False)
class Cell:
    """One unit of work: ``method`` with ``params`` (in ``role``) on ``task`` for ``seed``;
    cells are equal when their keys are."""

    task: str
    method: str
    params: Mapping[str, Any]
    seed: int
    role: Role = field(default_factory=lambda: Role(origin="preset"))

    @property
    def key(self) -> str:
        return cell_key(self.task, self.method, self.params, self.seed, self.role.as_dict())

    @property
    def computation(self) -> str:
        """What the cell computes (:func:`bench.store.computation_key`): its key less the
        role's provenance."""
        return computation_key(self.task, self.method, self.params, self.seed, self.role.as_dict())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Cell) and self.key == other.key

    def __hash__(self) -> int:
        return hash(self.key)


@dataclass(frozen=True)
class Entry:
    """A row of a comparison: a method, its parameters and their role (cells over seeds)."""

    method: str
    params: Mapping[str, Any]
    role: Role

    def cells(self, task: str, seeds: Iterable[int]) -> list[Cell]:
        return [Cell(task, self.method, dict(self.params), int(s), self.role) for s in seeds]


def preset_entry(name: str, key: str) -> Entry:
    """Method ``name`` at preset ``key``, or at its class defaults if it has no such preset."""
    if key not in methods.method_class(name).presets:
        key = methods.DEFAULT_PRESET
    spec = methods.preset_spec(name, key)
    params = methods.preset(name, key).params()
    return Entry(name, params, Role.of_preset(key, spec.by))


def unique(items: Iterable) -> list:
    """The items in their first order, each once."""
    return list(dict.fromkeys(items))


# --- tuning, stored and reused ------------------------------------------------------------
@dataclass(frozen=True)
class TuningJob:
    """One tuning: ``method`` on ``task``'s realisations ``tuning_seed`` ..
    ``tuning_seed + tuning_seeds - 1`` (the loss averaged over them) for ``order``, the loss
    taken on ``region`` ("interior" or "whole"); with ``screen``, the combinations of the
    method's choice parameters screened down to that many (the tuner's ``screen_choices``)."""

    task: str
    method: str
    criterion: str
    order: int
    tuning_seed: int
    cutoff_hz: float | None = None
    budget: int | None = None
    tuning_seeds: int = 1
    region: str = "interior"
    screen: int | None = None

    def fields(self) -> dict[str, Any]:
        return {
            "task": self.task,
            "method": self.method,
            "criterion": self.criterion,
            "order": self.order,
            "tuning_seed": self.tuning_seed,
            "cutoff_hz": self.cutoff_hz,
            "budget": self.budget,
            "tuning_seeds": self.tuning_seeds,
            "region": self.region,
            "screen": self.screen,
        }

    @property
    def seeds(self) -> range:
        """The noise seeds tuned on."""
        return range(self.tuning_seed, self.tuning_seed + self.tuning_seeds)

    @property
    def role(self) -> Role:
        return Role.tuned(
            self.criterion,
            self.order,
            self.tuning_seed,
            self.cutoff_hz,
            self.tuning_seeds,
            self.region,
        )


def tuned_entries(found: Mapping[TuningJob, dict], scored: str | None = None) -> list[Entry]:
    """An entry per successful tuning (one that found parameters); a tuning on a task other
    than ``scored`` (the task its cells are scored on) says so in its role (``tuned_on``)."""
    entries = []
    for job, record in found.items():
        if not record["params"]:
            continue
        role = job.role
        if scored is not None and job.task != scored:
            role = dataclasses.replace(role, tuned_on=job.task)
        entries.append(Entry(job.method, record["params"], role))
    return entries
