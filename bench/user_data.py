"""A user's own record: read from CSV or Parquet, checked once, with errors that say the fix.

Every refusal is a ``ValueError`` of one line naming the file, the column and the row where it
applies (the CLI prints it and exits with 2).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench.methods import check_dt, check_signal, is_uniform, mean_step

MIN_SAMPLES = 16
"""Fewest samples a record may have: below, no method here estimates a derivative with an
error worth reporting (and no noise level can be told from the signal)."""

FORMATS = {".csv": "CSV", ".parquet": "Parquet", ".pq": "Parquet"}


@dataclass(frozen=True)
class UserRecord:
    """A checked record: ``x`` (samples × channels, time on axis 0), and either its time stamps
    ``t`` (seconds, strictly increasing) or only its step ``dt_s``; ``dt_s`` is also the nominal
    step when ``t`` is given (the mean step when not stated), ``uniform`` whether ``t`` is."""

    x: np.ndarray
    channels: tuple[str, ...]
    dt_s: float
    t: np.ndarray | None
    uniform: bool
    source: str


def read_record(
    path: str | Path,
    columns: list[str] | None = None,
    time_column: str | None = None,
    dt: float | None = None,
) -> UserRecord:
    """Read ``columns`` (default: every column but ``time_column``) of the CSV or Parquet file
    ``path`` as channels, timed by ``time_column`` (seconds) or by the step ``dt`` (seconds).

    Both may be given: the time stamps are then the truth and ``dt`` the nominal step (a logger
    at 1 kHz with jitter or lost samples). Raises ``ValueError`` (one line, naming the file,
    column and row) for a missing file or column, text or empty cells among the numbers, time
    stamps that do not increase strictly, fewer than :data:`MIN_SAMPLES` samples, or no time
    at all.
    """
    path = Path(path)
    table = _read_table(path)
    if time_column is None and dt is None:
        raise ValueError(f"{path}: give the time column (--time NAME) or the step (--dt SECONDS)")
    available = [str(name) for name in table.columns]
    if time_column is not None and time_column not in available:
        raise ValueError(
            f"{path}: no time column {time_column!r}; the columns are {', '.join(available)}"
        )
    if columns is None:
        columns = [name for name in available if name != time_column]
        if not columns:
            raise ValueError(f"{path}: no column to differentiate besides the time column")
    missing = [name for name in columns if name not in available]
    if missing:
        raise ValueError(
            f"{path}: no column {missing[0]!r}; the columns are {', '.join(available)}"
        )
    if len(table) < MIN_SAMPLES:
        raise ValueError(
            f"{path}: {len(table)} samples; at least {MIN_SAMPLES} are needed to estimate a "
            "derivative and its error"
        )
    x = np.column_stack([_numbers(table[name], name, path) for name in columns])
    nominal = None if dt is None else check_dt(dt)
    if time_column is None:
        x, nominal = check_signal(x, nominal, min_samples=MIN_SAMPLES)
        return UserRecord(x, tuple(columns), nominal, None, True, str(path))
    times = _numbers(table[time_column], time_column, path)
    steps = np.diff(times)
    if np.any(steps <= 0):
        index = int(np.argmax(steps <= 0)) + 1  # the first time not after its predecessor
        what = "repeats" if steps[index - 1] == 0 else "goes back from"
        raise ValueError(
            f"{path}: column {time_column!r} must increase strictly; row {index + 2} "
            f"({float(times[index])!r}) {what} the row before ({float(times[index - 1])!r}); "
            "sort the rows and drop duplicates"
        )
    step = mean_step(times) if nominal is None else nominal
    x, _ = check_signal(x, step, min_samples=MIN_SAMPLES)
    return UserRecord(x, tuple(columns), step, times, is_uniform(times), str(path))


def _read_table(path: Path) -> pd.DataFrame:
    kind = _format_of(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    if kind == "CSV":
        try:
            return pd.read_csv(path, skipinitialspace=True)
        except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as error:
            reason = str(error).strip().splitlines()[0] if str(error).strip() else "empty"
            raise ValueError(f"{path}: not a readable CSV table ({reason})") from None
    try:
        return pd.read_parquet(path)
    except ImportError:
        raise ValueError(
            f"{path}: reading Parquet needs pyarrow: pip install 'diffbench[data]'"
        ) from None


def _numbers(column: pd.Series, name: str, path: Path) -> np.ndarray:
    """The column as float64; the first cell that is text or empty is named with its row
    (rows counted as a spreadsheet shows them: the header is row 1)."""
    values = pd.to_numeric(column, errors="coerce").to_numpy(dtype=np.float64)
    bad = ~np.isfinite(values)
    if bad.any():
        index = int(np.argmax(bad))
        cell = column.iloc[index]
        what = "is empty" if pd.isna(cell) else f"holds {cell!r}, not a finite number"
        raise ValueError(f"{path}: column {name!r} row {index + 2} {what}")
    return values


def write_scenario_record(realisation, path: str | Path) -> Path:
    """Write a scenario's realisation as a user's file (CSV or Parquet by ``path``'s suffix):
    columns ``t`` (its time stamps, s), ``x`` (the noisy samples) and the truth beside,
    ``x_true``, ``dx_true``, ``ddx_true``, for scoring what is done with ``x`` afterwards.
    CSV numbers are written with 17 significant digits (they read back exactly)."""
    path = Path(path)
    kind = _format_of(path)
    x = np.asarray(realisation.x)
    if x.ndim != 1:
        raise ValueError(f"{path}: only one-channel scenarios are written, got shape {x.shape}")
    frame = pd.DataFrame({
        "t": realisation.t, "x": x, "x_true": realisation.truth[0],
        "dx_true": realisation.truth[1], "ddx_true": realisation.truth[2],
    })  # fmt: skip
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind == "CSV":
        frame.to_csv(path, index=False, float_format="%.17g")
    else:
        frame.to_parquet(path, index=False)
    return path


def _format_of(path: Path) -> str:
    """``"CSV"`` or ``"Parquet"`` by the file's suffix; any other is refused."""
    kind = FORMATS.get(path.suffix.lower())
    if kind is None:
        raise ValueError(f"{path}: unknown format {path.suffix!r}; give a .csv or .parquet file")
    return kind
