"""The runner and its store: bit-identical results, resumption after an interruption."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from diffbench.bench import runner, tables
from diffbench.bench.store import COLUMNS, ResultStore

ROOT = Path(__file__).resolve().parents[2]


def _cells(seeds=3, names=("finite_difference", "savitzky_golay")):
    return runner.preset_cells("paper-signal", range(seeds), list(names))


def test_cells_expand_methods_times_seeds_with_presets():
    cells = _cells(seeds=2, names=("butterworth", "savitzky_golay"))
    assert [(c.method, c.seed) for c in cells] == [
        ("butterworth", 0),
        ("savitzky_golay", 0),
        ("butterworth", 1),
        ("savitzky_golay", 1),
    ]
    assert cells[0].params == {"order": 6, "cutoff_hz": 25.0}
    assert "paper, sec. III.C" in cells[0].preset


def test_unknown_scenario_or_method_is_an_error():
    with pytest.raises(ValueError, match="paper-signal"):
        runner.preset_cells("paper-sig", range(1))
    with pytest.raises(ValueError, match="unknown method 'jacobbi'"):
        runner.preset_cells("paper-signal", range(1), ["jacobbi"])


def test_same_seed_gives_bit_identical_numbers(tmp_path):
    first, second = ResultStore(tmp_path / "a.csv"), ResultStore(tmp_path / "b.csv")
    runner.run(_cells(), first)
    runner.run(_cells(), second)
    a, b = first.load(), second.load()
    np.testing.assert_array_equal(a["value"].to_numpy(), b["value"].to_numpy())
    assert list(a["cell_key"]) == list(b["cell_key"])
    # and the stored text reloads to exactly the computed floats
    direct = runner.compute_cell(_cells()[0])
    stored = a[a["cell_key"] == _cells()[0].key]["value"].to_numpy()
    np.testing.assert_array_equal(stored, [row["value"] for row in direct])


def test_different_seeds_give_different_numbers(tmp_path):
    store = ResultStore(tmp_path / "r.csv")
    runner.run(_cells(seeds=2, names=("finite_difference",)), store)
    rows = store.load()
    rmse = rows[(rows["metric"] == "rmse") & (rows["order"] == 1) & (rows["region"] == "valid")]
    assert rmse["value"].nunique() == 2


def test_rerun_computes_nothing_and_adds_no_rows(tmp_path):
    store = ResultStore(tmp_path / "r.csv")
    first = runner.run(_cells(), store)
    rows = len(store.load())
    again = runner.run(_cells(), store)
    assert (first.computed, again.computed, again.skipped) == (6, 0, 6)
    assert len(store.load()) == rows


def test_interrupted_run_keeps_finished_cells_and_resumes_to_the_same_table(tmp_path):
    reference = ResultStore(tmp_path / "reference.csv")
    runner.run(_cells(), reference)

    store = ResultStore(tmp_path / "interrupted.csv")

    def interrupt_after_two(cells, total):
        for index, cell in enumerate(cells):
            if index == 2:
                raise KeyboardInterrupt
            yield cell

    with pytest.raises(KeyboardInterrupt):
        runner.run(_cells(), store, progress=interrupt_after_two)
    assert len(store.completed_keys()) == 2
    summary = runner.run(_cells(), store)
    assert (summary.skipped, summary.computed) == (2, 4)
    assert tables.rmse_wide(store.load()).equals(tables.rmse_wide(reference.load()))
    decomposition = tables.DECOMPOSITION_COLUMNS
    assert tables.wide_table(store.load(), decomposition).equals(
        tables.wide_table(reference.load(), decomposition)
    )


def test_torn_last_line_and_partial_cell_are_dropped(tmp_path):
    path = tmp_path / "r.csv"
    store = ResultStore(path)
    runner.run(_cells(seeds=1), store)
    complete = path.read_text()
    lines = complete.splitlines(keepends=True)
    # a kill during the write of a third cell: two whole lines of it, then half a line
    extra = ResultStore(tmp_path / "other.csv")
    runner.run(_cells(seeds=2)[2:3], extra)
    third = extra.path.read_text().splitlines(keepends=True)[1:]
    path.write_text("".join(lines) + "".join(third[:2]) + third[2][:17])
    repaired = ResultStore(path)
    assert path.read_text() == complete
    assert len(repaired.completed_keys()) == 2


def test_store_refuses_a_foreign_file(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a diffbench results file"):
        ResultStore(path)


def test_store_header_is_the_documented_columns(tmp_path):
    store = ResultStore(tmp_path / "r.csv")
    assert store.path.read_text().strip() == ",".join(COLUMNS)


@pytest.mark.skipif(os.name != "posix", reason="uses SIGKILL")
def test_killed_process_resumes_to_the_same_table(tmp_path):
    """A real kill -9 half-way: the same command then completes the run, and the table equals
    that of an uninterrupted run."""
    command = [
        sys.executable,
        "-m",
        "diffbench.bench",
        "run",
        "paper-signal",
        "--seeds",
        "40",
        "--methods",
        "finite_difference,savitzky_golay,butterworth",
        "--no-progress",
    ]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    subprocess.run(
        [*command, "--out", str(tmp_path / "full")], env=env, check=True, capture_output=True
    )
    store_path = tmp_path / "killed" / "paper-signal" / "cells.csv"
    process = subprocess.Popen(
        [*command, "--out", str(tmp_path / "killed")],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if store_path.exists() and store_path.read_text().count("\n") > 60:
            break
        time.sleep(0.005)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert process.returncode == -signal.SIGKILL
    stored = len(ResultStore(store_path).completed_keys())
    assert 0 < stored < 120, "the kill should land mid-run"
    subprocess.run(
        [*command, "--out", str(tmp_path / "killed")], env=env, check=True, capture_output=True
    )
    full = (tmp_path / "full" / "paper-signal" / "rmse.csv").read_text()
    resumed = (tmp_path / "killed" / "paper-signal" / "rmse.csv").read_text()
    assert resumed == full


def test_two_jobs_store_the_same_numbers_as_a_serial_run(tmp_path):
    serial, parallel = ResultStore(tmp_path / "s.csv"), ResultStore(tmp_path / "p.csv")
    cells = _cells(seeds=3, names=("finite_difference", "jacobi", "kalman"))
    runner.run(cells, serial)
    summary = runner.run(cells, parallel, jobs=2)
    assert summary.computed == 9
    a, b = serial.load(), parallel.load()
    assert list(a["cell_key"]) == list(b["cell_key"])
    np.testing.assert_array_equal(a["value"].to_numpy(), b["value"].to_numpy())


def test_jobs_must_be_a_positive_integer(tmp_path):
    with pytest.raises(ValueError, match="`jobs` must be an integer >= 1, got 0"):
        runner.run(_cells(), ResultStore(tmp_path / "r.csv"), jobs=0)
