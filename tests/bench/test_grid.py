"""The scenario grid and its winners table."""

import numpy as np
import pandas as pd
import pytest
from diffbench import signals
from diffbench.bench import grid
from diffbench.signals.scenarios import GRID_NOISE_LEVELS, GRID_NOISE_TYPES, GRID_STEPS_S


def test_grid_has_every_noise_type_level_and_step():
    names = [n for n in signals.available_scenarios() if n.startswith("grid-")]
    assert len(names) == len(GRID_NOISE_TYPES) * len(GRID_NOISE_LEVELS) * len(GRID_STEPS_S)
    scenario = signals.get_scenario("grid-combined-0.5-0.1ms")
    assert scenario.n_samples == 9301 and scenario.dt_s == 1e-4
    realisation = scenario.realise(1)
    # 0.93 s holds no whole number of 4, 9 or 15 Hz periods
    assert all(abs(f * 0.93 - round(f * 0.93)) > 0.04 for f in (4, 9, 15))
    noise = realisation.x - realisation.truth[0]
    assert np.std(noise) > 0.5  # 0.5·N(0,1) + 0.5·sin + 0.5·Poisson
    gaussian = signals.get_scenario("grid-gaussian-0.02-1ms").realise(1)
    assert np.std(gaussian.x - gaussian.truth[0]) == pytest.approx(0.02, rel=0.15)


def test_tuning_job_returns_full_valid_parameters_on_a_coarse_step():
    _, params = grid._tuned(("jacobi", "grid-gaussian-0.2-10ms", 2))
    assert params is not None
    for key in ("window_s", "accel_window_s"):
        steps = params[key] / 1e-2
        assert abs(steps - round(steps)) < 1e-9 and round(steps) % 2 == 0


def test_winners_names_the_best_method_and_tests_significance():
    rows = []
    rng = np.random.default_rng(0)
    name = "grid-gaussian-0.2-1ms"
    base = rng.normal(10, 2, size=8)
    for method, shift in (("a", 0.0), ("b", 1.0)):
        rows += [{"method": method, "params": "{}", "preset": "tuned: oracle for ẍ on seed 1",
                  "scenario": name, "metric": "rmse", "order": 2, "region": "interior",
                  "seed": seed, "value": value + shift}
                 for seed, value in enumerate(base)]  # fmt: skip
    table = grid.winners(pd.DataFrame(rows), order=2)
    row = table[table["step_ms"] == 1.0].iloc[0]
    assert row["winner"] == "a" and row["runner_up"] == "b" and bool(row["significant"])
