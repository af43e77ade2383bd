"""The ``diffbench`` command line: a thin layer over the Python API.

Exit codes: 0 done; 2 a usage error (bad input, or a machine that cannot take the output: a
full disk, the file size limit, a read-only folder; one line on stderr, never a traceback); 1 an
internal error (its traceback: a bug, never disguised as a usage error); 130 interrupted by
Ctrl-C, 143 by SIGTERM (every finished result is stored; the same command resumes; no worker
process is left behind); 141 when the reader of the output went away (``diffbench list | head``).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import math
import os
import signal
import sys
import warnings
from importlib import metadata
from pathlib import Path

from diffbench import methods, signals
from diffbench.bench import runner
from diffbench.bench.core import executor, tuning, uptodate
from diffbench.bench.core.executor import Terminated, WorkerDied, terminate_on_sigterm
from diffbench.bench.core.provenance import provenance
from diffbench.bench.core.store import Store, StoreError, set_command, store_exists
from diffbench.bench.studies import recommend, user_data
from diffbench.bench.tasks import (
    ItemStudy,
    LimitStudy,
    ParetoStudy,
    RecommendCheck,
    TimingStudy,
    available_tasks,
    dfki_task,
    get_task,
)
from diffbench.signals.dfki import load_pendulum_model

EXIT_INTERNAL = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141
EXIT_TERMINATED = 143


class UsageError(Exception):
    """A mistake in the command line (reported in one line, exit code 2)."""


@contextlib.contextmanager
def user_input(prefix: str = ""):
    """Where the API checks what the user typed: its ``ValueError`` is a usage error."""
    try:
        yield
    except ValueError as error:
        raise UsageError(f"{prefix}{error}") from None


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # argparse would print usage and exit itself
        raise UsageError(message)


def _whole_number(low: int, high: int):
    """An argparse type: a whole number in ``low .. high`` (the message gives the range)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not low <= value <= high:
            raise argparse.ArgumentTypeError(
                f"must be a whole number >= {low} and <= {high:_}, got {text!r}"
            )
        return value

    return parse


_positive_int = _whole_number(1, runner.MAX_COUNT)
_seed_count = _whole_number(1, runner.MAX_SEEDS)
_tuning_seed_count = _whole_number(1, runner.MAX_TUNING_SEEDS)
_jobs = _whole_number(1, executor.MAX_JOBS)


def _record_length(text: str) -> int:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    exponent = math.log10(value) if value > 0 else math.nan
    if not (4 <= exponent <= 8 and exponent == round(exponent)):
        raise argparse.ArgumentTypeError(
            f"must be a power of ten from 1e4 to 1e8, e.g. 1e6, got {text!r}"
        )
    return int(value)


_seed = _whole_number(0, runner.MAX_SEED)


def _finite_positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def _timeout(text: str) -> float:
    value = _finite_positive(text)
    if value > runner.MAX_TIMEOUT_S:
        raise argparse.ArgumentTypeError(
            f"must be a number of seconds > 0 and <= {runner.MAX_TIMEOUT_S:g}, got {text}"
        )
    return value


def _name_list(text: str) -> list[str]:
    names = [name.strip() for name in text.split(",") if name.strip()]
    if not names:
        raise argparse.ArgumentTypeError("must name at least one, comma-separated")
    return runner.unique(names)


def _orders(text: str) -> list[int]:
    try:
        orders = [int(o) for o in _name_list(text)]
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be 1, 2 or 1,2, got {text!r}") from None
    if not set(orders) <= {1, 2}:
        raise argparse.ArgumentTypeError(f"must be 1, 2 or 1,2, got {text!r}")
    return orders


def _criteria(text: str) -> list[str]:
    criteria = _name_list(text)
    unknown = [c for c in criteria if c not in tuning.COMMAND_CRITERIA]
    if unknown:
        raise argparse.ArgumentTypeError(
            f"must be among {', '.join(tuning.COMMAND_CRITERIA)}, got {', '.join(unknown)}"
        )
    return criteria


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="diffbench", description=__doc__.splitlines()[0])
    parser.add_argument(
        "--version", action="version", version=f"diffbench {metadata.version('diffbench')}"
    )
    out = _Parser(add_help=False)
    out.add_argument(
        "--out",
        type=Path,
        default=Path("results"),
        help="results directory: reports in OUT/TASK/, the store in OUT/store/ (default results/)",
    )
    work = _Parser(add_help=False)
    work.add_argument(
        "--jobs",
        type=_jobs,
        default=1,
        help="local worker processes, or Dask workers with --executor dask (results identical "
        "to a serial run)",
    )
    work.add_argument(
        "--executor",
        choices=("local", "dask"),
        default="local",
        help="local: this machine's processes (--jobs); dask: a Dask LocalCluster of --jobs "
        "workers, or the scheduler given by --scheduler (pip install 'diffbench[dask]')",
    )
    work.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        default=None,
        help="a running Dask scheduler (tcp://host:8786; implies --executor dask): the "
        "workers compute, this process stores",
    )
    work.add_argument(
        "--timeout",
        dest="timeout_s",
        type=_timeout,
        default=runner.DEFAULT_TIMEOUT_S,
        metavar="SECONDS",
        help="most seconds one cell's computation may take; a cell past it is recorded as "
        f"failed, the run goes on, the next run tries it again (default "
        f"{runner.DEFAULT_TIMEOUT_S:g}: the slowest built-in cell takes about 160 s)",
    )
    work.add_argument("--no-progress", action="store_true", help="no progress bar")
    seeds = _Parser(add_help=False)
    seeds.add_argument(
        "--seeds",
        type=_seed_count,
        default=None,
        help="scored seeds 0..N-1 (default: the task's, 10 for signals)",
    )
    pick = _Parser(add_help=False)
    pick.add_argument(
        "--methods",
        type=_name_list,
        default=None,
        help="comma-separated method names or groups (all, native, peers, causal; default: all)",
    )

    plug = _Parser(add_help=False)
    plug.add_argument(
        "--plugin",
        dest="plugins",
        action="append",
        default=[],
        metavar="MODULE",
        help="import MODULE first, registering its methods (repeatable; installed plugins "
        "load by themselves through their entry points; see also $DIFFBENCH_PLUGINS)",
    )

    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    listing = commands.add_parser(
        "list", parents=[plug], help="methods (parameters, ranges, presets) and tasks"
    )
    listing.set_defaults(handler=_cmd_list)

    run = commands.add_parser(
        "run",
        parents=[out, work, seeds, pick, plug],
        help="run every method at its preset on a task, write its report",
    )
    run.add_argument("task", help="task name (see `diffbench list`)")
    run.add_argument(
        "--orders",
        type=_orders,
        default=[1, 2],
        help="derivatives a study (grid, limit) tunes for (default 1,2)",
    )
    run.add_argument(*RECORDS_FLAG, **RECORDS_OPTIONS)
    run.add_argument(*ROBOT_MODEL_FLAG, **ROBOT_MODEL_OPTIONS)
    run.set_defaults(handler=_cmd_run)

    tune = commands.add_parser(
        "tune",
        parents=[out, work, seeds, plug],
        help="tune methods on a task's tuning seed (stored, reused), score on other seeds",
    )
    tune.add_argument(
        "method", help="method names or groups (all, native, peers, causal), comma-separated"
    )
    tune.add_argument("task", help="a signal task (see `diffbench list`)")
    tune.add_argument(
        "--criteria",
        type=_criteria,
        default=["oracle"],
        help="oracle (against the truth), no-truth (spectral risk, linear methods),"
        " pynumdiff (PyNumDiff's loss), surrogate (the truth of surrogate records drawn from"
        " the record's spectrum); comma-separated (default oracle)",
    )
    tune.add_argument(
        "--orders", type=_orders, default=[2], help="derivatives tuned for: 1, 2 or 1,2 (default 2)"
    )
    tune.add_argument(
        "--cutoff-hz",
        type=_finite_positive,
        default=20.0,
        help="bandlimit guess of the no-truth and pynumdiff criteria, inside (0, Nyquist) "
        "(default 20)",
    )
    tune.add_argument(
        "--tuning-seed",
        type=_seed,
        default=tuning.TUNING_SEED,
        help=f"noise seed tuned on (default {tuning.TUNING_SEED}; never scored)",
    )
    tune.add_argument(
        "--tuning-seeds",
        type=_tuning_seed_count,
        default=1,
        metavar="K",
        help="average the tuning loss over K seeds, TUNING_SEED .. TUNING_SEED+K-1 (default 1)",
    )
    tune.add_argument(
        "--budget",
        type=_positive_int,
        default=None,
        metavar="N",
        help="at most N evaluations per differential-evolution run (default: 100 per searched "
        "parameter, within 150..400; one run per combination of choices)",
    )
    tune.add_argument(
        "--region",
        choices=("interior", "whole"),
        default="interior",
        help="samples the loss is taken on: the task's interior (default) or the whole record "
        "(every sample must be estimated; edge treatments are tuned too)",
    )
    tune.set_defaults(handler=_cmd_tune)

    # the sweeps that tune every method per task, then score it: grid and limit
    sweep = _Parser(add_help=False)
    sweep.add_argument("--seeds", type=_seed_count, default=10, help="scored seeds 0..N-1")
    sweep.add_argument(
        "--orders", type=_orders, default=[1, 2], help="derivatives tuned for (default 1,2)"
    )
    grid = commands.add_parser(
        "grid",
        parents=[out, work, plug, pick, sweep],
        help="tune every method on the noise x level x step grid, score it, name the winners",
    )
    grid.set_defaults(handler=_cmd_grid)

    limit = commands.add_parser(
        "limit",
        parents=[out, work, plug, pick, sweep],
        help="tune every method on the random signals with a known least error, score its "
        "efficiency (results in OUT/limit/)",
    )
    limit.add_argument(
        "--scenarios",
        type=_name_list,
        default=None,
        help="limit scenarios, comma-separated (default: all; diffbench list names them)",
    )
    limit.set_defaults(handler=_cmd_limit)

    pareto = commands.add_parser(
        "pareto",
        parents=[out, work, plug, pick],
        help="each method's front of accuracy against smoothness without the truth, with its "
        "knee and the oracle's setting (OUT/limit/pareto_TASK.*)",
    )
    pareto.add_argument("task", help="a signal task, e.g. limit-matern52-0.01")
    pareto.set_defaults(handler=_cmd_pareto)

    figures = commands.add_parser(
        "paper-figures",
        parents=[out, work, plug],
        help="the paper's figures 1-3 (PNG + CSV), frequency table, error against position",
    )
    figures.add_argument(
        "--seeds",
        type=_seed_count,
        default=20,
        help="noise seeds of the error-against-position figure (default 20)",
    )
    figures.add_argument(
        "--methods",
        type=_name_list,
        default=None,
        help="the methods drawn, names or groups (all, native, peers), comma-separated "
        "(default: all)",
    )
    figures.set_defaults(handler=_cmd_paper_figures)

    timing = commands.add_parser(
        "timing",
        parents=[out, plug],
        help="throughput and peak memory of every method vs signal length, and the speed "
        "ratios against the peers",
    )
    timing.add_argument(
        "--largest",
        type=_record_length,
        default=10_000_000,
        help="the longest record timed, a power of ten from 1e4 (default 1e7)",
    )
    timing.add_argument(
        "--no-ratios",
        dest="ratios",
        action="store_false",
        help="leave out the speed ratios against filterpy, scipy and PyNumDiff (about 3 min)",
    )
    timing.set_defaults(handler=_cmd_timing)

    export = commands.add_parser(
        "export",
        parents=[plug],
        help="write a scenario's record (time, samples and truth) as a user's CSV or Parquet file",
    )
    export.add_argument("scenario", help="a scenario name (diffbench list shows them)")
    export.add_argument("file", type=Path, help="the .csv or .parquet file to write")
    export.add_argument("--seed", type=_seed, default=0, help="the noise seed (default 0)")
    export.set_defaults(handler=_cmd_export)

    advice = commands.add_parser(
        "recommend",
        parents=[plug],
        help="which method, with which settings, for your own record (CSV or Parquet)",
    )
    advice.add_argument("file", type=Path, help="a .csv or .parquet file, one column per channel")
    advice.add_argument(
        "--column",
        dest="columns",
        type=_name_list,
        default=None,
        help="comma-separated channel columns (default: every column but the time)",
    )
    advice.add_argument("--time", default=None, help="the time column (seconds)")
    advice.add_argument("--dt", type=float, default=None, help="the sampling step (seconds)")
    advice.add_argument(
        "--methods",
        type=_name_list,
        default=["native"],
        help="method names or groups (all, native, peers, causal; default: native)",
    )
    advice.add_argument(
        "--orders", type=_orders, default=[1, 2], help="derivatives to recommend for (1,2)"
    )
    advice.add_argument(
        "--budget", type=_positive_int, default=None, help="most evaluations per tuning"
    )
    advice.add_argument(
        "--out",
        type=Path,
        default=None,
        help="where the ranking, derivatives and figure go (default: recommend-FILESTEM/)",
    )
    advice.set_defaults(handler=_cmd_recommend)

    check = commands.add_parser(
        "recommend-check",
        parents=[out, plug, work],
        help="score `recommend` against the truth on the signal scenarios (as if unknown)",
    )
    check.add_argument(
        "--scenarios",
        type=_name_list,
        default=None,
        help="comma-separated scenario names (default: every uniformly sampled noisy one)",
    )
    check.add_argument(
        "--methods",
        type=_name_list,
        default=None,
        help="methods to recommend among (default: the six that tune in seconds)",
    )
    check.set_defaults(handler=_cmd_recommend_check)

    report = commands.add_parser(
        "report", parents=[out, plug], help="render a task's report again from the store"
    )
    report.add_argument("task")
    report.add_argument(*RECORDS_FLAG, **RECORDS_OPTIONS)
    report.add_argument(*ROBOT_MODEL_FLAG, **ROBOT_MODEL_OPTIONS)
    report.set_defaults(handler=_cmd_report)
    return parser


# --- commands ------------------------------------------------------------------------------
STAMPS_SHOWN = {"uniform": "uniform only"}
"""How `diffbench list` words a method's handling of time stamps, where not its own name."""


def _cmd_list(args) -> None:
    print("methods (name: parameter range [tuning range] default; presets)")
    plugins = methods.loaded_plugins()
    for name in methods.available(causal=None):
        cls = methods.method_class(name)
        shipped = [p for p in plugins if f"{cls.__module__}.".startswith(f"{p.module}.")]
        origin = f"; plugin {shipped[0].label}" if shipped else ""
        kind = ("linear" if cls.linear else "nonlinear") + (", causal" if cls.causal else "")
        print(
            f"  {name}  ({kind}; runs {methods.package_of(name)}; {cls.reference}{origin}; "
            f"time stamps: {STAMPS_SHOWN.get(cls.time_stamps, cls.time_stamps)})"
        )
        if cls.second_derivative != "native":
            print(f"      ẍ: {cls.second_derivative}")
        for spec in methods.params_of(cls):
            tune = ""
            if spec.tune_low is not None:
                scale = ", log" if spec.log else ""
                tune = f" [tune {spec.tune_low:g}..{spec.tune_high:g}{scale}]"
            print(
                f"      {spec.name}: {spec.describe_range()}{tune} default {spec.default!r}"
                f"  - {spec.doc}"
            )
        for key, chosen in cls.presets.items():
            values = ", ".join(f"{k}={v!r}" for k, v in chosen.values.items())
            print(f"      preset {key} (by {chosen.by}): {values}  ({chosen.source})")
    for prefix, why in methods.missing_peers().items():
        print(f"  {prefix}.*  not available: {why}")
    print("tasks (diffbench run TASK)")
    for name in available_tasks(listed_only=True):
        task = get_task(name)
        print(f"  {name} [{task.kind}]: {task.description}")
    unlisted = [n for n in available_tasks() if not get_task(n).listed]
    for prefix, kind, how in (
        ("grid-", "grid", "diffbench grid"),
        ("limit-", "limit (random signals, known least error)", "diffbench run TASK"),
    ):
        names = [n for n in unlisted if n.startswith(prefix)]
        if names:
            print(f"  ... and {len(names)} {kind} tasks ({names[0]} ... {names[-1]}; {how})")


def _load_plugins(modules: list[str]) -> None:
    """The installed plugins and ``$DIFFBENCH_PLUGINS``, then each ``--plugin`` module."""
    with user_input():
        methods.available()  # loads the entry points and the environment's modules
    for module in modules:
        with user_input("--plugin: "):
            methods.load_plugin(module)


def _workers(args) -> None:
    """``args.jobs`` becomes where the work runs: an int (local processes) or
    :class:`~bench.executor.DaskWorkers` (``--executor dask`` or ``--scheduler``)."""
    if not hasattr(args, "executor"):
        return
    if args.scheduler is None and args.executor == "local":
        return
    if getattr(args, "records", None):
        raise UsageError("--records runs on this machine only: drop --executor/--scheduler")
    args.jobs = executor.DaskWorkers(
        address=args.scheduler, workers=args.jobs, plugins=tuple(args.plugins)
    )
    with user_input("--executor dask: "):
        executor.check(args.jobs)


def _task(name: str):
    with user_input():
        return get_task(name)


GROUPS = {
    "all": "every registered offline method",
    "native": "the offline methods diffbench implements",
    "peers": "the methods other packages implement (the peers' adapters, plugins)",
    "causal": "the causal methods (the online track)",
}


def _expand(name: str) -> list[str]:
    """A method name, or every method of a group (:data:`GROUPS`)."""
    if name not in GROUPS:
        return [name]
    if name == "causal":
        return methods.available(causal=True)
    everything = methods.available()
    if name == "all":
        return everything
    native = [n for n in everything if methods.package_of(n).startswith("diffbench ")]
    return native if name == "native" else [n for n in everything if n not in native]


def _method_names(names) -> list[str] | None:
    """Registered names of ``names`` (each a method or a group: all, native, peers, causal)."""
    if names is None:
        return None
    with user_input("--methods: "):
        expanded = runner.unique(n for name in names for n in _expand(name))
        return [methods.method_class(name).name for name in expanded]


def _open_store(out: Path) -> Store:
    try:
        store = Store(out / "store")
    except StoreError as error:
        raise UsageError(str(error)) from None
    _warn_set_aside(store.set_aside)
    return store


def _warn_set_aside(items) -> None:
    for item in items:
        print(
            f"diffbench: warning: not imported {item} (the file is left as it is)",
            file=sys.stderr,
        )


def _progress(args, unit: str = "cell"):
    if getattr(args, "no_progress", True):
        return None

    def wrap(items, total):
        from tqdm import tqdm

        return tqdm(items, total=total, unit=unit, file=sys.stderr, dynamic_ncols=True)

    return wrap


def _run_cells(cells, store: Store, args) -> runner.RunSummary:
    try:
        return runner.run(
            cells, store, progress=_progress(args), jobs=args.jobs, timeout_s=args.timeout_s
        )
    except (KeyboardInterrupt, Terminated) as stop:
        store.refresh()
        print(
            f"diffbench: interrupted; {len(store.cells.records)} cells are stored in "
            f"{store.directory}; run the same command to resume",
            file=sys.stderr,
        )
        code = EXIT_INTERRUPTED if isinstance(stop, KeyboardInterrupt) else EXIT_TERMINATED
        raise SystemExit(code) from None


def _run_items(study, items, store: Store, args) -> dict:
    try:
        rows, summary = runner.run_items(
            study, items, store, progress=_progress(args, "item"), jobs=getattr(args, "jobs", 1)
        )
    except (KeyboardInterrupt, Terminated) as stop:
        print(
            f"diffbench: interrupted; the finished items of {study.name} are stored in "
            f"{store.directory}; run the same command to resume",
            file=sys.stderr,
        )
        code = EXIT_INTERRUPTED if isinstance(stop, KeyboardInterrupt) else EXIT_TERMINATED
        raise SystemExit(code) from None
    _say(summary, "items")
    return rows


def _say(summary: runner.RunSummary, unit: str = "cells") -> None:
    text = f"{summary.computed} {unit} computed, {summary.skipped} already stored"
    if summary.reused:
        text += f", {summary.reused} the same computation as another cell (its scores taken)"
    if summary.stored_by_others:
        text += f", {summary.stored_by_others} stored meanwhile by another writer"
    if summary.failed:
        text += f", {len(summary.failed)} failed (recorded; the next run tries them again)"
    print(text)
    for cell, reason in summary.failed:
        print(
            f"diffbench: warning: cell failed: {cell.method} on {cell.task} seed {cell.seed}: "
            f"{reason}",
            file=sys.stderr,
        )


def _report(task, store: Store, out: Path) -> list[Path]:
    store.refresh()
    cells = store.cells_frame(task.parts())
    failed = store.failed_cells(task.parts())
    if cells.empty and not failed.empty:
        raise UsageError(
            f"every cell of {task.name} asked for failed ({len(failed)}: "
            f"{failed['reason'].iloc[-1]}); nothing to report"
        )
    if cells.empty:
        raise UsageError(
            f"no stored results of {task.name} in {store.directory}; run "
            f"`diffbench run {task.name} --out {out}` first"
        )
    tables = ("cells", "tunings", "failures") if not failed.empty else ("cells", "tunings")
    options = {"report": task.name, "folder": task.folder}
    key = uptodate.inputs_key(options, store.content_version(tables))
    directory = out / task.folder

    def write() -> list[Path]:
        written = task.report(cells, store.tunings_frame(), directory)
        return written + _write_failed(failed, directory)

    written = uptodate.report_once(directory, key, write)
    if not failed.empty:
        print(
            f"diffbench: warning: {len(failed)} cells of {task.name} failed and are not in its "
            f"tables (listed in {directory / FAILED_CSV}); the next run tries them again",
            file=sys.stderr,
        )
    current = provenance()["git_rev"]
    others = sorted(r[:12] for r in set(cells["git_rev"]) - {current})
    if others:
        print(
            f"diffbench: note: some stored cells of {task.name} were computed by other code "
            f"revisions ({', '.join(others)}); delete {store.directory} to recompute",
            file=sys.stderr,
        )
    return written


FAILED_CSV = "failed.csv"


def _write_failed(failed, directory: Path) -> list[Path]:
    """``failed.csv`` beside a report: the cells that failed (so none is silently missing);
    an older one is removed once none has."""
    path = directory / FAILED_CSV
    if failed.empty:
        path.unlink(missing_ok=True)
        return []
    failed.to_csv(path, index=False)
    return [path]


RECORDS_FLAG = ("--records",)
RECORDS_OPTIONS = {
    "nargs": "+",
    "type": Path,
    "metavar": "CSV",
    "help": "identify-dfki only: recordings in the DFKI lab's CSV layout (time, pos_meas1/2, "
    "tau_meas1/2, tau_con1/2; .csv or .csv.gz), at least 3, instead of the six packaged runs",
}


ROBOT_MODEL_FLAG = ("--robot-model",)
ROBOT_MODEL_OPTIONS = {
    "type": Path,
    "metavar": "FILE",
    "help": "with --records only: the robot that recorded them, the DFKI lab's "
    "model_parameters.yml of their design (identified_parameters/design_<name>/...; default "
    "the packaged design C.0 model); records that evidently are not of it are refused",
}


def _task_of(args):
    """The task ``args.task``, on ``args.records`` (identify-dfki only) of the robot
    ``args.robot_model`` when given."""
    records = getattr(args, "records", None)
    model = getattr(args, "robot_model", None)
    if not records:
        if model is not None:
            raise UsageError(
                "--robot-model is valid with --records only (it describes the robot that "
                "recorded them): add --records CSV... or drop --robot-model"
            )
        return _task(args.task)
    if args.task != "identify-dfki":
        raise UsageError(f"--records is for identify-dfki only, not {args.task!r}")
    if getattr(args, "jobs", 1) > 1 and not executor.forks():
        args.jobs = 1  # workers started afresh would not know a task registered here
    if model is not None:
        with user_input("--robot-model: "):
            model = load_pendulum_model(model)
    with user_input("--records: "):
        return dfki_task(records, robot_model=model)


def _cmd_run(args) -> None:
    _run_task(_task_of(args), args)


def _run_task(task, args) -> None:
    """Any task, a study too: its tunings (stored, reused), then its cells, then its report."""
    names = _method_names(getattr(args, "methods", None))
    if isinstance(task, ItemStudy):
        with user_input():
            items = task.items(names, task.seeds(getattr(args, "seeds", None)))
        rows = _run_items(task, items, _open_store(args.out), args)
        for path in runner.report_items(task, rows, args.out):
            print(path)
        return
    with user_input():
        seeds = task.seeds(args.seeds)
        jobs_list = task.tuning_jobs(names, args.orders)
        cells = None if jobs_list else task.plan({}, names, seeds)
    store = _open_store(args.out)
    if jobs_list:
        found, _ = _tune(jobs_list, store, args)
        cells = task.plan(found, names, seeds)
    _say(_run_cells(cells, store, args))
    for path in _report(task, store, args.out):
        print(path)


def _cmd_report(args) -> None:
    task = _task_of(args)
    if not store_exists(args.out / "store"):
        raise UsageError(
            f"no results store in {args.out / 'store'}; run "
            f"`diffbench run {task.name} --out {args.out}` first"
        )
    for path in _report(task, _open_store(args.out), args.out):
        print(path)


def _check_cutoff(cutoff_hz: float, task, criteria, region: str) -> None:

    realisation = task.tuning_data(0)
    for criterion in criteria:
        with user_input(f"--cutoff-hz on {task.name}: "):
            tuning.check_cutoff(cutoff_hz, realisation, criterion, region)


def _cmd_tune(args) -> None:
    task = _task(args.task)
    tuned_on = range(args.tuning_seed, args.tuning_seed + args.tuning_seeds)
    if tuned_on[-1] > runner.MAX_SEED:
        raise UsageError(
            f"--tuning-seed {args.tuning_seed} with --tuning-seeds {args.tuning_seeds} goes "
            f"past the largest seed {runner.MAX_SEED}; choose a tuning seed <= "
            f"{runner.MAX_SEED - args.tuning_seeds + 1}"
        )
    with user_input():
        seeds = task.seeds(args.seeds)
        task.tuning_data(tuned_on[-1])
    if set(tuned_on) & set(seeds):
        span = "" if len(tuned_on) == 1 else f" .. {tuned_on[-1]} (--tuning-seeds)"
        raise UsageError(
            f"--tuning-seed {args.tuning_seed}{span} overlaps the scored seeds "
            f"0..{seeds[-1]}; choose a tuning seed >= {len(seeds)}"
        )
    names = _method_names(_name_list(args.method))
    if args.region == "whole" and "no-truth" in args.criteria:
        raise UsageError(
            "--region whole cannot go with the no-truth criterion (a spectral estimate that "
            "knows no ends): use --criteria oracle or pynumdiff"
        )
    data_only = [c for c in args.criteria if c in tuning.DATA_ONLY_CRITERIA]  # need f_c
    if data_only:
        _check_cutoff(args.cutoff_hz, task, data_only, args.region)
    jobs_list = []
    for criterion in args.criteria:
        for name in names:
            if criterion == "no-truth" and not methods.method_class(name).linear:
                print(f"{name}: not linear, skipped for the no-truth criterion", file=sys.stderr)
                continue
            cutoff = args.cutoff_hz if criterion in data_only else None
            jobs_list += [
                runner.TuningJob(
                    task.name,
                    name,
                    criterion,
                    order,
                    args.tuning_seed,
                    cutoff,
                    budget=args.budget,
                    tuning_seeds=args.tuning_seeds,
                    region=args.region,
                )
                for order in args.orders
            ]
    store = _open_store(args.out)
    found, _ = _tune(jobs_list, store, args)
    for job, record in found.items():
        chosen = ", ".join(f"{k}={v!r}" for k, v in record["params"].items())
        print(
            f"{job.method} ({job.role.label}): {chosen or 'no setting covers the task'} "
            f"(loss {record['loss']:.4g}, {record['evaluations']} evaluations)"
        )
    entries = runner.tuned_entries(found)
    cells = [cell for entry in entries for cell in entry.cells(task.name, seeds)]
    _say(_run_cells(cells, store, args))
    for path in _report(task, store, args.out):
        print(path)


def _tune(jobs_list, store: Store, args):
    try:
        found, summary = runner.tune_all(
            jobs_list, store, jobs=args.jobs, progress=_progress(args, "tuning")
        )
    except (KeyboardInterrupt, Terminated) as stop:
        print(
            "diffbench: interrupted; finished tunings are stored; run the same command to resume",
            file=sys.stderr,
        )
        code = EXIT_INTERRUPTED if isinstance(stop, KeyboardInterrupt) else EXIT_TERMINATED
        raise SystemExit(code) from None
    except runner.PluginFailed as error:
        raise UsageError(f"{error}; finished tunings are stored") from None
    print(f"{summary.computed} tunings computed, {summary.reused} reused from the store")
    return found, summary


def _cmd_grid(args) -> None:
    """``diffbench grid``: ``diffbench run grid`` (the study task)."""
    _run_task(_task("grid"), args)


def _cmd_limit(args) -> None:
    """``diffbench limit``: ``diffbench run limit``, on ``--scenarios`` if given."""
    with user_input():  # its message names `scenarios`
        study = LimitStudy(tuple(args.scenarios or ()))
    _run_task(study, args)


def _cmd_pareto(args) -> None:
    """``diffbench pareto TASK``: ``diffbench run pareto`` on that one record."""
    with user_input():
        study = ParetoStudy(scenarios=(args.task,))
    _run_task(study, args)


def _cmd_paper_figures(args) -> None:
    """``diffbench paper-figures``: ``diffbench run paper-figures``."""
    _run_task(_task("paper-figures"), args)


def _cmd_export(args) -> None:

    with user_input():
        realisation = signals.get_scenario(args.scenario).realise(args.seed)
        path = user_data.write_scenario_record(realisation, args.file)
    print(path)


def _cmd_recommend(args) -> None:

    names = _method_names(args.methods)
    with user_input():
        record = user_data.read_record(args.file, args.columns, args.time, args.dt)
    with user_input():
        results = recommend.recommend_record(
            record, names, tuple(args.orders), max_evaluations=args.budget
        )
    out = args.out if args.out is not None else Path(f"recommend-{args.file.stem}")
    for channel, (advice, _) in results.items():
        for order in args.orders:
            name, params = advice.best(order)
            print(f"{channel} {'ẋẍ'[order - 1]}: {name} {params}")
    for path in recommend.write_recommendation(record, results, out):
        print(path)


def _cmd_recommend_check(args) -> None:
    """``diffbench recommend-check``: ``diffbench run recommend-check``, on ``--scenarios``."""
    with user_input("--scenarios: "):
        study = RecommendCheck(tuple(args.scenarios or ()))
    legacy = args.out / study.folder / "rows.jsonl"
    if legacy.exists():
        print(
            f"diffbench: note: {legacy} (an older diffbench's) is no longer read; the rows "
            f"are kept in {args.out / 'store'}",
            file=sys.stderr,
        )
    _run_task(study, args)


def _cmd_timing(args) -> None:
    """``diffbench timing``: ``diffbench run timing`` up to ``--largest`` samples."""
    _run_task(TimingStudy(largest_samples=args.largest, ratios=args.ratios), args)


# --- entry point ---------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``diffbench`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    previous = terminate_on_sigterm()
    stdout = sys.stdout
    if stdout is not None and stdout is sys.__stdout__:
        sys.stdout = _NamedOutput(stdout)  # its OSErrors name it (e.g. `> /dev/full`)
    try:
        with warnings.catch_warnings():  # restores the caller's warning display afterwards
            warnings.showwarning = functools.partial(_one_line_warning, warnings.showwarning)
            return _main(argv)
    finally:
        # called in-process (a test, a script), the caller keeps its own SIGTERM handling
        signal.signal(signal.SIGTERM, previous)
        sys.stdout = stdout


def _one_line_warning(fallback, message, category, filename, lineno, file=None, line=None):
    """diffbench's own warnings (about the user's record, a failed cell...) as one line on
    stderr, ``diffbench: warning: ...``; other packages' by ``fallback`` (the usual form)."""
    if category.__module__.startswith("diffbench."):
        print(f"diffbench: warning: {message}", file=sys.stderr if file is None else file)
    else:
        fallback(message, category, filename, lineno, file, line)


class _NamedOutput:
    """The standard output, whose ``OSError`` names it as its file (Python's own names none)."""

    def __init__(self, stream) -> None:
        self._stream = stream
        self.error: OSError | None = None

    def _named(self, call, *args):
        try:
            return call(*args)
        except BrokenPipeError:
            raise
        except OSError as error:
            if error.errno is None or error.filename is not None:
                raise
            # kept: a caller may swallow it (argparse's help does), the exit code may not
            self.error = type(error)(error.errno, error.strerror, STDOUT_NAME)
            raise self.error from None

    def write(self, text: str) -> int:
        return self._named(self._stream.write, text)

    def flush(self) -> None:
        return self._named(self._stream.flush)

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


STDOUT_NAME = "the standard output"


def _main(argv: list[str]) -> int:
    try:
        args = build_parser().parse_args(argv)
        set_command(argv)
        _load_plugins(args.plugins)
        _workers(args)
        args.handler(args)
    except UsageError as error:
        message = str(error).splitlines()[0] if str(error) else "bad command line"
        print(f"diffbench: error: {message}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:
        return _os_error(error)
    except KeyboardInterrupt:
        print("diffbench: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Terminated:
        print("diffbench: terminated", file=sys.stderr)
        return EXIT_TERMINATED
    except WorkerDied as error:
        print(f"diffbench: error: {error}", file=sys.stderr)
        return EXIT_INTERNAL
    except SystemExit as stop:  # argparse's --help and errors, a plugin's sys.exit at import
        code = int(stop.code or 0) if not isinstance(stop.code, str) else EXIT_USAGE
        return _flushed(code)
    return _flushed(0)


def _flushed(code: int) -> int:
    """``code``, once the standard output is flushed; the flush's ``OSError`` (a full disk
    under ``--help > /dev/full``) as one line and its exit code."""
    try:
        sys.stdout.flush()
    except OSError as error:
        return _os_error(error)
    swallowed = getattr(sys.stdout, "error", None)  # a failed write someone caught
    return _os_error(swallowed) if swallowed is not None else code


def _os_error(error: OSError) -> int:
    """An ``OSError`` the machine gave (the reader of the output gone, a disk full, the file
    size limit, a read-only or unwritable folder): one line naming the file, and the exit
    code; one without an error number is diffbench's bug, raised again (its traceback)."""
    if isinstance(error, BrokenPipeError):
        return _broken_pipe()
    if error.errno is None:
        raise error
    name = error.filename
    if name == STDOUT_NAME:
        _silence_stdout()  # so that Python's own flush at exit does not fail again
    where = f": {name}" if name is not None else " (writing a report or reading input)"
    reason = error.strerror or os.strerror(error.errno)
    print(f"diffbench: error: {reason}{where}", file=sys.stderr)
    return EXIT_USAGE


def _silence_stdout() -> None:
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())


def _broken_pipe() -> int:
    # The reader went away (e.g. `| head`): stop quietly, and keep Python's exit-time flush of
    # stdout from failing again (the pattern the Python documentation gives for SIGPIPE).
    _silence_stdout()
    return EXIT_BROKEN_PIPE


def console() -> None:
    """The console script: :func:`main`, with an internal error shown as its traceback and
    exit code 1 (Python's own behaviour for an uncaught exception)."""
    sys.exit(main())


if __name__ == "__main__":
    console()
