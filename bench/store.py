"""The results store: one tidy CSV file, appended cell by cell, that survives interruption.

Each finished cell (method x parameters x scenario x seed) is written as one block of rows in a
single ``write`` followed by ``fsync``, each row carrying the cell's key and its row count. On
opening, a torn last line (a kill during a write) is cut off and any cell with fewer rows than
it announced is dropped, so the store only ever holds complete cells and a rerun of the same
command computes exactly the missing ones.
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

COLUMNS = (
    "cell_key", "method", "params", "preset", "scenario", "seed", "order", "region", "metric",
    "value", "cell_rows", "git_rev", "versions", "finished_utc", "elapsed_s",
)  # fmt: skip


def cell_key(method: str, params: Mapping[str, Any], scenario: str, seed: int) -> str:
    """The identity of a cell: method, canonical parameters, scenario and seed."""
    return f"{method}|{canonical_params(params)}|{scenario}|{seed}"


def canonical_params(params: Mapping[str, Any]) -> str:
    """Parameters as compact JSON with sorted keys (one spelling per parameter set)."""
    return json.dumps(dict(params), sort_keys=True, separators=(",", ":"))


class ResultStore:
    """Append-only tidy CSV of result rows at ``path`` (created with its header if missing)."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if not self.path.exists() or self.path.stat().st_size == 0:
            self._write_atomically(",".join(COLUMNS) + "\n")
        self._repair()

    def _write_atomically(self, text: str) -> None:
        tmp = self.path.with_name(self.path.name + ".tmp")
        with open(tmp, "w", encoding="utf-8", newline="") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, self.path)

    def _repair(self) -> None:
        """Cut a torn last line and drop incomplete cells (left by a kill mid-write)."""
        raw = self.path.read_bytes()
        text = raw.decode("utf-8", errors="replace")
        header = text.split("\n", 1)[0]
        if header != ",".join(COLUMNS):
            raise ValueError(
                f"{self.path} is not a diffbench results file (unexpected header); "
                "choose another --out directory"
            )
        complete = text[: text.rfind("\n") + 1]
        frame = self._parse(complete)
        counts = frame.groupby("cell_key")["cell_rows"].transform("size")
        keep = counts == frame["cell_rows"]
        if complete != text or not keep.all():
            kept = frame[keep]
            buffer = io.StringIO()
            buffer.write(",".join(COLUMNS) + "\n")
            _write_rows(buffer, kept.to_dict("records"))
            self._write_atomically(buffer.getvalue())

    @staticmethod
    def _parse(text: str) -> pd.DataFrame:
        frame = pd.read_csv(
            io.StringIO(text),
            dtype={"cell_key": str, "params": str, "versions": str, "git_rev": str},
            keep_default_na=False,
            na_values={"value": ["nan", "NaN"]},
        )
        return frame

    def completed_keys(self) -> set[str]:
        """Keys of the cells already stored."""
        return set(self.load()["cell_key"])

    def append(self, rows: Iterable[Mapping[str, Any]]) -> None:
        """Append one cell's rows in a single write, then flush them to disk."""
        buffer = io.StringIO()
        _write_rows(buffer, rows)
        data = buffer.getvalue().encode("utf-8")
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)
        try:
            os.write(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)

    def load(self) -> pd.DataFrame:
        """All stored rows as a DataFrame (``params`` kept as canonical JSON)."""
        return self._parse(self.path.read_text(encoding="utf-8"))


def _write_rows(handle, rows: Iterable[Mapping[str, Any]]) -> None:
    writer = csv.DictWriter(handle, fieldnames=COLUMNS, lineterminator="\n")
    for row in rows:
        writer.writerow({column: _format(row[column]) for column in COLUMNS})


def _format(value: Any) -> Any:
    # repr() of a float round-trips exactly, so stored numbers are bit-identical on reload.
    if isinstance(value, float):
        return repr(value)
    return value


def expand_params(frame: pd.DataFrame) -> pd.DataFrame:
    """The tidy table with one column per parameter (``param.<name>``) beside ``params``."""
    parsed = frame["params"].map(json.loads)
    names = sorted({name for params in parsed for name in params})
    expanded = frame.copy()
    for name in names:
        expanded[f"param.{name}"] = parsed.map(lambda params, key=name: params.get(key))
    return expanded
