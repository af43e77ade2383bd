"""Monte Carlo statistics: confidence intervals that cover, paired tests that detect."""

import numpy as np
import pandas as pd
import pytest
from diffbench.bench.stats import confidence_interval, paired_comparison, ranking
from scipy import stats


def test_confidence_interval_by_hand():
    mean, half = confidence_interval([1.0, 2.0, 3.0, 4.0])
    assert mean == 2.5
    assert half == pytest.approx(stats.t.ppf(0.975, 3) * np.std([1, 2, 3, 4], ddof=1) / 2)
    assert np.isnan(confidence_interval([5.0])[1])
    with pytest.raises(ValueError, match="`values` is empty"):
        confidence_interval([])


def test_confidence_intervals_cover_the_true_mean_at_the_nominal_rate():
    """3000 experiments of 20 skewed (exponential) draws with known mean 2: the 95 % interval
    covers 2 in 95 % ± 1.5 % of them (about 4 binomial standard errors)."""
    rng = np.random.default_rng(11)
    covered = 0
    trials = 3000
    for _ in range(trials):
        mean, half = confidence_interval(rng.exponential(2.0, size=20))
        covered += abs(mean - 2.0) <= half
    assert 0.92 <= covered / trials <= 0.965


def test_paired_comparison_detects_a_small_consistent_difference():
    rng = np.random.default_rng(3)
    common = rng.normal(10, 3, size=20)  # a large seed-to-seed spread shared by both
    better, worse = common, common + 0.2 + rng.normal(0, 0.05, size=20)
    result = paired_comparison(better, worse)
    assert result["mean_difference"] == pytest.approx(-0.2, abs=0.05)
    assert result["t_p"] < 1e-6 and result["wilcoxon_p"] < 1e-4
    # an unpaired view of the same numbers could not tell them apart
    assert stats.ttest_ind(better, worse).pvalue > 0.5
    same = paired_comparison(common, common + rng.normal(0, 1, size=20))
    assert same["t_p"] > 0.01


def test_ranking_orders_by_mean_and_marks_significance():
    seeds = np.arange(15)
    rng = np.random.default_rng(0)
    base = rng.normal(5, 1, size=15)
    rows = []
    for method, values in (
        ("a", base + 1.0),
        ("b", base),
        ("c", base + 1.0 + rng.normal(0, 1, 15)),
    ):
        rows += [
            {"method": method, "params": "{}", "metric": "rmse", "order": 1,
             "region": "interior", "seed": s, "value": v}
            for s, v in zip(seeds, values, strict=True)
        ]  # fmt: skip
    table = ranking(pd.DataFrame(rows), "rmse", 1, "interior")
    assert list(table["method"]) == ["b", "a", "c"] or list(table["method"]) == ["b", "c", "a"]
    assert bool(table.loc[0, "significant_vs_next"])  # b beats the next by exactly 1.0 each seed
    assert pd.isna(table.loc[2, "significant_vs_next"])
