"""Efficiency against the least possible error: the kalman method at the true model is the
optimal estimator, and no method scores above 1 beyond its Monte Carlo error."""

import json
import math

import numpy as np
import pandas as pd
import pytest

from diffbench import methods, signals
from diffbench.bench import limit
from diffbench.bench.cli import main


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
    # presets and a kalman at the true model (efficiency 1) on 10 realisations of a Matérn 5/2
    name = "limit-matern52-0.01"
    args = ["run", name, "--seeds", "10", "--out", str(tmp_path), "--no-progress", "--methods",
            "jacobi,kalman,savitzky_golay,spectral,butterworth"]  # fmt: skip
    assert main(args) == 0
    table = pd.read_csv(tmp_path / name / "efficiency.csv")
    assert set(table["method"]) == {"jacobi", "kalman", "savitzky_golay", "spectral",
                                    "butterworth"}  # fmt: skip
    assert (table["efficiency"] - table["efficiency_half_width"] <= 1).all()
    assert (table["efficiency"] > 0).all()
    # the table's numbers from the stored RMSEs: the mean of the squares over the seeds
    scenario = signals.get_scenario(name)
    jacobi = table[(table["method"] == "jacobi") & (table["order"] == 1)].iloc[0]
    preset = methods.get("jacobi", **json.loads(jacobi["params"]))
    squares = []
    for seed in range(10):
        realisation = scenario.realise(seed)
        error = preset(realisation.x, realisation.dt_s)[1] - realisation.truth[1]
        squares.append(np.mean(error[realisation.interior] ** 2))
    assert jacobi["mse"] == pytest.approx(np.mean(squares), rel=1e-9)
    assert jacobi["efficiency"] == pytest.approx(limit.scenario_bound(scenario, 1)
                                                 / np.mean(squares), rel=1e-9)  # fmt: skip
    assert "efficiency" in (tmp_path / name / "efficiency.md").read_text()


def test_a_scenario_without_a_known_bound_is_refused():
    with pytest.raises(ValueError, match="has no known bound"):
        limit.scenario_bound(signals.get_scenario("paper-signal"), 1)
