"""Scores against numbers computed by hand."""

import numpy as np
import pytest

from diffbench.bench.core.scores import error_metrics, score_estimate
from diffbench.methods import Estimate


def test_error_metrics_by_hand():
    truth = np.array([1.0, -1.0, 1.0, -1.0])
    estimate = np.array([1.5, -1.0, 1.0, -2.0])  # errors 0.5, 0, 0, -1
    metrics = error_metrics(estimate, truth, np.ones(4, dtype=bool))
    assert metrics["rmse"] == pytest.approx(np.sqrt(1.25 / 4))
    assert metrics["max_abs"] == 1.0
    assert metrics["rel_rmse"] == pytest.approx(np.sqrt(1.25 / 4) / 1.0)
    masked = error_metrics(estimate, truth, np.array([False, True, True, True]))
    assert masked["rmse"] == pytest.approx(np.sqrt(1 / 3))


def test_error_metrics_broadcast_truth_over_channels():
    truth = np.array([0.0, 1.0, 2.0])
    estimate = np.stack([truth + 1.0, truth - 1.0], axis=1)
    assert error_metrics(estimate, truth, np.ones(3, dtype=bool))["rmse"] == pytest.approx(1.0)


def test_empty_mask_is_an_error():
    with pytest.raises(ValueError, match="`mask` selects no samples"):
        error_metrics(np.zeros(3), np.zeros(3), np.zeros(3, dtype=bool))


def test_score_rows_cover_the_three_regions_and_report_coverage():
    n = 10
    values = np.arange(n, dtype=float)
    first = values + 0.5
    first[:2] = np.nan
    valid = np.isfinite(first)
    estimate = Estimate(values={0: values, 1: first}, valid={0: np.ones(n, bool), 1: valid})
    truth = {0: values, 1: np.arange(n, dtype=float)}
    interior = np.zeros(n, dtype=bool)
    interior[1:9] = True  # the method misses sample 1 of the interior
    rows = {
        (r["order"], r["region"], r["metric"]): r["value"]
        for r in score_estimate(estimate, truth, interior)
    }
    assert rows[(0, "valid", "rmse")] == 0.0
    assert rows[(1, "valid", "rmse")] == pytest.approx(0.5)
    assert rows[(1, "valid", "coverage")] == pytest.approx(0.8)
    assert rows[(1, "interior", "coverage")] == pytest.approx(7 / 8)
    assert rows[(1, "interior", "max_abs")] == pytest.approx(0.5)
    # the whole record: every estimated sample, the two untrusted ends (error 3) included
    assert rows[(1, "whole", "coverage")] == pytest.approx(0.8)
    assert rows[(1, "whole", "rmse")] == pytest.approx(0.5)


def test_whole_region_scores_the_estimated_samples_the_valid_region_leaves_out():
    """An estimated, untrusted end (error 3 on samples 0 and 9) counts in ``whole``, not in
    ``valid`` or ``interior``; sample 5 has no estimate at all."""
    n = 10
    truth = {1: np.zeros(n)}
    first = np.full(n, 1.0)
    first[[0, 9]] = 3.0
    first[5] = np.nan
    valid = np.ones(n, dtype=bool)
    valid[[0, 5, 9]] = False
    interior = np.zeros(n, dtype=bool)
    interior[2:8] = True
    rows = {
        (r["order"], r["region"], r["metric"]): r["value"]
        for r in score_estimate(Estimate(values={1: first}, valid={1: valid}), truth, interior)
    }
    assert rows[(1, "whole", "rmse")] == pytest.approx(np.sqrt((2 * 9 + 7 * 1) / 9))
    assert rows[(1, "whole", "max_abs")] == 3.0
    assert rows[(1, "whole", "coverage")] == pytest.approx(0.9)
    assert rows[(1, "valid", "rmse")] == pytest.approx(1.0)
    assert rows[(1, "valid", "coverage")] == pytest.approx(0.7)
    assert rows[(1, "interior", "coverage")] == pytest.approx(5 / 6)


def test_whole_record_ranking_keeps_the_entries_that_estimate_every_sample():
    """``covering_whole``: on region ``whole`` an entry stays only if it estimates every
    sample on every seed; on ``valid`` (the grid's own-valid-samples ranking) 99 % marked
    valid on every seed suffices."""
    import pandas as pd

    from diffbench.bench.report import tables

    rows = pd.DataFrame(
        [
            {
                "method": m,
                "params": "{}",
                "role": "preset",
                "order": 1,
                "region": region,
                "metric": "coverage",
                "value": value,
                "seed": seed,
            }
            for m, region, values in (
                ("full", "whole", (1.0, 1.0)),
                ("short", "whole", (1.0, 0.999)),
                ("full", "valid", (0.995, 0.99)),
                ("short", "valid", (1.0, 0.98)),
            )
            for seed, value in enumerate(values)
        ]
    )
    assert set(tables.covering_whole(rows, 1)["method"]) == {"full"}
    assert set(tables.covering_whole(rows, 1, region="valid")["method"]) == {"full"}
    assert tables.covering_whole(rows, 2).empty  # no coverage row of ẍ: left out
