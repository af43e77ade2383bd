"""The CLI, called in-process through main([...]) (and as a process where exit codes matter)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from diffbench.bench import runner
from diffbench.bench.cli import main
from diffbench.bench.core import tuning
from diffbench.bench.core.store import Store

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def test_list_shows_methods_parameters_presets_and_tasks(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for text in (
        "butterworth",
        "cutoff_hz",
        "preset paper-signal (by paper): order=6, cutoff_hz=25.0",
        "savitzky_golay",
        "window_s",
        "paper-signal [signal]",
        "robot-sim [robot (simulated)]",
        "identify-dfki [robot (real)]",
        "jacobi-influence",
        "40 grid tasks",
        "Fornberg (1988); time stamps: native)",
        "Guo et al., AIM 2015; time stamps: resampled)",
    ):
        assert text in out
    assert "grid-gaussian-0.02-0.1ms [" not in out


def test_main_in_process_gives_back_the_callers_sigterm_handler(capsys):
    """A test or script calling main() keeps its own SIGTERM handling afterwards (a SIGTERM
    later must not surface as diffbench's Terminated in unrelated code)."""
    import signal

    def mine(signum, frame):
        return None

    previous = signal.signal(signal.SIGTERM, mine)
    try:
        assert main(["list"]) == 0
        assert signal.getsignal(signal.SIGTERM) is mine
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("diffbench ")


def test_run_writes_store_and_tables_then_resumes(tmp_path, capsys):
    args = [
        "run",
        "paper-signal",
        "--seeds",
        "2",
        "--out",
        str(tmp_path),
        "--no-progress",
        "--methods",
        "finite_difference,butterworth",
    ]
    assert main(args) == 0
    assert "4 cells computed, 0 already stored" in capsys.readouterr().out
    table = (tmp_path / "paper-signal" / "rmse.md").read_text()
    from importlib.metadata import version

    row = (
        f"| butterworth       | diffbench {version('diffbench')} | native | preset (paper) | "
        "order=6, cutoff_hz=25 "
    )
    assert row in table
    assert "RMSE ẍ interior" in table and "Presets —" not in table
    assert main([*args[:3], "3", *args[4:]]) == 0
    assert "2 cells computed, 4 already stored" in capsys.readouterr().out
    assert main(["report", "paper-signal", "--out", str(tmp_path)]) == 0


def test_no_report_stores_the_results_and_a_later_command_writes_the_same_report(tmp_path, capsys):
    """``--no-report`` (make studies between the steps of one task): the cells and tunings
    are stored, no report is written; the next command on the task (here a tuning) writes the
    report of everything stored, the files one written after each step would end as."""
    cells = ["run", "paper-signal", "--seeds", "2", "--no-progress", "--methods", "kalman"]
    tune = ["tune", "kalman", "paper-signal", "--seeds", "2", "--orders", "1", "--no-progress"]
    quiet, every = tmp_path / "quiet", tmp_path / "every"
    assert main([*cells, "--out", str(quiet), "--no-report"]) == 0
    printed = capsys.readouterr().out
    assert "2 cells computed" in printed and "rmse.md" not in printed
    assert not (quiet / "paper-signal").exists()
    assert len(Store(quiet / "store").cells.records) == 2
    assert main([*tune, "--out", str(quiet)]) == 0
    assert main([*cells, "--out", str(every)]) == 0
    assert main([*tune, "--out", str(every)]) == 0
    written = sorted(p.relative_to(every) for p in (every / "paper-signal").rglob("*"))
    assert written and written == sorted(
        p.relative_to(quiet) for p in (quiet / "paper-signal").rglob("*")
    )
    import pandas as pd

    for path in written:
        if path.suffix == ".csv":  # a tuning's seconds are its own run's: the rest is the same
            quiet_table, every_table = pd.read_csv(quiet / path), pd.read_csv(every / path)
            seconds = [c for c in every_table.columns if c.endswith(" s")]
            pd.testing.assert_frame_equal(
                quiet_table.drop(columns=seconds), every_table.drop(columns=seconds)
            )
        elif path.suffix == ".md" and path.stem != "tuning":
            assert (quiet / path).read_bytes() == (every / path).read_bytes(), path


def test_rankings_on_the_whole_record_take_every_sample_each_entry_estimates(tmp_path):
    """Jacobi's paper-signal preset marks part of its ends not valid (2 % of the record for
    ẋ) but estimates every sample: it is ranked on the whole record by its RMSE over every
    sample, beside spectral; the valid share is its own column."""
    import pandas as pd

    args = [
        "run",
        "paper-signal",
        "--seeds",
        "2",
        "--out",
        str(tmp_path),
        "--no-progress",
        "--methods",
        "jacobi,spectral",
    ]
    assert main(args) == 0
    ranked = pd.read_csv(tmp_path / "paper-signal" / "ranking.csv")
    rmse = pd.read_csv(tmp_path / "paper-signal" / "rmse.csv").set_index("method")
    assert rmse.loc["jacobi", "valid ẋ mean"] < 1.0
    assert rmse.loc["jacobi", "estimated ẋ mean"] == 1.0
    for symbol in ("ẋ", "ẍ"):
        interior = ranked[(ranked["derivative"] == symbol) & (ranked["region"] == "interior")]
        whole = ranked[(ranked["derivative"] == symbol) & (ranked["region"] == "whole record")]
        assert set(interior["method"]) == {"jacobi", "spectral"}
        assert set(whole["method"]) == {"jacobi", "spectral"}
        for name, mean in zip(whole["method"], whole["mean"], strict=True):
            expected = rmse.loc[name, f"RMSE {symbol} whole mean"]
            assert mean == pytest.approx(expected, rel=1e-12)
            # the whole record takes the untrusted ends the valid region leaves out
            assert mean > rmse.loc[name, f"RMSE {symbol} interior mean"] or name == "spectral"
    text = (tmp_path / "paper-signal" / "ranking.md").read_text()
    assert "## ẋ, whole record" in text and "only if it estimates every sample" in text


def test_repeated_method_names_run_once(tmp_path, capsys):
    args = [
        "run",
        "paper-signal",
        "--seeds",
        "2",
        "--out",
        str(tmp_path),
        "--no-progress",
        "--methods",
        "jacobi,jacobi",
    ]
    assert main(args) == 0
    assert "2 cells computed" in capsys.readouterr().out
    assert len(Store(tmp_path / "store").cells.records) == 2
    import pandas as pd

    table = pd.read_csv(tmp_path / "paper-signal" / "rmse.csv")
    assert table["method"].tolist() == ["jacobi"] and table["seeds"].tolist() == [2]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "no-such-task"], "unknown task 'no-such-task'"),
        (["run", "paper-signal", "--seeds", "0"], "--seeds: must be a whole number >= 1"),
        (["run", "paper-signal", "--seeds", "many"], "--seeds: must be a whole number >= 1"),
        (["run", "paper-signal", "--methods", "jacobbi"], "unknown method 'jacobbi'"),
        (["run", "paper-signal", "--methods", ","], "--methods: must name at least one"),
        (["frobnicate"], "invalid choice"),
        ([], "required"),
        (["report", "paper-signal", "--out", "/nonexistent-dir"], "no results store"),
        (["run", "paper-signal", "--out", "/proc/diffbench"], "/proc/diffbench"),
        (
            ["tune", "all", "paper-signal", "--criteria", "no-truth", "--cutoff-hz", "0"],
            "--cutoff-hz: must be a finite number > 0, got 0",
        ),
        (
            ["tune", "all", "paper-signal", "--criteria", "pynumdiff", "--cutoff-hz", "inf"],
            "--cutoff-hz: must be a finite number > 0, got inf",
        ),
        (
            ["tune", "all", "paper-signal", "--criteria", "no-truth", "--cutoff-hz", "500"],
            "`cutoff_hz` must lie in [1.427, 500) Hz",
        ),
        (["tune", "all", "paper-signal", "--criteria", "magic"], "--criteria: must be among"),
        (["tune", "all", "paper-signal", "--orders", "3"], "--orders: must be 1, 2 or 1,2"),
        (["tune", "all", "robot-sim"], "task 'robot-sim' cannot be tuned"),
        (["run", "identify-dfki", "--seeds", "7"], "--seeds must be at most 6"),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(argv, message, capsys):
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("diffbench: error:"), captured.err
    assert message in lines[0]
    assert "Traceback" not in captured.err


def test_an_internal_error_is_a_traceback_not_a_usage_error(tmp_path, monkeypatch):
    def broken(cell):
        raise ValueError("a bug deep inside")

    monkeypatch.setattr(runner, "compute_cell", broken)
    with pytest.raises(ValueError, match="a bug deep inside"):
        main(
            [
                "run",
                "paper-signal",
                "--seeds",
                "1",
                "--methods",
                "jacobi",
                "--out",
                str(tmp_path),
                "--no-progress",
            ]
        )
    script = (
        "import sys; from diffbench.bench import runner, cli\n"
        "def broken(cell): raise ValueError('a bug deep inside')\n"
        "runner.compute_cell = broken\n"
        f"sys.exit(cli.main(['run', 'paper-signal', '--seeds', '1', '--out', "
        f"{str(tmp_path / 'p')!r}, '--no-progress']))"
    )
    result = subprocess.run([sys.executable, "-c", script], env=ENV, capture_output=True, text=True)
    assert result.returncode == 1
    assert "Traceback" in result.stderr and "a bug deep inside" in result.stderr


def test_a_closed_pipe_ends_quietly():
    """`diffbench list | head`: the reader goes away before the output is written."""
    process = subprocess.Popen(
        [sys.executable, "-m", "diffbench.bench", "list"],
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    process.stdout.close()  # no reader left: every write fails with EPIPE
    err = process.stderr.read()
    assert process.wait(timeout=60) == 141
    assert err == b""


def test_ctrl_c_keeps_finished_cells_and_exits_130(tmp_path, capsys, monkeypatch):
    real = runner.compute_cell
    calls = []

    def interrupted_on_third(cell):
        calls.append(cell)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(cell)

    monkeypatch.setattr(runner, "compute_cell", interrupted_on_third)
    args = [
        "run",
        "paper-signal",
        "--seeds",
        "2",
        "--out",
        str(tmp_path),
        "--no-progress",
        "--methods",
        "finite_difference,butterworth",
    ]
    assert main(args) == 130
    err = capsys.readouterr().err
    assert "interrupted; 2 cells are stored" in err and "Traceback" not in err
    monkeypatch.setattr(runner, "compute_cell", real)
    assert main(args) == 0
    assert "2 cells computed, 2 already stored" in capsys.readouterr().out


@pytest.fixture
def tuning_calls(monkeypatch) -> list[str]:
    """The methods tuning.tune is called for, in order (the calls go through)."""
    calls = []
    real = tuning.tune

    def counted(*args, **kwargs):
        calls.append(args[0])
        return real(*args, **kwargs)

    monkeypatch.setattr(tuning, "tune", counted)
    return calls


def test_rerun_of_tune_retunes_nothing_and_tuning_is_reproducible(tmp_path, capsys, tuning_calls):
    calls = tuning_calls
    args = [
        "tune",
        "butterworth,finite_difference",
        "paper-signal",
        "--criteria",
        "oracle,no-truth",
        "--orders",
        "1,2",
        "--seeds",
        "2",
        "--no-progress",
    ]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert len(calls) == 8
    assert "8 tunings computed, 0 reused" in capsys.readouterr().out
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert len(calls) == 8  # nothing re-tuned
    assert "0 tunings computed, 8 reused" in capsys.readouterr().out
    assert main([*args, "--out", str(tmp_path / "b")]) == 0  # a fresh store: tuned again
    assert len(calls) == 16
    first, second = (Store(tmp_path / d / "store").tunings_frame() for d in ("a", "b"))
    columns = ["method", "criterion", "order", "params", "loss"]
    key = ["method", "criterion", "order"]
    assert first[columns].sort_values(key).to_numpy().tolist() == (
        second[columns].sort_values(key).to_numpy().tolist()
    )  # identical, bit for bit


def test_rerun_of_grid_retunes_and_recomputes_nothing(tmp_path, capsys, monkeypatch, tuning_calls):
    from diffbench.bench.studies import grid
    from diffbench.signals.scenarios import grid_scenario_name

    coarse = [grid_scenario_name(kind, 0.2, 1e-2) for kind in ("gaussian", "poisson")]
    monkeypatch.setattr(grid, "task_names", lambda: coarse)
    calls = tuning_calls
    chosen = ["finite_difference", "savitzky_golay", "spectral"]  # cheap: the resume is tested
    args = [
        "grid",
        "--orders",
        "1",
        "--seeds",
        "2",
        "--no-progress",
        "--out",
        str(tmp_path),
        "--methods",
        ",".join(chosen),
    ]
    n_methods = len(chosen)
    assert main(args) == 0
    out = capsys.readouterr().out
    assert len(calls) == 2 * n_methods
    assert f"{2 * n_methods} tunings computed, 0 reused" in out
    assert main(args) == 0
    out = capsys.readouterr().out
    assert len(calls) == 2 * n_methods  # nothing re-tuned
    assert f"0 tunings computed, {2 * n_methods} reused" in out
    assert "0 cells computed" in out
    table = (tmp_path / "grid" / "winners_velocity.md").read_text()
    assert table.count("(") >= 2  # both tasks name a winner with its RMSE
