"""The bad cases of issue 43's adversarial battery, each run as a real ``diffbench`` process:
one clear line and a non-zero exit (2 for what the user must fix), or a clear warning and a
correct result, and nothing stored lost."""

import contextlib
import json
import os
import re
import resource
import sqlite3
import subprocess
import sys
import textwrap
import uuid
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from diffbench.bench.core import tuning
from diffbench.bench.core.store import STORE_FILE, Store
from diffbench.bench.tasks import get_task

PLUGIN = textwrap.dedent(
    """
    import sys
    import time

    import numpy as np

    from diffbench.methods import Method, register


    class _Base(Method):
        linear = False
        reference = "test"

        def _estimate(self, x, dt, orders):
            valid = {o: np.ones(x.shape[0], bool) for o in orders}
            return self._values(x, orders), valid


    @register("bad.raises")
    class Raises(_Base):
        def _values(self, x, orders):
            raise RuntimeError("the plugin's own bug")


    @register("bad.exits")
    class Exits(_Base):
        def _values(self, x, orders):
            sys.exit(5)


    @register("bad.shape")
    class Shape(_Base):
        def _values(self, x, orders):
            return {o: np.zeros(x.shape[0] + 1) for o in orders}


    @register("bad.nan")
    class Nan(_Base):
        def _values(self, x, orders):
            return {o: np.full(x.shape, np.nan) for o in orders}


    @register("bad.inf")
    class Inf(_Base):
        def _values(self, x, orders):
            return {o: np.full(x.shape, np.inf) for o in orders}


    @register("bad.dies")
    class Dies(_Base):
        def _values(self, x, orders):
            import os

            os._exit(7)


    @register("bad.hangs")
    class Hangs(_Base):
        def _values(self, x, orders):
            while True:
                time.sleep(0.01)
    """
)


def _diffbench(*argv, env=None, **options):
    return subprocess.run(
        [sys.executable, "-m", "diffbench.bench", *map(str, argv)],
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
        timeout=300,
        **options,
    )


def _one_error_line(result, message: str, code: int = 2) -> None:
    assert result.returncode == code, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("diffbench: error:"), result.stderr
    assert message in lines[0], lines[0]


@pytest.fixture
def plugin(tmp_path):
    folder = tmp_path / "plugin"
    folder.mkdir()
    (folder / "bad_methods.py").write_text(PLUGIN)
    return {"PYTHONPATH": str(folder)}


# 1 -----------------------------------------------------------------------------------------
def test_a_cutoff_below_what_the_record_resolves_or_at_nyquist_is_refused(tmp_path):
    """paper-signal: 1001 samples 1 ms apart, 701 interior ones (what the no-truth spectrum is
    taken on): cutoffs from 1/0.701 s = 1.427 Hz up to below 500 Hz; PyNumDiff's loss reads the
    record, 1/1.001 s."""
    realisation = get_task("paper-signal").tuning_data(10_000)
    low, high = tuning.cutoff_range_hz(realisation, "no-truth")
    assert (low, high) == (1 / (701 * 0.001), 0.5 / 0.001)
    assert tuning.cutoff_range_hz(realisation, "pynumdiff")[0] == 1 / (1001 * 0.001)
    with pytest.raises(ValueError, match=r"`cutoff_hz` must lie in \[1.427, 500\) Hz"):
        tuning.tune("kalman", realisation, 2, "no-truth", cutoff_hz=1e-300)
    tuning.check_cutoff(low, realisation, "no-truth")  # the bounds that work are accepted
    tuning.check_cutoff(499.9, realisation, "no-truth")
    for cutoff in ("1e-300", "1.4", "500"):
        result = _diffbench(
            "tune",
            "kalman",
            "paper-signal",
            "--criteria",
            "no-truth",
            "--cutoff-hz",
            cutoff,
            "--out",
            tmp_path,
        )
        _one_error_line(
            result,
            "--cutoff-hz on paper-signal: `cutoff_hz` must lie in "
            "[1.427, 500) Hz for the no-truth criterion",
        )
    # the oracle does not read a cutoff: one given with it only is refused, not ignored
    result = _diffbench(
        "tune", "kalman", "paper-signal", "--cutoff-hz", "1e-300", "--out", tmp_path
    )
    _one_error_line(
        result,
        "--cutoff-hz is read by the no-truth and pynumdiff criteria only, not by oracle: "
        "drop it, or add one of them to --criteria",
    )
    assert not Store(tmp_path / "store").tunings.records  # nothing stored as a tuning


# 2 -----------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["run", "paper-signal", "--seeds", "99999999999999999999"],
            "--seeds: must be a whole number >= 1 and <= 10_000",
        ),
        (["grid", "--seeds", "10001"], "--seeds: must be a whole number >= 1 and <= 10_000"),
        (
            ["tune", "kalman", "paper-signal", "--tuning-seeds", "101"],
            "--tuning-seeds: must be a whole number >= 1 and <= 100",
        ),
        (
            ["tune", "kalman", "paper-signal", "--tuning-seed", "99999999999999999999"],
            "--tuning-seed: must be a whole number >= 0 and <= 4_294_967_295",
        ),
        (
            [
                "tune",
                "kalman",
                "paper-signal",
                "--tuning-seed",
                "4294967295",
                "--tuning-seeds",
                "2",
            ],
            "goes past the largest seed 4294967295; choose a tuning seed <= 4294967294",
        ),
        (
            ["export", "paper-signal", "x.csv", "--seed", "-1"],
            "--seed: must be a whole number >= 0 and <= 4_294_967_295",
        ),
        (["run", "paper-signal", "--jobs", "100000"], "--jobs: must be a whole number >= 1"),
    ],
)
def test_seeds_and_counts_are_bounded(argv, message, tmp_path):
    _one_error_line(
        _diffbench(*argv, "--out", tmp_path)
        if argv[0] != "export"
        else _diffbench(*argv, cwd=tmp_path),
        message,
    )
    assert not (tmp_path / "store").exists()


# 3 -----------------------------------------------------------------------------------------
def test_a_torn_line_in_an_old_stores_rows_is_not_imported_and_the_run_resumes(tmp_path):
    argv = [
        "recommend-check",
        "--scenarios",
        "grid-gaussian-0.2-10ms",
        "--methods",
        "spectral,butterworth",
        "--out",
        tmp_path,
    ]
    first = _diffbench(*argv)
    assert first.returncode == 0, first.stderr
    assert "1 items computed, 0 already stored" in first.stdout
    table = (tmp_path / "recommend-validation" / "validation.csv").read_text()
    # the same rows in the JSON Lines store of an earlier diffbench, killed mid-line
    (tmp_path / "store").rename(tmp_path / "new")
    (record,) = Store(tmp_path / "new").studies.records.values()
    header = {"record": "header", "format": "diffbench-store", "kind": "study", "version": 1}
    (tmp_path / "store").mkdir()
    with (tmp_path / "store" / "studies.jsonl").open("w") as stream:
        stream.write(json.dumps(header) + "\n" + json.dumps(record) + "\n")
        stream.write('{"key":"[\\"recommend-validation\\",\\"grid-gau')  # a killed writer's
    again = _diffbench(*argv)
    assert again.returncode == 0, again.stderr
    assert "0 items computed, 1 already stored" in again.stdout  # nothing recomputed
    assert "not imported studies.jsonl line 3: torn last line" in again.stderr
    assert (tmp_path / "recommend-validation" / "validation.csv").read_text() == table
    stored = Store(tmp_path / "store").studies.records
    assert [record["item"] for record in stored.values()] == ["grid-gaussian-0.2-10ms"]
    rows = Store(tmp_path / "store").find_study_rows(
        "recommend-validation", "grid-gaussian-0.2-10ms", ["spectral", "butterworth"]
    )
    assert [row["order"] for row in rows] == [1, 2]


# 4 -----------------------------------------------------------------------------------------
def _processes_marked(mark: str) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and mark.encode() in (entry / "environ").read_bytes():
                found.append(int(entry.name))
        except OSError:
            continue
    return found


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_method_that_never_returns_times_out_as_a_failed_cell(jobs, tmp_path, plugin):
    mark = f"DIFFBENCH_TEST_{uuid.uuid4().hex}"
    argv = [
        "run",
        "paper-signal",
        "--plugin",
        "bad_methods",
        "--seeds",
        "2",
        "--no-progress",
        "--methods",
        "bad.hangs,finite_difference",
        "--timeout",
        "1",
        "--jobs",
        jobs,
        "--out",
        tmp_path,
    ]
    result = _diffbench(*argv, env={**plugin, mark: "1"})
    assert result.returncode == 0, result.stderr
    assert "2 cells computed, 0 already stored, 2 failed" in result.stdout
    for seed in (0, 1):
        assert (
            f"cell failed: bad.hangs on paper-signal seed {seed}: plugin bad_methods "
            "(dist none): method bad.hangs: timed out after 1 s (--timeout)"
        ) in result.stderr
    failed = pd.read_csv(tmp_path / "paper-signal" / "failed.csv")
    assert sorted(failed["seed"]) == [0, 1] and set(failed["method"]) == {"bad.hangs"}
    store = Store(tmp_path / "store")
    assert {r["method"] for r in store.cells.records.values()} == {"finite_difference"}
    assert _processes_marked(mark) == []  # no worker left behind


# 5 -----------------------------------------------------------------------------------------
def test_a_plugin_method_that_fails_is_a_named_failed_cell_retried_by_the_next_run(
    tmp_path, plugin
):
    argv = [
        "run",
        "paper-signal",
        "--plugin",
        "bad_methods",
        "--seeds",
        "1",
        "--no-progress",
        "--methods",
        "bad.raises,bad.exits,bad.shape,bad.nan,bad.inf,finite_difference",
        "--out",
        tmp_path,
    ]
    result = _diffbench(*argv, env=plugin)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert "1 cells computed, 0 already stored, 5 failed" in result.stdout
    prefix = "cell failed: {} on paper-signal seed 0: plugin bad_methods (dist none): method {}: "
    for name, reason in [
        ("bad.raises", "RuntimeError: the plugin's own bug"),
        ("bad.exits", "SystemExit: 5"),
        ("bad.shape", "ValueError: valid mask of order 0 does not match the time axis"),
        ("bad.nan", "ValueError: order 0: the estimate is not finite on a valid sample"),
        ("bad.inf", "ValueError: order 0: the estimate is not finite on a valid sample"),
    ]:
        assert prefix.format(name, name) + reason in result.stderr
    assert "5 cells of paper-signal failed and are not in its tables" in result.stderr
    failed = pd.read_csv(tmp_path / "paper-signal" / "failed.csv")
    assert sorted(failed["method"]) == [
        "bad.exits",
        "bad.inf",
        "bad.nan",
        "bad.raises",
        "bad.shape",
    ]
    # a failed cell is not a finished one: the next run tries it again, and only it
    again = _diffbench(*argv, env=plugin)
    assert again.returncode == 0, again.stderr
    assert "0 cells computed, 1 already stored, 5 failed" in again.stdout
    store = Store(tmp_path / "store")
    assert len(store.cells.records) == 1 and len(store.failures.records) == 10
    assert len(store.failed_cells("paper-signal")) == 5


# 6 -----------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("code", "message"),
    [
        (
            "import no_such_dependency_xyz\n",
            "--plugin: plugin module 'broken' failed to import: ModuleNotFoundError: No module "
            "named 'no_such_dependency_xyz'",
        ),
        (
            "import sys\nsys.exit(3)\n",
            "--plugin: plugin module 'broken' failed to import: it called sys.exit(3) while "
            "being imported",
        ),
    ],
)
def test_a_plugin_module_that_fails_to_import_is_one_line(code, message, tmp_path):
    (tmp_path / "broken.py").write_text(code)
    result = _diffbench("list", "--plugin", "broken", env={"PYTHONPATH": str(tmp_path)})
    _one_error_line(result, message)
    assert result.stdout == ""


def test_a_plugin_that_ends_its_worker_process_is_one_line_and_the_run_resumes(tmp_path, plugin):
    """``os._exit`` in a plugin's method on 2 workers: the pool breaks; one line says so
    (exit 1, no traceback), the cells finished before are kept, and the run without the plugin
    completes from them."""
    common = ["run", "paper-signal", "--seeds", "6", "--no-progress", "--out", tmp_path]
    methods = ["--methods", "finite_difference,bad.dies"]
    first = _diffbench(*common, "--plugin", "bad_methods", "--jobs", "2", *methods, env=plugin)
    _one_error_line(first, "a worker process died", code=1)
    assert "run the same command to resume" in first.stderr
    again = _diffbench(*common, "--methods", "finite_difference")
    assert again.returncode == 0, again.stderr
    assert "6 cells computed" not in again.stdout  # some were stored by the first run
    assert (tmp_path / "paper-signal" / "rmse.csv").exists()


# 7 -----------------------------------------------------------------------------------------
@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full on this system")
@pytest.mark.parametrize("argv", [["list"], ["--help"], ["run", "--help"]])
def test_a_full_disk_on_the_output_is_one_line(argv):
    """``--help`` too: argparse prints it and exits, the output still has to reach the disk."""
    with open("/dev/full", "w") as full:
        result = subprocess.run(
            [sys.executable, "-m", "diffbench.bench", *argv],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            timeout=300,
        )
    _one_error_line(result, "No space left on device: the standard output")


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full on this system")
def test_a_full_disk_on_the_error_output_leaves_the_exit_code(tmp_path):
    """Nowhere to say it: the usage error's exit code alone (1 and a failed traceback
    before)."""
    with open("/dev/full", "w") as full:
        result = subprocess.run(
            [sys.executable, "-m", "diffbench.bench", "run", "nosuch", "--out", tmp_path],
            stdout=subprocess.PIPE,
            stderr=full,
            text=True,
            timeout=300,
        )
    assert result.returncode == 2


def test_an_out_that_is_a_file_is_one_line_saying_so(tmp_path):
    (tmp_path / "rec.csv").write_text("t,x\n")
    result = _diffbench(
        "run",
        "paper-signal",
        "--seeds",
        "1",
        "--methods",
        "finite_difference",
        "--no-progress",
        "--out",
        tmp_path / "rec.csv",
    )
    _one_error_line(
        result, "a file stands where the path needs a folder: give a folder, e.g. --out"
    )


def test_the_file_size_limit_during_a_run_is_one_line_and_the_run_resumes(tmp_path):
    """128 kB holds the empty database (about 50 kB) and a few cells: the limit falls inside
    the run (the write-ahead log reaches it)."""
    argv = [
        "run",
        "paper-signal",
        "--seeds",
        "3",
        "--no-progress",
        "--methods",
        "butterworth,finite_difference",
        "--out",
        tmp_path,
    ]

    def limited():
        resource.setrlimit(resource.RLIMIT_FSIZE, (131072, 131072))

    result = _diffbench(*argv, preexec_fn=limited)
    _one_error_line(result, "File too large: the file size limit (ulimit -f) is 131072 bytes")
    assert result.stderr.strip().endswith(str(tmp_path / "store" / STORE_FILE))
    kept = set(Store(tmp_path / "store").cells.records)
    assert 1 <= len(kept) < 6
    again = _diffbench(*argv)
    assert again.returncode == 0, again.stderr
    assert f"{6 - len(kept)} cells computed, {len(kept)} already stored" in again.stdout
    store = Store(tmp_path / "store")
    assert len(store.cells.records) == 6 and kept <= set(store.cells.records)


# 8 -----------------------------------------------------------------------------------------
def test_a_store_of_another_format_version_is_one_line(tmp_path):
    cells = tmp_path / "store" / "cells.jsonl"
    cells.parent.mkdir()
    header = '{"format":"diffbench-store","kind":"cell","record":"header","version":2}\n'
    cells.write_text(header)
    result = _diffbench(
        "run", "paper-signal", "--seeds", "1", "--methods", "butterworth", "--out", tmp_path
    )
    _one_error_line(
        result,
        f"{cells} was written by another diffbench store version: its "
        "header says version 2, this diffbench reads version 1 only; read it with "
        "the diffbench that wrote it (pip install -U diffbench), or give another "
        "--out directory",
    )
    assert cells.read_text() == header


def test_a_database_of_another_store_version_is_one_line_and_left_as_it_is(tmp_path):
    Store(tmp_path / "store").close()
    path = tmp_path / "store" / STORE_FILE
    with contextlib.closing(sqlite3.connect(path)) as connection, connection:
        connection.execute("UPDATE meta SET value = '3' WHERE name = 'version'")
    data = path.read_bytes()
    result = _diffbench(
        "run", "paper-signal", "--seeds", "1", "--methods", "butterworth", "--out", tmp_path
    )
    _one_error_line(
        result,
        f"{path} was written by another diffbench store version: it says version 3, this "
        "diffbench reads version 2 only; read it with the diffbench that wrote it (pip install "
        "-U diffbench), or give another --out directory",
    )
    assert path.read_bytes() == data


def test_a_plugin_method_that_fails_while_tuned_is_one_line(tmp_path, plugin):
    result = _diffbench(
        "tune",
        "bad.raises",
        "paper-signal",
        "--plugin",
        "bad_methods",
        "--no-progress",
        "--out",
        tmp_path,
        env=plugin,
    )
    _one_error_line(
        result,
        "plugin bad_methods (dist none): method bad.raises: RuntimeError: "
        "the plugin's own bug (tuning it on paper-signal); nothing else to tune",
    )
    # beside other methods it is a warning, and they are tuned, scored and reported (the
    # battery's case: the whole tune stopped at it)
    result = _diffbench(
        "tune",
        "bad.raises,finite_difference",
        "paper-signal",
        "--plugin",
        "bad_methods",
        "--seeds",
        "2",
        "--no-progress",
        "--out",
        tmp_path,
        env=plugin,
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert (
        "diffbench: warning: tuning failed: plugin bad_methods (dist none): method bad.raises: "
        "RuntimeError: the plugin's own bug (tuning it on paper-signal)"
    ) in result.stderr
    assert "1 failed (not stored; the next run tries them again)" in result.stdout
    assert "finite_difference" in (tmp_path / "paper-signal" / "rmse.md").read_text()


def test_a_plugin_method_that_never_returns_while_tuned_times_out(tmp_path, plugin):
    """The battery's case: --timeout bounded cells but not the calls inside a tuning, so a
    hanging plugin held `tune` forever; each call is bounded now."""
    result = _diffbench(
        "tune",
        "bad.hangs,finite_difference",
        "paper-signal",
        "--plugin",
        "bad_methods",
        "--timeout",
        "2",
        "--seeds",
        "1",
        "--no-progress",
        "--out",
        tmp_path,
        env=plugin,
    )
    assert result.returncode == 0, result.stderr
    assert (
        "diffbench: warning: tuning failed: plugin bad_methods (dist none): method bad.hangs: "
        "a call timed out after 2 s (--timeout) (tuning it on paper-signal)"
    ) in result.stderr


def _recommend_with_plugin(tmp_path, plugin, names: str, *options):
    """`recommend` on a 400-sample noisy sine (2 ms stamps) among ``names``, the test plugin
    loaded; its ranking goes to ``tmp_path/out``."""
    t = np.arange(400) * 2e-3
    x = np.sin(2 * np.pi * 3 * t) + 0.01 * np.random.default_rng(0).standard_normal(t.size)
    pd.DataFrame({"t": t, "x": x}).to_csv(tmp_path / "rec.csv", index=False)
    return _diffbench(
        "recommend",
        tmp_path / "rec.csv",
        "--time",
        "t",
        "--plugin",
        "bad_methods",
        "--methods",
        names,
        "--orders",
        "1",
        "--budget",
        "20",
        *options,
        "--no-progress",
        "--out",
        tmp_path / "out",
        env=plugin,
    )


def test_a_plugin_method_that_fails_in_recommend_is_named_not_a_traceback(tmp_path, plugin):
    """The battery's case: a plugin raising, exiting or returning the wrong shape while
    `recommend` tunes it stopped the command with a raw traceback; now its row says why, a
    warning names the plugin, and the other methods are recommended as before."""
    names = "bad.raises,bad.exits,bad.shape,savitzky_golay"
    result = _recommend_with_plugin(tmp_path, plugin, names)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    ranking = (tmp_path / "out" / "ranking.md").read_text()
    for name, reason in [
        ("bad.raises", "RuntimeError: the plugin's own bug"),
        ("bad.exits", "SystemExit: 5"),
    ]:
        named = f"plugin bad_methods (dist none): method {name}: {reason}"
        assert f"diffbench: warning: {named}" in result.stderr
        assert named in ranking
    # a wrong shape is a ValueError, which the tuner reads as a setting that does not fit: its
    # row says it was not tuned (not yet that the plugin's output was wrong)
    assert re.search(r"\| bad\.shape +\| not tuned: ", ranking)
    assert "x ẋ: savitzky_golay" in result.stdout


def test_a_plugin_method_that_never_returns_in_recommend_times_out(tmp_path, plugin):
    """The battery's case: a hanging plugin held `recommend` forever (it had no --timeout)."""
    result = _recommend_with_plugin(tmp_path, plugin, "bad.hangs,savitzky_golay", "--timeout", "2")
    assert result.returncode == 0, result.stderr
    named = (
        "plugin bad_methods (dist none): method bad.hangs: a call timed out after 2 s (--timeout)"
    )
    assert f"diffbench: warning: {named}" in result.stderr
    assert named in (tmp_path / "out" / "ranking.md").read_text()
    assert "x ẋ: savitzky_golay" in result.stdout
