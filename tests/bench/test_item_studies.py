"""The four studies whose unit of work is not a cell are tasks too (issue 44): ``pareto``,
``paper-figures``, ``recommend-check`` and ``timing`` are item studies (:mod:`bench.tasks.items`)
that run through the same store and executor as every task. Each gives the files of a serial
run on two local workers and on Dask, recomputes nothing on a rerun (counted from what the
command prints), and resumes after SIGKILL to the files of an uninterrupted run. Their reports
are the bespoke commands' reports byte for byte (checked against the committed results by
test_reproducible_results and ``make bench``)."""

import importlib
import pkgutil
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from diffbench import methods, signals
from diffbench.bench import api, runner
from diffbench.bench import tasks as tasks_package
from diffbench.bench.cli import main
from diffbench.bench.core.executor import DaskWorkers
from diffbench.bench.core.store import Store
from diffbench.bench.studies import paper, pareto, recommend_check
from diffbench.bench.tasks import (
    ItemStudy,
    PaperFigures,
    ParetoStudy,
    RecommendCheck,
    TimingStudy,
    available_tasks,
    get_task,
)
from tests.bench.killing import kill_once_stored, stored_items

STUDIES = {
    "pareto": ["pareto", "limit-iwn2-0.01", "--methods", "savitzky_golay,butterworth"],
    "paper-figures": [
        *("run", "paper-figures", "--seeds", "2"),
        *("--methods", "finite_difference,jacobi"),
    ],
    "recommend-check": [
        *("recommend-check", "--scenarios", "paper-signal"),
        *("--methods", "savitzky_golay,finite_difference"),
    ],
}
"""Each deterministic item study at a small size, as the command a user types."""
FOLDERS = {
    "timing": "timing",
    "pareto": "limit",
    "paper-figures": "paper-figures",
    "recommend-check": ("recommend-validation"),
}


def _counts(text: str) -> tuple[int, int]:
    """(items computed, items already stored) as printed."""
    return tuple(map(int, re.search(r"(\d+) items computed, (\d+) already stored", text).groups()))


def _files(out: Path, study: str) -> dict[str, bytes]:
    """The report's files (not the key file of the report cache); a CSV's ``seconds`` column
    (a tuning's wall time, which no two runs share) left out."""
    folder = out / FOLDERS[study]
    files = {}
    for path in sorted(folder.iterdir()):
        if path.name.startswith("."):
            continue
        if path.suffix == ".csv" and "seconds" in (table := pd.read_csv(path)).columns:
            files[path.name] = table.drop(columns="seconds").to_csv(index=False).encode()
        else:
            files[path.name] = path.read_bytes()
    return files


def test_the_former_bespoke_commands_are_registered_item_studies():
    for name, kind in (
        ("pareto", ParetoStudy),
        ("paper-figures", PaperFigures),
        ("recommend-check", RecommendCheck),
        ("timing", TimingStudy),
    ):
        study = get_task(name)
        assert isinstance(study, kind) and isinstance(study, ItemStudy), name
        with pytest.raises(ValueError, match=f"{name} is a study of its own items"):
            study.lineup()
    fronts = get_task("pareto").items(["jacobi", "spectral"], range(1))
    assert len(fronts) == 2 * len(pareto.SCENARIOS)  # a method on a record
    assert get_task("recommend-check").items(None, range(1))[0].setting == list(
        recommend_check.VALIDATION_METHODS
    )
    assert [item.setting for item in get_task("paper-figures").items(["jacobi"], range(7))] == [
        {"seeds": 7}
    ]
    timing_items = TimingStudy(largest_samples=10_000, ratios=True).items(["jacobi"], range(1))
    assert [item.name for item in timing_items] == ["jacobi", "speed-ratios"]
    assert timing_items[0].setting["sizes"][-1] == 10_000
    with pytest.raises(ValueError, match="unknown scenario 'limit-nope'"):
        ParetoStudy(scenarios=("limit-nope",))
    with pytest.raises(ValueError, match="unknown scenario 'nope'"):
        RecommendCheck(scenarios=("nope",))


def test_every_module_of_the_tasks_package_registers_its_builtin_tasks():
    """A new kind of task or study is one module of bench/tasks/ with ``builtin_tasks()``: the
    registry finds it by walking the package, no list to edit."""
    registered = set(available_tasks())
    found = set()
    for info in pkgutil.iter_modules(tasks_package.__path__):
        module = importlib.import_module(f"{tasks_package.__name__}.{info.name}")
        for task in getattr(module, "builtin_tasks", tuple)():
            assert get_task(task.name).__class__ is task.__class__, task.name
            found.add(task.name)
    assert found <= registered and {"pareto", "timing", "grid", "paper-signal"} <= found
    # the others were made at run time by other tests: DFKI tasks on a user's records
    assert all(name.startswith("identify-dfki-") for name in registered - found)


def test_an_error_profile_item_is_the_sum_of_squares_over_its_seeds():
    """The stored item (a method's sums over seeds) gives the RMS error at each sample, checked
    against the errors computed here from the scenario's truth."""
    study = get_task("paper-figures")
    (item,) = study.items(["jacobi"], range(3))
    rows = study.compute(item)
    assert [row["order"] for row in rows] == [1, 2] and len(rows[0]["squares"]) == 1001
    profile = paper.error_profile_frame(
        {"jacobi": {row["order"]: np.array(row["squares"]) for row in rows}}, 3
    )
    scenario, method = (
        signals.get_scenario(paper.SCENARIO),
        methods.preset("jacobi", "paper-signal"),
    )
    squares = 0.0
    for seed in range(3):
        realisation = scenario.realise(seed)
        squares = (
            squares
            + (method(realisation.x, realisation.dt_s).trusted(2) - realisation.truth[2]) ** 2
        )
    expected = np.sqrt(squares / 3)
    got = profile["jacobi_acceleration_rms_error"].to_numpy()
    assert np.array_equal(np.isnan(got), np.isnan(expected))  # the same masked ends
    finite = np.isfinite(expected)
    # the same additions in the same order: equal up to the last bit
    assert np.array_equal(got[finite], expected[finite])


@pytest.mark.parametrize("study", sorted(STUDIES))
def test_an_item_study_on_workers_and_on_dask_gives_the_serial_files_and_a_rerun_computes_nothing(
    study, tmp_path, capsys
):
    pytest.importorskip("distributed")
    command = [*STUDIES[study], "--no-progress"]
    assert main([*command, "--out", str(tmp_path / "serial")]) == 0
    computed, stored = _counts(capsys.readouterr().out)
    assert computed >= 1 and stored == 0
    for name, extra in (("jobs", ["--jobs", "2"]), ("dask", ["--executor", "dask", "--jobs", "2"])):
        assert main([*command, *extra, "--out", str(tmp_path / name)]) == 0
        assert _counts(capsys.readouterr().out) == (computed, 0)
        assert _files(tmp_path / name, study) == _files(tmp_path / "serial", study), name
    assert main([*command, "--out", str(tmp_path / "serial")]) == 0
    assert _counts(capsys.readouterr().out) == (0, computed)


SIX = "finite_difference,jacobi,savitzky_golay,butterworth,spectral,kalman"
THREE = "savitzky_golay,butterworth,finite_difference"
KILLED = {
    "paper-figures": (
        ["run", "paper-figures", "--seeds", "3", "--methods", f"{SIX},total_variation"],
        7,  # the slowest last: the other worker is still busy when the first item is stored
    ),
    "pareto": (["pareto", "limit-iwn2-0.01", "--methods", THREE], 3),
    "recommend-check": (
        [
            *("recommend-check", "--methods", "savitzky_golay,finite_difference"),
            *("--scenarios", "paper-signal,chirp-gaussian,damped-gaussian"),
        ],
        3,
    ),
    "timing": (["timing", "--no-ratios", "--largest", "100000", "--methods", SIX], 6),
}
"""Each item study as a command whose items take long enough to kill it mid-run, and how many
items it has."""


@pytest.mark.parametrize("study", sorted(KILLED))
def test_a_killed_item_study_resumes_to_the_uninterrupted_files(study, tmp_path, capsys):
    """SIGKILL of the study on two workers once one of its items is stored: the rerun computes
    only the items missing, and its files are those of an uninterrupted run (timing: the same
    rows, its times being measured anew)."""
    command, total = KILLED[study]
    command = [*command, "--no-progress", "--jobs", "2"]
    killed = tmp_path / "killed"
    stored = kill_once_stored(command, killed, stored_items, 1)
    assert 1 <= stored < total, "the kill should land mid-run"
    assert main([*command, "--out", str(killed)]) == 0
    computed, already = _counts(capsys.readouterr().out)
    assert already == stored and computed + already == total
    if study == "timing":
        table = pd.read_csv(killed / "timing" / "throughput.csv")
        assert sorted(set(table["method"])) == sorted(SIX.split(","))
        assert (table["samples_per_s"] > 0).all()
        return
    assert main([*command, "--out", str(tmp_path / "full")]) == 0
    assert _files(killed, study) == _files(tmp_path / "full", study)


def test_the_timing_study_runs_on_workers_and_on_dask_and_a_rerun_times_nothing(tmp_path):
    """Timings differ from run to run, so here the rows are checked, not their values: every
    method at every size asked for, a positive throughput; a rerun reads them from the store."""
    pytest.importorskip("distributed")
    study = TimingStudy(largest_samples=20_000, ratios=False)
    items = study.items(["finite_difference", "jacobi"], range(1))
    for name, jobs in (("serial", 1), ("jobs", 2), ("dask", DaskWorkers(workers=2))):
        store = Store(tmp_path / name / "store")
        rows, summary = runner.run_items(study, items, store, jobs=jobs)
        assert (summary.computed, summary.skipped) == (2, 0), name
        timed = {(row["method"], row["samples"]) for found in rows.values() for row in found}
        assert timed == {(m, n) for m in ("finite_difference", "jacobi") for n in (10_000, 20_000)}
        assert all(row["samples_per_s"] > 0 for found in rows.values() for row in found)
        again, summary = runner.run_items(study, items, Store(tmp_path / name / "store"), jobs=jobs)
        assert (summary.computed, summary.skipped) == (0, 2) and again == rows
    written = runner.report_items(study, rows, tmp_path / "serial")
    assert {path.name for path in written} >= {"throughput.md", "throughput.csv"}
    assert "| jacobi |" in (tmp_path / "serial" / "timing" / "throughput.md").read_text()


def test_an_item_recomputed_with_other_rows_is_reported_anew(tmp_path):
    """The same items' report is skipped on a rerun, but written again when an item's rows
    differ (rows deleted from the store and recomputed, as timings are): the report's key
    holds the rows' content, not only the items'."""
    study = TimingStudy(largest_samples=10_000, ratios=False)
    items = study.items(["finite_difference"], range(1))
    rows, _ = runner.run_items(study, items, Store(tmp_path / "store"), jobs=1)
    table = tmp_path / "timing" / "throughput.csv"
    runner.report_items(study, rows, tmp_path)
    first = table.stat().st_mtime_ns
    runner.report_items(study, rows, tmp_path)
    assert table.stat().st_mtime_ns == first  # the same rows: skipped
    (item,) = rows
    changed = {item: [{**row, "samples_per_s": 2 * row["samples_per_s"]} for row in rows[item]]}
    runner.report_items(study, changed, tmp_path)
    written = pd.read_csv(table)
    assert written["samples_per_s"].tolist() == [r["samples_per_s"] for r in changed[item]]


def test_report_renders_an_item_study_again_from_its_stored_items(tmp_path, monkeypatch):
    """``diffbench report`` of an item study reads its items at its defaults from the store:
    the same files again once they are all stored; a clear error naming the run otherwise."""
    study = ParetoStudy(scenarios=("limit-iwn2-0.01",))
    two = ["savitzky_golay", "butterworth"]
    api.run(study, methods=two, out=tmp_path)
    before = _files(tmp_path, "pareto")
    (tmp_path / "limit" / "pareto_limit-iwn2-0.01.md").unlink()
    with pytest.raises(api.BadInput, match=r"\d+ of the \d+ items of pareto \(at its defaults\)"):
        api.report(study, out=tmp_path)  # every method by default: most are not stored
    monkeypatch.setattr(methods, "available", lambda *args, **kwargs: list(two))
    api.report(study, out=tmp_path)
    assert _files(tmp_path, "pareto") == before
