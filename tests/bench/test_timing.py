"""The throughput table: every method gets a figure, sizes past a cap are left out and said."""

import numpy as np
import pandas as pd
import pytest

from diffbench import methods
from diffbench.bench.studies import ratios, timing


def test_a_method_capped_below_the_smallest_size_is_timed_at_its_cap(tmp_path, monkeypatch):
    monkeypatch.setitem(timing.SIZE_CAPS, "finite_difference", (1000, "a cap for this test"))
    table = timing.throughput(
        sizes=(2000, 4000), repeats=1, names=["finite_difference", "savitzky_golay"]
    )
    timed = table.groupby("method")["samples"].apply(list).to_dict()
    assert timed == {"finite_difference": [1000], "savitzky_golay": [2000, 4000]}
    assert np.all(table["samples_per_s"] > 0)
    assert np.allclose(table["samples_per_s"], table["samples"] / table["seconds"])
    markdown = (timing.write_throughput(tmp_path, table)[0]).read_text(encoding="utf-8")
    throughput = markdown.split("## Peak memory")[0]
    rows = {line.split(" | ")[0].lstrip("| "): line for line in throughput.splitlines()}
    assert "| 1e+03 | 2e+03 | 4e+03 | growth |" in markdown
    # one size timed: no growth, and the two sizes it was not timed at are dashes
    assert rows["finite_difference"].endswith("| — | — | — |")
    assert not rows["savitzky_golay"].endswith("| — |")
    assert rows["savitzky_golay"].split(" | ")[2] == "—"  # not timed at the 1000-sample column
    assert "- finite_difference: timed up to 1000 samples (a cap for this test)" in markdown


def test_peak_memory_is_the_calls_own_allocation():
    if not timing.memory_measurable():
        pytest.skip("no /proc/self/clear_refs here: peak memory is not measured")
    big = np.ones(20_000_000)  # held before the call: not counted
    result, peak = timing.peak_memory_mib(np.full, 10_000_000, 2.0)  # 76.3 MiB
    assert result.nbytes == 80_000_000 and big.size == 20_000_000
    assert 76 <= peak < 90
    _, nothing = timing.peak_memory_mib(lambda: None)
    assert nothing < 5


def test_throughput_reports_memory_growth_and_causal_methods(tmp_path):
    table = timing.throughput(
        sizes=(20_000, 40_000), repeats=1, names=["finite_difference", "causal_butterworth"]
    )
    assert set(table["causal"]) == {False, True}
    assert table["peak_mib"].notna().all() or not timing.memory_measurable()
    paths = timing.write_throughput(tmp_path, table)
    markdown = paths[0].read_text(encoding="utf-8")
    assert "## Peak memory (MiB above the input" in markdown
    assert "| causal_butterworth | " in markdown.split("## Peak memory")[1]
    assert paths[2].name == "growth.png" and paths[2].stat().st_size > 10_000


def test_the_speed_ratios_check_that_ours_and_the_peers_agree(tmp_path):
    kalman = ratios.kalman_against_filterpy(samples=50_000, filterpy_samples=2_000, repeats=1)
    jacobi = ratios.fir_against_oaconvolve("jacobi", 50_000, (0, 1, 2), repeats=1)
    assert kalman["agreement"] < 1e-9  # the same smoothed positions as filterpy's
    assert jacobi["agreement"] < 1e-12  # the same outputs as oaconvolve, relative
    for row in (kalman, jacobi):
        assert row["ratio"] == pytest.approx(row["peer_s"] / row["ours_s"])
    markdown = ratios.write_ratios(tmp_path, pd.DataFrame([kalman, jacobi]))[0].read_text(
        encoding="utf-8"
    )
    assert (
        "| Kalman smoother, per sample (ours 50,000, filterpy 2,000 samples) | kalman "
        "(paper-signal preset) | filterpy " in markdown
    )
    same = ratios.kalman_against_filterpy(samples=3_000, filterpy_samples=3_000, repeats=1)
    assert same["comparison"] == "Kalman smoother, per sample (both 3,000 samples)"
    assert same["agreement"] < 1e-9
    assert "| jacobi orders 0-2, one call, 50,000 samples |" in markdown
    one = ratios.fir_against_oaconvolve("savitzky_golay", 20_000, (1,), repeats=1)
    assert one["comparison"] == "savitzky_golay order 1, 20,000 samples"
    assert one["agreement"] < 1e-12 and one["target"] == 1.0


def test_forget_settings_empties_the_per_setting_caches_and_keeps_the_registry():
    from diffbench.methods import _ends, _registry, butterworth, jacobi

    method = methods.get("butterworth", order=4, cutoff_hz=20.0)
    method(np.random.default_rng(0).standard_normal(500), 1e-3)
    _registry.params_of(type(method))
    # Jacobi's kept boundary weights and central fits at time stamps (byte-bounded caches)
    times = np.arange(500) * 1e-3
    x = np.sin(2 * np.pi * 3 * times)
    methods.get("jacobi", window_s=0.05, accel_window_s=0.05)(x, 1e-3)
    methods.get("jacobi", window_s=0.05, accel_window_s=0.05)(x, 1e-3, t=times + 1e-5 * x)
    assert _ends._trusted.cache_info().currsize > 0
    assert butterworth._butter_sos.cache_info().currsize > 0
    assert len(jacobi._kept_end_weights) > 0 and len(jacobi._kept_central_fits) > 0
    ratios.forget_settings()
    assert _ends._trusted.cache_info().currsize == 0
    assert butterworth._butter_sos.cache_info().currsize == 0
    assert len(jacobi._kept_end_weights) == 0 and len(jacobi._kept_central_fits) == 0
    assert _registry.params_of.cache_info().currsize > 0  # unbounded: not a setting's


def test_the_time_to_reach_is_the_first_evaluation_at_most_the_peers_rmse():
    """From a search's history (losses in the order evaluated, their elapsed seconds): the
    first at or below the peer's RMSE, not the best nor the last; NaN where none is."""
    from diffbench.bench.core.tuning import TuningResult

    result = TuningResult(
        method="m",
        params={},
        loss=1.5,
        criterion="oracle",
        order=1,
        evaluations=4,
        seconds=0.5,
        history=(({}, 5.0), ({}, 3.0), ({}, 1.5), ({}, 2.0)),
        elapsed=(0.1, 0.2, 0.3, 0.4),
    )
    assert ratios._time_to_reach(result, 3.0) == 0.2
    assert ratios._time_to_reach(result, 2.5) == 0.3
    assert np.isnan(ratios._time_to_reach(result, 1.0))


def test_a_tunings_elapsed_times_follow_its_history():
    """Each evaluation of a tuning is stamped once, in order, within the search's time."""
    from diffbench.bench.core import tuning

    record = ratios._paper_signal_head(1000, 150)
    result = tuning.tune("savitzky_golay", record, 1, "oracle")
    assert len(result.elapsed) == len(result.history) == result.evaluations
    assert all(np.diff(result.elapsed) >= 0) and 0 < result.elapsed[-1] <= result.seconds


def test_the_new_setting_row_times_fresh_kalman_settings_against_rtsdiff(tmp_path):
    pytest.importorskip("pynumdiff")
    row = ratios.kalman_new_bandwidth(samples=300, settings=3, repeats=1)
    assert row["ours_s"] > 0 and row["peer_s"] > 0
    assert row["ratio"] == pytest.approx(row["peer_s"] / row["ours_s"])
    markdown = ratios.write_ratios(tmp_path, pd.DataFrame([row]))[0].read_text(encoding="utf-8")
    assert "| Kalman smoother, a new setting (300 samples) |" in markdown
    assert "| s per setting |" in markdown and "| — | — |" in markdown  # no target, agreement


def test_the_ends_check_share_is_zero_where_the_check_cannot_reach_the_samples_scored():
    """The interior read starts 150 samples in: a 51-sample Savitzky-Golay window's ends
    (25 samples) cannot reach it, so the evaluation skips the check (share 0); a Butterworth
    filter's start-up (684 samples at the paper preset) can, and its check is part of the
    evaluation's time, not all of it."""
    record = ratios._paper_signal_head(1000, 150)
    short = {"window_s": 0.05, "degree": 3}
    assert ratios.ends_check_share("savitzky_golay", record, [short]) == 0.0
    share = ratios.ends_check_share("butterworth", record, [{"order": 6, "cutoff_hz": 25.0}])
    assert 0.0 < share < 1.0
    refused = {"order": 6, "cutoff_hz": 0.2}  # below 1e-3 of Nyquist: +inf to the tuner
    assert np.isnan(ratios.ends_check_share("butterworth", record, [refused]))
