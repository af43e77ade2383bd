"""Online tasks: causal methods on the paper signal (delay, error) and in the 2R robot's loop."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from diffbench import methods, signals
from diffbench.bench.core.plan import Entry
from diffbench.bench.core.roles import Role
from diffbench.bench.studies import reports
from diffbench.bench.studies.loop import LoopSpec, loop_scores
from diffbench.bench.studies.online import online_scores, sweep_settings
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
        return reports.online_report(self.name, self.description, cells, directory)


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
        return reports.loop_report(self.name, self.description, cells, directory)
