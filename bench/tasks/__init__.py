"""Tasks: each kind of benchmark is one object that scores a method on one seed and writes its
own report. The runner and the CLI never ask what kind of task they hold.

A task has a ``name``, a ``description``, the ``preset`` key of the method presets it runs by
default, its seeds (``default_seeds``; ``max_seeds`` when the seeds are a fixed set such as the
folds of a cross-validation), and

* ``lineup(method_names)``: the entries (method, parameters, role) ``diffbench run`` computes;
* ``score(method, seed)``: tidy score rows (order, region, metric, value) of one cell;
* ``report(cells, tunings, directory)``: the tables and figures, from stored rows only;
* ``tuning_data(seed)``: the realisation a tuner works on (signal tasks), or a ValueError.

Each kind is a module of this package (:mod:`.signal`, :mod:`.robot`, :mod:`.online`,
:mod:`.study`, :mod:`.items`) on the base of :mod:`.base`; each lists its built-in tasks in a
``builtin_tasks()`` function, and every module of the package is asked for them on first use.
Adding a kind of benchmark or a study is one module here: its class(es) and ``builtin_tasks()``
(a task made at run time, e.g. from a user's records, is added by :func:`register_task`).
"""

from __future__ import annotations

import functools
import importlib
import pkgutil

from diffbench import methods
from diffbench.bench.studies.dfki import check_model_matches, dfki_record
from diffbench.bench.tasks.base import _TASKS, ScenarioTask, Task, register_task
from diffbench.bench.tasks.items import (
    Item,
    ItemStudy,
    PaperFigures,
    ParetoStudy,
    RecommendCheck,
    TimingStudy,
)
from diffbench.bench.tasks.online import LoopTask, OnlineTask, sweep_lineup
from diffbench.bench.tasks.robot import DfkiTask, RobotSimTask
from diffbench.bench.tasks.signal import JacobiInfluenceTask, LimitTask, SignalTask
from diffbench.bench.tasks.study import GridStudy, LimitStudy, Study
from diffbench.signals.dfki import load_pendulum_model


def dfki_task(records, robot_model=None) -> Task:
    """The DFKI identification task on ``records`` (packaged run numbers or paths of CSV files
    in the lab's layout, at least three), registered under its name (:class:`DfkiTask`).

    ``robot_model`` is the robot that recorded them: None for the packaged design C.0 model,
    else the lab's ``model_parameters.yml`` of their design (a path), a mapping of its
    parameters or a :class:`diffbench.signals.dfki.PendulumModel`
    (:func:`diffbench.signals.dfki.load_pendulum_model`). Records that evidently are not of
    that robot are refused (:func:`diffbench.bench.studies.dfki.check_model_matches`: a path naming
    another design, or a torque the model explains worse than its mean).
    """
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


@functools.cache
def _register_builtins() -> None:
    """Register the built-in tasks: those every module of this package lists in its
    ``builtin_tasks()`` (a new kind of task or study is one module, found here by its name)."""
    for info in pkgutil.iter_modules(__path__):
        module = importlib.import_module(f"{__name__}.{info.name}")
        for task in getattr(module, "builtin_tasks", tuple)():
            register_task(task)


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
        hint = methods.did_you_mean(name, available_tasks()) or (
            f"available: {', '.join(available_tasks(listed_only=True))} and the grid's "
            "(diffbench list)"
        )
        raise ValueError(f"unknown task {name!r}; {hint}") from None


__all__ = [
    "DfkiTask",
    "GridStudy",
    "Item",
    "ItemStudy",
    "JacobiInfluenceTask",
    "LimitStudy",
    "LimitTask",
    "LoopTask",
    "OnlineTask",
    "PaperFigures",
    "ParetoStudy",
    "RecommendCheck",
    "RobotSimTask",
    "ScenarioTask",
    "SignalTask",
    "Study",
    "Task",
    "TimingStudy",
    "available_tasks",
    "dfki_task",
    "get_task",
    "register_task",
    "sweep_lineup",
]
