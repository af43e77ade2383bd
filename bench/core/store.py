"""The results store: one SQLite database that keeps every stored record through anything.

A store is a folder (``<out>/store/``) holding one database, :data:`STORE_FILE`, with one
table per kind of record: ``cells`` (one row per finished cell: its key, the role of its
parameters, its scores), ``tunings`` (one per finished tuning), ``studies`` (one per item a
study outside the task model stored: ``recommend-check``'s scenarios) and ``failures`` (one
per failed attempt at a cell). Each run that writes adds one row to ``runs`` (git revision,
package versions, command) and its records name that run, so provenance is stored once per
run, not on every row. ``meta`` holds the format, its version and the store's identity.
Nested values (params, role, scores, a study's rows) are canonical JSON text (floats by
``repr``, exact); numbers outside them are stored as they are (8-byte floats, exact; no column
affinity, so ``-0.0`` keeps its sign). pandas reads any table with ``read_sql``;
:meth:`Store.export` writes them as CSV or Parquet files.

Guarantees
----------
* **Atomic, durable records.** Each record is one transaction (``BEGIN IMMEDIATE`` ...
  ``COMMIT``) in WAL mode with ``synchronous=FULL``: once ``add_cell`` returns, the record is
  on disk; a writer killed mid-transaction leaves nothing of it (SQLite's journal).
* **No duplicates.** ``key`` is ``UNIQUE`` and records are written with ``INSERT OR IGNORE``:
  a record whose key is stored is refused (``append`` returns False), so concurrent runs on
  one store end with every cell exactly once.
* **Never a lost or overwritten record.** A database file that SQLite cannot read (garbage,
  truncated, another program's database, another format version) is refused with a
  :class:`StoreError` naming the file and what to do; nothing is written to it.
* **Resume.** Because finished records are durable and keyed, an interrupted or killed run
  loses no finished record, and the same command computes only what is missing.
* **Migration.** A folder holding the JSON Lines files of earlier diffbench versions
  (``cells.jsonl``, ``tunings.jsonl``, ``studies.jsonl``, ``failures.jsonl``) is imported on
  opening, once: every valid record with its run, in one transaction (the database notes the
  import; keys are unique, so two openers store each record once). The lines that are not
  valid records (a torn last line, garbage) are listed in :attr:`Store.set_aside` by the
  opening that imports. The files are left as they are, and read no more. A database written
  before an optional column existed (a tuning's ``screen``) gets the column on opening, empty
  in its records: they read as they were written.
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import os
import sqlite3
import time
import uuid
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from diffbench.bench.core.provenance import provenance
from diffbench.bench.core.records import (
    CHECKS,
    FORMAT,
    OLD_FILES,
    ROLE_COLUMNS,
    SCHEMAS,
    TUNING_KEY_FIELDS,
    OldFile,
    Schema,
    SetAside,
    StoreError,
    as_number,
    canonical,
    cell_key,
    cells_frame,
    collector_paused,
    computation_key,
    expand_params,
    failed_cells,
    optional_fields,
    quoted,
    read_old_files,
    study_key,
    tuning_key,
    tunings_frame,
    utc_now,
)
from diffbench.bench.core.sqlite_errors import LOCK_TIMEOUT_S
from diffbench.bench.core.sqlite_errors import os_error as _os_error

__all__ = [  # the records' names that callers import from here
    "ROLE_COLUMNS",
    "Store",
    "StoreError",
    "canonical",
    "cell_key",
    "computation_key",
    "expand_params",
    "study_key",
    "tuning_key",
]

VERSION = 2
"""The version of the store's format: 1 was the JSON Lines files, 2 this SQLite schema."""
STORE_FILE = "diffbench.sqlite"
_SQLITE_HEADER = b"SQLite format 3\x00"


@dataclasses.dataclass
class _Run:
    """The provenance of this process's run, written once to each store it writes to."""

    run_id: str = dataclasses.field(default_factory=lambda: uuid.uuid4().hex[:16])
    command: str = ""

    def record(self) -> dict[str, Any]:
        meta = provenance()
        return {
            "record": "run",
            "run": self.run_id,
            "started_utc": utc_now(),
            "git_rev": meta["git_rev"],
            "versions": meta["versions"],
            "command": self.command,
        }


CURRENT_RUN = _Run()


def set_command(argv: Iterable[str]) -> None:
    """Record the command line of this run (stored with its provenance)."""
    CURRENT_RUN.command = " ".join(["diffbench", *argv])


def store_exists(directory: str | os.PathLike) -> bool:
    """Whether ``directory`` holds a store (this version's database or an earlier version's
    files, which opening imports)."""
    directory = Path(directory)
    return any((directory / name).exists() for name in (STORE_FILE, *OLD_FILES.values()))


_RUNS = (
    "CREATE TABLE IF NOT EXISTS runs (id INTEGER PRIMARY KEY, run TEXT NOT NULL UNIQUE, "
    "started_utc TEXT, git_rev TEXT, versions TEXT, command TEXT)"
)
_RUN_COLUMNS = ("run", "started_utc", "git_rev", "versions", "command")


class RecordTable:
    """The records of one table, unique by ``key``, as read so far (``records``: key to the
    record as a dict, in the order they were stored; :meth:`refresh` reads what other writers
    added since). ``validate(record)`` raises ``ValueError`` for a record not acceptable."""

    def __init__(self, store: Store, schema: Schema, validate: Callable[[dict], None]) -> None:
        self._store = store
        self.schema = schema
        self.kind = schema.kind
        self._validate = validate
        self.records: dict[str, dict] = {}
        self._last_id = 0
        columns = quoted((*schema.columns, "run"))
        self._select = f"SELECT id, {columns} FROM {schema.table} WHERE id > ? ORDER BY id"
        self._insert = (
            f"INSERT OR IGNORE INTO {schema.table} ({columns}) "
            f"VALUES ({', '.join('?' for _ in schema.columns)}, ?)"
        )

    def refresh(self) -> None:
        """Read the records other writers stored since the last read."""
        self._store._read_runs()
        rows = self._store._connection().execute(self._select, (self._last_id,)).fetchall()
        with collector_paused():
            for row in rows:
                record = self.schema.record(row[1:-1])
                record["run"] = row[-1]
                self.records.setdefault(record["key"], record)
                self._last_id = row[0]

    def append(self, record: Mapping[str, Any]) -> bool:
        """Store ``record`` (a dict with ``key``) unless its key is stored; True if written."""
        record = {"record": self.kind, **record, "run": CURRENT_RUN.run_id}
        self._validate(record)
        with self._store._transaction() as connection:
            self._store._add_run(connection, CURRENT_RUN.record())
            written = connection.execute(self._insert, [*self.schema.row(record), record["run"]])
        self._store._run_written = True
        if written.rowcount != 1:
            self.refresh()  # the other writer's record
            return False
        self.records.setdefault(record["key"], record)
        return True


class Store:
    """The results store of one output directory: cells and tunings (see module docstring),
    and the rows of studies outside the task model (:meth:`add_study_rows`).

    >>> store = Store(Path("results"))  # doctest: +SKIP
    >>> store.cells_frame("paper-signal")  # tidy rows: one per cell x score  # doctest: +SKIP
    """

    def __init__(self, directory: str | os.PathLike) -> None:
        self.directory = Path(directory)
        self.path = self.directory / STORE_FILE
        self.runs: dict[str, dict] = {}
        self.set_aside: list[SetAside] = []
        self._runs_read = 0
        self._run_written = False
        self._pid = os.getpid()
        self._db: sqlite3.Connection | None = None
        # an earlier version's files are read before anything is created (a refusal changes
        # nothing), unless this database says it imported them
        fresh = not (self.path.exists() and self.path.stat().st_size > 0)
        old = read_old_files(self.directory) if fresh else {}
        self.directory.mkdir(parents=True, exist_ok=True)
        self._open()
        if not fresh and not self._meta("imported_jsonl_utc"):
            old = read_old_files(self.directory)
        self.cells = RecordTable(self, SCHEMAS["cells"], CHECKS["cells"])
        self.tunings = RecordTable(self, SCHEMAS["tunings"], CHECKS["tunings"])
        self.studies = RecordTable(self, SCHEMAS["studies"], CHECKS["studies"])
        self.failures = RecordTable(self, SCHEMAS["failures"], CHECKS["failures"])
        self.tables = {"cells": self.cells, "tunings": self.tunings}
        self.tables.update(studies=self.studies, failures=self.failures)
        if old:
            self._migrate(old)
        self.refresh()

    # --- the database ----------------------------------------------------------------------
    def _refuse(self, what: str) -> StoreError:
        return StoreError(
            f"{self.path} {what}; it is left as it is: move it away (or restore it from a "
            "backup) or give another --out directory to start a new store"
        )

    def _open(self) -> None:
        """Connect, check the file is this version's store (or empty), create the tables."""
        existing = self.path.exists() and self.path.stat().st_size > 0
        if existing:
            with open(self.path, "rb") as handle:
                if handle.read(len(_SQLITE_HEADER)) != _SQLITE_HEADER:
                    raise self._refuse("is not a diffbench store (not an SQLite database)")
        deadline = time.monotonic() + LOCK_TIMEOUT_S
        pause = 0.01
        while True:
            # a fresh file is still in rollback-journal mode: two openers that both read it and
            # then ask for WAL (an exclusive lock) deadlock, and SQLite answers one of them
            # "locked" at once instead of waiting; that one tries again until the lock timeout
            try:
                self._set_up(existing)
                return
            except sqlite3.OperationalError as error:
                if "locked" not in str(error) or time.monotonic() > deadline:
                    self.close()
                    raise _os_error(error, self.path) from None
            except sqlite3.DatabaseError as error:
                self.close()
                raise self._refuse(f"is damaged, SQLite cannot read it ({error})") from None
            except OSError as error:  # the same lock, met in _set_up's write transaction
                if error.errno != errno.EBUSY or time.monotonic() > deadline:
                    raise
            if self._db is not None and self._db.in_transaction:
                self._db.execute("ROLLBACK")
            time.sleep(pause)
            pause = min(2 * pause, 0.5)

    def _set_up(self, existing: bool) -> None:
        """Check the file (if it held anything), switch to WAL, create the tables if missing."""
        connection = self._connection()
        if existing:
            self._check(connection)
        mode = connection.execute("PRAGMA journal_mode=WAL").fetchone()[0]
        if mode != "wal":
            raise OSError(errno.EIO, f"cannot use WAL mode (journal_mode={mode})", self.path)
        with self._transaction() as connection:
            found = connection.execute(
                "SELECT name FROM sqlite_master WHERE type = 'table' AND name = 'meta'"
            ).fetchone()
            if found is None:
                self._create(connection)
            else:
                self._add_optional_columns(connection)

    def _check(self, connection: sqlite3.Connection) -> None:
        tables = {
            name for (name,) in connection.execute("SELECT name FROM sqlite_master")
        }  # a file that is not a database fails here
        if "meta" not in tables:
            if tables:
                raise self._refuse("is an SQLite database but not a diffbench store")
            return
        meta = dict(connection.execute("SELECT name, value FROM meta"))
        if meta.get("format") != FORMAT:
            raise self._refuse("is an SQLite database but not a diffbench store")
        version = meta.get("version")
        if version != str(VERSION):
            newer = version is not None and version.isdigit() and int(version) > VERSION
            raise StoreError(
                f"{self.path} was written by another diffbench store version: it says version "
                f"{version}, this diffbench reads version {VERSION} only; read it with the "
                f"diffbench that wrote it{' (pip install -U diffbench)' if newer else ''}, or "
                "give another --out directory (or move this store away) to start a new one"
            )
        problems = [row[0] for row in connection.execute("PRAGMA quick_check")]
        if problems != ["ok"]:
            raise self._refuse(f"is damaged ({problems[0]})")

    def _create(self, connection: sqlite3.Connection) -> None:
        connection.execute("CREATE TABLE meta (name TEXT PRIMARY KEY, value TEXT NOT NULL)")
        connection.executemany(
            "INSERT INTO meta VALUES (?, ?)",
            [
                ("format", FORMAT),
                ("version", str(VERSION)),
                ("store_id", uuid.uuid4().hex),
                ("created_utc", utc_now()),
            ],
        )
        connection.execute(_RUNS)
        for schema in SCHEMAS.values():
            connection.execute(schema.create())

    def _add_optional_columns(self, connection: sqlite3.Connection) -> None:
        """Give a store written before an optional column existed that column (in the
        caller's transaction): its records hold NULL there, which reads as absent, as they
        were written; their keys are unchanged."""
        for schema in SCHEMAS.values():
            present = {row[1] for row in connection.execute(f'PRAGMA table_info("{schema.table}")')}
            for name in sorted(schema.optional - present):
                connection.execute(f'ALTER TABLE "{schema.table}" ADD COLUMN "{name}"')

    def _connection(self) -> sqlite3.Connection:
        """This process's connection (a forked process opens its own)."""
        if self._db is None or self._pid != os.getpid():
            self._pid = os.getpid()
            self._db = sqlite3.connect(
                self.path, timeout=LOCK_TIMEOUT_S, isolation_level=None, check_same_thread=False
            )
            self._db.execute("PRAGMA synchronous=FULL")
        return self._db

    @contextlib.contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        """One write transaction (waiting for other writers); rolled back on any exception,
        the interruption of the run included."""
        connection = self._connection()
        try:
            connection.execute("BEGIN IMMEDIATE")
            try:
                yield connection
            except BaseException:
                connection.execute("ROLLBACK")
                raise
            connection.execute("COMMIT")
        except sqlite3.OperationalError as error:
            if connection.in_transaction:
                connection.execute("ROLLBACK")
            raise _os_error(error, self.path) from None

    def close(self) -> None:
        if self._db is not None:
            self._db.close()
            self._db = None

    def _add_run(self, connection: sqlite3.Connection, run: Mapping[str, Any]) -> None:
        """Store ``run`` once (in the caller's transaction)."""
        if run["run"] == CURRENT_RUN.run_id and self._run_written:
            return
        connection.execute(
            f"INSERT OR IGNORE INTO runs ({', '.join(_RUN_COLUMNS)}) VALUES (?, ?, ?, ?, ?)",
            [run.get(name) for name in _RUN_COLUMNS],
        )  # noted as written once committed (a rolled-back run row is written again)

    def _read_runs(self) -> None:
        rows = self._connection().execute(
            f"SELECT id, {', '.join(_RUN_COLUMNS)} FROM runs WHERE id > ? ORDER BY id",
            (self._runs_read,),
        )
        for identity, *values in rows:
            self.runs[values[0]] = {"record": "run", **dict(zip(_RUN_COLUMNS, values, strict=True))}
            self._runs_read = identity
        self._run_written = self._run_written or CURRENT_RUN.run_id in self.runs

    # --- migration -------------------------------------------------------------------------
    def _meta(self, name: str) -> str | None:
        found = self._connection().execute("SELECT value FROM meta WHERE name = ?", (name,))
        row = found.fetchone()
        return None if row is None else row[0]

    def _migrate(self, old: dict[str, OldFile]) -> None:
        """Import the valid records of an earlier version's files with their runs, in one
        transaction, once (the database notes it; keys are unique, so concurrent openers
        store each record once); the files are left as they are and read no more."""
        with self._transaction() as connection:
            if connection.execute(
                "SELECT 1 FROM meta WHERE name = 'imported_jsonl_utc'"
            ).fetchone():
                return  # another opener imported them
            for table, found in old.items():
                for run in found.runs:
                    self._add_run(connection, run)
                for record in found.records:
                    connection.execute(
                        self.tables[table]._insert,
                        [*SCHEMAS[table].row(record), record["run"]],
                    )
            connection.execute("INSERT INTO meta VALUES ('imported_jsonl_utc', ?)", (utc_now(),))
        for found in old.values():
            self.set_aside += found.bad

    # --- what the store holds --------------------------------------------------------------
    def content_version(self, tables: Iterable[str] = ("cells", "tunings")) -> str:
        """A string that changes whenever a record is added to one of ``tables`` (records are
        never changed or removed, so the number of rows and the last row id name the content
        exactly), with the store's identity: a report key (:mod:`bench.core.uptodate`)."""
        connection = self._connection()
        (identity,) = connection.execute(
            "SELECT value FROM meta WHERE name = 'store_id'"
        ).fetchone()
        parts = [identity]
        for table in tables:
            if table not in SCHEMAS:
                raise ValueError(f"`tables`: no table {table!r} (one of {', '.join(SCHEMAS)})")
            count, last = connection.execute(f"SELECT count(*), max(id) FROM {table}").fetchone()
            parts.append(f"{table}={count}/{last or 0}")
        return ";".join(parts)

    def export(self, directory: str | os.PathLike, format: str = "csv") -> list[Path]:
        """Write every table (meta, runs, cells, tunings, studies, failures) to one file each in
        ``directory`` (``<table>.csv`` or ``<table>.parquet``; nested values are canonical JSON
        text); the files written. Parquet needs pyarrow."""
        if format not in ("csv", "parquet"):
            raise ValueError(f"`format` must be 'csv' or 'parquet', got {format!r}")
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        written = []
        for table in ("meta", "runs", *SCHEMAS):
            order = "name" if table == "meta" else "id"
            frame = pd.read_sql(f"SELECT * FROM {table} ORDER BY {order}", self._connection())
            path = directory / f"{table}.{format}"
            if format == "csv":
                frame.to_csv(path, index=False)
            else:
                frame.to_parquet(path, index=False)
            written.append(path)
        return written

    def add_failure(
        self,
        *,
        task: str,
        method: str,
        params: Mapping[str, Any],
        seed: int,
        role: Mapping[str, Any],
        reason: str,
        package: str = "unknown",
    ) -> bool:
        """Record that this run's attempt at a cell failed, and why (a timeout, a plugin's
        error). The cell stays unfinished: a later run computes it again."""
        cell = cell_key(task, method, params, seed, role)
        record = {
            "key": canonical([cell, CURRENT_RUN.run_id]),
            "cell": cell,
            "task": task,
            "method": method,
            "params": dict(params),
            "seed": int(seed),
            "role": dict(role),
            "reason": str(reason),
            "package": str(package),
            "finished_utc": utc_now(),
        }
        return self.failures.append(record)

    def failed_cells(self, task: str | Iterable[str] | None = None) -> pd.DataFrame:
        """The cells of ``task`` whose last recorded attempt failed and that no run has
        finished since (:func:`bench.core.records.failed_cells`)."""
        return failed_cells(self.failures.records.values(), self.cells.records, task)

    def find_study_rows(self, study: str, item: str, setting: Any) -> list[dict] | None:
        """The stored rows of ``study`` for ``item`` under ``setting``, None if not stored."""
        record = self.studies.records.get(study_key(study, item, setting))
        return None if record is None else [dict(row) for row in record["rows"]]

    def add_study_rows(self, study: str, item: str, setting: Any, rows: list[dict]) -> bool:
        """Store the rows ``study`` computed for ``item`` under ``setting`` (all in one
        record: an item is stored whole or not at all); False if another writer stored them
        first. ``setting`` must be JSON (a list of names, a dict)."""
        record = {
            "key": study_key(study, item, setting),
            "study": study,
            "item": item,
            "setting": setting,
            "rows": [[[str(k), v] for k, v in row.items()] for row in rows],
            "finished_utc": utc_now(),
        }
        return self.studies.append(record)

    def has_cell(self, key: str) -> bool:
        return key in self.cells.records

    def refresh(self) -> None:
        """Read the records other writers stored since the last read."""
        for table in (self.cells, self.tunings, self.studies, self.failures):
            table.refresh()

    def add_cell(
        self,
        *,
        task: str,
        method: str,
        params: Mapping[str, Any],
        seed: int,
        role: Mapping[str, Any],
        scores: list[dict[str, Any]],
        elapsed_s: float,
        package: str = "unknown",
        same_as: str | None = None,
    ) -> bool:
        """Store one finished cell; False if another writer stored it first. ``package``: the
        distribution and version whose code computed it (``methods.package_of``).
        ``same_as``: the key of the cell whose computation this one's scores are (the same
        computation key, see :func:`computation_key`; its ``elapsed_s`` is that one's)."""
        key = cell_key(task, method, params, seed, role)
        record = {
            "key": key,
            "task": task,
            "method": method,
            "params": dict(params),
            "seed": int(seed),
            "role": dict(role),
            "finished_utc": utc_now(),
            "elapsed_s": round(float(elapsed_s), 6),
            "package": str(package),
            "scores": [
                [int(s["order"]), str(s["region"]), str(s["metric"]), as_number(s["value"])]
                for s in scores
            ],
        }
        if same_as is not None:
            record["same_as"] = str(same_as)
        return self.cells.append(record)

    def computed_by_this_code(self) -> dict[str, dict]:
        """The stored cells whose run had this process's provenance (the same clean git
        revision and the same package versions and BLAS kernel), by computation key
        (:func:`computation_key`): their scores are what this code would compute. Empty when
        the working tree is dirty or not a git checkout (its code cannot be named)."""
        current = provenance()
        if current["git_rev"] in ("", "unknown") or current["git_rev"].endswith("+dirty"):
            return {}
        runs = {
            run
            for run, meta in self.runs.items()
            if meta.get("git_rev") == current["git_rev"]
            and meta.get("versions") == current["versions"]
        }
        return {
            computation_key(r["task"], r["method"], r["params"], r["seed"], r["role"]): r
            for r in self.cells.records.values()
            if r["run"] in runs
        }

    def find_tuning(self, **fields: Any) -> dict | None:
        return self.tunings.records.get(tuning_key(**fields))

    def add_tuning(
        self,
        *,
        params: Mapping[str, Any],
        loss: float,
        evaluations: int,
        seconds: float,
        **fields: Any,
    ) -> bool:
        """Store one finished tuning (its key fields; the optional ones when not default)."""
        record = {
            "key": tuning_key(**fields),
            **{n: fields[n] for n in TUNING_KEY_FIELDS},
            **optional_fields(fields),
            "params": dict(params),
            "loss": as_number(loss),
            "evaluations": int(evaluations),
            "seconds": round(float(seconds), 4),
            "finished_utc": utc_now(),
        }
        return self.tunings.append(record)

    def cells_frame(self, task: str | Iterable[str] | None = None) -> pd.DataFrame:
        """Tidy rows (one per cell and score) of the given task(s) with role and provenance
        columns (:func:`bench.core.records.cells_frame`)."""
        return cells_frame(self.cells.records.values(), self.runs, task)

    def tunings_frame(self) -> pd.DataFrame:
        """One row per stored tuning (:func:`bench.core.records.tunings_frame`)."""
        return tunings_frame(self.tunings.records.values())

    def revisions(self) -> set[str]:
        """Git revisions of the code that computed the stored cells."""
        used = {record["run"] for record in self.cells.records.values()}
        return {self.runs.get(run, {}).get("git_rev", "unknown") for run in used}
