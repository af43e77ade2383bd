"""The peers task ``pynumdiff-suite`` (issue 45): PyNumDiff's test records, its methods at its
tests' parameters, ours tuned by the truth, ẋ RMSE over every sample."""

import math

import numpy as np
import pandas as pd
import pytest

from diffbench.bench import api
from diffbench.bench.studies import pynumdiff_suite as study
from diffbench.bench.tasks import available_tasks, get_task
from diffbench.bench.tasks.pynumdiff_suite import ORACLE, TESTS, PyNumDiffSuite
from diffbench.signals import pynumdiff_suite as records

EPS = np.finfo(float).eps
CENTRAL = {
    2: [-1 / 2, 0, 1 / 2],
    4: [1 / 12, -2 / 3, 0, 2 / 3, -1 / 12],
    6: [-1 / 60, 3 / 20, -3 / 4, 0, 3 / 4, -3 / 20, 1 / 60],
}
"""Central first-derivative stencils (Fornberg's table), by accuracy order."""


def test_the_task_is_registered_on_every_record():
    assert "pynumdiff-suite" in available_tasks()
    task = get_task("pynumdiff-suite")
    assert isinstance(task, PyNumDiffSuite)
    assert task.records == tuple(records.SCENARIOS)
    assert task.default_seeds >= 10


def test_items_are_the_tests_settings_and_the_oracles():
    task = PyNumDiffSuite(records=("pynumdiff-f2",), tune_peers=False)
    names = ["finite_difference", "pynumdiff.tvrdiff", "derivative.kalman"]
    items = task.items(names, range(3))
    settings = [(item.setting["method"], item.setting["source"]) for item in items]
    # the other peers' methods are not PyNumDiff's: left out; tvrdiff at its 3 test settings
    assert settings == [("finite_difference", ORACLE)] + [("pynumdiff.tvrdiff", TESTS)] * 3
    assert [item.setting["params"]["gamma"] for item in items[1:]] == [0.5, 1.0, 10.0]
    with pytest.raises(ValueError, match="unknown PyNumDiff test record"):
        PyNumDiffSuite(records=("pynumdiff-f7",))


def _expected_finite_difference(record, accuracy, seeds):
    """Central differences of the record's samples, scored on the samples the stencil reaches,
    computed here from the scenario's samples and truth: (mean RMSE, coverage)."""
    stencil = np.array(CENTRAL[accuracy])
    half = len(stencil) // 2
    values = []
    for seed in range(seeds):
        realisation = records.get(record).realise(seed)
        x, dt = realisation.x, realisation.dt_s
        n = x.size
        estimate = sum(w * x[half + k - half : n - half + k - half] for k, w in enumerate(stencil))
        error = estimate / dt - realisation.truth[1][half : n - half]
        values.append(math.sqrt(np.mean(error**2)))
    return float(np.mean(values)), (n - 2 * half) / n


def test_a_native_only_run_writes_its_tables(tmp_path):
    # runs without PyNumDiff: only native rows, PyNumDiff's best a dash
    task = PyNumDiffSuite(records=("pynumdiff-f1", "pynumdiff-f4-irregular"), tune_peers=False)
    result = api.run(task, methods=["finite_difference", "spectral"], seeds=2, out=tmp_path)
    folder = tmp_path / "pynumdiff-suite"
    names = {path.name for path in result.written}
    assert {"summary.md", "summary.csv", "entries.csv", "pynumdiff-f1.md"} <= names
    entries = pd.read_csv(folder / "entries.csv")
    assert len(entries) == 4 and (entries["seeds"] == 2).all()
    summary = pd.read_csv(folder / "summary.csv")
    assert list(summary["record"]) == ["pynumdiff-f1", "pynumdiff-f4-irregular"]
    assert summary["ratio"].isna().all()
    # finite differences on f1 against central differences computed here
    row = entries[
        (entries["record"] == "pynumdiff-f1") & (entries["method"] == "finite_difference")
    ]
    accuracy = int(row["setting"].iloc[0].split("accuracy_order=")[1].split(",")[0])
    rmse, coverage = _expected_finite_difference("pynumdiff-f1", accuracy, 2)
    # every sample estimated; the valid ones are those the ends check trusts
    assert row["coverage"].iloc[0] == 1.0
    assert row["valid"].iloc[0] == pytest.approx(coverage, abs=1e-15)
    # the stencil sums round to a few eps of max|x|/dt (7/0.1), relative to an RMSE near 0.3
    tolerance = 64 * EPS * 7 / 0.1
    valid = row["rmse_valid"].iloc[0]
    assert abs(valid - rmse) <= tolerance, (valid, rmse)
    assert bool(row["covers"].iloc[0])
    # a rerun computes nothing: every item is stored
    again = api.run(task, methods=["finite_difference", "spectral"], seeds=2, out=tmp_path)
    assert again.cells.computed == 0 and again.cells.skipped == 4


def test_pynumdiffs_methods_at_its_tests_parameters(tmp_path):
    pynumdiff = pytest.importorskip("pynumdiff")
    task = PyNumDiffSuite(records=("pynumdiff-f1", "pynumdiff-f4"), tune_peers=False)
    api.run(task, methods=["spectral", "pynumdiff.polydiff"], seeds=2, jobs=2, out=tmp_path)
    folder = tmp_path / "pynumdiff-suite"
    entries = pd.read_csv(folder / "entries.csv")
    for record in ("pynumdiff-f1", "pynumdiff-f4"):
        assert (folder / f"{record}.md").exists()
        # polydiff at PyNumDiff's test parameters, called here directly
        values = []
        for seed in range(2):
            realisation = records.get(record).realise(seed)
            _, dxdt = pynumdiff.polydiff(realisation.x, 0.1, degree=5, window_size=15)
            values.append(math.sqrt(np.mean((dxdt - realisation.truth[1]) ** 2)))
        row = entries[(entries["record"] == record) & (entries["method"] == "pynumdiff.polydiff")]
        assert row["source"].iloc[0] == TESTS and bool(row["covers"].iloc[0])
        assert row["rmse_whole"].iloc[0] == pytest.approx(np.mean(values), rel=1e-12)
    summary = pd.read_csv(folder / "summary.csv").set_index("record")
    for record in ("pynumdiff-f1", "pynumdiff-f4"):
        ours, theirs = summary.loc[record, "its RMSE"], summary.loc[record, "its RMSE "]
        assert summary.loc[record, "ratio"] == pytest.approx(ours / theirs, rel=1e-15)
    text = (folder / "summary.md").read_text()
    assert (
        "pynumdiff.polydiff" in text
        and "PyNumDiff tests" in (folder / "pynumdiff-f4.md").read_text()
    )


def test_a_method_that_leaves_samples_unestimated_is_marked_not_covering():
    rows = [
        {
            "record": "r",
            "method": "m",
            "package": "diffbench",
            "source": ORACLE,
            "params": {"a": 1},
            "time_stamps": "uniform grid",
            "tuned_on": "whole",
            "seed": s,
            "coverage": c,
            "valid": c - 0.1,
            "rmse_whole": w,
            "rmse_valid": v,
            "failure": "",
        }
        for s, c, w, v in ((0, 1.0, 2.0, 2.0), (1, 0.9, math.nan, 1.0))
    ]
    entries = study.entries_frame(rows)
    assert not entries["covers"].iloc[0] and math.isnan(entries["rmse_whole"].iloc[0])
    assert entries["rmse_valid"].iloc[0] == 1.5 and entries["coverage"].iloc[0] == 0.95
    assert entries["valid"].iloc[0] == pytest.approx(0.85, abs=1e-15)


def test_ratio_against_an_exact_peer_is_infinite():
    assert study._ratio(0.5, 0.0) == math.inf and study._ratio(0.0, 0.0) == 1.0
    assert study._ratio(0.5, 0.25) == 2.0 and math.isnan(study._ratio(math.nan, 1.0))


def test_the_oracle_setting_is_tuned_on_the_mean_loss_of_ten_seeds():
    """The tuned setting's loss is the mean, over the seeds 10000..10009 (never scored), of its
    whole-record ẋ RMSE, recomputed here from the scenario's samples and truth: on 31
    samples one seed's noise would decide the setting."""
    from diffbench import methods
    from diffbench.bench.core import tuning

    tuned = study.oracle_setting("pynumdiff-f2", "total_variation", max_evaluations=40)
    assert tuned["tuned_on"] == "whole"
    method = methods.get("total_variation", **tuned["params"])
    losses = []
    for k in range(study.TUNING_SEEDS):
        realisation = records.get("pynumdiff-f2").realise(tuning.TUNING_SEED + k)
        error = method(realisation.x, realisation.dt_s, orders=(1,))[1] - realisation.truth[1]
        losses.append(math.sqrt(np.mean(error**2)))
    assert study.TUNING_SEEDS == 10
    # the tuner rounds its losses to 1e-9 of the RMS of ẋ (tuning.comparable_loss)
    scale = float(
        np.sqrt(np.mean(records.get("pynumdiff-f2").realise(tuning.TUNING_SEED).truth[1] ** 2))
    )
    assert tuned["loss"] == pytest.approx(np.mean(losses), abs=1e-9 * scale)
    assert abs(tuned["loss"] - losses[0]) > 1e-6  # not the first seed's alone
