"""A user's own record: read from CSV or Parquet, checked once, with errors that say the fix.

Every refusal is a ``ValueError`` of one line naming the file, the column and the row where it
applies (the CLI prints it and exits with 2). What is accepted but deserves a word (gaps in the
time stamps short enough to resample across, a long record) is a :class:`RecordWarning` and is
kept in :attr:`UserRecord.notes`, so that the report written from the record says it too.

Only the columns asked for are read, as float64 (a CSV through pandas' C parser with
``usecols``, a Parquet file by its columns): memory is about 8 bytes per number kept plus the
parser's buffers, not the whole table as text.
"""

from __future__ import annotations

import errno
import os
import stat
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from diffbench.methods import (
    UNIFORM_TOLERANCE,
    check_dt,
    check_signal,
    did_you_mean,
    is_uniform,
    mean_step,
)

MIN_SAMPLES = 16
"""Fewest samples a record may have: below, no method here estimates a derivative with an
error worth reporting (and no noise level can be told from the signal)."""

FORMATS = {".csv": "CSV", ".parquet": "Parquet", ".pq": "Parquet"}

GAP_STEPS = 3.0
"""A step of the time stamps more than this many times their median step is a *gap*: the
record is resampled across it by a cubic spline (what a resampled method does), which invents
the samples in it; a :class:`RecordWarning` says so."""

MAX_GAP_STEPS = 10.0
"""A gap longer than this many median steps is refused: the spline across it is a guess, not
an interpolation (a 1000 s pause in a 1 ms record), and the surrogates the error is predicted
on have no such gap. The fix is to split the record there."""

DT_TOLERANCE = 0.25
"""A nominal step ``dt`` given with uneven time stamps must lie within this fraction of their
median step (a logger's jitter, its lost samples or a slow clock move the median by far less; a step
in other units than the stamps' by far more)."""

TIME_NAMES = frozenset({"t", "t_s", "time", "time_s", "times", "timestamp", "seconds", "sec"})
"""Column names (any case; also any name starting with ``time``) that a channel rising at every
row is warned about as a likely time column (:func:`_time_like_channels`)."""

LONG_RECORD = 1_000_000
"""Records of more samples than this are read, and warned about: ``recommend`` tunes every
method on six surrogates of the record's length, so its time and memory grow in proportion."""


class RecordWarning(UserWarning):
    """Something in a user's record that is accepted but changes what its results mean."""


@dataclass(frozen=True)
class UserRecord:
    """A checked record: ``x`` (samples × channels, time on axis 0), and either its time stamps
    ``t`` (seconds, strictly increasing) or only its step ``dt_s``; ``dt_s`` is also the nominal
    step when ``t`` is given (the mean step when not stated), ``uniform`` whether ``t`` is;
    ``notes``: the :class:`RecordWarning` messages reading it gave."""

    x: np.ndarray
    channels: tuple[str, ...]
    dt_s: float
    t: np.ndarray | None
    uniform: bool
    source: str
    notes: tuple[str, ...] = ()


def read_record(
    path: str | Path,
    columns: list[str] | None = None,
    time_column: str | None = None,
    dt: float | None = None,
) -> UserRecord:
    """Read ``columns`` (default: every column but ``time_column``) of the CSV or Parquet file
    ``path`` as channels, timed by ``time_column`` (seconds) or by the step ``dt`` (seconds).

    Both may be given: the time stamps are then the truth and ``dt`` the nominal step (a logger
    at 1 kHz with jitter or lost samples); it must agree with their median step within
    :data:`DT_TOLERANCE`, and with their step to ``UNIFORM_TOLERANCE`` when they are evenly
    spaced (then the record's step, which any other would scale every derivative by). Raises
    ``ValueError`` (one line, naming the file, column and row) for a path that is not a readable
    regular file (missing, a directory, a FIFO, a symlink loop), a missing column, the time
    column among the channels, text, empty or NaN cells among the numbers, time stamps that do
    not increase strictly or have a gap over :data:`MAX_GAP_STEPS` median steps, a ``dt`` that
    contradicts them, fewer than :data:`MIN_SAMPLES` samples, or no time at all. Warns
    (:class:`RecordWarning`) about gaps over :data:`GAP_STEPS` median steps and records over
    :data:`LONG_RECORD` samples.
    """
    path = Path(path)
    _check_file(path)
    kind = _format_of(path)
    if time_column is None and dt is None:
        raise ValueError(f"{path}: give the time column (--time NAME) or the step (--dt SECONDS)")
    available = _column_names(path, kind)
    if time_column is not None and time_column not in available:
        raise ValueError(
            f"{path}: no time column {time_column!r}; " + _columns_hint(time_column, available)
        )
    if columns is None:
        columns = [name for name in available if name != time_column]
        if not columns:
            raise ValueError(f"{path}: no column to differentiate besides the time column")
    columns = list(columns)
    missing = [name for name in columns if name not in available]
    if missing:
        raise ValueError(
            f"{path}: no column {missing[0]!r}; " + _columns_hint(missing[0], available)
        )
    if time_column is not None and time_column in columns:
        raise ValueError(
            f"{path}: column {time_column!r} is both the time (--time) and a channel "
            "(--column); give the channels without the time column"
        )
    repeated = sorted({name for name in columns if columns.count(name) > 1})
    if repeated:
        raise ValueError(f"{path}: column {repeated[0]!r} is named twice among the channels")
    wanted = columns if time_column is None else [*columns, time_column]
    table = _read_columns(path, kind, wanted)
    samples = len(table[wanted[0]])
    if samples < MIN_SAMPLES:
        raise ValueError(
            f"{path}: {samples} samples; at least {MIN_SAMPLES} are needed to estimate a "
            "derivative and its error"
        )
    notes = []
    if samples > LONG_RECORD:
        notes.append(
            f"{path}: {samples} samples; recommend tunes every method on surrogates of this "
            f"length, its time and memory growing in proportion: above {LONG_RECORD:.0e} "
            "samples, try it on a representative stretch first"
        )
    if len(columns) == 1:  # a view: no copy of a long record
        x = _numbers(table, columns[0], path, kind)[:, np.newaxis]
    else:
        x = np.column_stack([_numbers(table, name, path, kind) for name in columns])
    nominal = None if dt is None else check_dt(dt)
    if time_column is None:
        x, nominal = check_signal(x, nominal, min_samples=MIN_SAMPLES)
        notes.extend(_time_like_channels(path, columns, x))
        return _warned(UserRecord(x, tuple(columns), nominal, None, True, str(path), tuple(notes)))
    times = _numbers(table, time_column, path, kind)
    del table
    steps = np.diff(times)
    if np.any(steps <= 0):
        index = int(np.argmax(steps <= 0)) + 1  # the first time not after its predecessor
        what = "repeats" if steps[index - 1] == 0 else "goes back from"
        raise ValueError(
            f"{path}: column {time_column!r} must increase strictly; row {index + 2} "
            f"({float(times[index])!r}) {what} the row before ({float(times[index - 1])!r}); "
            "sort the rows and drop duplicates"
        )
    median = float(np.median(steps.copy(), overwrite_input=True))  # one copy, partitioned
    gap_note = _check_gaps(path, time_column, times, steps, median)
    del steps
    if gap_note:
        notes.append(gap_note)
    uniform = is_uniform(times)
    if nominal is not None:
        if abs(nominal - median) > DT_TOLERANCE * median:
            raise ValueError(
                f"{path}: the step `dt` (--dt) {nominal!r} s contradicts column "
                f"{time_column!r}, whose median step is {median:.6g} s "
                f"({_times(nominal, median)}); give the step of the time stamps in seconds, "
                "or leave `dt` out (the stamps give it)"
            )
        stamped = mean_step(times)
        if uniform and abs(nominal - stamped) > UNIFORM_TOLERANCE * stamped:
            # evenly stamped: their step is the record's, and any other one scales every
            # derivative (a slow clock would not leave them even)
            raise ValueError(
                f"{path}: the step `dt` (--dt) {nominal!r} s contradicts column "
                f"{time_column!r}, whose stamps are evenly {stamped:.9g} s apart "
                f"({_times(nominal, stamped)}); leave `dt` out (the stamps give it) or give "
                "their step"
            )
        step = nominal
    else:
        step = mean_step(times)
    x, _ = check_signal(x, step, min_samples=MIN_SAMPLES)
    return _warned(UserRecord(x, tuple(columns), step, times, uniform, str(path), tuple(notes)))


def _times(value: float, reference: float) -> str:
    ratio = value / reference
    return f"{ratio:.3g} times it" if ratio >= 1 else f"1/{1 / ratio:.3g} of it"


def _check_gaps(path, name, times, steps, median) -> str:
    """Refuse a gap over ``MAX_GAP_STEPS`` median steps; the note on gaps over ``GAP_STEPS``
    (empty when there is none)."""
    gaps = np.flatnonzero(steps > GAP_STEPS * median)
    if gaps.size == 0:
        return ""
    largest = int(gaps[np.argmax(steps[gaps])])
    where = (
        f"{float(steps[largest]):.6g} s between row {largest + 2} ({float(times[largest])!r}) "
        f"and row {largest + 3} ({float(times[largest + 1])!r}), "
        f"{steps[largest] / median:.3g} times the median step {median:.6g} s"
    )
    too_long = np.flatnonzero(steps > MAX_GAP_STEPS * median)
    if too_long.size:
        count = f"{too_long.size} gaps" if too_long.size > 1 else "a gap"
        raise ValueError(
            f"{path}: column {name!r} has {count} over {MAX_GAP_STEPS:g} median steps, the "
            f"longest {where}; no spline bridges that: split the file at each such gap "
            f"(the longest after row {largest + 2}) and give each part alone"
        )
    count = f"{gaps.size} gaps" if gaps.size > 1 else "a gap"
    return (
        f"{path}: column {name!r} has {count} over {GAP_STEPS:g} median steps, the longest "
        f"{where}; the record is resampled across them by a cubic spline: the predicted "
        "errors are for evenly sampled data, and near the gaps the error is larger"
    )


def _time_like_channels(path: Path, columns: list[str], x: np.ndarray) -> list[str]:
    """Notes on channels that rise at every row and are named like time (:data:`TIME_NAMES`)
    or rise by even steps (:func:`~diffbench.methods.is_uniform`), as time stamps do: without
    ``--time`` a time column is differentiated as data (its derivative the constant 1/step,
    ranked beside the real channels) and the other channels are taken as evenly spaced, gaps
    or not."""
    notes = []
    for k, name in enumerate(columns):
        if not np.all(np.diff(x[:, k]) > 0):
            continue
        named = name.casefold() in TIME_NAMES or name.casefold().startswith("time")
        if named or is_uniform(x[:, k]):
            notes.append(
                f"{path}: column {name!r} increases at every row, like time stamps, and is "
                f"differentiated as a channel, the others taken as evenly spaced; if it is "
                f"the time, give it as --time {name} (and the channels with --column)"
            )
    return notes


def _warned(record: UserRecord) -> UserRecord:
    for note in record.notes:
        warnings.warn(note, RecordWarning, stacklevel=3)
    return record


def _columns_hint(name: str, available: list[str]) -> str:
    """The close column names (:func:`~diffbench.methods.did_you_mean`), then every one."""
    close = did_you_mean(name, available)
    return (f"{close} " if close else "") + f"the columns are {', '.join(available)}"


def _check_file(path: Path) -> None:
    """Refuse a path that is not a regular file one can read, saying what it is instead."""
    try:
        status = path.stat()  # follows symlinks
    except OSError as error:
        if error.errno == errno.ENOENT and path.is_symlink():
            raise ValueError(
                f"{path}: a symbolic link to {os.readlink(path)}, which does not exist"
            ) from None
        if error.errno == errno.ENOENT:
            raise ValueError(f"{path}: no such file") from None
        if error.errno == errno.ELOOP:
            raise ValueError(
                f"{path}: a loop of symbolic links (it never reaches a file); point it at the "
                "data file"
            ) from None
        raise ValueError(f"{path}: cannot be read ({error.strerror})") from None
    if stat.S_ISDIR(status.st_mode):
        raise ValueError(f"{path}: a directory, not a file; give the .csv or .parquet file in it")
    if stat.S_ISFIFO(status.st_mode):
        raise ValueError(
            f"{path}: a named pipe (FIFO), not a regular file; the record is read more than "
            "once (its header, then its columns): save it to a file first"
        )
    if not stat.S_ISREG(status.st_mode):
        raise ValueError(f"{path}: not a regular file (a device or a socket); give a data file")
    if not os.access(path, os.R_OK):
        raise ValueError(f"{path}: cannot be read (permission denied)")


def _column_names(path: Path, kind: str) -> list[str]:
    if kind == "CSV":
        header = _csv(path, nrows=0)
        return [str(name) for name in header.columns]
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise ValueError(
            f"{path}: reading Parquet needs pyarrow: pip install 'diffbench[data]'"
        ) from None
    try:
        schema = pq.read_schema(path)
    except Exception as error:  # pyarrow's ArrowInvalid and kin: not a Parquet file
        raise ValueError(f"{path}: not a readable Parquet file ({_first_line(error)})") from None
    return [str(name) for name in schema.names]


def _read_columns(path: Path, kind: str, names: list[str]) -> dict[str, object]:
    """The columns ``names``: float64 arrays where every cell is a number (NaN for an empty
    one), or the column as pandas read it where some cell is text (for :func:`_numbers` to
    name it)."""
    if kind == "Parquet":
        frame = pd.read_parquet(path, columns=names)
        return {name: frame[name] for name in names}
    try:
        frame = _csv(path, usecols=names, dtype=dict.fromkeys(names, np.float64))
    except ValueError:  # some cell is text: read again without the dtype, to name it
        frame = _csv(path, usecols=names)
    return {name: frame[name] for name in names}


def _csv(path: Path, **options) -> pd.DataFrame:
    try:
        return pd.read_csv(path, skipinitialspace=True, **options)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as error:
        reason = _first_line(error) or "empty"
        raise ValueError(f"{path}: not a readable CSV table ({reason})") from None


def _first_line(error: Exception) -> str:
    text = str(error).strip()
    return text.splitlines()[0] if text else ""


def _numbers(table: dict, name: str, path: Path, kind: str) -> np.ndarray:
    """The column as float64; the first cell that is text, empty or NaN (or ±inf) is named
    with its row (rows counted as a spreadsheet shows them: the header is row 1)."""
    column = table[name]
    if column.dtype == np.float64:
        values = column.to_numpy()
    else:
        values = pd.to_numeric(column, errors="coerce").to_numpy(dtype=np.float64)
    bad = ~np.isfinite(values)
    if bad.any():
        index = int(np.argmax(bad))
        raise ValueError(
            f"{path}: column {name!r} row {index + 2} {_cell(path, kind, name, index)}"
        )
    return values


def _cell(path: Path, kind: str, name: str, index: int) -> str:
    """What is wrong with the cell at ``index`` of column ``name``, read as written."""
    if kind == "CSV":
        text = _csv(
            path,
            usecols=[name],
            dtype=str,
            keep_default_na=False,
            skiprows=range(1, index + 1),
            nrows=1,
        )[name].iloc[0]
        text = str(text).strip()
        if text == "":
            return "is empty"
        if text.lower() in {"nan", "-nan", "+nan"}:
            return f"is NaN ({text!r}), not a number"
        if text.lower() in {"na", "n/a", "null", "none", "<na>", "#n/a"}:
            return f"is empty ({text!r})"
        return f"holds {text!r}, not a finite number"
    import pyarrow.parquet as pq

    cell = pq.read_table(path, columns=[name]).column(0)[index]
    if not cell.is_valid:
        return "is empty (null)"
    value = cell.as_py()
    if isinstance(value, float) and np.isnan(value):
        return "is NaN, not a number"
    return f"holds {value!r}, not a finite number"


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
    frame = pd.DataFrame(
        {
            "t": realisation.t,
            "x": x,
            "x_true": realisation.truth[0],
            "dx_true": realisation.truth[1],
            "ddx_true": realisation.truth[2],
        }
    )
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
