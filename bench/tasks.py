"""Tasks: each kind of benchmark is one object that scores a method on one seed and writes its
own report. The runner and the CLI never ask what kind of task they hold.

A task has a ``name``, a ``description``, the ``preset`` key of the method presets it runs by
default, its seeds (``default_seeds``; ``max_seeds`` when the seeds are a fixed set such as the
folds of a cross-validation), and

* ``lineup(method_names)``: the entries (method, parameters, role) ``diffbench run`` computes;
* ``score(method, seed)``: tidy score rows (order, region, metric, value) of one cell;
* ``report(cells, tunings, directory)``: the tables and figures, from stored rows only;
* ``tuning_data(seed)``: the realisation a tuner works on (signal tasks), or a ValueError.

Adding a kind of benchmark is one subclass and one :func:`register_task` call.
"""

from __future__ import annotations

import functools
import hashlib
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pandas as pd

from diffbench import methods, signals
from diffbench.bench import reports
from diffbench.bench.roles import Role
from diffbench.bench.runner import Entry, preset_entry

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


@dataclass(frozen=True, eq=False)
class SignalTask(ScenarioTask):
    """A signal scenario (``diffbench.signals``): each method differentiates the noisy samples
    and is scored against the exact derivatives, on the common interior and on its own valid
    samples; linear methods also get the bias and noise parts of their error."""

    scenario: signals.Scenario
    listed: bool = True
    kind: ClassVar[str] = "signal"

    def score(self, method, seed):
        from diffbench.bench.frequency import decompose_error
        from diffbench.bench.scores import estimate_on, score_estimate

        realisation = self.scenario.realise(seed)
        estimate = estimate_on(method, realisation)
        rows = score_estimate(estimate, realisation.truth, realisation.interior)
        if method.linear:
            for order in (1, 2):
                parts = decompose_error(method, realisation, order)
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
        return reports.signal_report(self.name, self.description, cells, tunings, directory)


@dataclass(frozen=True, eq=False)
class LimitTask(SignalTask):
    """A signal task on a random signal with a known spectrum (the ``limit-*`` scenarios):
    also the efficiency of every entry against the least error any method can reach
    (:mod:`diffbench.bench.limit`)."""

    listed: bool = False

    def score(self, method, seed):
        """Also the interior RMSE of the optimal estimator on the same realisation (metric
        ``optimal_rmse``; the filter's for a causal method): the efficiency is then a paired
        ratio, free of the realisation's own luck
        (:func:`diffbench.bench.limit.efficiency_table`)."""
        from diffbench.bench import limit

        rows = super().score(method, seed)
        return rows + limit.optimal_scores(self.scenario, seed, causal=method.causal)

    def report(self, cells, tunings, directory):
        from diffbench.bench import limit

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
        return reports.influence_report(cells, directory)


@dataclass(frozen=True, eq=False)
class RobotSimTask(ScenarioTask):
    """A simulated 2R identification (``signals.robot2r``): each method's q̇, q̈ feed IDIM-LS;
    scored by parameter error (the truth is known), torque prediction on a fresh trajectory
    and derivative errors."""

    scenario: object
    listed: bool = True
    kind: ClassVar[str] = "robot (simulated)"

    def score(self, method, seed):
        from diffbench.bench.robot import score_identification

        return score_identification(method, self.scenario, seed)

    def longest_record(self):
        realisation = self.scenario.realise(0)
        return realisation.q.shape[0], realisation.dt_s

    def report(self, cells, tunings, directory):
        return reports.robot_sim_report(self.scenario, cells, directory)


@dataclass(frozen=True, eq=False)
class DfkiTask(Task):
    """Real recordings of the DFKI double pendulum: leave-one-run-out identification (a cell's
    seed is the held-out run), scored by the measured torque of the held-out run at its logged
    time stamps; each method at its preset and at the settings nested cross-validation
    chooses (:class:`diffbench.bench.robot.DfkiCrossValidation`). ``robot_model``: the
    records' robot (:class:`diffbench.signals.dfki.PendulumModel`), None for the packaged
    design C.0 one."""

    records: tuple | None = None
    listed: bool = True
    kind: ClassVar[str] = "robot (real)"
    robot_model: object = None

    @functools.cached_property
    def spec(self):
        from diffbench.bench.robot import DfkiCrossValidation
        from diffbench.signals.dfki import load_pendulum_model

        model = load_pendulum_model(self.robot_model)
        if self.records is None:
            return DfkiCrossValidation(model=model)
        return DfkiCrossValidation(records=tuple(self.records), model=model)

    @property
    def default_seeds(self) -> int:  # type: ignore[override]
        return len(self.spec.records)

    @property
    def max_seeds(self) -> int:  # type: ignore[override]
        return len(self.spec.records)

    @functools.cached_property
    def name(self) -> str:
        """``identify-dfki`` on the packaged runs with the packaged model; with other records or
        another model, that name and a digest of the records' contents and of the model's
        parameters when they are not the packaged model's (the store never mixes cells of
        different data or models under one name; records with the packaged model keep the
        digest they always had)."""
        from diffbench.signals.dfki import packaged_model

        model = self.spec.model
        if self.records is None and model == packaged_model():
            return self.spec.name
        from diffbench.bench.robot import dfki_record

        digest = hashlib.sha256()
        for source in self.spec.records:
            record = dfki_record(source)
            for array in (record.t, record.q, record.tau, record.tau_commanded):
                digest.update(np.ascontiguousarray(array).tobytes())
        if model != packaged_model():
            digest.update(b"robot model")
            digest.update(np.array(model.identity, dtype=np.float64).tobytes())
        return f"{self.spec.name}-{digest.hexdigest()[:10]}"

    @property
    def description(self) -> str:
        return self.spec.description

    @property
    def preset(self) -> str:
        return self.spec.preset

    def lineup(self, method_names=None):
        from diffbench.bench.robot import NESTED_VARIANT

        entries = []
        for entry in super().lineup(method_names):
            entries.append(entry)
            nested = Role(
                origin="variant", preset=entry.role.preset, by=entry.role.by, variant=NESTED_VARIANT
            )
            entries.append(Entry(entry.method, entry.params, nested))
        return entries

    def score(self, method, seed):
        from diffbench.bench.robot import score_dfki_fold

        return score_dfki_fold(method, self.spec, seed)

    def score_cell(self, method, seed, role):
        from diffbench.bench.robot import NESTED_VARIANT, score_dfki_fold

        if role.variant != NESTED_VARIANT:
            return self.score(method, seed)
        return score_dfki_fold(method, self.spec, seed, nested=True)

    def longest_record(self):
        from diffbench.bench.robot import dfki_record

        records = [dfki_record(source) for source in self.spec.records]
        return max(r.t.size for r in records), self.spec.nominal_dt_s

    def report(self, cells, tunings, directory):
        return reports.dfki_report(cells, directory, self.spec)


def sweep_lineup(task: str, method_names=None) -> list[Entry]:
    """The online tasks' entries: each causal method of ``method_names`` (default: all) at
    every setting of its sweep (:func:`diffbench.bench.online.sweep_settings`); an offline
    method is refused by name."""
    from diffbench.bench.online import sweep_settings

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
    (:func:`diffbench.bench.online.sweep_settings`), scored by the error of its estimate at
    the time it is made, its delay, the error once that delay is compensated and its noise
    gain (:func:`diffbench.bench.online.online_scores`); the report draws each method's
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
        from diffbench.bench.online import online_scores

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
    exact-velocity controller (:mod:`diffbench.bench.loop`); a setting that loses the loop is
    reported as unstable."""

    listed: bool = True
    kind: ClassVar[str] = "online (in the loop)"
    default_seeds: ClassVar[int] = 3
    name: str = "online-2r-loop"
    loop: object = None

    @property
    def spec(self):
        """The experiment (:class:`~diffbench.bench.loop.LoopSpec`; its defaults unless
        ``loop`` gives one)."""
        from diffbench.bench.loop import LoopSpec

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
        from diffbench.bench.loop import loop_scores

        return loop_scores(self.spec, method, seed)

    def report(self, cells, tunings, directory):
        return reports.loop_report(self.name, self.description, cells, directory)


def dfki_task(records, robot_model=None) -> Task:
    """The DFKI identification task on ``records`` (packaged run numbers or paths of CSV files
    in the lab's layout, at least three), registered under its name (:class:`DfkiTask`).

    ``robot_model`` is the robot that recorded them: None for the packaged design C.0 model,
    else the lab's ``model_parameters.yml`` of their design (a path), a mapping of its
    parameters or a :class:`diffbench.signals.dfki.PendulumModel`
    (:func:`diffbench.signals.dfki.load_pendulum_model`). Records that evidently are not of
    that robot are refused (:func:`diffbench.bench.robot.check_model_matches`: a path naming
    another design, or a torque the model explains worse than its mean).
    """
    from diffbench.bench.robot import check_model_matches, dfki_record
    from diffbench.signals.dfki import load_pendulum_model

    records = tuple(records)
    if len(records) < 3:
        raise ValueError(
            f"give at least 3 records (each identified on the others, nested), got {len(records)}"
        )
    for source in records:
        dfki_record(source)  # a bad file is refused here, naming it
    task = DfkiTask(records=records, robot_model=load_pendulum_model(robot_model))
    check_model_matches(task.spec)
    _register_builtins()
    return _TASKS.get(task.name) or register_task(task)


def register_task(task: Task) -> Task:
    """Add ``task`` under its name; ``ValueError`` if the name is taken."""
    if task.name in _TASKS:
        raise ValueError(f"a task named {task.name!r} is already registered")
    _TASKS[task.name] = task
    return task


@functools.cache
def _register_builtins() -> None:
    from diffbench.signals import robot2r
    from diffbench.signals.scenarios import grid_scenario_names

    grid = set(grid_scenario_names())
    limits = set(signals.scenarios.limit_scenario_names())
    for name in signals.available_scenarios():
        scenario = signals.get_scenario(name)
        task = LimitTask(scenario) if name in limits else SignalTask(scenario, name not in grid)
        register_task(task)
    register_task(JacobiInfluenceTask(signals.get_scenario("paper-signal")))
    register_task(OnlineTask(signals.get_scenario("paper-signal")))
    register_task(LoopTask())
    for name in robot2r.available_robot_scenarios():
        register_task(RobotSimTask(robot2r.get_robot_scenario(name)))
    register_task(DfkiTask())


def available_tasks(listed_only: bool = False) -> list[str]:
    """Names of the registered tasks, sorted (``listed_only``: without the grid's)."""
    _register_builtins()
    return sorted(name for name, task in _TASKS.items() if task.listed or not listed_only)


def get_task(name: str) -> Task:
    """The task registered as ``name``; an unknown name lists the valid ones."""
    _register_builtins()
    try:
        return _TASKS[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown task {name!r}; available: "
            f"{', '.join(available_tasks(listed_only=True))} and the grid's "
            "(diffbench list)"
        ) from None
