"""The scenario grid and its winners table."""

import re

import numpy as np
import pandas as pd
import pytest

from diffbench import signals
from diffbench.bench.core import tuning
from diffbench.bench.studies import grid
from diffbench.signals.scenarios import GRID_NOISE_LEVELS, GRID_NOISE_TYPES, GRID_STEPS_S


def test_grid_has_every_noise_type_level_and_step():
    from diffbench.signals.scenarios import GRID_SAMPLING_STEPS_S, GRID_SAMPLINGS

    names = [n for n in signals.available_scenarios() if n.startswith("grid-")]
    assert len(names) == len(GRID_NOISE_TYPES) * len(GRID_NOISE_LEVELS) * len(GRID_STEPS_S) + len(
        GRID_SAMPLINGS
    ) * len(GRID_SAMPLING_STEPS_S)
    assert sorted(names) == sorted(grid.task_names())
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
    from diffbench.bench.runner import TuningJob, _tune

    job = TuningJob(
        "grid-gaussian-0.2-10ms", "jacobi", "oracle", 2, tuning.TUNING_SEED, None, grid.BUDGET
    )
    params = _tune(job)["params"]
    assert params
    for key in ("window_s", "accel_window_s"):
        steps = params[key] / 1e-2
        assert abs(steps - round(steps)) < 1e-9 and round(steps) % 2 == 0


def _rows(name, entries, order=2, seeds=8, region="interior"):
    rows = []
    base = np.random.default_rng(0).normal(10, 2, size=seeds)
    for method, shift in entries:
        rows += [
            {
                "task": name,
                "method": method,
                "params": "{}",
                "tuned_order": order,
                "metric": "rmse",
                "order": order,
                "region": region,
                "seed": seed,
                "value": value + shift,
            }
            for seed, value in enumerate(base)
        ]
    frame = pd.DataFrame(rows)
    frame["tuned_order"] = frame["tuned_order"].astype("Int64")
    return frame


def test_winners_names_the_best_method_and_tests_significance():
    table = grid.winners(_rows("grid-gaussian-0.2-1ms", (("a", 0.0), ("b", 1.0))), order=2)
    row = table[
        (table["noise"] == "gaussian") & (table["level"] == 0.2) & (table["step_ms"] == 1.0)
    ].iloc[0]
    assert row["winner"] == "a" and row["runner_up"] == "b" and bool(row["significant"])
    assert row["detectable_difference_80"] == 0.0  # the same difference on every seed


def _coverage(rows, coverages, order=2):
    """Coverage rows of ``rows``'s entries: ``{method: coverage on every seed}``."""
    seeds = sorted(set(rows["seed"]))
    extra = [
        {
            "task": rows["task"].iloc[0],
            "method": method,
            "params": "{}",
            "tuned_order": order,
            "metric": "coverage",
            "order": order,
            "region": "whole",
            "seed": seed,
            "value": value,
        }
        for method, value in coverages.items()
        for seed in seeds
    ]
    frame = pd.concat([rows, pd.DataFrame(extra)], ignore_index=True)
    frame["tuned_order"] = frame["tuned_order"].astype("Int64")
    return frame


def test_whole_record_winner_leaves_out_entries_that_mask_their_ends(tmp_path):
    """'a' wins the interior and has the least RMSE over the samples it estimates, but
    estimates only 90 % of the record: on the whole record 'b' (every sample) wins."""
    name = "grid-gaussian-0.2-1ms"
    interior = _rows(name, (("a", 0.0), ("b", 1.0)))
    whole = _rows(name, (("a", 0.5), ("b", 3.0)), region="whole")
    rows = _coverage(pd.concat([interior, whole], ignore_index=True), {"a": 0.9, "b": 1.0})
    pick = {"noise": "gaussian", "level": 0.2, "step_ms": 1.0}

    def row(table):
        return table[(table[list(pick)] == pd.Series(pick)).all(axis=1)].iloc[0]

    assert row(grid.winners(rows, 2, "interior"))["winner"] == "a"
    best = row(grid.winners(rows, 2, "whole"))
    assert best["winner"] == "b" and pd.isna(best["runner_up"])
    assert best["rmse"] == pytest.approx(whole[whole["method"] == "b"]["value"].mean())
    with pytest.raises(ValueError, match="`region`"):
        grid.winners(rows, 2, "ends")
    grid.write_winners(rows, tmp_path)
    text = (tmp_path / "winners_acceleration.md").read_text()
    assert "Ts = 1 ms, interior" in text and "Ts = 1 ms, whole" in text
    lines = [[c.strip() for c in li.strip("|").split("|")] for li in text.splitlines()]
    cells = next(c for c in lines if c[:2] == ["gaussian", "0.2"])
    assert cells[4].startswith("a*") and cells[5].startswith("b (")  # 1 ms: interior, whole


def test_aliased_disturbance_is_labelled_not_ranked(tmp_path):
    """200 Hz sampled every 10 ms lands on its zeros: the sinusoid-only cells hold no noise."""
    from diffbench.signals.scenarios import vanishing_disturbances

    clean = signals.get_scenario("grid-sinusoid-0.2-10ms").realise(3)
    assert np.max(np.abs(clean.x - clean.truth[0])) < 1e-12  # rounding of sin(2πk·2)
    assert vanishing_disturbances(signals.get_scenario("grid-sinusoid-0.2-10ms"))
    assert not vanishing_disturbances(signals.get_scenario("grid-sinusoid-0.2-1ms"))
    rows = _rows("grid-sinusoid-0.2-10ms", (("a", 0.0), ("b", 1.0)))
    rows = pd.concat([rows, _rows("grid-combined-0.2-10ms", (("a", 0.0), ("b", 1.0)))])
    written = grid.write_winners(rows, tmp_path)
    text = (tmp_path / "winners_acceleration.md").read_text()
    assert "no noise (200 Hz aliases to 0 Hz)" in text
    assert re.search(r"\| a\* \([\d.]+; next b [\d.]+\) † +\|", text)  # ranked, marked
    # no rows tuned for ẋ: no velocity table; which_method: the combined task alone
    assert [path.name for path in written] == [
        "winners_acceleration.md",
        "winners_acceleration.csv",
        "which_method.md",
        "which_method.csv",
        "errors.csv",
    ]
    choice = pd.read_csv(tmp_path / "which_method.csv")
    assert choice[["noise", "tasks", "method"]].values.tolist() == [["combined", 1, "a"]]
    # the explorer's errors: both methods on the task with noise left (not the aliased one),
    # the winner at ratio 1
    errors = pd.read_csv(tmp_path / "errors.csv")
    assert set(errors["task"]) == {"grid-combined-0.2-10ms"}
    assert set(errors["method"]) == {"a", "b"} and set(errors["order"]) == {2}
    assert errors.loc[errors["method"] == "a", "ratio"].eq(1.0).all()
    assert (errors.loc[errors["method"] == "b", "ratio"] > 1.0).all()


def test_irregular_sampling_rows_are_ranked_where_run_and_dashed_elsewhere(tmp_path):
    from diffbench.signals.scenarios import grid_sampling_name

    name = grid_sampling_name("jitter", 1e-3)
    rows = _rows(name, (("a", 0.0), ("b", 1.0)))
    marked = _rows(name, (("spectral", 0.0), ("kalman", 1.0)))
    text = grid._winner_text(grid.winners(marked, 2).query("task == @name").iloc[0])
    assert text.startswith("spectral (resampled)*") and "next kalman " in text  # kalman: native
    table = grid.winners(rows, 2)
    jitter = table[table["noise"].str.contains("jitter")].set_index("step_ms")
    assert jitter.loc[1.0, "winner"] == "a" and jitter.loc[1.0, "task"] == name
    assert pd.isna(jitter.loc[0.1, "task"]) and pd.isna(jitter.loc[0.1, "winner"])
    grid.write_winners(rows, tmp_path)
    text = (tmp_path / "winners_acceleration.md").read_text()
    line = next(li for li in text.splitlines() if "jitter ±30% of the step" in li)
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[2] == "—" and cells[4].startswith("a*")  # 0.1 ms: not run; 1 ms: ranked


def test_which_method_picks_the_least_worst_ratio_to_the_best_over_a_noise_kind(tmp_path):
    """Three Gaussian-noise tasks, three methods (mean RMSE B + shift, B the mean of the
    shared seeds' values): 'a' wins two tasks but is 3 worse on the third; 'b' wins one and is
    at most 1 worse anywhere; 'c' is 8 worse on one. The choice is 'b', at worst (B+1)/B."""
    names = ["grid-gaussian-0.02-1ms", "grid-gaussian-0.2-1ms", "grid-gaussian-0.5-1ms"]
    shifts = {
        names[0]: (("a", 0.0), ("b", 1.0), ("c", 2.0)),
        names[1]: (("a", 3.0), ("b", 0.0), ("c", 0.5)),
        names[2]: (("a", 0.0), ("b", 0.5), ("c", 8.0)),
    }
    rows = pd.concat([_rows(name, shifts[name]) for name in names], ignore_index=True)
    base = rows[(rows["task"] == names[0]) & (rows["method"] == "a")]["value"].mean()
    regrets = grid.regrets(rows, 2, "interior").set_index(["task", "method"])["ratio"]
    assert regrets[names[1], "a"] == pytest.approx((base + 3.0) / base, rel=1e-12)
    assert regrets[names[0], "a"] == 1.0 and regrets[names[1], "b"] == 1.0
    choice = grid.which_method(rows).iloc[0]
    assert (choice["noise"], choice["tasks"], choice["methods"]) == ("gaussian", 3, 3)
    assert choice["method"] == "b" and choice["wins"] == 1
    assert choice["worst_ratio"] == pytest.approx((base + 1.0) / base, rel=1e-12)
    assert choice["median_ratio"] == pytest.approx((base + 0.5) / base, rel=1e-12)
    assert choice["runner_up"] == "a"
    assert choice["runner_up_worst_ratio"] == pytest.approx((base + 3.0) / base, rel=1e-12)
    # a method missing on one task of the kind is not a choice there
    partial = rows[~((rows["method"] == "b") & (rows["task"] == names[2]))]
    assert grid.which_method(partial).iloc[0]["method"] == "a"
    grid.write_which_method(rows, tmp_path)
    text = (tmp_path / "which_method.md").read_text()
    line = next(li for li in text.splitlines() if li.startswith("| gaussian (3)"))
    cells = [c.strip() for c in line.strip("|").split("|")]
    worst, median = (base + 1.0) / base, (base + 0.5) / base
    assert cells[3] == f"b ≤ {worst:.2f}× (median {median:.2f}×)"  # ẍ, interior
    assert cells[1] == cells[2] == cells[4] == "—"  # ẋ, and the whole record: not run
