"""The API of the four studies that are not tasks yet: ``pareto``, ``paper_figures``,
``recommend_check`` and ``timing``, each one function, as the command line ran them (each
becomes ``api.run(<task>)`` when its study is a task). Re-exported by :mod:`.api`."""

from __future__ import annotations

import functools
import warnings
from collections.abc import Iterable
from pathlib import Path

from diffbench import methods as methods_module
from diffbench import signals
from diffbench.bench.arguments import (
    DiffbenchNote,
    Echo,
    Workers,
    check,
    checked,
    method_names,
    name_list,
    open_store,
    progress_bar,
    ready,
    record_length,
    say,
    seed_count,
)
from diffbench.bench.core import executor, tuning, uptodate
from diffbench.bench.studies import paper
from diffbench.bench.studies import pareto as pareto_study
from diffbench.bench.studies import recommend as advice
from diffbench.bench.studies import timing as timing_study
from diffbench.bench.tasks import get_task


def pareto(
    task: str,
    *,
    methods: str | Iterable[str] | None = None,
    jobs: Workers = 1,
    out: Path = Path("results"),
) -> list[Path]:
    """Each method's front of accuracy against smoothness without the truth on a signal task,
    with its knee and the oracle's setting (``out/limit/pareto_<task>.*``)."""
    jobs = ready(jobs)
    with checked():
        task = get_task(task)
    with checked():
        realisation = task.tuning_data(tuning.TUNING_SEED)
    names = method_names(methods) or methods_module.available()
    directory = Path(out) / "limit"

    def write() -> list[Path]:
        work = functools.partial(pareto_study.pareto_front, realisation=realisation)
        fronts = list(executor.ordered_map(work, names, jobs))
        return pareto_study.write_pareto(fronts, task.name, directory)

    key = uptodate.inputs_key({"report": "pareto", "task": task.name, "methods": names})
    return uptodate.report_once(directory, key, write, part=f"pareto-{task.name}")


def paper_figures(
    *,
    seeds: int = 20,
    methods: str | Iterable[str] | None = None,
    jobs: Workers = 1,
    out: Path = Path("results"),
    progress: bool = False,
) -> list[Path]:
    """The paper's figures 1-3 (PNG + CSV), its frequency table and the error against position
    over ``seeds`` noise seeds, in ``out/paper-figures``."""
    seeds = check("seeds", seed_count, seeds)
    jobs = ready(jobs)
    directory = Path(out) / "paper-figures"
    directory.mkdir(parents=True, exist_ok=True)
    names = method_names(methods)

    def write() -> list[Path]:
        written = paper.write_figure1(directory, names=names)
        written += paper.write_figure2(directory, names) + paper.write_figure3(directory)
        written += paper.write_frequency_table(directory, names)
        return written + paper.write_error_profile(
            directory, seeds, names, jobs, progress_bar(progress, "run")
        )

    key = uptodate.inputs_key({"report": "paper-figures", "methods": names, "seeds": seeds})
    return uptodate.report_once(directory, key, write)


VALIDATION = "recommend-validation"
"""The study name of :func:`recommend_check`'s rows in the store."""


def recommend_check(
    *,
    scenarios: Iterable[str] | None = None,
    methods: str | Iterable[str] | None = None,
    jobs: Workers = 1,
    out: Path = Path("results"),
    echo: Echo | None = None,
) -> list[Path]:
    """Score :func:`recommend` against the truth on signal scenarios taken as unknown (default
    every uniformly sampled noisy one), each finished scenario stored in ``out/store`` (a
    stopped call resumes); ``echo`` gets each scenario's ratios as it finishes."""
    jobs = ready(jobs)
    names = method_names(methods) or list(advice.VALIDATION_METHODS)
    scenarios = (
        check("scenarios", name_list, scenarios)
        if scenarios is not None
        else [
            name
            for name in signals.available_scenarios()
            if not (scenario := signals.get_scenario(name)).sampling
            and scenario.noise.models
            and not name.startswith("limit-")  # the random signals have their own study
        ]
    )
    with checked("--scenarios: "):
        for name in scenarios:
            signals.get_scenario(name)
    out = Path(out)
    directory = out / "recommend-validation"
    directory.mkdir(parents=True, exist_ok=True)
    legacy = directory / "rows.jsonl"
    if legacy.exists():
        warnings.warn(
            f"{legacy} (an older diffbench's) is no longer read; the rows are kept in "
            f"{out / 'store'}",
            DiffbenchNote,
            stacklevel=2,
        )
    # each finished scenario is one record of the store: a stopped run resumes where it stopped
    store = open_store(out)
    key = ",".join(names)
    stored = {name: store.find_study_rows(VALIDATION, name, names) for name in scenarios}
    todo = [name for name, found in stored.items() if found is None]
    validate = functools.partial(advice.validate, names=tuple(names))
    # workers return rows, this process alone stores them, each scenario as it finishes
    for name, found in executor.completed_map(validate, todo, jobs):
        stored[name] = [{**row, "methods": key} for row in found]
        store.add_study_rows(VALIDATION, name, names, stored[name])
        say(echo, f"{name}: " + ", ".join(f"{r['ratio']:.3g}" for r in stored[name]))
    rows = [row for name in scenarios for row in stored[name]]
    return advice.write_validation(rows, directory, names)


def timing(
    *,
    largest: int = 10_000_000,
    ratios: bool = True,
    out: Path = Path("results"),
    echo: Echo | None = None,
) -> list[Path]:
    """Throughput and peak memory of every method against the record's length up to
    ``largest`` samples (a power of ten), and (``ratios``) the speed ratios against the peers,
    in ``out/timing``; ``echo`` gets a line after each method timed."""
    largest = check("largest", record_length, largest)
    sizes = [size for size in timing_study.SIZES if size < largest] + [largest]
    table = timing_study.throughput(sizes=sizes, progress=echo)
    written = timing_study.write_throughput(Path(out) / "timing", table)
    if ratios:
        written += timing_study.write_ratios(Path(out) / "timing", timing_study.speed_ratios())
    return written
