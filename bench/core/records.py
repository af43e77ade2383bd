"""The records of the results store (:mod:`bench.core.store`): their keys (the same, bit for
bit, as every earlier version's), their validation, the columns of their tables, and the reader
of the JSON Lines files of the stores before SQLite (version 1 of the format), which the store
imports once."""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import json
from collections.abc import Callable, Container, Iterable, Iterator, Mapping
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import pandas as pd

from diffbench.bench.core.roles import OPTIONAL_DEFAULTS, TUNED_REGIONS, Role

FORMAT = "diffbench-store"


def canonical(value: Any) -> str:
    """Compact JSON with sorted keys: one spelling per value (floats by ``repr``, exact)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False)


def utc_now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


@dataclasses.dataclass(frozen=True)
class SetAside:
    """A line of an earlier version's store file that was not imported, and why."""

    path: Path
    line: int
    reason: str

    def __str__(self) -> str:
        return f"{self.path.name} line {self.line}: {self.reason}"


class StoreError(ValueError):
    """A store this code cannot use as it is (another format version, not a store at all, a
    damaged database): the message says what was found and what to do. Nothing is changed on
    disk."""


@contextlib.contextmanager
def collector_paused() -> Iterator[None]:
    """Python's cyclic garbage collector paused while records are decoded: each record's
    JSON makes dicts and lists that all stay alive, so the collector's passes over the
    growing heap found nothing and took most of the time (a store of 58k cells read in
    4.5 s, 2.2-2.8 s of it collection passes). Nothing decoded is cyclic garbage; the
    collector runs again after."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


# --- tables --------------------------------------------------------------------------------
def quoted(names: Iterable[str]) -> str:
    """SQL column names, quoted."""
    return ", ".join(f'"{name}"' for name in names)


@dataclasses.dataclass(frozen=True)
class Schema:
    """A table of records of one ``kind``: its columns (``json`` ones hold canonical JSON) and
    the columns a record holds only when set (NULL when absent)."""

    table: str
    kind: str
    columns: tuple[str, ...]
    json: frozenset[str]
    optional: frozenset[str] = frozenset()

    def row(self, record: Mapping[str, Any]) -> list[Any]:
        return [
            None
            if name not in record
            else canonical(record[name])
            if name in self.json
            else record[name]
            for name in self.columns
        ]

    def record(self, row: Iterable[Any]) -> dict[str, Any]:
        record: dict[str, Any] = {"record": self.kind}
        for name, value in zip(self.columns, row, strict=True):
            if value is None and name in self.optional:
                continue
            record[name] = json.loads(value) if name in self.json else value
        return record

    def create(self) -> str:
        # no declared type but the key's: no affinity, each value kept as it was given
        columns = quoted(name for name in self.columns if name != "key")
        return (
            f"CREATE TABLE IF NOT EXISTS {self.table} (id INTEGER PRIMARY KEY, "
            f"key TEXT NOT NULL UNIQUE, {columns}, run TEXT NOT NULL REFERENCES runs(run))"
        )


# --- cells ---------------------------------------------------------------------------------
ROLE_FIELDS = (
    "origin",
    "preset",
    "by",
    "criterion",
    "tuned_order",
    "tuning_seed",
    "cutoff_hz",
    "variant",
)
# fields a role stores only when they differ from their default (older records lack them)
OPTIONAL_ROLE_FIELDS = dict(OPTIONAL_DEFAULTS)
ROLE_COLUMNS = (*ROLE_FIELDS, *OPTIONAL_ROLE_FIELDS)
ORIGINS = ("preset", "tuned", "variant")


def cell_key(
    task: str, method: str, params: Mapping[str, Any], seed: int, role: Mapping[str, Any]
) -> str:
    """The identity of a cell: task, method, canonical parameters, seed and role."""
    return canonical([task, method, dict(params), int(seed), dict(role)])


def computation_key(
    task: str, method: str, params: Mapping[str, Any], seed: int, role: Mapping[str, Any]
) -> str:
    """What a cell computes: its key without the role, which is provenance (a preset, a
    tuning), except for the role's ``variant``, which can change what a task computes
    (:meth:`bench.tasks.Task.score_cell`). Cells with equal computation keys have equal
    scores, bit for bit, when the same code computes them."""
    return canonical([task, method, dict(params), int(seed), dict(role).get("variant", "")])


def check_cell(record: dict) -> None:
    for name, kind in (
        ("task", str),
        ("method", str),
        ("params", dict),
        ("role", dict),
        ("scores", list),
    ):
        if not isinstance(record.get(name), kind):
            raise ValueError(f"`{name}` must be a {kind.__name__}")
    if not isinstance(record.get("package", ""), str):
        raise ValueError("`package` must be a str")
    seed = record.get("seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError("`seed` must be an integer >= 0")
    role = record["role"]
    if set(role) - set(OPTIONAL_ROLE_FIELDS) != set(ROLE_FIELDS) or role["origin"] not in ORIGINS:
        raise ValueError(f"`role` must have the fields {', '.join(ROLE_FIELDS)}")
    Role(**role)  # the values: a ValueError names the field
    for score in record["scores"]:
        if not (
            isinstance(score, list)
            and len(score) == 4
            and isinstance(score[0], int)
            and isinstance(score[1], str)
            and isinstance(score[2], str)
            and (score[3] is None or isinstance(score[3], (int, float)))
        ):
            raise ValueError(f"a score must be [order, region, metric, value], got {score!r}")
    expected = cell_key(record["task"], record["method"], record["params"], seed, role)
    if record.get("key") != expected:
        raise ValueError("`key` does not match the record's task, method, params, seed, role")


def _check_positive_count(value: Any, name: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")


# --- tunings -------------------------------------------------------------------------------
TUNING_KEY_FIELDS = ("task", "method", "criterion", "order", "tuning_seed", "cutoff_hz", "budget")


# key fields stored only when they differ from their default (older records lack them);
# ``screen``: the choice combinations screened down to (the tuner's ``screen_choices``)
OPTIONAL_TUNING_FIELDS = {"tuning_seeds": 1, "region": "interior", "screen": None}


def optional_fields(fields: Mapping[str, Any]) -> dict[str, Any]:
    """The optional key fields of ``fields`` that differ from their defaults."""
    values = {name: fields.get(name, default) for name, default in OPTIONAL_TUNING_FIELDS.items()}
    return {name: value for name, value in values.items() if value != OPTIONAL_TUNING_FIELDS[name]}


def tuning_key(**fields: Any) -> str:
    """The identity of a tuning: task, method, criterion, order, (first) tuning seed,
    bandlimit, budget, and the number of tuning seeds, the region of the loss and the
    screening of the choices when they are not 1, "interior" and none (so the key of a
    one-seed interior tuning is what it was before those fields existed)."""
    return canonical(
        {**{name: fields[name] for name in TUNING_KEY_FIELDS}, **optional_fields(fields)}
    )


def check_tuning(record: dict) -> None:
    if not isinstance(record.get("params"), dict):
        raise ValueError("`params` must be a dict")
    if not isinstance(record.get("loss"), (int, float)):
        raise ValueError("`loss` must be a number")
    _check_positive_count(record.get("tuning_seeds", 1), "`tuning_seeds`")
    if record.get("region", "interior") not in TUNED_REGIONS:
        raise ValueError(f"`region` must be one of {', '.join(TUNED_REGIONS)}")
    if "screen" in record:
        _check_positive_count(record["screen"], "`screen`")
    fields = {n: record.get(n) for n in TUNING_KEY_FIELDS}
    optional = {n: record[n] for n in OPTIONAL_TUNING_FIELDS if n in record}
    if record.get("key") != tuning_key(**fields, **optional):
        raise ValueError("`key` does not match the record's fields")


# --- study rows ----------------------------------------------------------------------------
def study_key(study: str, item: str, setting: Any) -> str:
    """The identity of a study's rows: the study, the item they score (a scenario), and the
    setting that changes them (e.g. the methods recommended among)."""
    return canonical([study, item, setting])


def check_study(record: dict) -> None:
    for name, kind in (("study", str), ("item", str), ("rows", list)):
        if not isinstance(record.get(name), kind):
            raise ValueError(f"`{name}` must be a {kind.__name__}")
    for row in record["rows"]:  # [[column, value], ...]: the columns keep their order
        if not (
            isinstance(row, list)
            and all(
                isinstance(item, list) and len(item) == 2 and isinstance(item[0], str)
                for item in row
            )
        ):
            raise ValueError("`rows` must be lists of [column, value] pairs")
    if record.get("key") != study_key(record["study"], record["item"], record.get("setting")):
        raise ValueError("`key` does not match the record's study, item, setting")


# --- failed cells ----------------------------------------------------------------------------
def check_failure(record: dict) -> None:
    for name, kind in (
        ("cell", str),
        ("task", str),
        ("method", str),
        ("params", dict),
        ("role", dict),
        ("reason", str),
    ):
        if not isinstance(record.get(name), kind):
            raise ValueError(f"`{name}` must be a {kind.__name__}")
    role, seed = record["role"], record.get("seed")
    if record["cell"] != cell_key(record["task"], record["method"], record["params"], seed, role):
        raise ValueError("`cell` does not match the record's task, method, params, seed, role")
    if record.get("key") != canonical([record["cell"], record.get("run")]):
        raise ValueError("`key` does not match the record's cell and run")


SCHEMAS = {
    "cells": Schema(
        "cells",
        "cell",
        (
            "key",
            "task",
            "method",
            "params",
            "seed",
            "role",
            "finished_utc",
            "elapsed_s",
            "package",
            "scores",
            "same_as",
        ),
        frozenset({"params", "role", "scores"}),
        frozenset({"package", "same_as"}),
    ),
    "tunings": Schema(
        "tunings",
        "tuning",
        (
            "key",
            *TUNING_KEY_FIELDS,
            *OPTIONAL_TUNING_FIELDS,
            "params",
            "loss",
            "evaluations",
            "seconds",
            "finished_utc",
        ),
        frozenset({"params"}),
        frozenset(OPTIONAL_TUNING_FIELDS),
    ),
    "studies": Schema(
        "studies",
        "study",
        ("key", "study", "item", "setting", "rows", "finished_utc"),
        frozenset({"setting", "rows"}),
    ),
    "failures": Schema(
        "failures",
        "failure",
        (
            "key",
            "cell",
            "task",
            "method",
            "params",
            "seed",
            "role",
            "reason",
            "package",
            "finished_utc",
        ),
        frozenset({"params", "role"}),
    ),
}
CHECKS = {
    "cells": check_cell,
    "tunings": check_tuning,
    "studies": check_study,
    "failures": check_failure,
}
OLD_FILES = {table: f"{table}.jsonl" for table in SCHEMAS}
"""The JSON Lines file of each table in the stores of diffbench before the SQLite store."""


def as_number(value: Any) -> float | None:
    """The value as a float, None for NaN (stored as JSON null; a stored null stays null)."""
    if value is None:
        return None
    number = float(value)
    if number != number:
        return None
    return number


def expand_params(frame: pd.DataFrame) -> pd.DataFrame:
    """The tidy table with one column per parameter (``param.<name>``) beside ``params``."""
    parsed = frame["params"].map(json.loads)
    names = sorted({name for params in parsed for name in params})
    expanded = frame.copy()
    for name in names:
        expanded[f"param.{name}"] = parsed.map(lambda params, key=name: params.get(key))
    return expanded


# --- the JSON Lines files of earlier versions (read once, to import them) -------------------
@dataclasses.dataclass
class OldFile:
    runs: list[dict] = dataclasses.field(default_factory=list)
    records: list[dict] = dataclasses.field(default_factory=list)
    bad: list[SetAside] = dataclasses.field(default_factory=list)


def read_old_files(directory: Path) -> dict[str, OldFile]:
    """The runs, valid records and bad lines of each JSON Lines file of an earlier version in
    ``directory`` (version 1 of the format); a ``StoreError`` for another version's file or one
    that is not a store at all."""
    found = {}
    for table, name in OLD_FILES.items():
        path = directory / name
        if path.exists():
            found[table] = _read_old_file(path, SCHEMAS[table].kind, CHECKS[table])
    return found


def _read_old_file(path: Path, kind: str, validate: Callable[[dict], None]) -> OldFile:
    result = OldFile()
    lines = path.read_bytes().split(b"\n")
    tail = lines.pop()  # b"" when the file ends with a newline, else a torn last line
    keys: set[str] = set()
    header_seen = False

    def bad(number: int, raw: bytes, reason: str) -> None:
        result.bad.append(SetAside(path, number, reason))

    for number, raw in enumerate(lines, start=1):
        if not raw.strip():
            continue
        try:
            record = json.loads(raw.decode("utf-8"))
        except UnicodeDecodeError:
            bad(number, raw, "not UTF-8 text (binary bytes)")
            continue
        except json.JSONDecodeError as error:
            bad(number, raw, f"not a JSON record ({error.msg} at column {error.colno})")
            continue
        if not isinstance(record, dict):
            bad(number, raw, "not a JSON object")
        elif record.get("record") == "header" and number == 1:
            if record.get("format") != FORMAT or record.get("kind") != kind:
                bad(number, raw, f"not this store's header line ({raw[:80]!r})")
                continue
            header_seen = True
            if record.get("version") != 1:
                version = record.get("version")
                newer = isinstance(version, int) and version > 1
                raise StoreError(
                    f"{path} was written by another diffbench store version: its header says "
                    f"version {version!r}, this diffbench reads version 1 only"
                    f"; read it with the diffbench that wrote it"
                    f"{' (pip install -U diffbench)' if newer else ''}, or give another --out "
                    "directory (or move this store away) to start a new one"
                )
        elif record.get("record") == "header":
            bad(number, raw, "a second header line" if number > 1 else "a header")
        elif record.get("record") == "run":
            if isinstance(record.get("run"), str):
                result.runs.append(record)
            else:
                bad(number, raw, "run record without a run id")
        elif record.get("record") != kind:
            bad(number, raw, f"not a {kind} record (record={record.get('record')!r})")
        else:
            try:
                validate(record)
                if not isinstance(record.get("run"), str):
                    raise ValueError("`run` must be a str")
            except (ValueError, TypeError, KeyError) as error:
                bad(number, raw, f"invalid {kind} record: {error}")
                continue
            if record["key"] in keys:
                bad(number, raw, "duplicate of an earlier record (same key)")
            else:
                keys.add(record["key"])
                result.records.append(record)
    if tail:
        bad(len(lines) + 1, tail, "torn last line (a write cut short)")
    if result.bad and not header_seen and not result.records and not result.runs:
        raise StoreError(
            f"{path} is not a diffbench store and holds no diffbench record; "
            "move it away or choose another --out directory"
        )
    return result


# --- the records as tables ---------------------------------------------------------------
_FIXED = (
    "task",
    "method",
    "params",
    "seed",
    "role",
    *ROLE_COLUMNS,
    "run",
    "git_rev",
    "finished_utc",
    "elapsed_s",
    "package",
)
FRAME_COLUMNS = (*_FIXED, "order", "region", "metric", "value")


def cells_frame(
    cells: Iterable[dict], runs: Mapping[str, dict], task: str | Iterable[str] | None = None
) -> pd.DataFrame:
    """Tidy rows (one per cell and score) of the given task(s), with role and provenance
    columns: task, method, params (canonical JSON), seed, role (canonical JSON), the role
    fields, order, region, metric, value, run, git_rev, finished_utc, elapsed_s, package (the
    distribution and version that computed the cell; "unknown" in older records)."""
    wanted = None if task is None else ({task} if isinstance(task, str) else set(task))
    columns: dict[str, list] = {name: [] for name in FRAME_COLUMNS}
    for record in cells:
        if wanted is not None and record["task"] not in wanted:
            continue
        params, role = canonical(record["params"]), canonical(record["role"])
        run = runs.get(record["run"], {})
        fixed = (
            record["task"],
            record["method"],
            params,
            record["seed"],
            role,
            *(record["role"][f] for f in ROLE_FIELDS),
            *(record["role"].get(f, d) for f, d in OPTIONAL_ROLE_FIELDS.items()),
            record["run"],
            run.get("git_rev", "unknown"),
            record["finished_utc"],
            record["elapsed_s"],
            record.get("package", "unknown"),
        )
        for order, region, metric, value in record["scores"]:
            for name, item in zip(_FIXED, fixed, strict=True):
                columns[name].append(item)
            columns["order"].append(order)
            columns["region"].append(region)
            columns["metric"].append(metric)
            columns["value"].append(float("nan") if value is None else float(value))
    frame = pd.DataFrame(columns)
    for name in ("tuned_order", "tuning_seed"):
        frame[name] = frame[name].astype("Int64")
    frame["tuning_seeds"] = frame["tuning_seeds"].astype(int)
    frame["cutoff_hz"] = frame["cutoff_hz"].astype(float)
    return frame


def tunings_frame(tunings: Iterable[dict]) -> pd.DataFrame:
    """One row per stored tuning: its key fields, tuning_seeds, region, params
    (canonical JSON), loss, evaluations, seconds."""
    records = [
        {
            **{n: r[n] for n in TUNING_KEY_FIELDS},
            **{n: r.get(n, d) for n, d in OPTIONAL_TUNING_FIELDS.items()},
            "params": canonical(r["params"]),
            "loss": r["loss"],
            "evaluations": r["evaluations"],
            "seconds": r["seconds"],
        }
        for r in tunings
    ]
    return pd.DataFrame(
        records,
        columns=[
            *TUNING_KEY_FIELDS,
            *OPTIONAL_TUNING_FIELDS,
            "params",
            "loss",
            "evaluations",
            "seconds",
        ],
    )


def failed_cells(
    failures: Iterable[dict], finished: Container[str], task: str | Iterable[str] | None = None
) -> pd.DataFrame:
    """The cells of ``task`` whose last recorded attempt failed and that no run has
    finished since: task, method, params (canonical JSON), seed, role (canonical JSON),
    reason, package, finished_utc (of the failed attempt)."""
    columns = ["task", "method", "params", "seed", "role", "reason", "package", "finished_utc"]
    wanted = None if task is None else ({task} if isinstance(task, str) else set(task))
    last: dict[str, dict] = {}
    for record in failures:  # in the order they were written
        if record["cell"] not in finished:
            if wanted is None or record["task"] in wanted:
                last[record["cell"]] = record
    rows = [
        [
            r["task"],
            r["method"],
            canonical(r["params"]),
            r["seed"],
            canonical(r["role"]),
            r["reason"],
            r["package"],
            r["finished_utc"],
        ]
        for r in last.values()
    ]
    return pd.DataFrame(rows, columns=columns)
