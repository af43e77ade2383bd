"""Runs on Dask (the optional extra): the same numbers as a serial run, a killed client that
resumes, a running scheduler by address."""

import signal
import subprocess
import time

import numpy as np
import pytest

from diffbench.bench import runner
from diffbench.bench.cli import main
from diffbench.bench.core import executor
from diffbench.bench.core.executor import DaskWorkers
from diffbench.bench.core.store import Store

distributed = pytest.importorskip("dask.distributed")

from tests.bench.killing import CLI, STOPPABLE_RUN, finish, slow_plugin_env  # noqa: E402
from tests.bench.test_runner import _cells, _rows, _values, _wait_for_cells  # noqa: E402

IN_PROCESS = DaskWorkers(workers=2, processes=False)  # threads of this process: fast to start


def test_a_local_cluster_stores_the_same_numbers_as_a_serial_run(tmp_path):
    serial, on_dask = Store(tmp_path / "s"), Store(tmp_path / "d")
    cells = _cells(seeds=3, names=("finite_difference", "jacobi", "kalman"))
    runner.run(cells, serial)
    summary = runner.run(cells, on_dask, jobs=IN_PROCESS)
    assert summary.computed == 9
    np.testing.assert_array_equal(_values(serial), _values(on_dask))


def test_a_tuning_on_dask_is_the_serial_tuning(tmp_path):
    jobs = [
        runner.TuningJob("paper-signal", name, "oracle", 1, 10_000, budget=12)
        for name in ("savitzky_golay", "butterworth")
    ]
    serial, _ = runner.tune_all(jobs, Store(tmp_path / "s"))
    on_dask, summary = runner.tune_all(jobs, Store(tmp_path / "d"), jobs=IN_PROCESS)
    assert summary.computed == 2
    for job in jobs:
        assert on_dask[job]["params"] == serial[job]["params"]
        assert on_dask[job]["loss"] == serial[job]["loss"]


def test_completed_map_on_dask_returns_each_item_with_its_result():
    items = list(range(7))
    found = dict(executor.completed_map(abs, [-i for i in items], IN_PROCESS))
    assert found == {-i: i for i in items}
    assert list(executor.ordered_map(abs, [-3, 1, -2], IN_PROCESS)) == [3, 1, 2]
    assert list(executor.ordered_map(abs, [], IN_PROCESS)) == []


def test_the_cli_runs_on_a_scheduler_given_by_address(tmp_path):
    command = [
        "run",
        "paper-signal",
        "--seeds",
        "2",
        "--methods",
        "finite_difference,savitzky_golay",
        "--no-progress",
    ]
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        address = cluster.scheduler_address
        assert main([*command, "--scheduler", address, "--out", str(tmp_path / "d")]) == 0
    assert main([*command, "--out", str(tmp_path / "s")]) == 0
    on_dask = (tmp_path / "d" / "paper-signal" / "rmse.csv").read_text()
    assert on_dask == (tmp_path / "s" / "paper-signal" / "rmse.csv").read_text()
    (run,) = Store(tmp_path / "d" / "store").runs.values()
    assert f"--scheduler {address}" in run["command"]


def test_a_scheduler_that_does_not_answer_is_a_usage_error(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(executor, "SCHEDULER_TIMEOUT_S", 1)
    code = main(
        [
            "run",
            "paper-signal",
            "--seeds",
            "1",
            "--methods",
            "finite_difference",
            "--scheduler",
            "tcp://127.0.0.1:9",
            "--out",
            str(tmp_path),
        ]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no Dask scheduler answers at 'tcp://127.0.0.1:9'" in err
    assert not (tmp_path / "store").exists()


def test_killing_the_client_mid_run_loses_nothing_and_the_rerun_completes(tmp_path):
    """SIGKILL of `run --executor dask --jobs 2` (its LocalCluster's processes with it or
    after them): the finished cells are stored once each, and the same command completes the
    run to the table of an uninterrupted one. One method sleeps 50 ms a call in the killed run
    (``STOPPABLE_RUN``), so the kill lands while the workers compute."""
    env = slow_plugin_env(tmp_path / "plugin")
    out = tmp_path / "killed"
    process = subprocess.Popen(
        [*CLI, *STOPPABLE_RUN, "--executor", "dask", "--jobs", "2", "--out", str(out)],
        env={**env, "DIFFBENCH_TEST_SLOW": "1"},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    _wait_for_cells(out / "store", 4, process)
    process.send_signal(signal.SIGKILL)
    process.communicate(timeout=60)
    stored = len(Store(out / "store").cells.records)
    assert 0 < stored < 90, "the kill should land mid-run"
    time.sleep(0.5)
    finish([*STOPPABLE_RUN, "--executor", "dask", "--jobs", "2"], out, env)
    finish(STOPPABLE_RUN, tmp_path / "full", env)
    full = (tmp_path / "full" / "paper-signal" / "rmse.csv").read_text()
    assert (out / "paper-signal" / "rmse.csv").read_text() == full
    keys = _rows(out / "store", "SELECT key FROM cells")
    assert len(keys) == len(set(keys)) == 90


def _warns_like_scipy(value):
    """A third-party warning (a category of another package, raised from its file)."""
    import warnings

    from scipy.signal import BadCoefficients

    warnings.warn_explicit("Badly conditioned filter coefficients", BadCoefficients, "scipy.py", 7)
    return -value


def test_warnings_on_dask_worker_processes_reach_the_clients_log(tmp_path):
    """Workers in other processes would keep third-party warnings in their own logs: each
    comes back with its result and goes to the run's warnings log, one line each."""
    from diffbench.bench import console

    log = tmp_path / console.WARNINGS_LOG
    console.route_third_party_warnings(log)
    try:
        import functools
        import warnings

        with warnings.catch_warnings():
            warnings.showwarning = functools.partial(console.one_line_warning, warnings.showwarning)
            warnings.simplefilter("always")
            spec = DaskWorkers(workers=2)  # worker processes
            found = list(executor.ordered_map(_warns_like_scipy, [1, 2, 3], spec))
    finally:
        console.route_third_party_warnings(None)
    assert found == [-1, -2, -3]
    lines = log.read_text().splitlines()
    assert len(lines) == 3 and all("BadCoefficients: Badly conditioned" in li for li in lines)


def test_a_dask_session_starts_one_cluster_for_every_map_within_it(monkeypatch):
    """``recommend`` maps once per channel: within a session they share one local cluster."""
    started = []

    class Counted(distributed.LocalCluster):
        def __init__(self, *args, **kwargs):
            started.append(1)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(distributed, "LocalCluster", Counted)
    with executor.dask_session(IN_PROCESS):
        assert list(executor.ordered_map(abs, [-1, -2], IN_PROCESS)) == [1, 2]
        assert list(executor.ordered_map(abs, [-3], IN_PROCESS)) == [3]
    assert len(started) == 1
    assert list(executor.ordered_map(abs, [-4], IN_PROCESS)) == [4]  # after it: its own
    assert len(started) == 2
    with executor.dask_session(2):  # local processes: nothing to share
        assert list(executor.ordered_map(abs, [-5], 2)) == [5]
