"""The runner and its store: bit-identical results, resumption, concurrent writers, no orphans."""

import contextlib
import json
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from diffbench.bench import runner
from diffbench.bench.core import executor
from diffbench.bench.core import store as store_module
from diffbench.bench.core.roles import Role
from diffbench.bench.core.store import STORE_FILE, Store
from diffbench.bench.report import tables
from diffbench.bench.tasks import available_tasks, get_task
from tests.bench.killing import CLI, ENV, STOPPABLE_RUN, finish, slow_plugin_env


def _cells(seeds=3, names=("finite_difference", "savitzky_golay"), task="paper-signal"):
    entries = get_task(task).lineup(list(names))
    return [
        cell for seed in range(seeds) for entry in entries for cell in entry.cells(task, [seed])
    ]


def _values(store: Store) -> np.ndarray:
    frame = store.cells_frame()
    return frame.sort_values(["method", "seed", "metric", "region", "order"])["value"].to_numpy()


def test_cells_expand_methods_times_seeds_with_presets_as_roles():
    cells = _cells(seeds=2, names=("butterworth", "kalman"))
    assert [(c.method, c.seed) for c in cells] == [
        ("butterworth", 0),
        ("kalman", 0),
        ("butterworth", 1),
        ("kalman", 1),
    ]
    assert cells[0].params == {"order": 6, "cutoff_hz": 25.0}
    assert cells[0].role.label == "preset (paper)" and cells[1].role.label == "preset (diffbench)"


def test_unknown_task_or_method_is_an_error():
    with pytest.raises(ValueError, match=r"unknown task 'paper-sig'; did you mean 'paper-signal'"):
        get_task("paper-sig")
    with pytest.raises(ValueError, match=r"unknown task 'zzz'; available: .*paper-signal"):
        get_task("zzz")
    with pytest.raises(ValueError, match="unknown method 'jacobbi'"):
        get_task("paper-signal").lineup(["jacobbi"])


def test_same_seed_gives_bit_identical_numbers(tmp_path):
    first, second = Store(tmp_path / "a"), Store(tmp_path / "b")
    runner.run(_cells(), first)
    runner.run(_cells(), second)
    np.testing.assert_array_equal(_values(first), _values(second))
    direct = runner.compute_cell(_cells()[0])
    frame = Store(tmp_path / "a").cells_frame()
    stored = frame[(frame["method"] == _cells()[0].method) & (frame["seed"] == 0)]
    np.testing.assert_array_equal(stored["value"].to_numpy(), [row["value"] for row in direct])


def test_rerun_computes_nothing_and_duplicates_are_computed_once(tmp_path):
    store = Store(tmp_path / "s")
    first = runner.run(_cells() + _cells(), store)  # every cell asked twice
    assert (first.total, first.computed) == (6, 6)
    again = runner.run(_cells(), store)
    assert (again.computed, again.skipped) == (0, 6)
    assert len(Store(tmp_path / "s").cells.records) == 6


def _retuned(cells, order=1):
    """The same cells in a tuned role (as if a tuning had landed on their parameters)."""
    role = Role.tuned("oracle", order, 10000)
    return [runner.Cell(c.task, c.method, dict(c.params), c.seed, role) for c in cells]


def _by_key(store: Store) -> dict:
    return dict(Store(store.directory).cells.records)


def test_cells_that_differ_only_in_their_role_are_computed_once(tmp_path):
    store = Store(tmp_path / "s")
    presets = _cells(seeds=2)
    summary = runner.run(presets + _retuned(presets) + _retuned(presets, 2), store)
    assert (summary.total, summary.computed, summary.reused) == (12, 4, 8)
    records = _by_key(store)
    assert len(records) == 12
    for cell in presets:
        computed = records[cell.key]
        assert "same_as" not in computed
        assert computed["scores"] == [
            [r["order"], r["region"], r["metric"], r["value"]] for r in runner.compute_cell(cell)
        ]
        for order in (1, 2):
            (twin,) = _retuned([cell], order)
            assert records[twin.key]["scores"] == computed["scores"]
            assert records[twin.key]["same_as"] == cell.key
            assert records[twin.key]["elapsed_s"] == computed["elapsed_s"]


def test_a_later_run_takes_a_computation_stored_by_the_same_code_only(tmp_path, monkeypatch):
    revision = {"git_rev": "0123abc", "versions": "numpy=2"}
    monkeypatch.setattr(store_module, "provenance", lambda: dict(revision))
    store = Store(tmp_path / "s")
    presets = _cells(seeds=2)
    runner.run(presets, store)
    again = runner.run(_retuned(presets), store)
    assert (again.computed, again.reused) == (0, 4)
    assert {_by_key(store)[c.key]["same_as"] for c in _retuned(presets)} == {c.key for c in presets}
    # other code (another revision, other versions, an uncommitted change): computed anew
    changes = ({"git_rev": "4567def"}, {"versions": "numpy=3"}, {"git_rev": "0123abc+dirty"})
    for index, changed in enumerate(changes):
        revision.update({"git_rev": "0123abc", "versions": "numpy=2", **changed})
        role = Role.tuned("oracle", 1, 20000 + index)  # a role not stored yet
        cells = [runner.Cell(c.task, c.method, dict(c.params), c.seed, role) for c in presets]
        summary = runner.run(cells, store)
        assert (summary.computed, summary.reused) == (4, 0), changed


def test_a_stored_computation_with_a_nan_score_is_taken_as_nan(tmp_path, monkeypatch):
    # NaN is stored as null; a cell taking that computation's scores stores null again
    monkeypatch.setattr(
        store_module, "provenance", lambda: {"git_rev": "0123abc", "versions": "numpy=2"}
    )
    (cell,) = _cells(seeds=1, names=("finite_difference",))
    scores = runner.compute_cell(cell)
    scores[0] = {**scores[0], "value": float("nan")}
    store = Store(tmp_path / "s")
    store.add_cell(
        task=cell.task,
        method=cell.method,
        params=cell.params,
        seed=cell.seed,
        role=cell.role.as_dict(),
        scores=scores,
        elapsed_s=0.1,
    )
    summary = runner.run(_retuned([cell]), store)
    assert (summary.computed, summary.reused) == (0, 1)
    taken = _by_key(store)[_retuned([cell])[0].key]["scores"]
    assert taken[0][3] is None
    assert taken[1:] == _by_key(store)[cell.key]["scores"][1:]


def test_a_variant_is_a_different_computation_from_its_base():
    (cell,) = _cells(seeds=1, names=("finite_difference",))
    variant = runner.Cell(
        cell.task,
        cell.method,
        dict(cell.params),
        cell.seed,
        Role(origin="variant", preset="paper-signal", by="diffbench", variant="nested"),
    )
    assert variant.computation != cell.computation
    assert _retuned([cell])[0].computation == cell.computation


def test_interrupted_run_keeps_finished_cells_and_resumes_to_the_same_table(tmp_path):
    reference = Store(tmp_path / "reference")
    runner.run(_cells(), reference)
    store = Store(tmp_path / "interrupted")

    def interrupt_after_two(cells, total):
        for index, cell in enumerate(cells):
            if index == 2:
                raise KeyboardInterrupt
            yield cell

    with pytest.raises(KeyboardInterrupt):
        runner.run(_cells(), store, progress=interrupt_after_two)
    assert len(Store(tmp_path / "interrupted").cells.records) == 2
    summary = runner.run(_cells(), store)
    assert (summary.skipped, summary.computed) == (2, 4)
    for columns in (tables.RMSE_COLUMNS, tables.DECOMPOSITION_COLUMNS):
        a = tables.wide_table(store.cells_frame(), columns)
        b = tables.wide_table(reference.cells_frame(), columns)
        assert a.equals(b)


def test_two_jobs_store_the_same_numbers_as_a_serial_run(tmp_path):
    serial, parallel = Store(tmp_path / "s"), Store(tmp_path / "p")
    cells = _cells(seeds=3, names=("finite_difference", "jacobi", "kalman"))
    runner.run(cells, serial)
    summary = runner.run(cells, parallel, jobs=2)
    assert summary.computed == 9
    np.testing.assert_array_equal(_values(serial), _values(parallel))


def test_jobs_must_be_a_positive_integer(tmp_path):
    with pytest.raises(ValueError, match="`jobs` must be an integer >= 1, got 0"):
        runner.run(_cells(), Store(tmp_path / "s"), jobs=0)


@pytest.mark.parametrize("task", ["paper-signal-clean", "jacobi-influence", "robot-sim-short"])
def test_every_kind_of_task_runs_and_reports(task, tmp_path):
    """Signal, variant (table I) and simulated-robot tasks through the one interface (the real
    robot's is in test_identification.py)."""
    from diffbench.bench.cli import main

    names = "jacobi" if task == "jacobi-influence" else "butterworth,jacobi"
    assert (
        main(
            [
                "run",
                task,
                "--seeds",
                "2",
                "--methods",
                names,
                "--out",
                str(tmp_path),
                "--no-progress",
            ]
        )
        == 0
    )
    written = sorted(p.name for p in (tmp_path / task).iterdir())
    expected = {
        "paper-signal-clean": "rmse.md",
        "jacobi-influence": "table1.md",
        "robot-sim-short": "table2.md",
    }[task]
    assert expected in written
    assert all(get_task(name).name == name for name in available_tasks())


def _children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        text = (task / "children").read_text().split()
        found += [int(child) for child in text]
    return found


def _alive(pid: int) -> bool:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except FileNotFoundError:
        return False
    return "State:\tZ" not in status


def _rows(directory: Path, sql: str) -> list[tuple]:
    """The rows of ``sql`` on the store in ``directory`` (read as it is on disk)."""
    with contextlib.closing(sqlite3.connect(directory / STORE_FILE)) as connection:
        return connection.execute(sql).fetchall()


def _wait_for_cells(directory: Path, count: int, process) -> None:
    """Wait until the store in ``directory`` holds ``count`` cells."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if (directory / STORE_FILE).exists() and len(Store(directory).cells.records) >= count:
            return
        if process.poll() is not None:
            raise AssertionError("the run ended before it could be interrupted")
        time.sleep(0.02)
    raise AssertionError("no cells stored in time")


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="reads /proc (Linux)")
@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGKILL])
def test_stopping_a_jobs_run_leaves_no_worker_and_the_rerun_completes(tmp_path, stop):
    """SIGTERM (exit 143) or SIGKILL of `run --jobs 2` mid-run: no worker process survives,
    every finished cell is kept, and the same command completes the run to the table of an
    uninterrupted one. One method sleeps 50 ms a call in the stopped run (``STOPPABLE_RUN``),
    so the stop lands while the workers compute."""
    env = slow_plugin_env(tmp_path / "plugin")
    out = tmp_path / "killed"
    process = subprocess.Popen(
        [*CLI, *STOPPABLE_RUN, "--jobs", "2", "--out", str(out)],
        env={**env, "DIFFBENCH_TEST_SLOW": "1"},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    _wait_for_cells(out / "store", 4, process)
    workers = _children(process.pid)
    assert len(workers) >= 2
    process.send_signal(stop)
    _, err = process.communicate(timeout=60)
    assert process.returncode == (143 if stop == signal.SIGTERM else -signal.SIGKILL)
    if stop == signal.SIGTERM:
        assert b"run the same command to resume" in err
    deadline = time.monotonic() + 10
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [pid for pid in workers if _alive(pid)], "orphaned workers"
    stored = len(Store(out / "store").cells.records)
    assert 0 < stored < 90, "the stop should land mid-run"
    finish(STOPPABLE_RUN, out, env)
    finish(STOPPABLE_RUN, tmp_path / "full", env)
    full = (tmp_path / "full" / "paper-signal" / "rmse.csv").read_text()
    assert (out / "paper-signal" / "rmse.csv").read_text() == full
    assert "slow.savitzky_golay" in full


def test_two_concurrent_runs_on_one_store_store_each_cell_once(tmp_path):
    """Two `diffbench run` processes on the same --out at once: every cell once, tables that
    count the seeds right, no error."""
    command = [
        *CLI,
        "run",
        "paper-signal",
        "--seeds",
        "10",
        "--methods",
        "finite_difference,savitzky_golay,butterworth",
        "--no-progress",
        "--out",
        str(tmp_path),
    ]
    runs = [
        subprocess.Popen(
            command, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        for _ in range(2)
    ]
    outputs = [run.communicate(timeout=300) for run in runs]
    assert [run.returncode for run in runs] == [0, 0], outputs
    keys = _rows(tmp_path / "store", "SELECT key FROM cells")
    assert len(keys) == len(set(keys)) == 30
    table = (tmp_path / "paper-signal" / "rmse.csv").read_text()
    assert table.count("\n") == 4 and all(",10\n" in row + "\n" for row in table.splitlines()[1:])


def test_tables_print_the_parameters_a_setting_uses_in_declaration_order():
    odd = json.dumps({"extension": "odd", "rolloff": 0.2, "cutoff_hz": 5.0, "fit_degree": 1})
    fitted = json.dumps(
        {"extension": "odd-fitted", "rolloff": 0.16, "cutoff_hz": 16.3, "fit_degree": 3}
    )
    assert tables.readable_params("spectral", odd) == "cutoff_hz=5, rolloff=0.2, extension=odd"
    assert tables.readable_params("spectral", fitted) == (
        "cutoff_hz=16.3, rolloff=0.16, extension=odd-fitted, fit_degree=3"
    )
    # a method not registered keeps every stored parameter, sorted by name
    assert tables.readable_params("nowhere.method", '{"b": 2, "a": 1.23456}') == "a=1.235, b=2"


def _square_after(item):
    import time

    time.sleep(item[1])
    return item[0] ** 2


def test_completed_map_yields_each_result_as_it_finishes():
    """Two workers, the first item the slowest: its result comes last, every result is its
    item's, and one job keeps the items' order."""
    from diffbench.bench.core.executor import completed_map

    items = [(3, 1.0), (4, 0.0), (5, 0.0)]
    found = list(completed_map(_square_after, items, jobs=2))
    assert sorted(found) == [((3, 1.0), 9), ((4, 0.0), 16), ((5, 0.0), 25)]
    assert found[-1] == ((3, 1.0), 9)
    assert list(completed_map(_square_after, items[1:], jobs=1)) == [((4, 0.0), 16), ((5, 0.0), 25)]
    with pytest.raises(ValueError, match="`jobs` must be an integer >= 1, got 0"):
        list(completed_map(_square_after, items, jobs=0))


def _blas_threads(item):
    import numpy  # noqa: F401  (loads its BLAS)
    from threadpoolctl import threadpool_info

    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


@pytest.mark.parametrize("jobs", [1, 2])
def test_every_item_runs_with_one_blas_thread_here_and_on_workers(jobs):
    """Items run under ``BLAS_THREADS`` (1) BLAS threads, serially here or on local workers:
    two workers run two threads, not two each, and compute as a serial run does; this
    process's own limit is given back after a serial map."""
    from threadpoolctl import threadpool_info

    from diffbench.bench.core.executor import BLAS_THREADS, completed_map, ordered_map

    def outside():
        return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]

    before = outside()
    assert before, "numpy's BLAS is not seen by threadpoolctl"
    for found in ordered_map(_blas_threads, [0, 1, 2], jobs=jobs):
        assert found and set(found) == {BLAS_THREADS}
    for _, found in completed_map(_blas_threads, [0, 1], jobs=jobs):
        assert found and set(found) == {BLAS_THREADS}
    assert outside() == before


def _stub_tuning(job, timeout_s=None):
    """A tuning record of ``job`` (its method's defaults), without tuning; the ẍ Kalman one
    first waits until the store holds the ẋ one (the store of ``_STUB_STORE``)."""
    waited = None
    if job.order == 2:
        deadline = time.monotonic() + 60
        with contextlib.closing(sqlite3.connect(_STUB_STORE[0])) as connection:
            while time.monotonic() < deadline:
                query = 'SELECT count(*) FROM tunings WHERE method = ? AND "order" = 1'
                if connection.execute(query, (job.method,)).fetchone()[0]:
                    waited = True
                    break
                time.sleep(0.05)
            else:
                waited = False
    from diffbench import methods

    params = methods.get(job.method).params()
    return {
        "params": params,
        "loss": 1.0 if waited is not False else 2.0,
        "evaluations": 1,
        "seconds": 0.0,
    }


_STUB_STORE: list[Path] = []


def test_tunings_start_longest_first_and_come_back_in_the_order_asked(tmp_path, monkeypatch):
    """More tuning seeds first, then ẍ before ẋ; the records returned in the order asked."""
    started = []

    def record_order(job, timeout_s=None):
        started.append((job.method, job.order, job.tuning_seeds))
        return {"params": {}, "loss": float("inf"), "evaluations": 0, "seconds": 0.0}

    monkeypatch.setattr(runner, "_tune", record_order)
    jobs = [
        runner.TuningJob("paper-signal", name, "oracle", order, 10_000, tuning_seeds=seeds)
        for seeds in (1, 10)
        for name in ("kalman", "jacobi")
        for order in (1, 2)
    ]
    found, summary = runner.tune_all(jobs, Store(tmp_path / "s"))
    assert started == [
        ("kalman", 2, 10),
        ("jacobi", 2, 10),
        ("kalman", 1, 10),
        ("jacobi", 1, 10),
        ("kalman", 2, 1),
        ("jacobi", 2, 1),
        ("kalman", 1, 1),
        ("jacobi", 1, 1),
    ]
    assert list(found) == jobs and summary.computed == len(jobs)


@pytest.mark.skipif(not executor.forks(), reason="the stub reaches workers by fork only")
def test_a_tuning_is_stored_as_soon_as_it_is_done_not_after_those_begun_before_it(
    tmp_path, monkeypatch
):
    """On two workers the ẍ tuning (begun first) waits until the store holds the ẋ one
    (begun second): which only happens if each tuning is stored when it finishes. Stored in
    the order the store got them, ẋ first; an interruption during the ẍ tuning keeps ẋ."""
    store = Store(tmp_path / "s")
    _STUB_STORE[:] = [store.path]
    monkeypatch.setattr(runner, "_tune", _stub_tuning)
    jobs = [runner.TuningJob("paper-signal", "kalman", "oracle", order, 10_000) for order in (1, 2)]
    found, _ = runner.tune_all(jobs, store, jobs=2)
    assert found[jobs[1]]["loss"] == 1.0  # the ẍ tuning saw the ẋ one stored
    with contextlib.closing(sqlite3.connect(store.path)) as connection:
        stored = connection.execute('SELECT "order" FROM tunings ORDER BY id').fetchall()
    assert stored == [(1,), (2,)]


FORKED_CHILD = """
import os, signal, sys, time
from diffbench.bench.core import executor

previous = executor.terminate_on_sigterm()
read, write = os.pipe()
child = os.fork()
if child == 0:
    os.write(write, b"dfl" if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL else b"own")
    sum(range(10**13))  # C code that never returns to the interpreter to run a handler
    os._exit(0)
print(os.read(read, 3).decode(), flush=True)
os.kill(child, signal.SIGTERM)
deadline = time.monotonic() + 10
while time.monotonic() < deadline:
    done, status = os.waitpid(child, os.WNOHANG)
    if done:
        break
    time.sleep(0.05)
else:
    os.kill(child, signal.SIGKILL)
    os.waitpid(child, 0)
    print("survived SIGTERM", flush=True)
    sys.exit(1)
print("killed" if os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGTERM else status)
assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL  # the parent keeps its own
"""


def test_a_child_forked_by_a_library_is_ended_by_sigterm_even_inside_c_code():
    """A process forked from diffbench's (PyNumDiff's pool workers) starts with the default
    SIGTERM, not diffbench's Python handler, which would wait for its main thread to return to
    the interpreter: a child busy in C code is ended at once, by the signal."""
    found = subprocess.run(
        [sys.executable, "-c", FORKED_CHILD], capture_output=True, text=True, timeout=60, env=ENV
    )
    assert found.returncode == 0, found.stdout + found.stderr
    assert found.stdout.split() == ["dfl", "killed"]
