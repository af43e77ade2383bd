"""Efficiency against the least possible error: the kalman method at the true model is the
optimal estimator, and no method scores above 1 beyond its Monte Carlo error."""

import json
import math

import numpy as np
import pandas as pd
import pytest

from diffbench import methods, signals
from diffbench.bench import tasks
from diffbench.bench.cli import main
from diffbench.bench.studies import limit, pareto


@pytest.mark.parametrize("name", ["limit-iwn3-0.001", "limit-iwn3-0.01", "limit-iwn3-0.1"])
def test_kalman_at_the_true_model_is_the_optimal_smoother_inside_the_record(name):
    # kalman's model is an integrated white noise of spectral density (2π f_b)^(2m) R Δt, R = 1:
    # with f_b from the scenario's q/σ² it is the RTS smoother with the true model, and only
    # its prior at the start differs (vague, not "at rest"), which the interior has forgotten
    scenario = signals.get_scenario(name)
    noise_std = scenario.noise.models[0].std
    states = scenario.signal.times
    ratio = scenario.signal.intensity / (noise_std**2 * scenario.dt_s)
    bandwidth_hz = ratio ** (1 / (2 * states)) / (2 * math.pi)
    method = methods.get("kalman", model_order=states - 1, bandwidth_hz=bandwidth_hz)
    realisation = scenario.realise(3)
    estimate = method(realisation.x, realisation.dt_s)
    optimal = limit.optimal_states(scenario.signal, scenario.dt_s, noise_std, realisation.x)
    inside = realisation.interior
    for order in range(1, states):
        scale = np.sqrt(limit.scenario_bound(scenario, order))
        gap = np.max(np.abs(estimate[order][inside] - optimal[inside, order])) / scale
        assert gap < 1e-6, (order, gap)


def test_no_method_beats_the_bound_beyond_monte_carlo_error(tmp_path, capsys):
    # presets of five methods on 10 realisations of a Matérn 5/2
    name = "limit-matern52-0.01"
    args = [
        "run",
        name,
        "--seeds",
        "10",
        "--out",
        str(tmp_path),
        "--no-progress",
        "--methods",
        "jacobi,kalman,savitzky_golay,spectral,butterworth",
    ]
    assert main(args) == 0
    table = pd.read_csv(tmp_path / name / "efficiency.csv")
    assert set(table["method"]) == {"jacobi", "kalman", "savitzky_golay", "spectral", "butterworth"}
    assert len(table) == 5 * 2  # ẋ and ẍ
    assert (table["efficiency"] - table["efficiency_half_width"] <= 1).all()
    assert (table["efficiency"] > 0).all()
    # the table's numbers from the stored RMSEs: the optimal estimator's and the method's
    # mean squares over the same seeds
    scenario = signals.get_scenario(name)
    jacobi = table[(table["method"] == "jacobi") & (table["order"] == 1)].iloc[0]
    preset = methods.get("jacobi", **json.loads(jacobi["params"]))
    ours, best = [], []
    for seed in range(10):
        realisation = scenario.realise(seed)
        inside = realisation.interior
        error = preset(realisation.x, realisation.dt_s)[1] - realisation.truth[1]
        optimal = limit.optimal_states(scenario.signal, scenario.dt_s, 0.01, realisation.x)
        ours.append(np.mean(error[inside] ** 2))
        best.append(np.mean((optimal[inside, 1] - realisation.truth[1][inside]) ** 2))
    assert jacobi["mse"] == pytest.approx(np.mean(ours), rel=1e-9)
    assert jacobi["efficiency"] == pytest.approx(np.mean(best) / np.mean(ours), rel=1e-9)
    assert jacobi["efficiency_unpaired"] == pytest.approx(
        limit.scenario_bound(scenario, 1) / np.mean(ours), rel=1e-9
    )
    assert "efficiency" in (tmp_path / name / "efficiency.md").read_text()


def test_the_optimal_estimator_as_a_method_scores_efficiency_one_exactly():
    # kalman_filter at the true model is the Kalman filter: paired efficiency 1, interval 0
    scenario = signals.get_scenario("limit-iwn3-0.1")
    bandwidth_hz = (1e6 / (0.1**2 * 1e-3)) ** (1 / 6) / (2 * math.pi)
    method = methods.get("kalman_filter", model_order=2, bandwidth_hz=bandwidth_hz)
    rows = []
    for seed in range(4):
        for row in tasks.get_task(scenario.name).score(method, seed):
            rows.append(
                {
                    "task": scenario.name,
                    "method": "kalman_filter",
                    "params": "{}",
                    "role": "{}",
                    "seed": seed,
                    **row,
                }
            )
    table = limit.efficiency_table(pd.DataFrame(rows))
    assert list(table["order"]) == [1, 2] and table["causal_bound"].all()
    np.testing.assert_allclose(table["efficiency"], 1.0, rtol=1e-6)
    np.testing.assert_allclose(table["efficiency_half_width"], 0.0, atol=1e-5)


def test_the_limit_command_tunes_scores_and_writes_the_study(tmp_path, capsys):
    args = [
        "limit",
        "--scenarios",
        "limit-iwn3-0.01",
        "--methods",
        "savitzky_golay,kalman",
        "--seeds",
        "4",
        "--orders",
        "1",
        "--out",
        str(tmp_path),
        "--no-progress",
    ]
    assert main(args) == 0
    output = capsys.readouterr().out
    # two methods, oracle- and surrogate-tuned, scored on 4 seeds
    assert "4 tunings computed" in output and "16 cells computed" in output
    table = pd.read_csv(tmp_path / "limit" / "efficiency.csv")
    assert sorted(zip(table["criterion"], table["method"], strict=True)) == [
        ("oracle", "kalman"),
        ("oracle", "savitzky_golay"),
        ("surrogate", "kalman"),
        ("surrogate", "savitzky_golay"),
    ]
    assert (table["order"] == 1).all() and (
        table["efficiency"] <= 1 + table["efficiency_half_width"]
    ).all()
    best = (tmp_path / "limit" / "best.md").read_text()
    assert "| iwn3" in best and "kalman" in best
    assert (tmp_path / "limit" / "efficiency.png").stat().st_size > 10_000
    assert main(args) == 0  # a rerun: nothing tuned or computed again
    assert "0 tunings computed" in capsys.readouterr().out
    assert main([*args[:2], "limit-nope", *args[3:]]) == 2
    assert "not limit scenarios: limit-nope" in capsys.readouterr().err


def test_a_scenario_without_a_known_bound_is_refused():
    with pytest.raises(ValueError, match="has no known bound"):
        limit.scenario_bound(signals.get_scenario("paper-signal"), 1)


def test_the_surrogate_criterion_tunes_on_the_data_alone():
    # the realisation's truth is never read: the same setting with the truth replaced
    import dataclasses

    from diffbench.bench.core import tuning

    realisation = signals.get_scenario("limit-iwn3-0.01").realise(10_000)
    first = tuning.tune("savitzky_golay", realisation, 1, "surrogate", max_evaluations=60)
    blind = dataclasses.replace(
        realisation, truth=signals.get_scenario("limit-iwn3-0.01").realise(10_001).truth
    )
    again = tuning.tune("savitzky_golay", blind, 1, "surrogate", max_evaluations=60)
    assert first.criterion == "surrogate" and first.params == again.params
    assert first.loss == again.loss
    oracle = tuning.tune("savitzky_golay", realisation, 1, "oracle", max_evaluations=60)
    assert oracle.params != first.params  # the truth does change the oracle's choice


def test_the_front_is_every_point_no_other_beats_on_both():
    rng = np.random.default_rng(0)
    fit, roughness = rng.random(200), rng.random(200)
    fit[5], roughness[5] = fit[6], roughness[6]  # a tie: the first of equals is kept
    front = pareto.non_dominated(fit, roughness)
    for i in range(200):
        beaten = np.any(
            (fit <= fit[i])
            & (roughness <= roughness[i])
            & ((fit < fit[i]) | (roughness < roughness[i]))
        )
        tied_before = np.any((fit[:i] == fit[i]) & (roughness[:i] == roughness[i]))
        assert front[i] == (not beaten and not tied_before), i


def test_the_knee_is_the_corner_of_an_l_shaped_front():
    # two straight arms in log-log coordinates meeting at (1e-2, 1e2)
    fit = np.concatenate([np.geomspace(1e-3, 1e-2, 10), np.geomspace(1e-2, 1.0, 21)[1:]])
    roughness = np.concatenate([np.geomspace(1e5, 1e2, 10), np.geomspace(1e2, 10.0, 21)[1:]])
    order = np.random.default_rng(1).permutation(fit.size)  # any order
    assert fit[order][pareto.knee(fit[order], roughness[order])] == pytest.approx(1e-2)
    assert pareto.knee(np.array([1.0, 2.0]), np.array([2.0, 1.0])) == 0  # too few: an end


def test_reintegration_and_total_variation_on_exact_values():
    dt = 1e-3
    t = np.arange(1001) * dt
    x = 3.0 + 2.0 * t - 5.0 * t**2
    keep = np.zeros(t.size, dtype=bool)
    keep[100:900] = True
    exact = 2.0 - 10.0 * t  # linear: the trapezoidal integral is exact
    assert pareto.reintegration_rmse(x, exact, dt, keep) == pytest.approx(0.0, abs=1e-12)
    # a derivative off by a constant c leaves a residual ramp c·t: RMSE c·T/√12 on T = 799 dt
    assert pareto.reintegration_rmse(x, exact + 0.5, dt, keep) == pytest.approx(
        0.5 * 799 * dt * math.sqrt((1 + 2 / 799) / 12), rel=1e-9
    )
    assert pareto.total_variation(exact, keep) == pytest.approx(10.0 * 799 * dt, rel=1e-12)
    assert pareto.total_variation(np.sign(np.sin(40 * t)), keep) == pytest.approx(
        2.0 * np.count_nonzero(np.diff(np.sign(np.sin(40 * t[100:900]))))
    )


def test_the_pareto_command_writes_fronts_with_knee_and_oracle(tmp_path, capsys):
    args = [
        "pareto",
        "limit-iwn3-0.01",
        "--methods",
        "savitzky_golay,spectral",
        "--out",
        str(tmp_path),
    ]
    assert main(args) == 0
    table = pd.read_csv(tmp_path / "limit" / "pareto_limit-iwn3-0.01.csv")
    assert sorted(table["method"]) == ["savitzky_golay", "spectral"]
    assert (table["knee_over_oracle"] >= 1).all()  # the oracle's is the least RMSE tried
    assert (table["front"] <= table["settings"]).all() and (table["front"] >= 3).all()
    assert (tmp_path / "limit" / "pareto_limit-iwn3-0.01.png").stat().st_size > 10_000
    capsys.readouterr()
    assert main(args) == 0  # a rerun finds the report written from the same inputs
    assert "pareto_limit-iwn3-0.01.md" in capsys.readouterr().out


def test_a_brick_wall_just_above_the_band_comes_near_the_band_limited_bound():
    # on a band-limited signal the optimal estimator is its exact posterior on the record; the
    # spectral method oracle-tuned on seed 0 (cut at 24 Hz, the band's edge 20) reaches an
    # efficiency of 0.73 on seeds 1-4 (and not above 1), Savitzky–Golay at its default 0.0001
    scenario = signals.get_scenario("limit-band20-0.01")
    spectral = methods.get(
        "spectral", cutoff_hz=23.96, rolloff=0.246, extension="odd-fitted", fit_degree=1
    )
    rows = []
    for method in (spectral, methods.get("savitzky_golay")):
        for seed in range(1, 5):
            for row in tasks.get_task(scenario.name).score(method, seed):
                rows.append(
                    {
                        "task": scenario.name,
                        "method": method.name,
                        "params": "{}",
                        "role": "{}",
                        "seed": seed,
                        **row,
                    }
                )
    table = limit.efficiency_table(pd.DataFrame(rows)).set_index(["method", "order"])
    assert not table["causal_bound"].any()
    assert (table["efficiency"] - table["efficiency_half_width"] <= 1).all()
    assert table.loc[("spectral", 1), "efficiency"] > 0.6  # measured: 0.73
    assert table.loc[("savitzky_golay", 1), "efficiency"] < 0.01
    # the bound: the exact posterior's variance over the interior, met by its estimate
    assert table.loc[("spectral", 1), "bound"] == pytest.approx(
        table.loc[("spectral", 1), "optimal_mse"], rel=0.25
    )


def test_the_study_tunes_each_order_the_signal_has():
    # ẍ of twice-integrated white noise does not exist; the band-limited signal has both
    jobs = limit.tuning_jobs(["kalman"], (1, 2))
    orders = {}
    for job in jobs:
        orders.setdefault(job.task, set()).add(job.order)
        assert job.criterion in ("oracle", "surrogate")
    assert set(orders) == set(limit.task_names()) and len(orders) == 15
    assert orders["limit-iwn2-0.01"] == {1}
    assert orders["limit-band20-0.01"] == orders["limit-matern52-0.01"] == {1, 2}
    assert len(jobs) == 2 * (12 * 2 + 3)  # two criteria; the 3 iwn2 tasks only ẋ
