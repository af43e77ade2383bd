"""diffbench's Python API: every command of the ``diffbench`` command line is one function here.

>>> from diffbench.bench import api
>>> result = api.run("paper-signal", seeds=2, methods=["jacobi"], out=Path("results"))
>>> result.cells.computed, result.written

The functions take Python values, store what they compute in ``out/store`` (reused by the next
call) and return what they did: the files written and the summaries. They never print to the
standard output: news as the work goes is given to ``echo`` (the command line prints it),
progress bars go to stderr when ``progress`` is true, and remarks (a failed cell, a set-aside
record) are Python warnings (:class:`DiffbenchWarning`, :class:`DiffbenchNote`). Bad input
raises :class:`~diffbench.bench.core.errors.BadInput` (a ``ValueError``) naming the argument and
the fix; a message from a check deeper down names it as the command line does (``--seeds`` for
``seeds=``). An interrupted run (Ctrl-C, SIGTERM) raises its ``KeyboardInterrupt`` or
:class:`~diffbench.bench.core.executor.Terminated` with an attribute ``resume`` saying what is
stored; the same call resumes.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from diffbench import methods, signals
from diffbench.bench import runner
from diffbench.bench.arguments import (
    GROUPS,
    Echo,
    Workers,
    check,
    checked,
    dask_workers,
    finite_positive,
    load_plugins,
    method_names,
    name_list,
    one_of,
    open_store,
    positive_count,
    progress_bar,
    ready,
    record_length,
    say,
    seed_count,
    task_of,
    timeout,
    tuning_seed_count,
    tuning_task_for,
)
from diffbench.bench.arguments import criteria as criteria_list
from diffbench.bench.arguments import orders as order_list
from diffbench.bench.arguments import seed as noise_seed
from diffbench.bench.catalogue import list_methods, list_tasks
from diffbench.bench.core import executor, tuning
from diffbench.bench.core.errors import BadInput, DiffbenchNote, DiffbenchWarning, MethodSkipped
from diffbench.bench.core.executor import Terminated
from diffbench.bench.core.store import Store, store_exists
from diffbench.bench.studies import recommend as advice
from diffbench.bench.studies import user_data
from diffbench.bench.tasks import (
    ItemStudy,
    LimitStudy,
    ParetoStudy,
    RecommendCheck,
    Task,
    TimingStudy,
    get_task,
)

methods_module = methods  # several functions take an argument named `methods`

__all__ = [
    "GROUPS",
    "BadInput",
    "DiffbenchNote",
    "DiffbenchWarning",
    "MethodSkipped",
    "Recommendation",
    "RunResult",
    "dask_workers",
    "export_scenario",
    "list_methods",
    "list_tasks",
    "load_plugins",
    "method_names",
    "open_store",
    "pareto",
    "recommend",
    "recommend_check",
    "report",
    "run",
    "task_of",
    "timing",
    "tune",
]


# --- run, tune, report -----------------------------------------------------------------------
@dataclass
class RunResult:
    """What :func:`run` or :func:`tune` did: the tunings (None when none was asked for), the
    cells, the report's files, and (:func:`tune`) each tuning job's stored result."""

    tunings: runner.TuningSummary | None
    cells: runner.RunSummary
    written: list[Path]
    tuned: dict = field(default_factory=dict)


def run(
    task: str | Task,
    *,
    methods: str | Iterable[str] | None = None,
    seeds: int | None = None,
    orders: Iterable[int] = (1, 2),
    jobs: Workers = 1,
    timeout_s: float = runner.DEFAULT_TIMEOUT_S,
    out: Path = Path("results"),
    records: Sequence[Path] | None = None,
    robot_model: Path | None = None,
    scenarios: Iterable[str] | None = None,
    progress: bool = False,
    report: bool = True,
    echo: Echo | None = None,
) -> RunResult:
    """Run every method at its preset on a task (a study: its tunings first), write its report.

    Parameters
    ----------
    task : str or Task
        A task name (:func:`list_tasks`) or a task.
    methods : str or iterable of str, optional
        Method names or groups (all, native, peers, causal); default every method.
    seeds : int, optional
        Scored seeds 0..seeds-1 (default: the task's).
    orders : iterable of int
        Derivatives a study (grid, limit) tunes for.
    jobs : int or DaskWorkers
        Local worker processes, or :func:`dask_workers`; results identical to a serial run.
    timeout_s : float
        Most seconds one cell may take; past it the cell is recorded as failed (an item
        study's items have no such limit).
    out : Path
        Results directory: the store in ``out/store``, the report in ``out/<task folder>``.
    records, robot_model : optional
        identify-dfki only: the DFKI lab's CSV recordings, the robot's model file.
    scenarios : iterable of str, optional
        The studies limit, pareto and recommend-check only: the scenarios they run on
        (default theirs).
    progress : bool
        Show progress bars on stderr.
    report : bool
        Write the task's report (False: only store, for a later command on the task to report).
    echo : callable, optional
        Called with each line of news (tunings and cells computed).

    Returns
    -------
    RunResult
    """
    seeds = None if seeds is None else check("seeds", seed_count, seeds)
    orders = check("orders", order_list, orders)
    timeout_s = check("timeout_s", timeout, timeout_s)
    if records and isinstance(jobs, executor.DaskWorkers):
        raise BadInput("--records runs on this machine only: drop --executor/--scheduler")
    jobs = ready(jobs)
    if scenarios is not None:
        if task not in SCENARIO_STUDIES:
            raise BadInput(
                f"scenarios: only the studies {', '.join(SCENARIO_STUDIES)} take scenarios, "
                f"not {task!r}"
            )
        with checked("--scenarios: "):
            chosen = tuple(check("scenarios", name_list, scenarios))
            task = SCENARIO_STUDIES[task](scenarios=chosen)
    if records and jobs > 1 and not executor.forks():
        jobs = 1  # workers started afresh would not know a task registered here
    task = task_of(task, records, robot_model)
    names = method_names(methods)
    if isinstance(task, ItemStudy):
        with checked():
            items = task.items(names, task.seeds(seeds))
        rows, summary = _run_items(task, items, open_store(out), jobs, progress, echo)
        written = runner.report_items(task, rows, Path(out)) if report else []
        return RunResult(None, summary, written)
    with checked():
        seed_list = task.seeds(seeds)
        jobs_list = task.tuning_jobs(names, orders)
        cells = None if jobs_list else task.plan({}, names, seed_list)
    store = open_store(out)
    tunings = None
    if jobs_list:
        found, tunings = _tune(jobs_list, store, jobs, timeout_s, progress, echo)
        cells = task.plan(found, names, seed_list)
    summary = _run_cells(cells, store, jobs, timeout_s, progress, echo)
    written = runner.report_task(task, store, Path(out)) if report else []
    return RunResult(tunings, summary, written)


DEFAULT_CUTOFF_HZ = 20.0
"""The data-only criteria's bandlimit guess when none is given (:func:`tune`)."""


def tune(
    methods: str | Iterable[str],
    task: str,
    *,
    criteria: str | Iterable[str] = ("oracle",),
    orders: Iterable[int] = (2,),
    cutoff_hz: float | None = None,
    tuning_seed: int = tuning.TUNING_SEED,
    tuning_seeds: int = 1,
    budget: int | None = None,
    region: str = "interior",
    screen: int | None = None,
    tuned_on: str | None = None,
    seeds: int | None = None,
    jobs: Workers = 1,
    timeout_s: float = runner.DEFAULT_TIMEOUT_S,
    out: Path = Path("results"),
    progress: bool = False,
    report: bool = True,
    echo: Echo | None = None,
) -> RunResult:
    """Tune methods on a signal task's tuning seed (stored, reused), score them on other seeds.

    Parameters
    ----------
    methods : str or iterable of str
        Method names or groups (all, native, peers, causal).
    task : str
        A signal task.
    criteria : str or iterable of str
        oracle, no-truth, pynumdiff, surrogate (see ``diffbench tune --help``).
    orders : iterable of int
        Derivatives tuned for.
    cutoff_hz : float, optional
        Bandlimit guess of the data-only criteria (no-truth, pynumdiff), inside (0, Nyquist);
        default :data:`DEFAULT_CUTOFF_HZ`. Refused when no criterion given reads it.
    tuning_seed, tuning_seeds : int
        The noise seeds tuned on, ``tuning_seed .. tuning_seed + tuning_seeds - 1`` (unscored).
    budget : int, optional
        Most evaluations per differential-evolution run.
    region : {"interior", "whole"}
        The samples the loss is taken on.
    screen : int, optional
        With more combinations of a method's choice parameters than this, each is screened
        by one generation of its search and only this many best are searched in full,
        sharing the budget of all (default: every combination, each with its own budget).
    tuned_on : str, optional
        A signal task of the same step to tune on instead (rows say so; scored on ``task``).
    seeds, jobs, timeout_s, out, progress, report, echo
        As for :func:`run`; ``echo`` also gets each tuning found.

    Returns
    -------
    RunResult
        With ``tuned``: each tuning job's stored result (params, loss, evaluations).
    """
    orders = check("orders", order_list, orders)
    criteria = check("criteria", criteria_list, criteria)
    given_cutoff = cutoff_hz is not None
    cutoff_hz = check(
        "cutoff_hz", finite_positive, DEFAULT_CUTOFF_HZ if cutoff_hz is None else cutoff_hz
    )
    tuning_seed = check("tuning_seed", noise_seed, tuning_seed)
    tuning_seeds = check("tuning_seeds", tuning_seed_count, tuning_seeds)
    budget = None if budget is None else check("budget", positive_count, budget)
    region = check("region", one_of("interior", "whole"), region)
    screen = None if screen is None else check("screen", positive_count, screen)
    seeds = None if seeds is None else check("seeds", seed_count, seeds)
    timeout_s = check("timeout_s", timeout, timeout_s)
    jobs = ready(jobs)
    with checked():
        task = get_task(task)
    tuning_task = task if tuned_on is None else tuning_task_for(tuned_on, task)
    tuned_seeds = range(tuning_seed, tuning_seed + tuning_seeds)
    if tuned_seeds[-1] > runner.MAX_SEED:
        raise BadInput(
            f"--tuning-seed {tuning_seed} with --tuning-seeds {tuning_seeds} goes past the "
            f"largest seed {runner.MAX_SEED}; choose a tuning seed <= "
            f"{runner.MAX_SEED - tuning_seeds + 1}"
        )
    with checked():
        seed_list = task.seeds(seeds)
        tuning_task.tuning_data(tuned_seeds[-1])
    if set(tuned_seeds) & set(seed_list):
        span = "" if len(tuned_seeds) == 1 else f" .. {tuned_seeds[-1]} (--tuning-seeds)"
        raise BadInput(
            f"--tuning-seed {tuning_seed}{span} overlaps the scored seeds "
            f"0..{seed_list[-1]}; choose a tuning seed >= {len(seed_list)}"
        )
    names = method_names(methods)
    if region == "whole" and "no-truth" in criteria:
        raise BadInput(
            "--region whole cannot go with the no-truth criterion (a spectral estimate that "
            "knows no ends): use --criteria oracle or pynumdiff"
        )
    data_only = [c for c in criteria if c in tuning.DATA_ONLY_CRITERIA]  # need f_c
    if given_cutoff and not data_only:
        raise BadInput(
            f"--cutoff-hz is read by the {' and '.join(tuning.DATA_ONLY_CRITERIA)} criteria "
            f"only, not by {', '.join(criteria)}: drop it, or add one of them to --criteria"
        )
    if data_only:
        realisation = tuning_task.tuning_data(0)
        for criterion in data_only:
            with checked(f"--cutoff-hz on {tuning_task.name}: "):
                tuning.check_cutoff(cutoff_hz, realisation, criterion, region)
    search = dict(budget=budget, tuning_seeds=tuning_seeds, region=region, screen=screen)
    on = tuning_task.name  # the task tuned on
    jobs_list = []
    for criterion in criteria:
        for name in names:
            if criterion == "no-truth" and not methods_module.method_class(name).linear:
                message = f"{name}: not linear, skipped for the no-truth criterion"
                warnings.warn(message, MethodSkipped, stacklevel=2)
                continue
            cutoff = cutoff_hz if criterion in data_only else None
            jobs_list += [
                runner.TuningJob(on, name, criterion, order, tuning_seed, cutoff, **search)
                for order in orders
            ]
    store = open_store(out)
    found, tunings = _tune(jobs_list, store, jobs, timeout_s, progress, echo)
    for job, record in found.items():
        chosen = ", ".join(f"{k}={v!r}" for k, v in record["params"].items())
        say(
            echo,
            f"{job.method} ({job.role.label}): {chosen or 'no setting covers the task'} "
            f"(loss {record['loss']:.4g}, {record['evaluations']} evaluations)",
        )
    entries = runner.tuned_entries(found, scored=task.name)
    cells = [cell for entry in entries for cell in entry.cells(task.name, seed_list)]
    summary = _run_cells(cells, store, jobs, timeout_s, progress, echo)
    written = runner.report_task(task, store, Path(out)) if report else []
    return RunResult(tunings, summary, written, found)


def _tune(
    jobs_list, store: Store, jobs: Workers, timeout_s: float, progress: bool, echo: Echo | None
):
    try:
        found, summary = runner.tune_all(
            jobs_list,
            store,
            jobs=jobs,
            progress=progress_bar(progress, "tuning"),
            timeout_s=timeout_s,
        )
    except (KeyboardInterrupt, Terminated) as stop:
        stop.resume = "interrupted; finished tunings are stored; run the same command to resume"
        raise
    text = f"{summary.computed} tunings computed, {summary.reused} reused from the store"
    if summary.failed:
        text += f", {len(summary.failed)} failed (not stored; the next run tries them again)"
    say(echo, text)
    if summary.failed and not found:
        raise BadInput(f"{summary.failed[0][1]}; nothing else to tune")
    for _, reason in summary.failed:
        warnings.warn(f"tuning failed: {reason}", DiffbenchWarning, stacklevel=3)
    return found, summary


def _run_cells(cells, store: Store, jobs: Workers, timeout_s: float, progress, echo):
    try:
        summary = runner.run(
            cells, store, progress=progress_bar(progress, "cell"), jobs=jobs, timeout_s=timeout_s
        )
    except (KeyboardInterrupt, Terminated) as stop:
        store.refresh()
        stop.resume = (
            f"interrupted; {len(store.cells.records)} cells are stored in {store.directory}; "
            "run the same command to resume"
        )
        raise
    say(echo, summary.news())
    for cell, reason in summary.failed:
        warnings.warn(
            f"cell failed: {cell.method} on {cell.task} seed {cell.seed}: {reason}",
            DiffbenchWarning,
            stacklevel=3,
        )
    return summary


def _run_items(study: ItemStudy, items, store: Store, jobs: Workers, progress, echo):
    try:
        rows, summary = runner.run_items(
            study, items, store, progress=progress_bar(progress, "item"), jobs=jobs
        )
    except (KeyboardInterrupt, Terminated) as stop:
        stop.resume = (
            f"interrupted; the finished items of {study.name} are stored in "
            f"{store.directory}; run the same command to resume"
        )
        raise
    say(echo, f"{summary.computed} items computed, {summary.skipped} already stored")
    return rows, summary


# --- the studies' own commands (aliases of run) ----------------------------------------------
SCENARIO_STUDIES = {"limit": LimitStudy, "pareto": ParetoStudy, "recommend-check": RecommendCheck}
"""The studies that take a subset of scenarios (``scenarios=``), by name."""


def pareto(
    task: str,
    *,
    methods: str | Iterable[str] | None = None,
    jobs: Workers = 1,
    out: Path = Path("results"),
    progress: bool = False,
    echo: Echo | None = None,
) -> RunResult:
    """:func:`run` of the ``pareto`` study on one record ``task`` (e.g. limit-iwn2-0.01):
    each method's front of accuracy against smoothness without the truth, with its knee and
    the oracle's setting (``out/limit/pareto_<task>.*``)."""
    return run(
        "pareto",
        scenarios=[task],
        methods=methods,
        jobs=jobs,
        out=out,
        progress=progress,
        echo=echo,
    )


def recommend_check(
    *,
    scenarios: Iterable[str] | None = None,
    methods: str | Iterable[str] | None = None,
    jobs: Workers = 1,
    out: Path = Path("results"),
    progress: bool = False,
    echo: Echo | None = None,
) -> RunResult:
    """:func:`run` of the ``recommend-check`` study: :func:`recommend` scored against the truth
    on signal scenarios taken as unknown (default every uniformly sampled noisy one), each
    scenario one stored item."""
    legacy = Path(out) / "recommend-validation" / "rows.jsonl"
    if legacy.exists():
        warnings.warn(
            f"{legacy} (an older diffbench's) is no longer read; the rows are kept in "
            f"{Path(out) / 'store'}",
            DiffbenchNote,
            stacklevel=2,
        )
    return run(
        "recommend-check",
        scenarios=scenarios,
        methods=methods,
        jobs=jobs,
        out=out,
        progress=progress,
        echo=echo,
    )


def timing(
    *,
    largest: int = 10_000_000,
    ratios: bool = True,
    methods: str | Iterable[str] | None = None,
    jobs: Workers = 1,
    out: Path = Path("results"),
    progress: bool = False,
    echo: Echo | None = None,
) -> RunResult:
    """:func:`run` of the ``timing`` study: throughput and peak memory of every method against
    the record's length up to ``largest`` samples (a power of ten), and (``ratios``) the speed
    ratios against the peers, in ``out/timing``. Each method's timings are one stored item."""
    largest = check("largest", record_length, largest)
    study = TimingStudy(largest_samples=largest, ratios=bool(ratios))
    return run(study, methods=methods, jobs=jobs, out=out, progress=progress, echo=echo)


def report(
    task: str | Task,
    *,
    out: Path = Path("results"),
    records: Sequence[Path] | None = None,
    robot_model: Path | None = None,
) -> list[Path]:
    """Render a task's report again from the store ``out/store``; returns the report's files
    (written again only when the stored rows or the code changed). An item study's report is
    rendered at its defaults (every method; its default seeds and scenarios)."""
    task = task_of(task, records, robot_model)
    out = Path(out)
    if not store_exists(out / "store"):
        raise BadInput(
            f"no results store in {out / 'store'}; run "
            f"`diffbench run {task.name} --out {out}` first"
        )
    store = open_store(out)
    if isinstance(task, ItemStudy):  # its report at its defaults, from the items stored
        with checked():
            items = task.items(None, task.seeds(None))
        rows = runner.stored_items(task, items, store)
        missing = sum(found is None for found in rows.values())
        if missing:
            raise BadInput(
                f"{missing} of the {len(rows)} items of {task.name} (at its defaults) are not "
                f"stored in {store.directory}; run `diffbench run {task.name} --out {out}` first"
            )
        return runner.report_items(task, rows, out)
    return runner.report_task(task, store, out)


# --- a user's record ------------------------------------------------------------------------
def export_scenario(scenario: str, file: Path, *, seed: int = 0) -> Path:
    """Write a scenario's record (time, samples and truth) with noise seed ``seed`` as a user's
    ``.csv`` or ``.parquet`` file; returns its path."""
    seed = check("seed", noise_seed, seed)
    with checked():
        realisation = signals.get_scenario(scenario).realise(seed)
        return user_data.write_scenario_record(realisation, Path(file))


@dataclass
class Recommendation:
    """What :func:`recommend` found: per channel its advice and estimates
    (``{channel: (Recommendation, {order: Estimate})}``), the best method and setting per
    channel and order, and the files written."""

    results: dict
    best: dict[tuple[str, int], tuple[str, dict]]
    written: list[Path]


def recommend_out(file: Path, out: Path | None = None) -> Path:
    """Where :func:`recommend` writes for ``file``: ``out``, or ``recommend-<file stem>/``."""
    return Path(out) if out is not None else Path(f"recommend-{Path(file).stem}")


def recommend(
    file: Path,
    *,
    columns: Iterable[str] | None = None,
    time: str | None = None,
    dt: float | None = None,
    methods: str | Iterable[str] | None = None,
    causal: bool = False,
    orders: Iterable[int] = (1, 2),
    budget: int | None = None,
    out: Path | None = None,
    jobs: Workers = 1,
    timeout_s: float = runner.DEFAULT_TIMEOUT_S,
    progress: bool = False,
) -> Recommendation:
    """Which method, with which settings, for a user's record (a ``.csv`` or ``.parquet`` file,
    one column per channel): the ranking, derivatives and figure go to ``out`` (default
    :func:`recommend_out`). ``jobs``: local worker processes or Dask workers, each tuning and
    scoring one method for one order (the same recommendation as one process); ``progress``:
    a bar per channel on stderr, with its time left. ``methods``: names or groups (default
    ``native``); ``causal``: for online use, among the causal methods only (default all of
    them: the estimate at t from the samples up to t, scored as they run on a stream).
    ``timeout_s`` bounds each call of a method: one that outlives it is reported in its row
    and the ranking goes on."""
    orders = check("orders", order_list, orders)
    timeout_s = check("timeout_s", timeout, timeout_s)
    jobs = ready(jobs)
    budget = None if budget is None else check("budget", positive_count, budget)
    columns = None if columns is None else check("columns", name_list, columns)
    names = method_names(methods if methods is not None else ("causal" if causal else "native"))
    offline = [name for name in names if not methods_module.method_class(name).causal]
    if causal and offline:
        verb = "is not causal (it reads" if len(offline) == 1 else "are not causal (they read"
        raise BadInput(
            f"--causal: {', '.join(offline)} {verb} samples after t); drop "
            f"{'it' if len(offline) == 1 else 'them'}, or give --methods causal"
        )
    file = Path(file)
    with checked():
        record = user_data.read_record(file, columns, time, dt)
    if causal and record.t is not None and not record.uniform:
        raise BadInput(
            f"--causal: {file} has irregular time stamps; the causal methods take uniformly "
            "sampled records only (resampling reads the next sample): give a uniform record"
        )
    with checked():
        results = advice.recommend_record(
            record,
            names,
            tuple(orders),
            max_evaluations=budget,
            jobs=jobs,
            progress=progress_bar(progress, "tuning"),
            timeout_s=timeout_s,
        )
    out = recommend_out(file, out)
    best = {
        (channel, order): found.best(order)
        for channel, (found, _) in results.items()
        for order in orders
    }
    return Recommendation(results, best, advice.write_recommendation(record, results, out))
