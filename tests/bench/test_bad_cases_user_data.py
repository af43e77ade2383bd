"""Issue 43's bad cases in reading a user's record and in `diffbench recommend`: each ends in
one line and exit code 2 (the CLI run as a real subprocess), or in a warning and a correct
result."""

import os
import subprocess
import sys
import warnings

import numpy as np
import pandas as pd
import pytest

from diffbench.bench.studies import user_data
from diffbench.bench.studies.recommend import recommend, recommend_record, write_recommendation
from diffbench.bench.studies.user_data import RecordWarning, UserRecord, read_record

FAST = ["--methods", "savitzky_golay,butterworth", "--budget", "20"]


def _cli(*argv, cwd):
    done = subprocess.run(
        [sys.executable, "-m", "diffbench.bench", "recommend", *map(str, argv)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=600,
    )
    return done.returncode, done.stdout, done.stderr


def _refused(code, err) -> str:
    """The one line of a usage error."""
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("diffbench: error: "), err
    return err


def _csv(path, t, **columns):
    pd.DataFrame({"t": t, **columns}).to_csv(path, index=False, float_format="%.17g")
    return path


def _sine(t, seed=0):
    noise = 0.01 * np.random.default_rng(seed).standard_normal(t.size)
    return np.sin(2 * np.pi * 3 * t) + noise


def test_a_1000_s_gap_in_the_time_stamps_is_refused_with_where_and_the_fix(tmp_path):
    """Stamps 1 ms apart with one 1000 s pause after row 101 (the header is row 1): refused,
    naming the rows, the gap, its ratio to the median step and the split."""
    t = np.arange(200) * 1e-3
    t[100:] += 1000.0
    path = _csv(tmp_path / "gap.csv", t, x=_sine(t))
    err = _refused(*_cli(path, "--time", "t", *FAST, cwd=tmp_path)[::2])
    assert "column 't' has a gap over 10 median steps, the longest 1000 s between row 101" in err
    assert "median step 0.001 s" in err and "split the file at each such gap" in err


def test_a_short_gap_is_resampled_across_with_a_warning_in_the_report(tmp_path):
    """A gap of 5 median steps (4 samples lost) is accepted: warned about in one line on
    stderr (a RecordWarning, shown as ``diffbench: warning: ...``) and at the head of
    ranking.md."""
    t = np.delete(np.arange(300) * 2e-3, [150, 151, 152, 153])
    path = _csv(tmp_path / "lost.csv", t, x=_sine(t))
    out = tmp_path / "advice"
    code, _, err = _cli(path, "--time", "t", "--orders", "1", *FAST, "--out", out, cwd=tmp_path)
    assert code == 0, err
    warning = [line for line in err.splitlines() if "has a gap over 3 median steps" in line]
    assert len(warning) == 1 and warning[0].startswith("diffbench: warning: ")
    assert "lost.csv: column 't' has" in warning[0]
    assert "the longest 0.01 s" in warning[0] and "RecordWarning" not in err
    assert "**Warning:**" in (out / "ranking.md").read_text()
    with pytest.warns(RecordWarning):
        record = read_record(path, time_column="t")
    assert len(record.notes) == 1 and "5 times the median step 0.002 s" in record.notes[0]


def test_a_dt_that_contradicts_the_time_stamps_is_refused_with_both(tmp_path):
    t = np.arange(100) * 1e-3
    path = _csv(tmp_path / "ms.csv", t, x=_sine(t))
    err = _refused(*_cli(path, "--time", "t", "--dt", "1", *FAST, cwd=tmp_path)[::2])
    assert "the step `dt` (--dt) 1.0 s contradicts column 't', whose median step is 0.001 s" in err
    # evenly stamped, their step is the record's: 10 % off would scale every derivative by
    # 1/1.1 (the battery's case: accepted, ẋ RMSE 15.0 against 9.8)
    err = _refused(*_cli(path, "--time", "t", "--dt", "0.0011", *FAST, cwd=tmp_path)[::2])
    assert "--dt) 0.0011 s contradicts column 't', whose stamps are evenly 0.001 s apart" in err
    assert "leave `dt` out" in err
    assert read_record(path, time_column="t", dt=1e-3).dt_s == 1e-3
    # jittered stamps: within 25 % of their median step it is the logger's nominal step
    jittered = t + np.r_[0.0, np.random.default_rng(3).uniform(-2e-4, 2e-4, t.size - 2), 0.0]
    uneven = _csv(tmp_path / "jitter.csv", jittered, x=_sine(jittered))
    assert read_record(uneven, time_column="t", dt=1.2e-3).dt_s == 1.2e-3


def test_scaled_records_get_the_same_recommendation_errors_scaled():
    """x·1e-300 and x·1e300 (and x·3): the same methods and settings as x, the predicted
    errors and noise c times x's. The record is divided by its half range first, so the
    scaled records differ from x's by rounding (an ulp) only; through the nonlinear fit of
    the record's lines (stopped at 1e-12 relative, scipy's xtol) the errors move by 1.2e-11
    relative at most (measured): 1e-9 is allowed."""
    dt = 0.002
    t = np.arange(400) * dt
    x = np.exp(-0.4 * t) * np.sin(2 * np.pi * 3 * t + 0.7) + 0.01 * np.random.default_rng(
        1
    ).standard_normal(t.size)
    names = ["savitzky_golay", "butterworth"]
    base = recommend(x, dt, names, (1, 2), max_evaluations=30)
    assert 0.008 < base.noise_std < 0.012  # the noise read off: 0.01
    for factor in (1e-300, 1e300, 3.0):
        scaled = recommend(x * factor, dt, names, (1, 2), max_evaluations=30)
        assert list(scaled.table["method"]) == list(base.table["method"])
        assert list(scaled.table["params"]) == list(base.table["params"])
        np.testing.assert_allclose(
            scaled.table["predicted_rmse"] / factor, base.table["predicted_rmse"], rtol=1e-9
        )
        assert scaled.noise_std / factor == pytest.approx(base.noise_std, rel=1e-9)
        assert np.all(scaled.table["predicted_rmse"] > 0)


def test_a_record_times_1e300_through_the_cli_gets_x_s_choice(tmp_path):
    t = np.arange(300) * 2e-3
    x = _sine(t)
    lines = []
    for name, values in (("unit", x), ("huge", x * 1e300)):  # 1e-300: the API test
        path = _csv(tmp_path / f"{name}.csv", t, x=values)
        code, out, err = _cli(path, "--time", "t", *FAST, "--out", tmp_path / name, cwd=tmp_path)
        assert code == 0, err
        lines.append([line for line in out.splitlines() if line.startswith("x ")])
        derivatives = pd.read_csv(tmp_path / name / "derivatives.csv")
        assert np.isfinite(derivatives["x_d2"][derivatives["x_d2_valid"] == 1]).all()
    assert lines[0] == lines[1] and len(lines[0]) == 2


def test_a_nan_cell_is_said_to_be_nan_with_its_row_and_column(tmp_path):
    rows = ["t,x"] + [f"{i * 0.01},{'nan' if i == 5 else i}" for i in range(30)]
    path = tmp_path / "nan.csv"
    path.write_text("\n".join(rows) + "\n")
    err = _refused(*_cli(path, "--time", "t", *FAST, cwd=tmp_path)[::2])
    assert "nan.csv: column 'x' row 7 is NaN ('nan'), not a number" in err
    pytest.importorskip("pyarrow")
    import pyarrow as pa
    import pyarrow.parquet as pq

    x = np.arange(30.0)
    x[4] = np.nan  # a NaN, not a null: pyarrow keeps it from a numpy array
    pq.write_table(pa.table({"t": np.arange(30) * 0.01, "x": x}), tmp_path / "nan.parquet")
    with pytest.raises(ValueError, match=r"column 'x' row 6 is NaN, not a number"):
        read_record(tmp_path / "nan.parquet", time_column="t")
    nulls = pa.array([None if i == 4 else float(i) for i in range(30)])
    pq.write_table(pa.table({"t": np.arange(30) * 0.01, "x": nulls}), tmp_path / "null.parquet")
    with pytest.raises(ValueError, match=r"column 'x' row 6 is empty \(null\)"):
        read_record(tmp_path / "null.parquet", time_column="t")


def test_the_time_column_as_a_channel_is_refused(tmp_path):
    t = np.arange(40) * 0.01
    path = _csv(tmp_path / "same.csv", t, x=_sine(t))
    err = _refused(*_cli(path, "--time", "t", "--column", "t", *FAST, cwd=tmp_path)[::2])
    assert "column 't' is both the time (--time) and a channel (--column)" in err


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_directory_a_fifo_and_a_symlink_loop_are_named_for_what_they_are(tmp_path):
    (tmp_path / "folder.csv").mkdir()
    os.mkfifo(tmp_path / "pipe.csv")
    (tmp_path / "a.csv").symlink_to(tmp_path / "b.csv")
    (tmp_path / "b.csv").symlink_to(tmp_path / "a.csv")
    for name, message in [
        ("folder.csv", "folder.csv: a directory, not a file"),
        ("pipe.csv", "pipe.csv: a named pipe (FIFO), not a regular file"),
        ("a.csv", "a.csv: a loop of symbolic links"),
        ("nowhere.csv", "nowhere.csv: no such file"),
    ]:
        err = _refused(*_cli(tmp_path / name, "--dt", "0.01", cwd=tmp_path)[::2])
        assert message in err


def test_only_the_needed_columns_are_read_and_a_long_record_is_warned_about(tmp_path, monkeypatch):
    """A text column that is not asked for is never parsed (pandas ``usecols``, float64), so
    it cannot fail the read; over ``LONG_RECORD`` samples a RecordWarning says what it costs.
    (Measured on 1e7 rows of t, x, y, a 337 MB CSV: 488 MB process peak, 168 MB of it the
    imports, against 887 MB reading the whole table.)"""
    t = np.arange(50) * 0.01
    path = _csv(tmp_path / "mixed.csv", t, x=_sine(t), note=["text"] * 50)
    record = read_record(path, ["x"], "t")
    assert record.x.dtype == np.float64 and record.x.shape == (50, 1)
    monkeypatch.setattr(user_data, "LONG_RECORD", 40)
    with pytest.warns(RecordWarning, match=r"50 samples; recommend tunes every method"):
        read_record(path, ["x"], "t")


def test_the_derivatives_file_flags_the_samples_its_prediction_is_for(tmp_path):
    """A damped sine of 2501 samples at 500 Hz with white noise of std 0.01, its derivatives
    exact. Spectral differentiation wins and marks every sample valid, but its ends are far
    worse than its middle: derivatives.csv writes them and flags them 0; on the samples it
    flags 1 the true RMSE is within 2 spreads (the standard deviation over the 16 scoring
    surrogates) of the predicted RMSE (measured: 1.35 spreads for ẋ, 1.43 for ẍ, both below
    it: this record's noise is kind to it) and inside the predicted 90 % interval (measured
    0.0120 in 0.0114..0.0191 for ẋ, 0.152 in 0.141..0.310 for ẍ), and the ends it flags 0 are
    at least 3 times worse (measured: 4.0 times for ẋ, 10 for ẍ)."""
    dt, n = 0.002, 2501
    t = np.arange(n) * dt
    z = -0.4 + 2j * np.pi * 1.5
    c = np.exp(z * t + 0.7j)
    truth = {1: np.imag(z * c), 2: np.imag(z**2 * c)}
    x = np.imag(c) + 0.01 * np.random.default_rng(1).standard_normal(n)
    record = UserRecord(x[:, np.newaxis], ("x",), dt, None, True, "damped")
    results = recommend_record(record, ["spectral", "savitzky_golay"], (1, 2), max_evaluations=60)
    advice, _ = results["x"]
    out = write_recommendation(record, results, tmp_path)[2]
    written = pd.read_csv(out)
    for order in (1, 2):
        name, _ = advice.best(order)
        assert name == "spectral"
        row = advice.table[(advice.table["order"] == order) & (advice.table["rank"] == 1)]
        predicted, spread = float(row["predicted_rmse"].iloc[0]), float(row["spread"].iloc[0])
        flagged = written[f"x_d{order}_valid"].to_numpy() == 1
        estimate = written[f"x_d{order}"].to_numpy()
        assert flagged.sum() == n - 2 * 125  # all but 5 % at either end
        assert np.isfinite(estimate).all()  # every sample estimated, the ends flagged 0
        error = estimate - truth[order]
        true_rmse = np.sqrt(np.mean(error[flagged] ** 2))
        assert abs(true_rmse - predicted) <= 2 * spread
        low, high = float(row["low"].iloc[0]), float(row["high"].iloc[0])
        assert low <= true_rmse <= high
        ends = np.sqrt(np.mean(error[~flagged] ** 2))
        assert ends > 3 * true_rmse  # why they are flagged


def test_a_time_column_read_as_a_channel_is_warned_about(tmp_path):
    """No --time and no --column: every column is a channel, the time one too. The battery's
    case: a 1 ms record with a 1000 s pause, its t ranked as data with no note."""
    t = np.arange(200) * 1e-3
    t[100:] += 1000.0
    path = _csv(tmp_path / "gap.csv", t, x=_sine(t))
    with pytest.warns(RecordWarning, match=r"column 't' increases at every row, like time"):
        record = read_record(path, dt=1e-3)
    assert record.x.shape == (200, 2) and "--time t" in record.notes[0]
    # an evenly rising column of another name too; channels chosen with --column: no note
    renamed = pd.DataFrame({"clock": np.arange(200) * 0.5, "x": _sine(t)})
    renamed.to_csv(tmp_path / "clock.csv", index=False)
    with pytest.warns(RecordWarning, match=r"column 'clock' increases at every row"):
        read_record(tmp_path / "clock.csv", dt=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RecordWarning)
        assert read_record(path, ["x"], dt=1e-3).notes == ()
