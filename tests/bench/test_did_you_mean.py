"""A mistyped name gets the close names, not a list of every name (issue 46, item 5): methods,
their parameters, choices and presets, tasks and scenarios, tuning criteria, and the columns of
a user's file. With no close name the message lists the valid ones, as before."""

import subprocess

import numpy as np
import pandas as pd
import pytest

from diffbench import methods, signals
from diffbench.bench.tasks import get_task
from diffbench.methods import did_you_mean
from diffbench.signals import robot2r
from tests.bench.killing import CLI, ENV


@pytest.mark.parametrize(
    ("typed", "choices", "said"),
    [
        (
            "jacobbi",
            ["jacobi", "kalman", "causal_jacobi"],
            "did you mean 'jacobi' or 'causal_jacobi'?",
        ),
        ("Kalman", ["kalman", "kalman_filter"], "did you mean 'kalman'?"),  # the case alone
        ("savitsky_golay", ["savitzky_golay", "spectral"], "did you mean 'savitzky_golay'?"),
        ("paper", ["paper-signal", "paper-signal-clean", "pap"], "did you mean 'pap'?"),
        ("zzz", ["jacobi", "kalman"], ""),
        (3, ["jacobi"], ""),  # not a name: nothing to suggest
    ],
)
def test_did_you_mean_offers_the_close_names_best_first(typed, choices, said):
    assert did_you_mean(typed, choices) == said


def test_the_three_closest_at_most_each_once():
    choices = ["paper-signal", "paper-signal-clean", "paper-signal-999ms", "paper-signal-4937ms"]
    said = did_you_mean("paper-signl", [*choices, "PAPER-SIGNAL"])
    assert said == "did you mean 'paper-signal', 'paper-signal-clean' or 'paper-signal-999ms'?"


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: methods.get("jacobbi"), r"^unknown method 'jacobbi'; did you mean 'jacobi'"),
        (
            lambda: methods.get("jacobi", windw_s=0.1),
            r"^unknown parameter\(s\) windw_s for method 'jacobi'; windw_s: did you mean "
            r"'window_s'.*"
            r"\? valid: kappa, mu, q, window_s",
        ),
        (
            lambda: methods.get("jacobi", windw_s=0.1, qq=3),
            r"^unknown parameter\(s\) qq, windw_s for method 'jacobi'; qq: did you mean 'q'\? "
            r"windw_s: did you mean 'window_s'",
        ),
        (lambda: methods.get(123), r"^a method name must be a string, got 123$"),
        (
            lambda: methods.get("jacobi", rule="trapezod"),
            r"`rule` must be one of \{trapezoid, linear, least_squares\}, got 'trapezod'; "
            r"did you mean 'trapezoid'\?$",
        ),
        (
            lambda: methods.preset("kalman", "Robot"),
            r"^method 'kalman' has no preset 'Robot'; did you mean 'robot'\?$",
        ),
        (
            lambda: get_task("paper-signl"),
            r"^unknown task 'paper-signl'; did you mean 'paper-signal'",
        ),
        (
            lambda: signals.get_scenario("chirp-gausian"),
            r"^unknown scenario 'chirp-gausian'; "
            r"did you mean 'chirp-gaussian' or 'damped-gaussian'\?$",
        ),
        (
            lambda: robot2r.get_robot_scenario("robot-sim-200"),
            r"^unknown robot scenario 'robot-sim-200'; did you mean 'robot-sim-200hz'",
        ),
    ],
)
def test_a_mistyped_name_in_the_api_is_a_value_error_naming_the_close_one(call, message):
    with pytest.raises(ValueError, match=message) as error:
        call()
    assert len(str(error.value)) < 250  # not the whole registry (its names alone: 470+ characters)


def test_a_name_like_no_other_still_lists_them_all():
    with pytest.raises(ValueError, match=r"unknown method 'xyz'; available: .*savitzky_golay"):
        methods.get("xyz")
    with pytest.raises(ValueError, match=r"unknown scenario 'xyz'; available: .*paper-signal"):
        signals.get_scenario("xyz")


def _cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], env=ENV, capture_output=True, text=True, cwd=cwd)


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (
            ["run", "paper-signal", "--methods", "jacobbi"],
            "diffbench: error: --methods: unknown method 'jacobbi'; "
            "did you mean 'jacobi' or 'causal_jacobi'?",
        ),
        (
            ["run", "paper-signal", "--methods", "native,-jacobbi"],
            "diffbench: error: --methods: unknown method 'jacobbi'; "
            "did you mean 'jacobi' or 'causal_jacobi'?",
        ),
        (
            ["run", "paper-signl"],
            "diffbench: error: unknown task 'paper-signl'; did you mean 'paper-signal', "
            "'paper-signal-clean' or 'paper-signal-999ms'?",
        ),
        (
            ["run", "paper-signal", "--methods", "nativ"],
            "diffbench: error: --methods: unknown method or group 'nativ'; did you mean 'native'?",
        ),
        (
            ["tune", "jacobi", "paper-signal", "--criteria", "orcale"],
            "diffbench: error: argument --criteria: must be among oracle, no-truth, pynumdiff, "
            "got orcale; did you mean 'oracle'?",
        ),
    ],
)
def test_a_mistyped_name_on_the_command_line_is_one_line_and_exit_2(args, said, tmp_path):
    result = _cli(*args, "--out", str(tmp_path))
    assert result.returncode == 2
    assert result.stderr.strip().splitlines()[-1] == said
    assert len(result.stderr.strip().splitlines()) <= 3  # argparse's usage lines, then this one


def test_a_mistyped_column_of_the_users_file_names_the_close_column(tmp_path):
    path = tmp_path / "arm.csv"
    t = np.arange(200) * 0.01
    pd.DataFrame({"time_s": t, "position": np.sin(t), "velocity": np.cos(t)}).to_csv(path)
    result = _cli("recommend", str(path), "--time", "time_s", "--column", "postion")
    assert result.returncode == 2
    assert result.stderr.strip() == (
        f"diffbench: error: {path}: no column 'postion'; did you mean 'position'? the columns "
        "are Unnamed: 0, time_s, position, velocity"
    )
    result = _cli("recommend", str(path), "--time", "time", "--column", "position")
    assert result.returncode == 2
    assert "no time column 'time'; did you mean 'time_s'?" in result.stderr
