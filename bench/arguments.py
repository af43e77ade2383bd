"""The arguments of diffbench's API and command line, checked and resolved in one place, and
how the API tells news, progress and remarks.

Each converter here takes a Python value or the text typed on the command line and returns the
value, or raises ``ValueError`` saying what is expected (``must be ..., got ...``). The API
checks its arguments with :func:`check`, which raises :class:`BadInput` naming the argument;
the command line parses with :func:`for_argparse`, whose error argparse prefixes with the
option's name.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import operator
import sys
import warnings
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, TypeVar

from diffbench import methods
from diffbench.bench import runner
from diffbench.bench.core import executor, tuning
from diffbench.bench.core.errors import BadInput, DiffbenchWarning
from diffbench.bench.core.store import Store, StoreError
from diffbench.bench.tasks import Task, dfki_task, get_task
from diffbench.signals.dfki import load_pendulum_model

T = TypeVar("T")
Echo = Callable[[str], None]
"""Where the API gives each line of news as the work goes (the command line prints it)."""
Workers = int | executor.DaskWorkers


@contextlib.contextmanager
def checked(prefix: str = ""):
    """Where the API checks what the user gave: a ``ValueError`` raised inside becomes a
    :class:`BadInput` (its message after ``prefix``); a :class:`BadInput` passes unchanged."""
    try:
        yield
    except BadInput:
        raise
    except ValueError as error:
        raise BadInput(f"{prefix}{error}") from None


def check(name: str, convert: Callable[[Any], T], value: Any) -> T:
    """``convert(value)``, its ``ValueError`` a :class:`BadInput` naming the argument ``name``.

    Parameters
    ----------
    name : str
        The argument's name, as the caller spells it.
    convert : callable
        One of this module's converters (e.g. ``whole_number(1, 10)``, :func:`orders`).
    value : object
        What the caller gave.

    Returns
    -------
    object
        The converted value.
    """
    try:
        return convert(value)
    except ValueError as error:
        raise BadInput(f"{name}: {error}") from None


def for_argparse(convert: Callable[[Any], T]) -> Callable[[str], T]:
    """An argparse ``type`` from a converter: its ``ValueError`` becomes argparse's error."""

    def parse(text: str) -> T:
        try:
            return convert(text)
        except ValueError as error:
            raise argparse.ArgumentTypeError(str(error)) from None

    parse.__name__ = getattr(convert, "__name__", "value")
    return parse


def whole_number(low: int, high: int) -> Callable[[Any], int]:
    """A converter to a whole number in ``low .. high`` (the message gives the range)."""

    def convert(value: Any) -> int:
        try:
            number = int(value) if isinstance(value, str) else operator.index(value)
        except (TypeError, ValueError):
            number = None
        if number is None or not low <= number <= high:
            raise ValueError(f"must be a whole number >= {low} and <= {high:_}, got {value!r}")
        return number

    return convert


positive_count = whole_number(1, runner.MAX_COUNT)
seed_count = whole_number(1, runner.MAX_SEEDS)
tuning_seed_count = whole_number(1, runner.MAX_TUNING_SEEDS)
job_count = whole_number(1, executor.MAX_JOBS)
seed = whole_number(0, runner.MAX_SEED)


def record_length(value: Any) -> int:
    """A number of samples that is a power of ten from 1e4 to 1e8."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    exponent = math.log10(number) if number > 0 else math.nan
    if not (4 <= exponent <= 8 and exponent == round(exponent)):
        raise ValueError(f"must be a power of ten from 1e4 to 1e8, e.g. 1e6, got {value!r}")
    return int(number)


def finite_positive(value: Any) -> float:
    """A finite number > 0."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"must be a number, got {value!r}") from None
    if not (math.isfinite(number) and number > 0):
        raise ValueError(f"must be a finite number > 0, got {value}")
    return number


def timeout(value: Any) -> float:
    """A number of seconds > 0 and at most :data:`~diffbench.bench.runner.MAX_TIMEOUT_S`."""
    number = finite_positive(value)
    if number > runner.MAX_TIMEOUT_S:
        raise ValueError(
            f"must be a number of seconds > 0 and <= {runner.MAX_TIMEOUT_S:g}, got {value}"
        )
    return number


def name_list(value: str | Iterable[str]) -> list[str]:
    """Names, comma-separated in a text or given as a list; each once, in order."""
    items = value.split(",") if isinstance(value, str) else list(value)
    names = [str(name).strip() for name in items if str(name).strip()]
    if not names:
        raise ValueError("must name at least one, comma-separated")
    return runner.unique(names)


def orders(value: str | Iterable[int]) -> list[int]:
    """Orders of derivative: 1, 2 or both."""
    items = name_list(value) if isinstance(value, str) else list(value)
    try:
        found = runner.unique(
            operator.index(o) if not isinstance(o, str) else int(o) for o in items
        )
    except (TypeError, ValueError):
        raise ValueError(f"must be 1, 2 or 1,2, got {value!r}") from None
    if not found or not set(found) <= {1, 2}:
        raise ValueError(f"must be 1, 2 or 1,2, got {value!r}")
    return found


def criteria(value: str | Iterable[str]) -> list[str]:
    """Tuning criteria among :data:`~diffbench.bench.core.tuning.COMMAND_CRITERIA`."""
    found = name_list(value)
    unknown = [c for c in found if c not in tuning.COMMAND_CRITERIA]
    if unknown:
        close = methods.did_you_mean(unknown[0], tuning.COMMAND_CRITERIA)
        raise ValueError(
            f"must be among {', '.join(tuning.COMMAND_CRITERIA)}, got {', '.join(unknown)}"
            + (f"; {close}" if close else "")
        )
    return found


def one_of(*choices: str) -> Callable[[Any], str]:
    """A converter to one of ``choices``."""

    def convert(value: Any) -> str:
        if value not in choices:
            close = methods.did_you_mean(value, choices)
            raise ValueError(
                f"must be one of {', '.join(choices)}, got {value!r}"
                + (f"; {close}" if close else "")
            )
        return value

    return convert


# --- news, progress and remarks -----------------------------------------------------------------
def say(echo: Echo | None, text: str) -> None:
    """Give ``text`` to ``echo`` (None: say nothing)."""
    if echo is not None:
        echo(text)


def progress_bar(progress: bool, unit: str):
    """A tqdm progress bar on stderr as the runner's ``progress`` (None: none)."""
    if not progress:
        return None

    def wrap(items, total):
        from tqdm import tqdm

        if total == 0:  # nothing to compute: no empty bar
            return items
        return tqdm(items, total=total, unit=unit, file=sys.stderr, dynamic_ncols=True)

    return wrap


# --- methods, plugins, workers, store, tasks ------------------------------------------------------
GROUPS = {
    "all": "every registered offline method",
    "native": "the offline methods diffbench implements",
    "peers": "the methods other packages implement (the peers' adapters, plugins)",
    "causal": "the causal methods (the online track)",
}


def _expand(name: str) -> list[str]:
    """A method name, or every method of a group (:data:`GROUPS`)."""
    if name not in GROUPS:
        group = methods.did_you_mean(name, GROUPS)
        if group and name not in methods.available(causal=None):  # a mistyped group
            raise ValueError(f"unknown method or group {name!r}; {group}")
        return [name]  # a method: its registry says what is wrong with it, if anything
    if name == "causal":
        return methods.available(causal=True)
    everything = methods.available()
    if name == "all":
        return everything
    native = [n for n in everything if methods.package_of(n).startswith("diffbench ")]
    return native if name == "native" else [n for n in everything if n not in native]


def method_names(names: str | Iterable[str] | None) -> list[str] | None:
    """The registered names of ``names``, each a method or a group (:data:`GROUPS`), less
    those named with a leading ``-`` (``peers,-derivative.kernel``: every peer but one).

    Parameters
    ----------
    names : str or iterable of str or None
        Method names or groups (all, native, peers, causal); a text is comma-separated. A name
        or group after ``-`` is left out of the others.

    Returns
    -------
    list of str or None
        Each method once, in order; None for None.
    """
    if names is None:
        return None
    names = check("methods", name_list, names)
    kept = [name for name in names if not name.startswith("-")]
    if not kept:
        raise BadInput(
            f"--methods: {','.join(names)} only leaves methods out (a leading -); name the "
            "methods or a group to leave them out of, e.g. peers,-derivative.kernel"
        )

    def registered(given: list[str]) -> list[str]:
        expanded = runner.unique(n for name in given for n in _expand(name))
        return [methods.method_class(name).name for name in expanded]

    with checked("--methods: "):
        found = registered(kept)
        left_out = set(registered([name[1:] for name in names if name.startswith("-")]))
        found = [name for name in found if name not in left_out]
    if not found:
        raise BadInput(f"--methods: {','.join(names)} leaves no method")
    return found


def load_plugins(modules: Iterable[str] = ()) -> None:
    """Load the installed plugins and ``$DIFFBENCH_PLUGINS``, then import each of ``modules``
    (registering its methods)."""
    with checked():
        methods.available()  # loads the entry points and the environment's modules
    for module in modules:
        with checked("--plugin: "):
            methods.load_plugin(module)


def dask_workers(
    workers: int = 1, scheduler: str | None = None, plugins: Iterable[str] = ()
) -> executor.DaskWorkers:
    """Where to run on Dask: the scheduler at ``scheduler`` (``tcp://host:8786``), or a local
    cluster of ``workers`` processes; ``plugins`` are imported on the workers. Give it as
    ``jobs`` (checked there: Dask installed, the scheduler answering)."""
    return executor.DaskWorkers(address=scheduler, workers=workers, plugins=tuple(plugins))


def ready(jobs: Workers) -> Workers:
    """``jobs`` checked: a number of local workers in range, or Dask workers that can run."""
    if not isinstance(jobs, executor.DaskWorkers):
        return check("jobs", job_count, jobs)
    with checked("--executor dask: "):
        executor.check(jobs)
    return jobs


def open_store(out: Path) -> Store:
    """The results store ``out/store`` (created if need be); a damaged one is a
    :class:`BadInput`, records set aside on import are warned about."""
    try:
        store = Store(Path(out) / "store")
    except StoreError as error:
        raise BadInput(str(error)) from None
    for item in store.set_aside:
        warnings.warn(
            f"not imported {item} (the file is left as it is)", DiffbenchWarning, stacklevel=2
        )
    return store


def task_of(
    task: str | Task, records: Sequence[Path] | None = None, robot_model: Path | None = None
) -> Task:
    """The task named ``task``, on ``records`` (identify-dfki only: recordings in the DFKI
    lab's CSV layout) of the robot described by ``robot_model`` when given."""
    if not records:
        if robot_model is not None:
            raise BadInput(
                "--robot-model is valid with --records only (it describes the robot that "
                "recorded them): add --records CSV... or drop --robot-model"
            )
        if isinstance(task, Task):
            return task
        with checked():
            return get_task(task)
    if task != "identify-dfki":
        raise BadInput(f"--records is for identify-dfki only, not {task!r}")
    if robot_model is not None:
        with checked("--robot-model: "):
            robot_model = load_pendulum_model(robot_model)
    with checked("--records: "):
        return dfki_task(records, robot_model=robot_model)


def tuning_task_for(name: str, task: Task) -> Task:
    """The signal task ``--tuned-on`` names: not ``task`` itself, and sampled at its step."""
    with checked("--tuned-on: "):
        other = get_task(name)
    if other.name == task.name:
        raise BadInput(f"--tuned-on {name} is the task scored: drop --tuned-on")
    with checked():
        scored = task.tuning_data(0)
    with checked(f"--tuned-on {name}: "):
        steps = other.tuning_data(0).dt_s, scored.dt_s
    if steps[0] != steps[1]:
        raise BadInput(
            f"--tuned-on {name} is sampled every {steps[0]!r} s, {task.name} every "
            f"{steps[1]!r} s: a setting carries only between records of the same step"
        )
    return other
