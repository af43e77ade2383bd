"""The ``diffbench`` command line: a thin layer over the Python API.

Each command is a row of :data:`COMMANDS`: the options it takes (by name, from
:data:`~diffbench.bench.cli_options.OPTIONS`; each option's ``dest`` is the argument of the
API's function, :mod:`.api`), the function it calls, and its help. What the function returns
(the files written) is printed; its news lines as they come. Exit codes and errors:
:mod:`.console`.
"""

from __future__ import annotations

import inspect
from importlib import metadata
from pathlib import Path
from typing import Any, NamedTuple

from diffbench.bench import api
from diffbench.bench.cli_options import OPTIONS
from diffbench.bench.console import WARNINGS_LOG, Parser, route_third_party_warnings
from diffbench.bench.console import run as run_process
from diffbench.bench.core.store import set_command
from diffbench.bench.studies import steps


class Command(NamedTuple):
    """A ``diffbench`` command: its help, the API function it calls (with ``fixed`` arguments
    besides the command line's), and the :data:`OPTIONS` it takes, in order."""

    help: str
    call: Any
    options: tuple[str, ...]
    fixed: dict = {}


OUT = ("out",)
WORK = ("jobs", "executor", "scheduler", "timeout", "progress")
ADVICE_WORK = ("jobs", "executor", "scheduler", "timeout2", "progress")  # per call, not cell
ITEMS = ("jobs", "executor", "scheduler", "progress")  # an item study has no per-call timeout
PLUG = ("plugins",)
RUN = (*OUT, *WORK, "seeds", "methods", *PLUG, "report")
TUNE = (*OUT, *WORK, "seeds", *PLUG, "method", "task2", "criteria", "orders2", "cutoff_hz")
TUNE = (*TUNE, "tuning_seed", "tuning_seeds", "budget", "screen", "region", "tuned_on", "report")
SWEEP = (*OUT, *WORK, *PLUG, "methods", "seeds2", "orders3")
ADVICE = ("methods3", "causal", "orders4", "budget2", "out2")


def _list() -> list[str]:
    """What ``diffbench list`` prints: the methods, then the tasks."""
    header = "methods (name: parameter range [tuning range] default; presets)"
    return [header, *api.list_methods(), "tasks (diffbench run TASK)", *api.list_tasks()]


COMMANDS: dict[str, Command] = {
    "list": Command("methods (parameters, ranges, presets) and tasks", _list, PLUG),
    "run": Command(
        "run every method at its preset on a task, write its report",
        api.run,
        (*RUN, "task", "orders", "records", "robot_model"),
    ),
    "tune": Command(
        "tune methods on a task's tuning seed (stored, reused), score on other seeds",
        api.tune,
        TUNE,
    ),
    "grid": Command(
        "tune every method on the noise x level x step grid, score it, name the winners",
        api.run,
        SWEEP,
        {"task": "grid"},
    ),
    "limit": Command(
        "tune every method on the random signals with a known least error, score its "
        "efficiency (results in OUT/limit/)",
        api.run,
        (*SWEEP, "scenarios"),
        {"task": "limit"},
    ),
    "pareto": Command(
        "each method's front of accuracy against smoothness without the truth, with its "
        "knee and the oracle's setting (OUT/limit/pareto_TASK.*)",
        api.pareto,
        (*OUT, *ITEMS, *PLUG, "methods", "task3"),
    ),
    "paper-figures": Command(
        "the paper's figures 1-3 (PNG + CSV), frequency table, error against position",
        api.run,
        (*OUT, *ITEMS, *PLUG, "seeds3", "methods2"),
        {"task": "paper-figures"},
    ),
    "studies": Command(
        "every long study (make studies), each step its own diffbench process, resumable; "
        "each step's wall time in TIMING_OUT/studies.md",
        steps.run_studies,
        ("out3", "timing_out", "seeds4", "jobs", "only"),
    ),
    "timing": Command(
        "throughput and peak memory of every method vs signal length, and the speed "
        "ratios against the peers",
        api.timing,
        (*OUT, *ITEMS, *PLUG, "methods", "largest", "ratios"),
    ),
    "export": Command(
        "write a scenario's record (time, samples and truth) as a user's CSV or Parquet file",
        api.export_scenario,
        (*PLUG, "scenario", "file", "seed"),
    ),
    "recommend": Command(
        "which method, with which settings, for your own record (CSV or Parquet)",
        api.recommend,
        (*PLUG, *ADVICE_WORK, "file2", "columns", "time", "dt", *ADVICE),
    ),
    "recommend-check": Command(
        "score `recommend` against the truth on the signal scenarios (as if unknown)",
        api.recommend_check,
        (*OUT, *PLUG, *ITEMS, "scenarios2", "methods4"),
    ),
    "report": Command(
        "render a task's report again from the store",
        api.report,
        (*OUT, *PLUG, "task4", "records", "robot_model"),
    ),
}
"""Every command: name → :class:`Command`."""

CLI_ONLY = ("command", "plugins", "executor", "scheduler")
"""Options the command line acts on itself rather than give to the API."""


def build_parser() -> Parser:
    """The argparse parser of every command in :data:`COMMANDS`."""
    parser = Parser(prog="diffbench", description=__doc__.splitlines()[0])
    version = f"diffbench {metadata.version('diffbench')}"
    parser.add_argument("--version", action="version", version=version)
    commands = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for name, command in COMMANDS.items():
        sub = commands.add_parser(name, help=command.help)
        for option in command.options:
            flags, keywords = OPTIONS[option]
            sub.add_argument(*flags, **keywords)
    return parser


def _echo(line: str) -> None:
    print(line, flush=True)


def _dispatch(argv: list[str]) -> None:
    """Parse ``argv``, call the command's API function, print what it returns."""
    args = build_parser().parse_args(argv)
    set_command(argv)
    out = getattr(args, "out", None)
    if args.command == "recommend":
        out = api.recommend_out(args.file, out)
    if isinstance(out, Path):  # other packages' warnings: a log there
        route_third_party_warnings(out / WARNINGS_LOG)
    api.load_plugins(getattr(args, "plugins", ()))  # studies: each step loads its own
    command = COMMANDS[args.command]
    given = {k: v for k, v in vars(args).items() if k not in CLI_ONLY}
    if "executor" in vars(args) and (args.executor == "dask" or args.scheduler is not None):
        given["jobs"] = api.dask_workers(args.jobs, args.scheduler, args.plugins)
    accepted = inspect.signature(command.call).parameters
    given = {k: v for k, v in {**given, "echo": _echo}.items() if k in accepted}
    _show(command.call(**given, **command.fixed))


def _show(result) -> None:
    """Print what an API function returned: lines, advice, the files written."""
    if isinstance(result, api.Recommendation):
        for (channel, order), (name, params) in result.best.items():
            print(f"{channel} {'ẋẍ'[order - 1]}: {name} {params}")
    if isinstance(result, Path):
        result = [result]
    for line in getattr(result, "written", result) or ():
        print(line)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``diffbench`` console script; returns the exit code."""
    return run_process(_dispatch, argv)


def console() -> None:
    """The console script: :func:`main`, with an internal error shown as its traceback and
    exit code 1 (Python's own behaviour for an uncaught exception)."""
    raise SystemExit(main())


if __name__ == "__main__":
    console()
