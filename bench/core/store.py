"""The results store: append-only JSON Lines files that keep every good record through anything.

A store is a folder (``<out>/store/``) holding one file per kind of record: ``cells.jsonl`` (one
line per finished cell: its key, the role of its parameters, its scores), ``tunings.jsonl``
(one line per finished tuning) and, once a study outside the task model stores its rows there,
``studies.jsonl`` (one line per study item: ``recommend-check``'s scenarios). Each file starts
with a header line; each run that writes to it adds one ``run`` line first (git revision,
package versions, command), and its records name that run, so provenance is stored once per
run, not on every row.

Guarantees
----------
* **Atomic records.** A record is one line written by one ``os.write`` and then ``fsync``-ed
  (a write the disk cuts short raises an ``OSError`` naming the file; its torn tail is set
  aside like any other),
  under an exclusive lock (``filelock``) shared by every process that writes to the file.
* **No duplicates.** Under the lock the writer first reads what other writers appended, and a
  record whose key is already stored is refused (``append`` returns False): two concurrent
  runs on one store end with every cell exactly once.
* **Never a lost good record.** Opening the file reads it line by line; a line that is not a
  valid record of this store (garbage, binary bytes, a torn last line left by a killed writer,
  a foreign header, a record whose key does not match its content) is *set aside*: appended to
  ``<name>.quarantine.jsonl`` with its line number and the reason, then the file is rewritten
  atomically (temporary file, ``fsync``, ``os.replace``) with every good line byte for byte.
  Nothing else ever rewrites the file.
* **Resume.** Because finished records are durable and keyed, an interrupted or killed run
  loses no finished record, and the same command computes only what is missing.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import os
import uuid
from collections.abc import Callable, Iterable, Mapping
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import pandas as pd
from filelock import FileLock

from diffbench.bench.core.provenance import provenance
from diffbench.bench.core.roles import OPTIONAL_DEFAULTS, TUNED_REGIONS, Role

FORMAT = "diffbench-store"
VERSION = 1
LOCK_TIMEOUT_S = 600.0


def canonical(value: Any) -> str:
    """Compact JSON with sorted keys: one spelling per value (floats by ``repr``, exact)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False)


def utc_now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


@dataclasses.dataclass(frozen=True)
class SetAside:
    """A line of a store file that is not a valid record, and why."""

    path: Path
    line: int
    reason: str

    def __str__(self) -> str:
        return f"{self.path.name} line {self.line}: {self.reason}"


class _BadRecord(ValueError):
    pass


class StoreError(ValueError):
    """A store this code cannot use as it is (another format version, not a store at all):
    the message says what was found and what to do. Nothing is changed on disk."""


@dataclasses.dataclass
class _Run:
    """The provenance of this process's run, written once to each file it appends to."""

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


class RecordFile:
    """One append-only JSON Lines file of records of one ``kind``, unique by ``key``.

    ``validate(record)`` raises ``ValueError`` for a record that is not acceptable (it is then
    set aside like any bad line). ``set_aside`` lists what opening the file put in quarantine.
    """

    def __init__(self, path: Path, kind: str, validate: Callable[[dict], None]) -> None:
        self.path = Path(path)
        self.kind = kind
        self._validate = validate
        self.quarantine_path = self.path.with_name(self.path.stem + ".quarantine.jsonl")
        self._lock = FileLock(str(self.path) + ".lock", timeout=LOCK_TIMEOUT_S)
        self.records: dict[str, dict] = {}
        self.runs: dict[str, dict] = {}
        self.set_aside: list[SetAside] = []
        self._offset = 0
        self._identity: tuple[int, int] | None = None
        self._run_written = False
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._lock:
            self._open()

    # --- reading -------------------------------------------------------------------------
    def _header(self) -> bytes:
        return (
            canonical({"record": "header", "format": FORMAT, "kind": self.kind, "version": VERSION})
            + "\n"
        ).encode()

    def _classify(self, number: int, raw: bytes) -> tuple[str, dict | None, str]:
        """('header' | 'run' | 'record' | 'blank' | 'bad', record, reason)."""
        if not raw.strip():
            return "blank", None, ""
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            return "bad", None, "not UTF-8 text (binary bytes)"
        try:
            record = json.loads(text)
        except json.JSONDecodeError as error:
            return "bad", None, f"not a JSON record ({error.msg} at column {error.colno})"
        if not isinstance(record, dict):
            return "bad", None, "not a JSON object"
        kind = record.get("record")
        if kind == "header":
            if record.get("format") != FORMAT or record.get("kind") != self.kind:
                return "bad", None, f"header of another file ({text.strip()[:80]})"
            if record.get("version") != VERSION:
                version = record.get("version")
                newer = isinstance(version, int) and version > VERSION
                raise StoreError(
                    f"{self.path} was written by another diffbench store version: its header "
                    f"says version {version!r}, this diffbench reads version {VERSION} only; "
                    "read it with the diffbench that wrote it"
                    f"{' (pip install -U diffbench)' if newer else ''}, or give another --out "
                    "directory (or move this store away) to start a new one"
                )
            return "header", record, ""
        if kind == "run":
            if not isinstance(record.get("run"), str):
                return "bad", None, "run record without a run id"
            return "run", record, ""
        if kind != self.kind:
            return "bad", None, f"not a {self.kind} record (record={kind!r})"
        try:
            self._validate(record)
        except (ValueError, TypeError, KeyError) as error:
            return "bad", None, f"invalid {self.kind} record: {error}"
        return "record", record, ""

    def _stat_identity(self) -> tuple[int, int]:
        status = os.stat(self.path)
        return (status.st_dev, status.st_ino)

    def _open(self) -> None:
        """Read the whole file (under the lock); set aside bad lines and a torn tail."""
        if not self.path.exists() or self.path.stat().st_size == 0:
            self._replace(self._header())
        data = self.path.read_bytes()
        lines = data.split(b"\n")
        tail = lines.pop()  # b"" when the file ends with a newline, else a torn last line
        good: list[bytes] = []
        bad: list[tuple[int, bytes, str]] = []
        header_seen = False
        for number, raw in enumerate(lines, start=1):
            kind, record, reason = self._classify(number, raw)
            if kind == "header":
                if number == 1:
                    header_seen = True
                    good.append(raw)
                else:
                    bad.append((number, raw, "a second header line"))
            elif kind == "bad":
                if number == 1:
                    reason = f"not this store's header line ({reason})"
                bad.append((number, raw, reason))
            elif kind == "blank":
                continue
            else:
                if record["record"] == "run":
                    self.runs[record["run"]] = record
                elif record["key"] in self.records:
                    bad.append((number, raw, "duplicate of an earlier record (same key)"))
                    continue
                else:
                    self.records[record["key"]] = record
                good.append(raw)
        if tail:
            bad.append((len(lines) + 1, tail, "torn last line (a write cut short)"))
        if bad and not header_seen and not self.records and not self.runs:
            raise StoreError(
                f"{self.path} is not a diffbench store and holds no diffbench record; "
                "move it away or choose another --out directory"
            )
        if bad or not header_seen:
            self._quarantine(bad)
            body = b"".join(line + b"\n" for line in good)
            if not header_seen:
                body = self._header() + body
            self._replace(body)
        self._offset = self.path.stat().st_size
        self._identity = self._stat_identity()

    def _quarantine(self, bad: list[tuple[int, bytes, str]]) -> None:
        if not bad:
            return
        entries = []
        for number, raw, reason in bad:
            self.set_aside.append(SetAside(self.path, number, reason))
            entries.append(
                canonical(
                    {
                        "file": self.path.name,
                        "line": number,
                        "reason": reason,
                        "found_utc": utc_now(),
                        "text": raw.decode("utf-8", errors="backslashreplace"),
                    }
                )
                + "\n"
            )
        _append_whole(self.quarantine_path, "".join(entries).encode("utf-8"), create=True)

    def _replace(self, body: bytes) -> None:
        temporary = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        try:
            with open(temporary, "wb") as handle:
                handle.write(body)
                handle.flush()
                os.fsync(handle.fileno())
        except OSError as error:  # disk full, file size limit: the original stays as it was
            temporary.unlink(missing_ok=True)
            raise _naming(error, temporary) from None
        os.replace(temporary, self.path)

    def refresh(self) -> None:
        """Read what other writers appended since the last read (whole lines only)."""
        if self._identity != self._stat_identity():  # rewritten by an opener: read it all
            self.records.clear()
            self.runs.clear()
            self._offset = 0
            self._identity = self._stat_identity()
        with open(self.path, "rb") as handle:
            handle.seek(self._offset)
            data = handle.read()
        end = data.rfind(b"\n") + 1
        number = 0
        for raw in data[:end].split(b"\n")[:-1]:
            number += 1
            kind, record, _ = self._classify(number, raw)
            if kind == "run":
                self.runs[record["run"]] = record
            elif kind == "record":
                self.records.setdefault(record["key"], record)
        self._offset += end

    # --- writing -------------------------------------------------------------------------
    def append(self, record: Mapping[str, Any]) -> bool:
        """Store ``record`` (a dict with ``key``) unless its key is stored; True if written."""
        record = {"record": self.kind, **record, "run": CURRENT_RUN.run_id}
        self._validate(record)
        with self._lock:
            self.refresh()
            if record["key"] in self.records:
                return False
            data = b""
            with open(self.path, "rb") as handle:
                handle.seek(0, os.SEEK_END)
                if handle.tell() > 0:
                    handle.seek(-1, os.SEEK_END)
                    if handle.read(1) != b"\n":
                        data += b"\n"  # a torn tail left by a killed writer stays its own line
            if CURRENT_RUN.run_id not in self.runs:
                run = CURRENT_RUN.record()
                data += (canonical(run) + "\n").encode()
                self.runs[run["run"]] = run
            data += (canonical(record) + "\n").encode()
            _append_whole(self.path, data)
            self._offset = self.path.stat().st_size
            self.records[record["key"]] = record
        return True


def _naming(error: OSError, path: Path) -> OSError:
    """``error`` with ``path`` as its file name (so it can be reported in one line)."""
    if error.filename is not None or error.errno is None:
        return error
    return type(error)(error.errno, error.strerror, str(path))


def _append_whole(path: Path, data: bytes, create: bool = False) -> None:
    """Append ``data`` to ``path`` and ``fsync`` it; a write cut short (disk full, the file
    size limit) is raised as an ``OSError`` naming the file and its cause. What it left is a
    torn last line, which readers skip and the next opening sets aside (no good record is
    touched). The caller holds the file's lock."""
    flags = os.O_WRONLY | os.O_APPEND | (os.O_CREAT if create else 0)
    try:
        fd = os.open(path, flags, 0o644)
        try:
            view = memoryview(data)
            while view:  # a short write is followed by one that fails with the cause
                written = os.write(fd, view)
                if written == 0:
                    raise OSError(errno.EIO, "no bytes written", str(path))
                view = view[written:]
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError as error:
        raise _naming(error, path) from None


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


def _check_cell(record: dict) -> None:
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


def _check_seed_count(value: Any, name: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")


# --- tunings -------------------------------------------------------------------------------
TUNING_KEY_FIELDS = ("task", "method", "criterion", "order", "tuning_seed", "cutoff_hz", "budget")


# key fields stored only when they differ from their default (older records lack them)
OPTIONAL_TUNING_FIELDS = {"tuning_seeds": 1, "region": "interior"}


def _optional(fields: Mapping[str, Any]) -> dict[str, Any]:
    """The optional key fields of ``fields`` that differ from their defaults."""
    values = {name: fields.get(name, default) for name, default in OPTIONAL_TUNING_FIELDS.items()}
    return {name: value for name, value in values.items() if value != OPTIONAL_TUNING_FIELDS[name]}


def tuning_key(**fields: Any) -> str:
    """The identity of a tuning: task, method, criterion, order, (first) tuning seed,
    bandlimit, budget, and the number of tuning seeds and the region of the loss when they
    are not 1 and "interior" (so the key of a one-seed interior tuning is what it was before
    those fields existed)."""
    return canonical({**{name: fields[name] for name in TUNING_KEY_FIELDS}, **_optional(fields)})


def _check_tuning(record: dict) -> None:
    if not isinstance(record.get("params"), dict):
        raise ValueError("`params` must be a dict")
    if not isinstance(record.get("loss"), (int, float)):
        raise ValueError("`loss` must be a number")
    _check_seed_count(record.get("tuning_seeds", 1), "`tuning_seeds`")
    if record.get("region", "interior") not in TUNED_REGIONS:
        raise ValueError(f"`region` must be one of {', '.join(TUNED_REGIONS)}")
    fields = {n: record.get(n) for n in TUNING_KEY_FIELDS}
    optional = {n: record[n] for n in OPTIONAL_TUNING_FIELDS if n in record}
    if record.get("key") != tuning_key(**fields, **optional):
        raise ValueError("`key` does not match the record's fields")


# --- study rows ----------------------------------------------------------------------------
def study_key(study: str, item: str, setting: Any) -> str:
    """The identity of a study's rows: the study, the item they score (a scenario), and the
    setting that changes them (e.g. the methods recommended among)."""
    return canonical([study, item, setting])


def _check_study(record: dict) -> None:
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
def _check_failure(record: dict) -> None:
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


class Store:
    """The results store of one output directory: cells and tunings (see module docstring),
    and the rows of studies outside the task model (:meth:`add_study_rows`).

    >>> store = Store(Path("results"))  # doctest: +SKIP
    >>> store.cells_frame("paper-signal")  # tidy rows: one per cell x score  # doctest: +SKIP
    """

    def __init__(self, directory: str | os.PathLike) -> None:
        self.directory = Path(directory)
        self.cells = RecordFile(self.directory / "cells.jsonl", "cell", _check_cell)
        self.tunings = RecordFile(self.directory / "tunings.jsonl", "tuning", _check_tuning)

        self._studies: RecordFile | None = None
        self._failures: RecordFile | None = None

    @property
    def studies(self) -> RecordFile:
        """``studies.jsonl``: each record the rows a study computed for one item (opened, so
        created, on first use)."""
        if self._studies is None:
            self._studies = RecordFile(self.directory / "studies.jsonl", "study", _check_study)
        return self._studies

    @property
    def failures(self) -> RecordFile:
        """``failures.jsonl``: one record per failed attempt at a cell (per run), with its
        reason (opened, so created, on first use; read at opening if it exists)."""
        if self._failures is None:
            self._failures = RecordFile(
                self.directory / "failures.jsonl", "failure", _check_failure
            )
        return self._failures

    @property
    def set_aside(self) -> list[SetAside]:
        extra = [
            item
            for file in (self._studies, self._failures)
            if file is not None
            for item in file.set_aside
        ]
        return self.cells.set_aside + self.tunings.set_aside + extra

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
        finished since: task, method, params (canonical JSON), seed, role (canonical JSON),
        reason, package, finished_utc (of the failed attempt)."""
        columns = ["task", "method", "params", "seed", "role", "reason", "package", "finished_utc"]
        if self._failures is None and not (self.directory / "failures.jsonl").exists():
            return pd.DataFrame(columns=columns)
        wanted = None if task is None else ({task} if isinstance(task, str) else set(task))
        last: dict[str, dict] = {}
        for record in self.failures.records.values():  # in the order they were written
            if record["cell"] not in self.cells.records:
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
        self.cells.refresh()
        self.tunings.refresh()
        for file in (self._studies, self._failures):
            if file is not None:
                file.refresh()

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
                [int(s["order"]), str(s["region"]), str(s["metric"]), _number(s["value"])]
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
            for run, meta in self.cells.runs.items()
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
            **_optional(fields),
            "params": dict(params),
            "loss": _number(loss),
            "evaluations": int(evaluations),
            "seconds": round(float(seconds), 4),
            "finished_utc": utc_now(),
        }
        return self.tunings.append(record)

    def cells_frame(self, task: str | Iterable[str] | None = None) -> pd.DataFrame:
        """Tidy rows (one per cell and score) of the given task(s), with role and provenance
        columns: task, method, params (canonical JSON), seed, role (canonical JSON), the role
        fields, order, region, metric, value, run, git_rev, finished_utc, elapsed_s, package (the
        distribution and version that computed the cell; "unknown" in older records)."""
        wanted = None if task is None else ({task} if isinstance(task, str) else set(task))
        columns: dict[str, list] = {name: [] for name in FRAME_COLUMNS}
        for record in self.cells.records.values():
            if wanted is not None and record["task"] not in wanted:
                continue
            params, role = canonical(record["params"]), canonical(record["role"])
            run = self.cells.runs.get(record["run"], {})
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

    def tunings_frame(self) -> pd.DataFrame:
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
            for r in self.tunings.records.values()
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

    def revisions(self) -> set[str]:
        """Git revisions of the code that computed the stored cells."""
        used = {record["run"] for record in self.cells.records.values()}
        return {self.cells.runs.get(run, {}).get("git_rev", "unknown") for run in used}


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


def _number(value: Any) -> float | None:
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
