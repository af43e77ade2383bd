"""The runner: expand a task into cells, compute each one, store it at once.

A cell is one method with one parameter set (and the role of that set: a preset, tuned, a
variant) on one task for one seed. A cell's numbers depend only on (task, method, parameters,
seed), so the same seed gives bit-identical numbers, and an interrupted run resumes by
computing only the cells the store does not hold. Two cells that differ only in their role
(a tuning that lands on the preset, ẋ and ẍ tuned to the same setting) are one computation:
it runs once and both are stored with its scores. The runner never asks what kind of task it
holds: the task scores the method (:meth:`bench.tasks.Task.score`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from diffbench import methods
from diffbench.bench.core import search_space, tuning, uptodate
from diffbench.bench.core.errors import (
    BadInput,
    DiffbenchNote,
    DiffbenchWarning,
    plugin_failure,
    plugin_label,
    timeout_failure,
)
from diffbench.bench.core.executor import CallTimeout, call_timeout, completed_map, ordered_map
from diffbench.bench.core.plan import (
    Cell,
    Entry,
    TuningJob,
    preset_entry,
    tuned_entries,
    unique,
)
from diffbench.bench.core.provenance import provenance
from diffbench.bench.core.store import Store, canonical, study_key
from diffbench.bench.tasks import Task, get_task
from diffbench.bench.tasks.items import Item, ItemStudy

MAX_SEEDS = 10_000
"""The most noise seeds a run scores (``--seeds``): each is one cell per entry."""
MAX_TUNING_SEEDS = 100
"""The most realisations one tuning averages its loss over (``--tuning-seeds``)."""
MAX_SEED = 2**32 - 1
"""The largest noise seed (a seed is any whole number from 0 to this)."""
MAX_COUNT = 10**9
"""The largest count any other option takes (``--budget``): beyond it a run never ends."""


def compute_cell(cell: Cell) -> list[dict[str, Any]]:
    """Score rows of one cell (pure computation: no I/O)."""
    method = methods.get(cell.method, **cell.params)
    return get_task(cell.task).score_cell(method, cell.seed, cell.role)


DEFAULT_TIMEOUT_S = 1800.0
"""The default limit of one cell's computation (``--timeout``): the slowest built-in cell
measured, Kalman on identify-dfki, took 162 s on a loaded 2-core machine; 1800 s leaves it
a factor of 11 on a slower one, and stops a method that never returns within half an hour."""

MAX_TIMEOUT_S = 7 * 24 * 3600.0
"""The largest ``--timeout``: a week."""


@dataclass(frozen=True)
class Failed:
    """A cell or a tuning whose computation failed without it being diffbench's bug: it (a
    call in it) outlived the timeout, or a plugin's method raised (or gave output the
    contract refuses)."""

    reason: str


def _timed(
    cell: Cell, timeout_s: float | None = None
) -> tuple[list[dict[str, Any]], float] | Failed:
    """The scores of ``cell`` and the seconds they took, or :class:`Failed` (a plugin's
    error, or longer than ``timeout_s``); an error of diffbench's own methods propagates."""
    start = time.perf_counter()
    try:
        with call_timeout(timeout_s):
            scores = compute_cell(cell)
    except CallTimeout:
        label = plugin_label(cell.method)
        where = f"{label}: method {cell.method}: " if label else ""
        return Failed(f"{where}timed out after {timeout_s:g} s (--timeout)")
    except (Exception, SystemExit) as error:  # a plugin may call sys.exit
        reason = plugin_failure(cell.method, error)
        if reason is None:
            raise
        return Failed(reason)
    return scores, time.perf_counter() - start


@dataclass
class RunSummary:
    """What a call of :func:`run` did: cells asked for, found stored, computed and stored,
    computed but stored first by another writer (so not stored again), and stored with the
    scores of the same computation (:attr:`Cell.computation`) done for another cell."""

    total: int
    skipped: int
    computed: int
    stored_by_others: int = 0
    reused: int = 0
    failed: list[tuple[Cell, str]] = field(default_factory=list)
    """The cells whose computation failed (:class:`Failed`) and why: recorded in the store's
    failures, not stored as finished, so the next run computes them again."""

    def news(self) -> str:
        """The line saying what the run did (the command line prints it)."""
        text = f"{self.computed} cells computed, {self.skipped} already stored"
        if self.reused:
            text += f", {self.reused} the same computation as another cell (its scores taken)"
        if self.stored_by_others:
            text += f", {self.stored_by_others} stored meanwhile by another writer"
        if self.failed:
            text += f", {len(self.failed)} failed (recorded; the next run tries them again)"
        return text


def run(
    cells: Sequence[Cell],
    store: Store,
    progress: Callable[[Iterable, int], Iterable] | None = None,
    jobs: int = 1,
    timeout_s: float | None = DEFAULT_TIMEOUT_S,
) -> RunSummary:
    """Compute every cell the store lacks and store each one as soon as it is finished.

    Duplicate cells are computed once, and so are cells that differ only in their role (the
    same :attr:`Cell.computation`): the others are stored with its scores (``same_as`` its
    key), also when the store holds that computation from an earlier run of this very code
    (:meth:`bench.store.Store.computed_by_this_code`). ``progress`` wraps the iterable of
    pending results (e.g. a tqdm bar). With ``jobs`` > 1 the cells are computed on that many
    local processes (:func:`bench.executor.ordered_map`); this process alone writes the store.
    An exception or interruption leaves every finished cell stored.

    A computation that outlives ``timeout_s`` seconds (None: no limit;
    :func:`bench.executor.call_timeout`), or a plugin's method that raises or returns what the
    call contract refuses (wrong shape, NaN or inf marked valid), is a failed cell: recorded
    with its reason (:meth:`bench.store.Store.add_failure`), listed in the summary, and the
    run goes on. A failed cell is not a finished one: the next run computes it again. An
    error of diffbench's own methods is a bug and propagates with its traceback.
    """
    cells = unique(cells)
    store.refresh()
    pending = [cell for cell in cells if not store.has_cell(cell.key)]
    twins: dict[str, list[Cell]] = {}
    for cell in pending:
        twins.setdefault(cell.computation, []).append(cell)
    done = store.computed_by_this_code() if pending else {}
    reused = 0
    for computation, group in twins.items():
        if computation in done:
            source = done[computation]
            scores = [
                dict(zip(("order", "region", "metric", "value"), score, strict=True))
                for score in source["scores"]
            ]
            reused += sum(
                _store(store, cell, scores, source["elapsed_s"], source["key"]) for cell in group
            )
    todo = [group[0] for computation, group in twins.items() if computation not in done]
    results = ordered_map(functools.partial(_timed, timeout_s=timeout_s), todo, jobs)
    paired = zip(todo, results, strict=True)
    iterable = progress(paired, len(todo)) if progress else paired
    computed = others = 0
    failed = []
    for cell, result in iterable:
        if isinstance(result, Failed):
            for twin in twins[cell.computation]:
                store.add_failure(
                    task=twin.task,
                    method=twin.method,
                    params=twin.params,
                    seed=twin.seed,
                    role=twin.role.as_dict(),
                    reason=result.reason,
                    package=methods.package_of(twin.method),
                )
                failed.append((twin, result.reason))
            continue
        scores, elapsed = result
        stored = _store(store, cell, scores, elapsed)
        computed += stored
        others += not stored
        for twin in twins[cell.computation][1:]:
            reused += _store(store, twin, scores, elapsed, cell.key)
    return RunSummary(
        total=len(cells),
        skipped=len(cells) - len(pending),
        computed=computed,
        stored_by_others=others,
        reused=reused,
        failed=failed,
    )


def compute_item(task_and_item: tuple[str, Item]) -> list[dict[str, Any]]:
    """The rows of one item of an item study (pure computation: no I/O); the study is looked
    up by name, so that a worker process computes it as this one would."""
    task, item = task_and_item
    return get_task(task).compute(item)


def stored_items(study: ItemStudy, items: Sequence[Item], store: Store) -> dict:
    """``{item: its stored rows, or None}`` for each of ``items`` of ``study``."""
    store.refresh()
    name = study.record_name
    return {item: store.find_study_rows(name, item.name, item.setting) for item in items}


def run_items(
    study: ItemStudy,
    items: Sequence[Item],
    store: Store,
    progress: Callable[[Iterable, int], Iterable] | None = None,
    jobs: int = 1,
) -> tuple[dict[Item, list[dict]], RunSummary]:
    """The stored rows of every item of ``study`` (:mod:`bench.tasks.items`), computing and
    storing those the store lacks, each as soon as it is finished (one record: whole or not at
    all), on ``jobs`` (:func:`bench.core.executor.completed_map`); this process alone writes
    the store. Returns ``{item: rows}`` in the order of ``items`` and what was computed."""
    items = list(dict.fromkeys(items))
    rows = stored_items(study, items, store)
    name = study.record_name
    todo = [item for item, found in rows.items() if found is None]
    results = completed_map(compute_item, [(study.name, item) for item in todo], jobs)
    computed = others = 0
    for (_, item), found in progress(results, len(todo)) if progress else results:
        stored = store.add_study_rows(name, item.name, item.setting, found)
        computed += stored
        others += not stored
        rows[item] = store.find_study_rows(name, item.name, item.setting)
    summary = RunSummary(len(items), len(items) - len(todo), computed, others)
    return rows, summary


FAILED_CSV = "failed.csv"
"""The file beside a report that lists the cells that failed (so none is silently missing)."""


def report_task(task: Task, store: Store, out: Path) -> list[Path]:
    """The report of ``task`` from its stored cells (and tunings), written under ``out`` in its
    folder unless the last report there came from the same store content by the same code
    (:func:`bench.core.uptodate.report_once`), with ``failed.csv`` listing its failed cells;
    :class:`BadInput` when nothing of it is stored."""
    store.refresh()
    cells = store.cells_frame(task.parts())
    failed = store.failed_cells(task.parts())
    if cells.empty and not failed.empty:
        raise BadInput(
            f"every cell of {task.name} asked for failed ({len(failed)}: "
            f"{failed['reason'].iloc[-1]}); nothing to report"
        )
    if cells.empty:
        raise BadInput(
            f"no stored results of {task.name} in {store.directory}; run "
            f"`diffbench run {task.name} --out {out}` first"
        )
    tables = ("cells", "tunings", "failures") if not failed.empty else ("cells", "tunings")
    options = {"report": task.name, "folder": task.folder}
    key = uptodate.inputs_key(options, store.content_version(tables))
    directory = out / task.folder

    def write() -> list[Path]:
        written = task.report(cells, store.tunings_frame(), directory)
        path = directory / FAILED_CSV  # the failed cells, so that none is silently missing
        if failed.empty:
            path.unlink(missing_ok=True)
            return written
        failed.to_csv(path, index=False)
        return [*written, path]

    written = uptodate.report_once(directory, key, write)
    if not failed.empty:
        warnings.warn(
            f"{len(failed)} cells of {task.name} failed and are not in its tables (listed in "
            f"{directory / FAILED_CSV}); the next run tries them again",
            DiffbenchWarning,
            stacklevel=3,
        )
    current = provenance()["git_rev"]
    others = sorted(r[:12] for r in set(cells["git_rev"]) - {current})
    if others:
        warnings.warn(
            f"some stored cells of {task.name} were computed by other code revisions "
            f"({', '.join(others)}); delete {store.directory} to recompute",
            DiffbenchNote,
            stacklevel=3,
        )
    return written


def report_items(study: ItemStudy, rows: dict[Item, list[dict]], out: Path) -> list[Path]:
    """The report of ``study`` from the rows of its items (:func:`run_items`), written under
    ``out`` in its folder unless the last report there came from the same items' same rows by
    the same code (:func:`bench.core.uptodate.report_once`; the rows' content is in the key,
    so an item recomputed after its rows were deleted from the store is reported anew)."""
    keys = [study_key(study.record_name, item.name, item.setting) for item in rows]
    content = json.dumps(list(rows.values()), sort_keys=True, default=str)
    key = uptodate.inputs_key(
        {
            "report": study.name,
            "folder": study.folder,
            "items": keys,
            "rows": hashlib.sha256(content.encode()).hexdigest(),
        }
    )
    directory = Path(out) / study.folder
    return uptodate.report_once(
        directory, key, lambda: study.write(rows, directory), part=study.name
    )


def _store(store: Store, cell: Cell, scores, elapsed: float, same_as: str | None = None) -> bool:
    return store.add_cell(
        task=cell.task,
        method=cell.method,
        params=cell.params,
        seed=cell.seed,
        role=cell.role.as_dict(),
        scores=scores,
        elapsed_s=elapsed,
        package=methods.package_of(cell.method),
        same_as=same_as,
    )


def _tune(job: TuningJob, timeout_s: float | None = None) -> dict[str, Any] | Failed:
    """The tuning record of ``job``, or :class:`Failed` when one call of its method outlived
    ``timeout_s`` or its method is a plugin's and failed (an error of diffbench's own methods
    propagates)."""
    task = get_task(job.task)
    realisations = [task.tuning_data(seed) for seed in job.seeds]
    try:
        return _tuned(job, realisations, timeout_s)
    except CallTimeout:
        return Failed(f"{timeout_failure(job.method, timeout_s)} (tuning it on {job.task})")
    except (Exception, SystemExit) as error:  # a plugin may call sys.exit
        reason = plugin_failure(job.method, error)
        if reason is None:
            raise
        return Failed(f"{reason} (tuning it on {job.task})")


def _tuned(job: TuningJob, realisations, timeout_s: float | None) -> dict[str, Any] | None:
    try:
        result = tuning.tune(
            job.method,
            realisations,
            job.order,
            job.criterion,
            job.cutoff_hz,
            max_evaluations=job.budget,
            region=job.region,
            timeout_s=timeout_s,
            screen_choices=job.screen,
            share_budget=True,
        )
    except search_space.NoRoomToTune as error:  # the method cannot cover the task at all
        return {
            "params": {},
            "loss": float("inf"),
            "evaluations": 0,
            "seconds": 0.0,
            "note": str(error),
        }
    if not math.isfinite(result.loss):  # no setting estimates the task's interior
        return {
            "params": {},
            "loss": float("inf"),
            "evaluations": result.evaluations,
            "seconds": result.seconds,
        }
    params = {**methods.get(job.method).params(), **result.params}
    return {
        "params": params,
        "loss": result.loss,
        "evaluations": result.evaluations,
        "seconds": result.seconds,
    }


@dataclass
class TuningSummary:
    """Tunings asked for, found stored (reused) and computed now."""

    total: int = 0
    reused: int = 0
    computed: int = 0
    failed: list[tuple[TuningJob, str]] = field(default_factory=list)
    """The tunings of plugin methods that failed, and why: not stored, so the next call tries
    them again; the others go on."""


def _expected_work(job: TuningJob) -> tuple[int, int]:
    """What orders the tunings longest first: the realisations each evaluation runs on, then
    the derivative's order (a peer's ẍ is the peer applied twice, two calls an evaluation)."""
    return (job.tuning_seeds, job.order)


def tune_all(
    jobs_list: Sequence[TuningJob],
    store: Store,
    jobs: int = 1,
    progress: Callable | None = None,
    timeout_s: float | None = None,
) -> tuple[dict[TuningJob, dict], TuningSummary]:
    """The stored tuning of every job, tuning (and storing) only those not stored yet; each
    call of a method limited to ``timeout_s``.

    Returns ``{job: record}`` (``record["params"]`` is empty when the method could not be
    tuned on the task; a failed plugin's job is left out, see ``TuningSummary.failed``), in the
    order of ``jobs_list``, and what was reused or computed.

    The missing tunings start longest first (:func:`_expected_work`: on ``jobs`` workers the
    last to start are the short ones, so the workers finish close together: a step of four
    peer tunings, two of them for ẍ, no longer waits for one ẍ tuning begun last), and each is
    stored as soon as it is done. A tuning's result does not depend on the order: each is
    seeded on its own.
    """
    jobs_list = unique(jobs_list)
    store.refresh()
    found = {job: store.find_tuning(**job.fields()) for job in jobs_list}
    missing = sorted(
        (job for job, record in found.items() if record is None), key=_expected_work, reverse=True
    )
    # each tuning stored as soon as it is done, whichever finishes first: a tuning that waited
    # behind a longer one started before it would be lost to an interruption
    paired = completed_map(functools.partial(_tune, timeout_s=timeout_s), missing, jobs)
    failed = []
    for job, result in progress(paired, len(missing)) if progress else paired:
        if isinstance(result, Failed):
            failed.append((job, result.reason))
            del found[job]
            continue
        store.add_tuning(
            **job.fields(),
            params=result["params"],
            loss=result["loss"],
            evaluations=result["evaluations"],
            seconds=result["seconds"],
        )
        found[job] = store.find_tuning(**job.fields())
    computed = len(missing) - len(failed)
    summary = TuningSummary(len(jobs_list), len(jobs_list) - len(missing), computed, failed)
    return found, summary


__all__ = [
    "Cell",
    "Entry",
    "RunSummary",
    "TuningJob",
    "canonical",
    "preset_entry",
    "report_items",
    "run",
    "run_items",
    "tune_all",
    "tuned_entries",
    "unique",
]
