"""Oracle tuning of Savitzky-Golay beside PyNumDiff's ``optimize`` on the same 1000 samples
(paper-signal seed 0, RMSE of ẋ on samples 150..849 for both; PyNumDiff serially, its default
search space). Target: ours >= 20x faster to a setting at least as accurate as PyNumDiff's;
`diffbench timing` writes the four pairs of results/timing/ratios.md. Compare the rows of
`pytest tests/timing/test_tuning_timing.py --benchmark-only`; the tuned settings are checked
against the truth, no time is asserted.
"""

import warnings

import numpy as np
import pytest
from scipy.signal import savgol_filter

from diffbench import methods
from diffbench.bench.core import tuning
from diffbench.bench.studies import ratios

pynumdiff = pytest.importorskip("pynumdiff")
DT = 1e-3


@pytest.fixture(scope="module")
def record():
    return ratios._paper_signal_head(1000, 150)


def _rmse(estimate, record):
    inside = np.asarray(record.interior)
    return float(np.sqrt(np.mean((estimate[inside] - record.truth[1][inside]) ** 2)))


@pytest.mark.benchmark(group="oracle-tuning-1000-samples")
def test_diffbench_oracle_tuning_savitzky_golay(benchmark, record):
    result = benchmark.pedantic(
        tuning.tune, args=("savitzky_golay", record, 1, "oracle"), rounds=1, iterations=1
    )
    estimate = methods.get("savitzky_golay", **result.params)(record.x, DT, orders=(1,))
    assert estimate.valid[1][record.interior].all()
    # the tuner compares losses rounded to 1e-9 of the RMS of the true ẋ (about 1e-7 here)
    assert _rmse(estimate[1], record) == pytest.approx(result.loss, rel=1e-7)
    # an independent brute force (scipy's savgol_filter, windows of 11..301 samples every 10,
    # degrees 2..12, all central on samples 150..849): the tuner finds at least its best
    best = min(
        _rmse(savgol_filter(record.x, window, degree, deriv=1, delta=DT), record)
        for window in range(11, 302, 10)
        for degree in range(2, min(12, window - 1) + 1)
    )
    assert result.loss <= best * (1 + 1e-9)


@pytest.mark.benchmark(group="oracle-tuning-1000-samples")
def test_pynumdiff_optimize_savgoldiff(benchmark, record):
    from pynumdiff.optimize import optimize

    x, truth = np.asarray(record.x), np.asarray(record.truth[1])

    def run():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return optimize(
                pynumdiff.savgoldiff, x, DT, dxdt_truth=truth, padding=150, parallel=False
            )

    params, value = benchmark.pedantic(run, rounds=1, iterations=1)
    _, derivative = pynumdiff.savgoldiff(x, DT, **params)
    assert _rmse(derivative, record) == pytest.approx(value, rel=1e-9)


def test_the_tuning_ratio_row_times_a_fresh_tuning_against_the_fastest_peer_run():
    (row,) = ratios.tuning_against_pynumdiff(names=["savitzky_golay"], repeats=2)
    record = ratios._paper_signal_head(1000, 150)
    again = tuning.tune("savitzky_golay", record, 1, "oracle")
    # the timed runs found what a tuning finds (their caches emptied first)
    assert (row["ours_params"], row["ours_rmse"]) == (again.params, again.loss)
    assert row["ours_evaluations"] == again.evaluations
    assert 0.0 <= row["ends_check_share"] < 1.0
    assert row["peer_s"] == min(row["peer_serial_s"], row["peer_pool_s"])
    assert row["ratio"] == pytest.approx(row["peer_s"] / row["ours_s"])
    # the ratio's time is to the first setting as accurate as the peer's, within the search's
    reached = [loss for _, loss in again.history if loss <= row["peer_rmse"]]
    assert reached and row["ours_rmse"] <= row["peer_rmse"]
    assert 0 < row["ours_s"] <= row["tuning_s"]
    _, derivative = pynumdiff.savgoldiff(np.asarray(record.x), DT, **row["peer_params"])
    assert _rmse(derivative, record) == pytest.approx(row["peer_rmse"], rel=1e-12)
