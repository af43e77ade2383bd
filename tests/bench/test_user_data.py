"""Reading a user's record: the good files come back exactly, each bad one is refused in one
line that names the file, the column and the row."""

import numpy as np
import pandas as pd
import pytest

from diffbench.bench.studies.user_data import MIN_SAMPLES, read_record


def _jittered_times(n: int, step: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.arange(n) * step + rng.uniform(-0.3, 0.3, n) * step


@pytest.fixture
def good_table():
    t = _jittered_times(200, 0.002)
    return pd.DataFrame({"time_s": t, "q1": np.sin(3 * t), "q2": np.cos(2 * t) + 0.5})


def test_a_csv_with_time_stamps_comes_back_exactly(tmp_path, good_table):
    path = tmp_path / "robot.csv"
    good_table.to_csv(path, index=False, float_format="%.17g")
    record = read_record(path, time_column="time_s")
    assert record.channels == ("q1", "q2")
    np.testing.assert_array_equal(record.x, good_table[["q1", "q2"]].to_numpy())
    np.testing.assert_array_equal(record.t, good_table["time_s"].to_numpy())
    assert not record.uniform
    assert record.dt_s == pytest.approx(np.diff(good_table["time_s"]).mean(), rel=1e-12)
    nominal = read_record(path, columns=["q2"], time_column="time_s", dt=0.002)
    assert nominal.dt_s == 0.002 and nominal.channels == ("q2",) and nominal.x.shape == (200, 1)


def test_a_csv_with_only_a_step_and_a_parquet_file(tmp_path, good_table):
    path = tmp_path / "log.csv"
    good_table[["q1"]].to_csv(path, index=False, float_format="%.17g")
    record = read_record(path, dt=0.002)
    assert record.t is None and record.uniform and record.dt_s == 0.002
    np.testing.assert_array_equal(record.x[:, 0], good_table["q1"].to_numpy())
    pytest.importorskip("pyarrow")
    parquet = tmp_path / "log.parquet"
    good_table.to_parquet(parquet)
    record = read_record(parquet, time_column="time_s")
    np.testing.assert_array_equal(record.x, good_table[["q1", "q2"]].to_numpy())


def _write(tmp_path, text: str, name: str = "data.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _table(rows: int, time=None, value=None) -> str:
    lines = ["t,x"]
    for i in range(rows):
        lines.append(f"{time(i) if time else i * 0.01},{value(i) if value else float(i) ** 2}")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize(
    ("text", "kwargs", "message"),
    [
        (_table(40), {"columns": ["q"], "time_column": "t"}, r"no column 'q'; the columns are"),
        (_table(40), {"time_column": "time"}, r"no time column 'time'; the columns are t, x"),
        (
            _table(40, value=lambda i: "abc" if i == 7 else i),
            {"time_column": "t"},
            r"column 'x' row 9 holds 'abc', not a finite number",
        ),
        (
            _table(40, value=lambda i: "" if i == 3 else i),
            {"time_column": "t"},
            r"column 'x' row 5 is empty",
        ),
        (
            _table(40, time=lambda i: 0.01 * (i if i != 10 else 8.5)),
            {"time_column": "t"},
            r"column 't' must increase strictly; row 12 \(0\.085\) goes back from the row "
            r"before \(0\.09\)",
        ),
        (
            _table(40, time=lambda i: 0.01 * (i if i != 10 else 9)),
            {"time_column": "t"},
            r"row 12 \(0\.09\) repeats the row before",
        ),
        (_table(MIN_SAMPLES - 1), {"time_column": "t"}, r"15 samples; at least 16 are needed"),
        (_table(40), {}, r"give the time column \(--time NAME\) or the step \(--dt SECONDS\)"),
        (_table(40), {"dt": -0.01}, r"`dt` must be"),
        ("", {"dt": 0.01}, r"not a readable CSV table"),
    ],
    ids=[
        "missing-column",
        "missing-time-column",
        "text-in-numbers",
        "empty-cell",
        "unsorted-times",
        "duplicate-times",
        "too-few-samples",
        "no-time",
        "negative-step",
        "empty-file",
    ],
)
def test_bad_files_are_refused_in_one_line_naming_the_place(tmp_path, text, kwargs, message):
    path = _write(tmp_path, text)
    with pytest.raises(ValueError, match=message) as refused:
        read_record(path, **kwargs)
    assert "\n" not in str(refused.value)
    if "dt" not in kwargs:
        assert str(refused.value).startswith(str(path))


def test_unknown_formats_and_missing_files_are_refused(tmp_path):
    with pytest.raises(ValueError, match=r"unknown format '\.txt'; give a \.csv or \.parquet"):
        read_record(_write(tmp_path, _table(40), "data.txt"), time_column="t")
    with pytest.raises(ValueError, match=r"nowhere\.csv: no such file"):
        read_record(tmp_path / "nowhere.csv", time_column="t")
