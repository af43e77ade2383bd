"""Monte Carlo statistics: confidence intervals that cover, paired tests that detect with the
power they state, rankings that refuse ambiguous input."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from diffbench.bench.core.stats import (
    confidence_interval,
    detectable_difference,
    paired_comparison,
    ranking,
)

RANKING_COLUMNS = [
    "method",
    "params",
    "preset",
    "mean",
    "ci95",
    "seeds",
    "vs_next_mean_difference",
    "vs_next_t_p",
    "vs_next_wilcoxon_p",
    "detectable_difference_80",
    "significant_vs_next",
]


def _rows(scores: dict, seeds=None, **extra) -> list[dict]:
    """Tidy rows of interior RMSE of ẋ: ``scores`` maps a method name to its per-seed values."""
    rows = []
    for method, values in scores.items():
        for seed, value in zip(range(len(values)) if seeds is None else seeds, values, strict=True):
            rows.append(
                {
                    "method": method,
                    "params": "{}",
                    "preset": f"{method} preset",
                    "metric": "rmse",
                    "order": 1,
                    "region": "interior",
                    "seed": int(seed),
                    "value": float(value),
                    **extra,
                }
            )
    return rows


def _t_test_by_hand(differences) -> float:
    """Two-sided one-sample t-test of mean 0, written out: p = 2 P(t_{n-1} > |d̄| √n / s_d)."""
    d = np.asarray(differences, dtype=float)
    t = d.mean() / (d.std(ddof=1) / math.sqrt(d.size))
    return float(2 * stats.t.sf(abs(t), d.size - 1))


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


@pytest.mark.parametrize("n", [5, 20])
def test_detectable_difference_is_detected_at_80_percent_in_simulation(n):
    """Independent check by simulation: 4000 experiments of ``n`` paired normal scores whose
    true mean difference is the computed δ and whose differences have standard deviation 2.
    The paired t-test rejects at 0.05 in 80 % of them, within 4 binomial standard errors
    (√(0.8·0.2/4000) ≈ 0.0063); with no true difference, in 5 %."""
    std, replications = 2.0, 4000
    delta = detectable_difference(n, std)
    rng = np.random.default_rng(100 + n)
    base = rng.normal(10.0, 3.0, size=(replications, n))  # seed-to-seed spread both share
    shifted = base + delta + rng.normal(0.0, std, size=(replications, n))
    rate = np.mean(stats.ttest_rel(shifted, base, axis=1).pvalue < 0.05)
    assert rate == pytest.approx(0.80, abs=4 * math.sqrt(0.8 * 0.2 / replications))
    null = base + rng.normal(0.0, std, size=(replications, n))
    assert np.mean(stats.ttest_rel(null, base, axis=1).pvalue < 0.05) == pytest.approx(
        0.05, abs=4 * math.sqrt(0.05 * 0.95 / replications)
    )


def test_detectable_difference_tends_to_the_normal_theory_value():
    """For large n the t and noncentral t become normal: δ → (z_0.975 + z_0.8) s/√n
    = (1.95996 + 0.84162) · 3 / 100 = 0.084047; the t correction is O(1/n), here ≈ 1e-4."""
    closed_form = (stats.norm.ppf(0.975) + stats.norm.ppf(0.8)) * 3.0 / math.sqrt(10_000)
    assert closed_form == pytest.approx(0.084047, abs=1e-6)
    assert detectable_difference(10_000, 3.0) == pytest.approx(closed_form, rel=5e-4)
    # more seeds, a stricter level or more power each need a larger true difference
    assert detectable_difference(5, 1.0) > detectable_difference(20, 1.0)
    assert detectable_difference(20, 1.0, level=0.01) > detectable_difference(20, 1.0)
    assert detectable_difference(20, 1.0, power=0.9) > detectable_difference(20, 1.0)
    # it scales with the standard deviation
    assert detectable_difference(7, 2.5) == pytest.approx(2.5 * detectable_difference(7, 1.0))


def test_detectable_difference_edge_cases_and_validation():
    assert np.isnan(detectable_difference(0, 1.0)) and np.isnan(detectable_difference(1, 1.0))
    assert detectable_difference(5, 0.0) == 0.0  # deterministic: any nonzero difference is sure
    assert detectable_difference(np.int64(2), 1.0) > 10  # 1 degree of freedom: very weak
    for arguments, message in (
        ((2.5, 1.0), "`n` must be an integer"),
        ((-1, 1.0), "`n` must be >= 0"),
        ((5, -1.0), "`std` must be finite and >= 0"),
        ((5, float("nan")), "`std` must be finite and >= 0"),
        ((5, 1.0, 1.5), "`level` must be in"),
        ((5, 1.0, 0.05, 0.04), "`power` must be in"),
        ((5, 1.0, 0.05, 1.0), "`power` must be in"),
    ):
        with pytest.raises(ValueError, match=message):
            detectable_difference(*arguments)


def test_paired_comparison_detects_a_small_consistent_difference():
    rng = np.random.default_rng(3)
    common = rng.normal(10, 3, size=20)  # a large seed-to-seed spread shared by both
    better, worse = common, common + 0.2 + rng.normal(0, 0.05, size=20)
    result = paired_comparison(better, worse)
    assert result["mean_difference"] == pytest.approx(-0.2, abs=0.05)
    assert result["t_p"] == pytest.approx(_t_test_by_hand(better - worse), rel=1e-9)
    assert result["t_p"] < 1e-6 and result["wilcoxon_p"] < 1e-4 and result["significant"]
    sd = np.std(better - worse, ddof=1)
    assert result["detectable_difference_80"] == pytest.approx(detectable_difference(20, sd))
    # an unpaired view of the same numbers could not tell them apart
    assert stats.ttest_ind(better, worse).pvalue > 0.5
    same = paired_comparison(common, common + rng.normal(0, 1, size=20))
    assert same["t_p"] > 0.01 and not same["significant"]


def test_wilcoxon_p_is_nan_where_it_cannot_reach_the_level():
    """Exact null distribution: all m signs alike has probability 2/2^m, the smallest p.
    m = 5 gives 2/32 = 0.0625 ≥ 0.05 (NaN); m = 6 gives 2/64 = 0.03125 (reported)."""
    five = paired_comparison([1.0, 2, 3, 4, 5], [0.0, 0, 0, 0, 0])
    assert np.isnan(five["wilcoxon_p"]) and five["significant"]
    six = paired_comparison([1.0, 2, 3, 4, 5, 6], [0.0, 0, 0, 0, 0, 0])
    assert six["wilcoxon_p"] == pytest.approx(2 / 2**6)
    # zero differences do not count: six seeds, five nonzero
    assert np.isnan(paired_comparison([0.0, 2, 3, 4, 5, 6], [0.0] * 6)["wilcoxon_p"])
    # at level 0.1 five nonzero differences can reach it (0.0625 < 0.1)
    assert paired_comparison([1.0, 2, 3, 4, 5], [0.0] * 5, level=0.1)["wilcoxon_p"] == (
        pytest.approx(2 / 2**5)
    )


def test_paired_comparison_deterministic_and_degenerate_cases():
    constant = paired_comparison([3.0, 4.0, 5.0], [1.0, 2.0, 3.0])  # +2 on every seed
    assert constant["t_p"] == 0.0 and constant["significant"]
    assert constant["detectable_difference_80"] == 0.0
    identical = paired_comparison([3.0, 4.0, 5.0], [3.0, 4.0, 5.0])
    assert np.isnan(identical["t_p"]) and not identical["significant"]
    assert identical["detectable_difference_80"] == 0.0 and identical["mean_difference"] == 0.0
    single = paired_comparison([3.0], [1.0])  # one seed: no test, no power
    assert single["mean_difference"] == 2.0 and not single["significant"]
    assert np.isnan(single["t_p"]) and np.isnan(single["detectable_difference_80"])
    with pytest.raises(ValueError, match="`first` and `second` must be 1-D"):
        paired_comparison([1.0, 2.0], [1.0])


def test_ranking_orders_by_mean_and_marks_a_deterministic_win_significant():
    rng = np.random.default_rng(0)
    base = rng.normal(5, 1, size=15)
    scores = {"a": base + 1.0, "b": base, "c": base + 1.0 + rng.normal(0, 1, 15)}
    table = ranking(pd.DataFrame(_rows(scores)), "rmse", 1, "interior")
    assert list(table.columns) == RANKING_COLUMNS
    assert list(table["method"]) == ["b", "a", "c"] or list(table["method"]) == ["b", "c", "a"]
    assert list(table["preset"]) == [f"{m} preset" for m in table["method"]]
    assert table.loc[0, "mean"] == pytest.approx(base.mean()) and table["seeds"].eq(15).all()
    assert table.loc[0, "ci95"] == pytest.approx(confidence_interval(base)[1])
    assert bool(table.loc[0, "significant_vs_next"])  # b beats the next by exactly 1.0 each seed
    assert table["significant_vs_next"].dtype == "boolean"
    assert pd.isna(table.loc[2, "significant_vs_next"])
    assert table.loc[2, ["vs_next_t_p", "detectable_difference_80"]].isna().all()


def test_means_equal_but_for_their_last_bits_rank_in_the_order_of_their_keys():
    """One computation reached by two paths differs in its last bits: its entries rank as a
    tie (to RANK_DIGITS digits), in the order of their keys, whichever is smaller; a
    difference in the tenth digit still ranks by value."""
    from diffbench.bench.core.stats import RANK_DIGITS

    base = np.array([4.843, 4.9, 4.7, 4.95, 4.8])
    for nudge in (1, -1):
        later = np.nextafter(base, nudge * np.inf)  # one ulp apart on every seed
        table = ranking(pd.DataFrame(_rows({"b": later, "a": base})), "rmse", 1, "interior")
        assert list(table["method"]) == ["a", "b"]
        # and a tie is no evidence of a difference (the paired test alone finds one: the
        # same ulp on every seed has no variance, p = 0)
        assert not bool(table.loc[0, "significant_vs_next"])
        assert np.isnan(table.loc[0, "vs_next_t_p"])
    apart = base * (1 + 10.0 ** -(RANK_DIGITS - 2))  # larger in the ninth digit
    table = ranking(pd.DataFrame(_rows({"a": apart, "b": base})), "rmse", 1, "interior")
    assert list(table["method"]) == ["b", "a"]


def test_ranking_with_5_seeds_finds_a_large_consistent_difference_the_wilcoxon_rule_missed():
    """The old rule (t and Wilcoxon both < 0.05) could never say yes with 5 seeds: the exact
    Wilcoxon p is at least 2/2^5 = 0.0625. The t-test decides, and states its power."""
    rng = np.random.default_rng(7)
    base = rng.normal(5, 1, size=5)
    better, worse = base, base + 1.0 + rng.normal(0, 0.1, size=5)
    table = ranking(pd.DataFrame(_rows({"worse": worse, "better": better})), "rmse", 1, "interior")
    assert list(table["method"]) == ["better", "worse"]
    first = table.loc[0]
    assert first["vs_next_mean_difference"] == pytest.approx(np.mean(better - worse))
    assert first["vs_next_t_p"] == pytest.approx(_t_test_by_hand(better - worse), rel=1e-9)
    assert first["vs_next_t_p"] < 1e-4 and bool(first["significant_vs_next"])
    assert np.isnan(first["vs_next_wilcoxon_p"])  # cannot reach 0.05 at 5 seeds
    assert stats.wilcoxon(better, worse).pvalue == pytest.approx(2 / 2**5)  # why
    sd = np.std(better - worse, ddof=1)
    assert first["detectable_difference_80"] == pytest.approx(1.682 * sd, rel=1e-3)


def test_ranking_compares_over_the_common_seeds_only():
    a, b = np.arange(10.0), np.arange(10.0) + 5.0 + np.linspace(0, 1, 10) ** 2
    rows = _rows({"a": a}, seeds=range(10)) + _rows({"b": b}, seeds=range(5, 15))
    table = ranking(pd.DataFrame(rows), "rmse", 1, "interior")
    assert list(table["method"]) == ["a", "b"] and list(table["seeds"]) == [10, 10]
    common = a[5:] - b[:5]  # seeds 5..9: a's last five against b's first five
    assert table.loc[0, "vs_next_mean_difference"] == pytest.approx(common.mean())
    assert table.loc[0, "vs_next_t_p"] == pytest.approx(_t_test_by_hand(common), rel=1e-9)
    assert table.loc[0, "detectable_difference_80"] == pytest.approx(
        detectable_difference(5, np.std(common, ddof=1))
    )


def test_ranking_groups_by_the_keys_given():
    """Two roles of one method at one parameter set are two entries when ``role`` is a key;
    without it, the same rows would be two values per seed for one entry, an error."""
    rows = pd.DataFrame(
        _rows({"m": [1.0, 2.0, 3.0]}, role="reference")
        + _rows({"m": [2.0, 3.0, 4.5]}, role="candidate")
    )
    table = ranking(rows, "rmse", 1, "interior", keys=("method", "params", "role"))
    assert list(table.columns[:4]) == ["method", "params", "role", "preset"]
    assert list(table["role"]) == ["reference", "candidate"]
    assert table.loc[0, "vs_next_mean_difference"] == pytest.approx((-1 - 1 - 1.5) / 3)
    with pytest.raises(ValueError, match="duplicated seeds"):
        ranking(rows, "rmse", 1, "interior")


def test_ranking_refuses_duplicated_seeds():
    """A store that double-counts cells must not turn a 3-seed run into 4 seeds."""
    rows = _rows({"a": [1.0, 2.0, 3.0], "b": [2.0, 3.0, 4.0]})
    rows.append(dict(rows[1]))  # seed 1 of "a" stored twice
    with pytest.raises(ValueError, match=r"duplicated seeds \[1\] for entry \{'method': 'a'"):
        ranking(pd.DataFrame(rows), "rmse", 1, "interior")
    # the same seed under another metric is not a duplicate
    other = [{**row, "metric": "max_error"} for row in rows[:3]]
    table = ranking(pd.DataFrame(rows[:6] + other), "rmse", 1, "interior")
    assert list(table["seeds"]) == [3, 3]


def test_ranking_refuses_missing_columns_and_bad_keys():
    rows = pd.DataFrame(_rows({"a": [1.0, 2.0], "b": [2.0, 3.0]}))
    with pytest.raises(ValueError, match="`rows` has no column 'role'"):
        ranking(rows, "rmse", 1, "interior", keys=("method", "params", "role"))
    with pytest.raises(ValueError, match="`rows` has no column 'seed'"):
        ranking(rows.drop(columns="seed"), "rmse", 1, "interior")
    with pytest.raises(ValueError, match="`keys` must be a sequence of column names"):
        ranking(rows, "rmse", 1, "interior", keys="method")
    with pytest.raises(ValueError, match="`keys` must name at least one column"):
        ranking(rows, "rmse", 1, "interior", keys=())
    with pytest.raises(ValueError, match="`level` must be in"):
        ranking(rows, "rmse", 1, "interior", level=0.0)
    with pytest.raises(ValueError, match="no stored rows for 'rmse', order 2"):
        ranking(rows, "rmse", 2, "interior")


def test_a_ranking_that_compares_the_first_entries_only_is_the_full_one_elsewhere_nan():
    """``compared=k``: the first k rows are the full ranking's row for row (their tests
    against the next one down included), every row's mean, interval and seeds too; the later
    rows' comparison columns are NaN / NA. Bad values name the argument."""
    rng = np.random.default_rng(3)
    base = rng.normal(5, 1, size=12)
    scores = {name: base + shift + rng.normal(0, 0.3, 12) for shift, name in enumerate("abcde")}
    rows = pd.DataFrame(_rows(scores))
    full = ranking(rows, "rmse", 1, "interior")
    comparison = [
        "vs_next_mean_difference",
        "vs_next_t_p",
        "vs_next_wilcoxon_p",
        "detectable_difference_80",
        "significant_vs_next",
    ]
    for k in (0, 1, 3, 4, 10):
        table = ranking(rows, "rmse", 1, "interior", compared=k)
        assert list(table.columns) == list(full.columns)
        shown = min(k, len(full) - 1)
        pd.testing.assert_frame_equal(table.iloc[:shown], full.iloc[:shown])
        pd.testing.assert_frame_equal(table.drop(columns=comparison), full.drop(columns=comparison))
        assert table.loc[shown:, comparison].isna().all().all()
        assert table["significant_vs_next"].dtype == "boolean"
    pd.testing.assert_frame_equal(
        ranking(rows, "rmse", 1, "interior", compared=np.int64(1)),
        ranking(rows, "rmse", 1, "interior", compared=1),
    )
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="`compared` must be a whole number >= 0"):
            ranking(rows, "rmse", 1, "interior", compared=bad)
