"""The CLI, called in-process through main([...])."""

import pytest
from diffbench.bench.cli import main


def test_list_shows_methods_parameters_presets_signals_and_scenarios(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for text in (
        "butterworth",
        "cutoff_hz",
        "preset paper-signal: order=6, cutoff_hz=25.0",
        "savitzky_golay",
        "window_s",
        "paper_sines",
        "paper-signal",
    ):
        assert text in out


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
    assert "| butterworth |" in table and "RMSE ẍ interior" in table
    assert main([*args[:3], "3", *args[4:]]) == 0
    assert "2 cells computed, 4 already stored" in capsys.readouterr().out
    assert main(["table", "paper-signal", "--out", str(tmp_path)]) == 0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "no-such-scenario"], "unknown scenario"),
        (["run", "paper-signal", "--seeds", "0"], "--seeds: must be a whole number >= 1"),
        (["run", "paper-signal", "--seeds", "many"], "--seeds: must be a whole number >= 1"),
        (["run", "paper-signal", "--methods", "jacobbi"], "unknown method 'jacobbi'"),
        (["frobnicate"], "invalid choice"),
        ([], "required"),
        (["table", "paper-signal", "--out", "/nonexistent-dir"], "no results at"),
        (["run", "paper-signal", "--out", "/proc/diffbench"], "/proc/diffbench"),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(argv, message, capsys, tmp_path):
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("diffbench: error:")
    assert message in lines[0]
    assert "Traceback" not in captured.err


def test_ctrl_c_keeps_finished_cells_and_exits_130(tmp_path, capsys, monkeypatch):
    from diffbench.bench import runner

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
