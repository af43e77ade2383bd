"""The online scores against known delays and gains, and the online task end to end."""

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy import signal as sps

from diffbench import methods
from diffbench.bench.cli import main
from diffbench.bench.studies import online

DT = 1e-3


def _white_record(n=4000, sigma=0.1, seed=0):
    t = np.arange(n) * DT
    clean = np.sin(2 * np.pi * 2 * t)
    truth = {0: clean, 1: 4 * np.pi * np.cos(2 * np.pi * 2 * t), 2: -((4 * np.pi) ** 2) * clean}
    noise = sigma * np.random.default_rng(seed).standard_normal(n)
    interior = np.zeros(n, dtype=bool)
    interior[500:-500] = True
    return SimpleNamespace(x=clean + noise, dt_s=DT, truth=truth, interior=interior)


def test_the_aligning_delay_finds_a_known_shift_between_steps():
    t = np.arange(3000) * DT
    truth = np.sin(2 * np.pi * 3 * t) + 0.5 * np.sin(2 * np.pi * 7 * t)
    shift_s = 7.3 * DT
    late = np.sin(2 * np.pi * 3 * (t - shift_s)) + 0.5 * np.sin(2 * np.pi * 7 * (t - shift_s))
    mask = (t > 0.2) & (t < 2.8)
    delay, aligned = online.aligning_delay(late, truth, mask, DT, 0.1)
    assert delay == pytest.approx(shift_s, abs=0.02 * DT)
    # at the nearest whole step the residual is that of 0.3 step
    assert aligned == pytest.approx(
        np.sqrt(np.mean((late[mask] - np.roll(truth, 7)[mask]) ** 2)), rel=1e-12
    )
    early, _ = online.aligning_delay(np.roll(truth, -4), truth, mask, DT, 0.1)
    assert early == pytest.approx(-4 * DT, abs=1e-3 * DT)  # the parabola's own error


@pytest.mark.parametrize("delay_s", [0.0, 0.004, 0.01])
def test_the_phase_delay_of_causal_jacobi_is_its_delay_parameter(delay_s):
    method = methods.get("causal_jacobi", window_s=0.02, accel_window_s=0.02, delay_s=delay_s)
    # exact on degree n + q: the relative response is e^{-i w delay} (1 + O((w T)^(q+1)))
    for order in (0, 1, 2):
        assert online.phase_delay_s(method, DT, order) == pytest.approx(delay_s, abs=2e-4 * 0.02)


@pytest.mark.parametrize("epsilon_s", [0.002, 0.01])
def test_the_phase_delay_of_the_high_gain_observer_s_last_state_is_m_epsilon(epsilon_s):
    # z_m / y = s^(m-1) / (1 + eps s)^m: the top state lags m eps at low frequency; a state
    # below it errs by O((eps s)^2), no lag
    method = methods.get("high_gain_observer", observer_dimension=3, epsilon_s=epsilon_s)
    assert online.phase_delay_s(method, DT, 2) == pytest.approx(3 * epsilon_s, rel=3e-3)
    assert abs(online.phase_delay_s(method, DT, 1)) < 0.01 * epsilon_s


def test_the_phase_delay_of_causal_butterworth_is_scipys_group_delay_at_low_frequency():
    method = methods.get("causal_butterworth", order=4, cutoff_hz=30.0, difference_accuracy=1)
    b, a = sps.sos2tf(sps.butter(4, 30.0, output="sos", fs=1 / DT))
    frequency = online.PHASE_FREQUENCY_FRACTION * 0.5 / DT
    _, steps = sps.group_delay((b, a), w=[frequency], fs=1 / DT)
    expected = steps[0] * DT
    assert online.phase_delay_s(method, DT, 0) == pytest.approx(expected, rel=1e-4)
    # the backward difference adds half a step
    assert online.phase_delay_s(method, DT, 1) == pytest.approx(expected + DT / 2, rel=1e-4)


def test_the_noise_gain_of_the_backward_difference_is_root_two_over_the_step():
    record = _white_record()
    rows = online.online_scores(methods.get("backward_difference", accuracy=1), record)
    values = {(r["order"], r["metric"]): r["value"] for r in rows}
    # white noise: var(x_k - x_{k-1}) = 2 sigma^2, so the gain is sqrt(2)/dt (and 6^0.5/dt^2)
    assert values[(1, "noise_gain")] == pytest.approx(np.sqrt(2) / DT, rel=0.05)
    assert values[(2, "noise_gain")] == pytest.approx(np.sqrt(6) / DT**2, rel=0.05)
    assert values[(1, "phase_delay_s")] == pytest.approx(DT / 2, rel=1e-3)
    assert values[(1, "coverage")] == 1.0


def test_online_scores_are_for_causal_methods_only():
    with pytest.raises(ValueError, match="savitzky_golay is not causal"):
        online.online_scores(methods.get("savitzky_golay"), _white_record())


def test_the_pareto_front_keeps_the_points_nothing_beats_in_both():
    delays = np.array([1.0, 2.0, 3.0, 2.5, -0.5])
    errors = np.array([10.0, 5.0, 6.0, 5.0, 20.0])
    np.testing.assert_array_equal(
        online.pareto_front(delays, errors), [True, True, False, False, True]
    )


def test_the_online_task_runs_stores_and_reports(tmp_path, capsys):
    argv = [
        "run",
        "online-paper-signal",
        "--methods",
        "causal_jacobi,backward_difference",
        "--seeds",
        "1",
        "--out",
        str(tmp_path),
        "--no-progress",
    ]
    assert main(argv) == 0
    folder = tmp_path / "online"
    for name in ("sweep.md", "front.csv", "best.md", "error_vs_delay.png"):
        assert (folder / name).stat().st_size > 0

    best = pd.read_csv(folder / "best.csv")
    assert set(best["method"]) == {"causal_jacobi", "backward_difference"}
    assert len(pd.read_csv(folder / "sweep.csv")) == 2 * (12 + 4)
    # a smoothing window beats the raw difference at the time of the estimate
    first = best[best["order"] == "ẋ"].sort_values("RMSE at the time")
    assert list(first["method"]) == ["causal_jacobi", "backward_difference"]
    # a second run recomputes nothing
    capsys.readouterr()
    assert main(argv) == 0
    printed = capsys.readouterr()
    assert "0 cells computed, 16 already stored" in printed.out + printed.err


def test_the_online_task_refuses_an_offline_method(tmp_path, capsys):
    argv = [
        "run",
        "online-paper-signal",
        "--methods",
        "jacobi",
        "--seeds",
        "1",
        "--out",
        str(tmp_path),
    ]
    assert main(argv) == 2
    assert "jacobi is not causal" in capsys.readouterr().err


@pytest.mark.parametrize(
    "name", ["causal_jacobi", "alpha_beta_gamma", "high_gain_observer", "levant"]
)
def test_causal_methods_are_tuned_like_the_others(name):
    from diffbench import signals
    from diffbench.bench.core import tuning

    scenario = signals.get_scenario("paper-signal")
    result = tuning.tune(name, scenario.realise(10_000), 1, "oracle", max_evaluations=30)
    tuned, default = methods.get(name, **result.params), methods.get(name)
    scored = scenario.realise(0)
    errors = {}
    for label, method in (("tuned", tuned), ("default", default)):
        estimate = method(scored.x, scored.dt_s, orders=(1,))
        mask = scored.interior & estimate.valid[1]
        errors[label] = np.sqrt(np.mean((estimate[1][mask] - scored.truth[1][mask]) ** 2))
    assert errors["tuned"] < 0.9 * errors["default"]


def test_causal_methods_are_left_out_of_irregularly_sampled_tasks_by_name(capsys):
    from diffbench import signals
    from diffbench.bench import tasks
    from diffbench.bench.studies import grid

    task = tasks.get_task("grid-gaussian-0.2-10ms-jitter")
    entries = task.lineup(["causal_jacobi", "spectral"])
    assert [entry.method for entry in entries] == ["spectral"]
    message = "causal_jacobi: not run on grid-gaussian-0.2-10ms-jitter: a causal method takes"
    assert message in capsys.readouterr().err
    jobs = grid.tuning_jobs(orders=(1,), names=["causal_jacobi", "spectral"])
    causal = {job.task for job in jobs if job.method == "causal_jacobi"}
    every = {job.task for job in jobs if job.method == "spectral"}
    irregular = {name for name in every if signals.get_scenario(name).sampling}
    assert len(irregular) == 4  # the jittered and dropped-sample ones
    assert causal == every - irregular


def test_the_price_of_causality_is_the_best_causal_rmse_over_the_best_offline():
    from diffbench.bench.studies import grid

    records = []
    for method, values in (
        ("kalman_filter", (2.0, 4.0)),
        ("causal_jacobi", (5.0, 5.0)),
        ("spectral", (1.0, 1.0)),
        ("jacobi", (1.5, 2.5)),
    ):
        for seed, value in enumerate(values):
            records.append(
                {
                    "task": "grid-gaussian-0.2-1ms",
                    "method": method,
                    "params": "{}",
                    "tuned_order": 1.0,
                    "metric": "rmse",
                    "order": 1,
                    "region": "interior",
                    "seed": seed,
                    "value": value,
                }
            )
    price = grid.causal_price(pd.DataFrame(records), 1)
    assert len(price) == 1
    row = price.iloc[0]
    assert (row["causal"], row["offline"]) == ("kalman_filter", "spectral")
    assert row["ratio"] == pytest.approx(3.0)
    assert grid.causal_price(pd.DataFrame(records), 2).empty  # nothing tuned for ẍ
