"""The options of the ``diffbench`` commands, as data: each an argparse flag with its keywords,
its ``dest`` the API's argument. A command (:data:`~diffbench.bench.cli.COMMANDS`) names the
options it takes; a name ending in a digit is a variant of an option (another default or help).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from diffbench.bench import runner
from diffbench.bench.arguments import (
    criteria,
    finite_positive,
    job_count,
    name_list,
    orders,
    positive_count,
    record_length,
    seed,
    seed_count,
    tuning_seed_count,
)
from diffbench.bench.arguments import for_argparse as typed
from diffbench.bench.arguments import timeout as timeout_s
from diffbench.bench.core import tuning

GROUPS_HELP = (
    "method names or groups (all, native, peers, causal; a leading - leaves one out: "
    "peers,-derivative.kernel"
)
TIMEOUT_HELP = (
    "most seconds one cell's computation may take; a cell past it is recorded as failed, the run "
    f"goes on, the next run tries it again (default {runner.DEFAULT_TIMEOUT_S:g}: the slowest "
    "built-in cell takes about 160 s)"
)


def _timeout_option(help_text: str) -> tuple[tuple[str, ...], dict[str, Any]]:
    """``--timeout SECONDS`` (into ``timeout_s``), with its help for the command at hand."""
    return (
        ("--timeout",),
        dict(
            dest="timeout_s",
            type=typed(timeout_s),
            default=runner.DEFAULT_TIMEOUT_S,
            metavar="SECONDS",
            help=help_text,
        ),
    )


OPTIONS: dict[str, tuple[tuple[str, ...], dict[str, Any]]] = {
    # name: (flags, argparse keywords); a name ending in a digit is a variant of an option
    "out": (
        ("--out",),
        dict(
            type=Path,
            default=Path("results"),
            help=(
                "results directory: reports in OUT/TASK/, the store in OUT/store/ "
                "(default results/)"
            ),
        ),
    ),
    "jobs": (
        ("--jobs",),
        dict(
            type=typed(job_count),
            default=1,
            help=(
                "local worker processes, or Dask workers with --executor dask (results "
                "identical to a serial run)"
            ),
        ),
    ),
    "executor": (
        ("--executor",),
        dict(
            choices=("local", "dask"),
            default="local",
            help=(
                "local: this machine's processes (--jobs); dask: a Dask LocalCluster of"
                " --jobs workers, or the scheduler given by --scheduler (pip install "
                "'diffbench[dask]')"
            ),
        ),
    ),
    "scheduler": (
        ("--scheduler",),
        dict(
            metavar="ADDRESS",
            default=None,
            help=(
                "a running Dask scheduler (tcp://host:8786; implies --executor dask): "
                "the workers compute, this process stores"
            ),
        ),
    ),
    "timeout": _timeout_option(TIMEOUT_HELP),
    "timeout2": _timeout_option(  # recommend's: it bounds calls, not cells
        "most seconds one call of a method may take (in its tuning or scoring); a method past "
        "it gets a row saying so and the others are still ranked (default "
        f"{runner.DEFAULT_TIMEOUT_S:g})"
    ),
    "progress": (
        ("--no-progress",),
        dict(dest="progress", action="store_false", help="no progress bar"),
    ),
    "report": (
        ("--no-report",),
        dict(
            dest="report",
            action="store_false",
            help="store the results but write no report (a later command on the task, or "
            "`diffbench report TASK`, writes it from the store)",
        ),
    ),
    "seeds": (
        ("--seeds",),
        dict(
            type=typed(seed_count),
            default=None,
            help="scored seeds 0..N-1 (default: the task's, 10 for signals)",
        ),
    ),
    "seeds2": (("--seeds",), dict(type=typed(seed_count), default=10, help="scored seeds 0..N-1")),
    "seeds3": (
        ("--seeds",),
        dict(
            type=typed(seed_count),
            default=20,
            help="noise seeds of the error-against-position figure (default 20)",
        ),
    ),
    "methods": (
        ("--methods",),
        dict(
            type=typed(name_list),
            default=None,
            help=f"comma-separated {GROUPS_HELP}; default: all)",
        ),
    ),
    "methods2": (
        ("--methods",),
        dict(
            type=typed(name_list),
            default=None,
            help=(
                "the methods drawn, names or groups (all, native, peers), "
                "comma-separated (default: all)"
            ),
        ),
    ),
    "methods3": (
        ("--methods",),
        dict(
            type=typed(name_list),
            default=None,
            help=f"{GROUPS_HELP}; default: native, or causal with --causal)",
        ),
    ),
    "causal": (
        ("--causal",),
        dict(
            action="store_true",
            help="for online use: recommend among the causal methods only (the estimate at t "
            "from the samples up to t), scored as they run on a stream",
        ),
    ),
    "methods4": (
        ("--methods",),
        dict(
            type=typed(name_list),
            default=None,
            help="methods to recommend among (default: the six that tune in seconds)",
        ),
    ),
    "plugins": (
        ("--plugin",),
        dict(
            dest="plugins",
            action="append",
            default=[],
            metavar="MODULE",
            help=(
                "import MODULE first, registering its methods (repeatable; installed "
                "plugins load by themselves through their entry points; see also "
                "$DIFFBENCH_PLUGINS)"
            ),
        ),
    ),
    "task": (("task",), dict(help="task name (see `diffbench list`)")),
    "task2": (("task",), dict(help="a signal task (see `diffbench list`)")),
    "task3": (("task",), dict(help="a signal task, e.g. limit-matern52-0.01")),
    "task4": (("task",), dict()),
    "orders": (
        ("--orders",),
        dict(
            type=typed(orders),
            default=[1, 2],
            help="derivatives a study (grid, limit) tunes for (default 1,2)",
        ),
    ),
    "orders2": (
        ("--orders",),
        dict(
            type=typed(orders), default=[2], help="derivatives tuned for: 1, 2 or 1,2 (default 2)"
        ),
    ),
    "orders3": (
        ("--orders",),
        dict(type=typed(orders), default=[1, 2], help="derivatives tuned for (default 1,2)"),
    ),
    "orders4": (
        ("--orders",),
        dict(type=typed(orders), default=[1, 2], help="derivatives to recommend for (1,2)"),
    ),
    "records": (
        ("--records",),
        dict(
            nargs="+",
            type=Path,
            metavar="CSV",
            help=(
                "identify-dfki only: recordings in the DFKI lab's CSV layout (time, "
                "pos_meas1/2, tau_meas1/2, tau_con1/2; .csv or .csv.gz), at least 3, "
                "instead of the six packaged runs"
            ),
        ),
    ),
    "robot_model": (
        ("--robot-model",),
        dict(
            type=Path,
            metavar="FILE",
            help=(
                "with --records only: the robot that recorded them, the DFKI lab's "
                "model_parameters.yml of their design "
                "(identified_parameters/design_<name>/...; default the packaged design "
                "C.0 model); records that evidently are not of it are refused"
            ),
        ),
    ),
    "method": (("methods",), dict(metavar="method", help=f"{GROUPS_HELP}), comma-separated")),
    "criteria": (
        ("--criteria",),
        dict(
            type=typed(criteria),
            default=["oracle"],
            help=(
                "oracle (against the truth), no-truth (spectral risk, linear methods), "
                "pynumdiff (PyNumDiff's loss), surrogate (the truth of surrogate "
                "records drawn from the record's spectrum); comma-separated (default "
                "oracle)"
            ),
        ),
    ),
    "cutoff_hz": (
        ("--cutoff-hz",),
        dict(
            type=typed(finite_positive),
            default=None,
            help=(
                "bandlimit guess of the no-truth and pynumdiff criteria, inside (0, "
                "Nyquist) (default 20); refused with the other criteria, which do not read it"
            ),
        ),
    ),
    "tuning_seed": (
        ("--tuning-seed",),
        dict(
            type=typed(seed),
            default=tuning.TUNING_SEED,
            help=f"noise seed tuned on (default {tuning.TUNING_SEED}; never scored)",
        ),
    ),
    "tuning_seeds": (
        ("--tuning-seeds",),
        dict(
            type=typed(tuning_seed_count),
            default=1,
            metavar="K",
            help=(
                "average the tuning loss over K seeds, TUNING_SEED .. TUNING_SEED+K-1 (default 1)"
            ),
        ),
    ),
    "budget": (
        ("--budget",),
        dict(
            type=typed(positive_count),
            default=None,
            metavar="N",
            help=(
                "at most N evaluations per differential-evolution run (default: 100 per"
                " searched parameter, within 150..400; one run per combination of "
                "choices)"
            ),
        ),
    ),
    "screen": (
        ("--screen",),
        dict(
            type=typed(positive_count),
            default=None,
            metavar="K",
            help=(
                "screen each combination of a method's choices by one generation of its "
                "search; only the K best are searched in full, sharing the budget of all "
                "(default: every combination in full)"
            ),
        ),
    ),
    "tuned_on": (
        ("--tuned-on",),
        dict(
            default=None,
            metavar="TASK",
            help=(
                "tune on TASK's tuning seeds instead (a signal task of the same step; its "
                "tunings stored and reused as its own) and score the settings on the task "
                "given: for a method too costly to tune on a long record"
            ),
        ),
    ),
    "budget2": (
        ("--budget",),
        dict(type=typed(positive_count), default=None, help="most evaluations per tuning"),
    ),
    "region": (
        ("--region",),
        dict(
            choices=("interior", "whole"),
            default="interior",
            help=(
                "samples the loss is taken on: the task's interior (default) or the "
                "whole record (every sample must be estimated; edge treatments are "
                "tuned too)"
            ),
        ),
    ),
    "scenarios": (
        ("--scenarios",),
        dict(
            type=typed(name_list),
            default=None,
            help=("limit scenarios, comma-separated (default: all; diffbench list names them)"),
        ),
    ),
    "scenarios2": (
        ("--scenarios",),
        dict(
            type=typed(name_list),
            default=None,
            help=("comma-separated scenario names (default: every uniformly sampled noisy one)"),
        ),
    ),
    "largest": (
        ("--largest",),
        dict(
            type=typed(record_length),
            default=10_000_000,
            help="the longest record timed, a power of ten from 1e4 (default 1e7)",
        ),
    ),
    "ratios": (
        ("--no-ratios",),
        dict(
            dest="ratios",
            action="store_false",
            help=("leave out the speed ratios against filterpy, scipy and PyNumDiff (about 3 min)"),
        ),
    ),
    "scenario": (("scenario",), dict(help="a scenario name (diffbench list shows them)")),
    "file": (("file",), dict(type=Path, help="the .csv or .parquet file to write")),
    "file2": (("file",), dict(type=Path, help="a .csv or .parquet file, one column per channel")),
    "seed": (("--seed",), dict(type=typed(seed), default=0, help="the noise seed (default 0)")),
    "columns": (
        ("--column",),
        dict(
            dest="columns",
            type=typed(name_list),
            default=None,
            help="comma-separated channel columns (default: every column but the time)",
        ),
    ),
    "time": (("--time",), dict(default=None, help="the time column (seconds)")),
    "dt": (("--dt",), dict(type=float, default=None, help="the sampling step (seconds)")),
    "out2": (
        ("--out",),
        dict(
            type=Path,
            default=None,
            help=("where the ranking, derivatives and figure go (default: recommend-FILESTEM/)"),
        ),
    ),
    "out3": (
        ("--out",),
        dict(
            type=Path,
            default=Path("results/studies"),
            help="the studies' results directory (default results/studies/; store in OUT/store/)",
        ),
    ),
    "timing_out": (
        ("--timing-out",),
        dict(
            type=Path,
            default=None,
            help="where the steps' timing table goes (default: OUT/../timing/)",
        ),
    ),
    "seeds4": (
        ("--seeds",),
        dict(
            type=typed(seed_count),
            default=20,
            help="scored seeds of the paper-signal and robot steps (default 20)",
        ),
    ),
    "only": (
        ("--only",),
        dict(
            type=typed(name_list),
            default=None,
            help="run only the steps of these studies, comma-separated (default: every step)",
        ),
    ),
}
"""Every option of every command, by name; a command names those it takes."""
