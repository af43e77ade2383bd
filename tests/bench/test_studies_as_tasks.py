"""Studies are tasks (issue 44): ``diffbench run grid`` and ``run limit`` plan their tunings and
cells through the same runner, store and executor as any task; they run on local workers and on
Dask with the same tables as a serial run, resume after SIGKILL, and recompute nothing on a
rerun (counted from what the command prints). ``diffbench grid`` and ``limit`` are aliases."""

import re
from pathlib import Path

import pytest

from diffbench.bench.cli import main
from diffbench.bench.studies import grid, limit
from diffbench.bench.tasks import GridStudy, LimitStudy, Study, get_task
from tests.bench.killing import kill_once_stored, stored_cells

GRID = ["run", "grid", "--methods", "finite_difference", "--orders", "1", "--seeds", "2"]
"""The grid study at its smallest: one method, ẋ, two seeds (40 tunings, 80 cells)."""


def _counts(text: str) -> tuple[int, int, int, int]:
    """(tunings computed, tunings reused, cells computed, cells already stored) as printed."""
    tunings = re.search(r"(\d+) tunings computed, (\d+) reused", text)
    cells = re.search(r"(\d+) cells computed, (\d+) already stored", text)
    return (*map(int, tunings.groups()), *map(int, cells.groups()))


def _table(out: Path) -> str:
    return (out / "grid" / "winners_velocity.csv").read_text()


def test_the_studies_are_registered_tasks():
    study = get_task("grid")
    assert isinstance(study, GridStudy) and isinstance(study, Study)
    assert study.parts() == grid.task_names() and len(study.parts()) == 40
    assert get_task("limit").parts() == limit.task_names()
    jobs = study.tuning_jobs(["finite_difference"], [1])
    assert {job.task for job in jobs} == set(grid.task_names())
    assert {(job.method, job.order, job.criterion) for job in jobs} == {
        ("finite_difference", 1, "oracle")
    }
    with pytest.raises(ValueError, match="grid is a study"):
        study.lineup()


def test_a_subset_of_the_limit_scenarios_is_checked_by_name():
    assert LimitStudy(("limit-iwn2-0.01",)).parts() == ["limit-iwn2-0.01"]
    with pytest.raises(ValueError, match="not limit scenarios: limit-nope"):
        LimitStudy(("limit-nope",))


def test_run_grid_serial_on_workers_and_on_dask_gives_one_table_and_a_rerun_computes_nothing(
    tmp_path, capsys
):
    pytest.importorskip("distributed")
    assert main([*GRID, "--no-progress", "--out", str(tmp_path / "serial")]) == 0
    assert _counts(capsys.readouterr().out) == (40, 0, 80, 0)
    assert main([*GRID, "--no-progress", "--jobs", "2", "--out", str(tmp_path / "jobs")]) == 0
    assert _counts(capsys.readouterr().out) == (40, 0, 80, 0)
    dask = ["--executor", "dask", "--jobs", "2", "--no-progress"]
    assert main([*GRID, *dask, "--out", str(tmp_path / "dask")]) == 0
    assert _counts(capsys.readouterr().out) == (40, 0, 80, 0)
    serial = _table(tmp_path / "serial")
    assert _table(tmp_path / "jobs") == serial and _table(tmp_path / "dask") == serial
    # the rerun: every tuning and cell found in the store, the same table
    assert main([*GRID, "--no-progress", "--out", str(tmp_path / "serial")]) == 0
    assert _counts(capsys.readouterr().out) == (0, 40, 0, 80)
    assert _table(tmp_path / "serial") == serial
    # the alias is the same study: nothing to compute either
    alias = ["grid", "--methods", "finite_difference", "--orders", "1", "--seeds", "2"]
    assert main([*alias, "--no-progress", "--out", str(tmp_path / "serial")]) == 0
    assert _counts(capsys.readouterr().out) == (0, 40, 0, 80)


def test_a_killed_study_resumes_to_the_uninterrupted_table(tmp_path, capsys):
    """SIGKILL of ``run grid --jobs 2`` once some of its cells are stored: the rerun completes
    it, computing only what is missing, to the table of an uninterrupted run."""
    command = [*GRID[:-1], "30", "--no-progress", "--jobs", "2"]  # 40 tunings, 1200 cells
    killed = tmp_path / "killed"
    stored = kill_once_stored(command, killed, stored_cells, 50)
    assert 50 <= stored < 1200, "the kill should land mid-run"
    assert main([*command, "--out", str(killed)]) == 0
    tunings_computed, tunings_reused, computed, already = _counts(capsys.readouterr().out)
    assert (tunings_computed, tunings_reused) == (0, 40)
    assert already >= stored and computed + already == 1200
    assert main([*command, "--out", str(tmp_path / "full")]) == 0
    assert _table(killed) == _table(tmp_path / "full")


LIMIT = ["limit", "--scenarios", "limit-iwn2-0.01", "--orders", "1", "--no-progress"]
"""The limit study on one record, ẋ (an oracle and a data-only tuning per method)."""


def _efficiency(out: Path) -> str:
    return (out / "limit" / "efficiency.csv").read_text()


def test_run_limit_serial_on_workers_and_on_dask_gives_one_table_and_a_rerun_computes_nothing(
    tmp_path, capsys
):
    pytest.importorskip("distributed")
    command = [*LIMIT, "--methods", "jacobi", "--seeds", "2"]
    assert main([*command, "--out", str(tmp_path / "serial")]) == 0
    tunings, _, cells, _ = _counts(capsys.readouterr().out)
    assert tunings == 2 and cells >= 2  # an oracle and a data-only tuning; a cell per seed
    for name, extra in (("jobs", ["--jobs", "2"]), ("dask", ["--executor", "dask", "--jobs", "2"])):
        assert main([*command, *extra, "--out", str(tmp_path / name)]) == 0
        assert _counts(capsys.readouterr().out) == (tunings, 0, cells, 0)
        assert _efficiency(tmp_path / name) == _efficiency(tmp_path / "serial"), name
    stored = stored_cells(tmp_path / "serial" / "store")  # twins of one computation too
    assert main([*command, "--out", str(tmp_path / "serial")]) == 0
    assert _counts(capsys.readouterr().out) == (0, tunings, 0, stored)


def test_a_killed_limit_study_resumes_to_the_uninterrupted_table(tmp_path, capsys):
    """SIGKILL of ``limit --jobs 2`` once some of its cells are stored: the rerun completes
    it, computing only what is missing, to the table of an uninterrupted run."""
    command = [*LIMIT, "--methods", "finite_difference,jacobi", "--seeds", "30"]
    command += ["--jobs", "2"]
    killed = tmp_path / "killed"
    stored = kill_once_stored(command, killed, stored_cells, 10)
    assert main([*command, "--out", str(killed)]) == 0
    tunings_computed, tunings_reused, computed, already = _counts(capsys.readouterr().out)
    assert (tunings_computed, tunings_reused) == (0, 4)
    assert already >= stored >= 10 and computed >= 1, "the kill should land mid-run"
    assert main([*command, "--out", str(tmp_path / "full")]) == 0
    assert _efficiency(killed) == _efficiency(tmp_path / "full")
