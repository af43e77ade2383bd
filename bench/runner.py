"""The runner: expand a benchmark into cells, compute each one, store it at once.

A cell is one method with one parameter set on one scenario realised with one noise seed. A
cell's numbers depend only on (method, parameters, scenario, seed), so the same seed gives
bit-identical numbers, and a run that is interrupted resumes by computing only the cells the
store does not hold yet.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any

from diffbench import methods, signals
from diffbench.bench.frequency import decompose_error
from diffbench.bench.provenance import provenance
from diffbench.bench.scores import score_estimate
from diffbench.bench.store import ResultStore, canonical_params, cell_key
from diffbench.signals import robot2r


@dataclass(frozen=True)
class Cell:
    """One unit of work: ``method`` with ``params`` on ``scenario`` realised with ``seed``."""

    method: str
    params: Mapping[str, Any]
    scenario: str
    seed: int
    preset: str = field(default="", compare=False)

    @property
    def key(self) -> str:
        return cell_key(self.method, self.params, self.scenario, self.seed)


def preset_cells(
    scenario: str, seeds: Iterable[int], method_names: Sequence[str] | None = None
) -> list[Cell]:
    """Cells of every registered method (or those named) at the scenario's preset, per seed.

    Raises ``ValueError`` for an unknown scenario or method name.
    """
    chosen = find_scenario(scenario)
    names = list(method_names) if method_names else methods.available()
    instances = []
    for name in names:
        key = chosen.preset if chosen.preset in methods.method_class(name).presets else "default"
        source = methods.preset_spec(name, key).source
        instances.append((name, methods.preset(name, key).params(), f"{chosen.preset}: {source}"))
    return [
        Cell(method=name, params=params, scenario=scenario, seed=int(seed), preset=source)
        for seed in seeds
        for name, params, source in instances
    ]


def find_scenario(name: str):
    """A signal scenario or a robot scenario by name; an unknown name lists both kinds."""
    if name in robot2r.available_robot_scenarios():
        return robot2r.get_robot_scenario(name)
    if name == "dfki-cv":
        from diffbench.bench.robot import DfkiCrossValidation

        return DfkiCrossValidation()
    if name in signals.available_scenarios():
        return signals.get_scenario(name)
    known = signals.available_scenarios() + robot2r.available_robot_scenarios() + ["dfki-cv"]
    raise ValueError(f"unknown scenario {name!r}; available: {', '.join(sorted(known))}")


def compute_cell(cell: Cell) -> list[dict[str, Any]]:
    """Score rows of one cell (pure computation: no I/O).

    On a robot scenario the cell is an identification (see :mod:`bench.robot`). Otherwise
    linear methods also get the interior RMS of the bias part (the method on the clean
    signal, minus the truth) and of the noise part (the method on the noise alone) of ẋ, ẍ.
    """
    scenario = find_scenario(cell.scenario)
    method = methods.get(cell.method, **cell.params)
    if isinstance(scenario, robot2r.RobotScenario):
        from diffbench.bench.robot import score_identification

        return score_identification(method, scenario, cell.seed)
    if scenario.name == "dfki-cv":
        from diffbench.bench.robot import score_dfki_fold

        return score_dfki_fold(method, scenario, cell.seed)
    realisation = scenario.realise(cell.seed)
    estimate = method(realisation.x, realisation.dt_s)
    rows = score_estimate(estimate, realisation.truth, realisation.interior)
    if method.linear:
        for order in (1, 2):
            parts = decompose_error(method, realisation, order)
            rows += [
                {"order": order, "region": "interior", "metric": "bias_rmse", "value": parts.bias},
                {
                    "order": order,
                    "region": "interior",
                    "metric": "noise_rmse",
                    "value": parts.noise,
                },
            ]
    return rows


@dataclass
class RunSummary:
    """What a call of :func:`run` did."""

    total: int
    skipped: int
    computed: int


def _ignore_interrupts() -> None:
    # Ctrl-C reaches the whole process group: let the parent handle it, quietly.
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _timed(cell: Cell) -> tuple[list[dict[str, Any]], float]:
    start = time.perf_counter()
    scores = compute_cell(cell)
    return scores, time.perf_counter() - start


def run(
    cells: Sequence[Cell],
    store: ResultStore,
    progress: Callable[[Iterable[Cell], int], Iterable[Cell]] | None = None,
    jobs: int = 1,
) -> RunSummary:
    """Compute every cell the store lacks and append each one as soon as it is finished.

    ``progress`` wraps the iterable of pending results (e.g. a tqdm progress bar). With
    ``jobs`` > 1 the cells are computed on that many local processes; results are stored in
    cell order, so the store (and every number in it) is the same as a serial run's. An
    exception or interruption leaves every finished cell in the store.
    """
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"`jobs` must be an integer >= 1, got {jobs!r}")
    done = store.completed_keys()
    pending = [cell for cell in cells if cell.key not in done]
    meta = provenance()
    computed = 0
    executor = None
    if jobs > 1 and len(pending) > 1:
        from concurrent.futures import ProcessPoolExecutor

        executor = ProcessPoolExecutor(max_workers=jobs, initializer=_ignore_interrupts)
        results = executor.map(_timed, pending)
    else:
        results = map(_timed, pending)
    paired = zip(pending, results, strict=True)
    iterable = progress(paired, len(pending)) if progress else paired
    try:
        for cell, (scores, elapsed) in iterable:
            finished = datetime.now(timezone.utc).isoformat(timespec="seconds")
            rows = [
                {
                    "cell_key": cell.key,
                    "method": cell.method,
                    "params": canonical_params(cell.params),
                    "preset": cell.preset,
                    "scenario": cell.scenario,
                    "seed": cell.seed,
                    **score,
                    "cell_rows": len(scores),
                    "git_rev": meta["git_rev"],
                    "versions": meta["versions"],
                    "finished_utc": finished,
                    "elapsed_s": round(elapsed, 6),
                }
                for score in scores
            ]
            store.append(rows)
            computed += 1
    finally:
        if executor is not None:
            executor.shutdown(wait=False, cancel_futures=True)
    return RunSummary(total=len(cells), skipped=len(cells) - len(pending), computed=computed)
