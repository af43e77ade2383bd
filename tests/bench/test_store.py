"""The results store (SQLite) keeps every stored record through damage, kills and concurrent
writers, reads numbers back bit for bit, and imports the JSON Lines stores of earlier versions."""

import json
import math
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

from diffbench.bench.core.records import Schema
from diffbench.bench.core.roles import Role
from diffbench.bench.core.store import (
    STORE_FILE,
    Store,
    StoreError,
    canonical,
    cell_key,
    tuning_key,
)

ROOT = Path(__file__).resolve().parents[2]
ROLE = Role.of_preset("paper-signal", "paper").as_dict()
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
FIELDS = {
    "task": "t",
    "method": "m",
    "criterion": "oracle",
    "order": 1,
    "tuning_seed": 10_000,
    "cutoff_hz": None,
    "budget": None,
}


def _add(store, seed, value=1.0, method="m"):
    scores = [{"order": 1, "region": "interior", "metric": "rmse", "value": value + seed}]
    return store.add_cell(
        task="t",
        method=method,
        params={"w": 0.5},
        seed=seed,
        role=ROLE,
        scores=scores,
        elapsed_s=0.1,
    )


def _filled(tmp_path, cells=5) -> Path:
    store = Store(tmp_path / "store")
    for seed in range(cells):
        assert _add(store, seed)
    store.close()
    return store.path


def _values(directory) -> dict[int, float]:
    frame = Store(directory).cells_frame("t")
    return dict(zip(frame["seed"], frame["value"], strict=True))


def _rows(path: Path, sql: str) -> list[tuple]:
    with sqlite3.connect(path) as connection:
        return connection.execute(sql).fetchall()


def test_records_round_trip_exactly_with_provenance_once_per_run(tmp_path):
    store = Store(tmp_path / "store")
    assert _add(store, 0, value=0.1 + 0.2)
    assert _add(store, 1, value=float("nan"))
    frame = Store(tmp_path / "store").cells_frame("t")
    assert frame["value"].iloc[0] == 0.1 + 0.2  # bit-exact
    assert frame["value"].isna().iloc[1]
    assert set(frame["origin"]) == {"preset"} and set(frame["by"]) == {"paper"}
    assert store.path == tmp_path / "store" / STORE_FILE
    runs = _rows(store.path, "SELECT run, git_rev FROM runs")
    assert len(runs) == 1 and runs[0][1]  # provenance once, not per row
    assert _rows(store.path, "SELECT DISTINCT run FROM cells") == [(runs[0][0],)]
    assert "git_rev" not in [c[1] for c in _rows(store.path, "PRAGMA table_info(cells)")]
    assert _rows(store.path, "PRAGMA journal_mode") == [("wal",)]
    meta = dict(_rows(store.path, "SELECT name, value FROM meta"))
    assert meta["format"] == "diffbench-store" and meta["version"] == "2"


def test_reading_the_store_pauses_the_garbage_collector_and_leaves_it_as_it_found_it(
    tmp_path, monkeypatch
):
    """The records are decoded with Python's cyclic collector paused (its passes over the
    growing heap were most of a store's opening time) and it is left as it was: running
    again after, still off when the caller had turned it off."""
    import gc

    path = _filled(tmp_path, cells=3)
    seen = []
    decode = Schema.record

    def record(schema, row):
        seen.append(gc.isenabled())
        return decode(schema, row)

    monkeypatch.setattr(Schema, "record", record)
    assert gc.isenabled()
    assert len(Store(path.parent).cells.records) == 3
    assert seen and not any(seen)  # every record decoded with the collector paused
    assert gc.isenabled()
    gc.disable()
    try:
        assert len(Store(path.parent).cells.records) == 3
        assert not gc.isenabled()
    finally:
        gc.enable()


AWKWARD = [1e-300, 0.1 + 0.2, -0.0, 5e-324, 1.7976931348623157e308, math.inf, -math.inf, 1 / 3]


def _same(a: float, b: float) -> bool:
    """Equal bit for bit (the sign of zero too)."""
    return math.copysign(1.0, a) == math.copysign(1.0, b) and (a == b or (a != a and b != b))


def test_awkward_floats_round_trip_bit_for_bit(tmp_path):
    store = Store(tmp_path / "store")
    scores = [
        {"order": 1, "region": "interior", "metric": f"m{i}", "value": value}
        for i, value in enumerate(AWKWARD)
    ]
    params = {f"p{i}": value for i, value in enumerate(AWKWARD)}
    assert store.add_cell(
        task="t", method="m", params=params, seed=0, role=ROLE, scores=scores, elapsed_s=0.1
    )
    for i, value in enumerate(AWKWARD):
        fields = {**FIELDS, "tuning_seed": i}
        assert store.add_tuning(**fields, params=params, loss=value, evaluations=1, seconds=0.25)
    rows = [{"value": value, "name": "x"} for value in AWKWARD]
    assert store.add_study_rows("s", "item", ["a"], rows)
    store.close()
    again = Store(tmp_path / "store")
    frame = again.cells_frame("t")
    assert all(_same(a, b) for a, b in zip(frame["value"], AWKWARD, strict=True))
    (record,) = again.cells.records.values()
    assert all(_same(record["params"][f"p{i}"], v) for i, v in enumerate(AWKWARD))
    tunings = again.tunings_frame().sort_values("tuning_seed")
    assert all(_same(a, b) for a, b in zip(tunings["loss"], AWKWARD, strict=True))
    assert all(
        _same(again.find_tuning(**{**FIELDS, "tuning_seed": i})["params"][f"p{i}"], value)
        for i, value in enumerate(AWKWARD)
    )
    found = again.find_study_rows("s", "item", ["a"])
    assert all(_same(row["value"], v) for row, v in zip(found, AWKWARD, strict=True))
    # pandas reads the tables with read_sql; the scores column is the canonical JSON
    with sqlite3.connect(again.path) as connection:
        cells = pd.read_sql("SELECT scores FROM cells", connection)
    values = [score[3] for score in json.loads(cells["scores"].iloc[0])]
    assert all(_same(a, b) for a, b in zip(values, AWKWARD, strict=True))


def test_a_stored_key_is_refused(tmp_path):
    store = Store(tmp_path / "store")
    assert _add(store, 0)
    assert not _add(store, 0, value=99.0)
    assert _values(tmp_path / "store") == {0: 1.0}
    other = Store(tmp_path / "store")  # a second writer that has not read the first's cell
    assert not _add(other, 0, value=98.0) and other.has_cell(next(iter(store.cells.records)))
    assert _rows(store.path, "SELECT count(*) FROM cells") == [(1,)]


def test_an_invalid_record_is_refused_before_it_is_written(tmp_path):
    store = Store(tmp_path / "store")
    with pytest.raises(ValueError, match="`tuning_seeds` must be an integer >= 1"):
        store.add_tuning(**FIELDS, tuning_seeds=0, params={}, loss=0.5, evaluations=1, seconds=0.1)
    assert _rows(store.path, "SELECT count(*) FROM tunings") == [(0,)]


def _damaged(data: bytes, damage: str) -> bytes:
    page = 4096
    return {
        "garbage": bytes(range(256)) * (len(data) // 256),
        "truncated to half": data[: len(data) // 2],
        "truncated in the header": data[:60],
        "last page cut": data[:-page],
        "a page overwritten": data[: 3 * page] + b"\xff" * page + data[4 * page :],
        "a text file": b"a,b\n1,2\n",
    }[damage]


@pytest.mark.parametrize(
    "damage",
    [
        "garbage",
        "truncated to half",
        "truncated in the header",
        "last page cut",
        "a page overwritten",
        "a text file",
    ],
)
def test_a_damaged_database_is_refused_in_one_line_and_never_overwritten(tmp_path, damage):
    path = _filled(tmp_path, cells=120)
    damaged = _damaged(path.read_bytes(), damage)
    path.write_bytes(damaged)
    with pytest.raises(StoreError) as refused:
        Store(tmp_path / "store")
    message = str(refused.value)
    assert "\n" not in message and str(path) in message
    assert "move it away" in message and "another --out directory" in message
    assert path.read_bytes() == damaged


def test_another_sqlite_database_or_version_is_refused_not_overwritten(tmp_path):
    foreign = tmp_path / "foreign" / STORE_FILE
    foreign.parent.mkdir()
    with sqlite3.connect(foreign) as connection:
        connection.execute("CREATE TABLE t (x)")
    data = foreign.read_bytes()
    with pytest.raises(StoreError, match="an SQLite database but not a diffbench store"):
        Store(foreign.parent)
    assert foreign.read_bytes() == data
    path = _filled(tmp_path, cells=1)
    with sqlite3.connect(path) as connection:
        connection.execute("UPDATE meta SET value = '3' WHERE name = 'version'")
    data = path.read_bytes()
    with pytest.raises(StoreError, match="another diffbench store version: it says version 3"):
        Store(path.parent)
    assert path.read_bytes() == data


def test_an_empty_file_is_a_new_store(tmp_path):
    path = tmp_path / "store" / STORE_FILE
    path.parent.mkdir()
    path.write_bytes(b"")
    store = Store(tmp_path / "store")
    assert store.set_aside == [] and _add(store, 0)
    assert _values(tmp_path / "store") == {0: 1.0}


WRITER = textwrap.dedent(
    """
    import sys, time
    from diffbench.bench.core.roles import Role
    from diffbench.bench.core.store import Store

    store = Store(sys.argv[1])
    role = Role.of_preset("p", "paper").as_dict()
    written = 0
    for seed in range(int(sys.argv[2])):
        store.refresh()
        stored = store.add_cell(task="t", method="m", params={}, seed=seed, role=role,
                                scores=[{"order": 1, "region": "r", "metric": "x",
                                         "value": float(seed)}], elapsed_s=0.0)
        written += stored
        if len(sys.argv) > 3 and stored:
            print(seed, flush=True)
    print(written)
    """
)


def test_two_concurrent_writers_store_every_cell_exactly_once(tmp_path):
    directory = tmp_path / "store"
    Store(directory)
    cells = 300
    writers = [
        subprocess.Popen(
            [sys.executable, "-c", WRITER, str(directory), str(cells)],
            stdout=subprocess.PIPE,
            text=True,
            env=ENV,
        )
        for _ in range(2)
    ]
    counts = [int(w.communicate(timeout=120)[0]) for w in writers]
    assert all(w.returncode == 0 for w in writers)
    assert sum(counts) == cells  # every cell written by exactly one of them
    keys = _rows(directory / STORE_FILE, "SELECT key FROM cells")
    assert len(keys) == len(set(keys)) == cells
    assert len(_rows(directory / STORE_FILE, "SELECT run FROM runs")) == 2  # one per writer
    assert len(Store(directory).cells.records) == cells


def _open_store_at_the_barrier(directory, barrier, results):
    try:
        barrier.wait()
        store = Store(directory)
        store.refresh()
        store.close()
        results.put("ok")
    except Exception as error:  # reported to the test, which shows it
        results.put(repr(error))


def test_processes_opening_a_new_store_at_once_all_open_it(tmp_path):
    """Three processes released together on a store not yet created, 20 times: every one opens
    it. A fresh file is in rollback-journal mode; two openers that both read it and then ask
    for WAL deadlock, and SQLite answered one of them "database is locked" at once (5 of 60
    such trials here before the retry; CI hit it in the two-concurrent-runs test)."""
    import multiprocessing

    context = multiprocessing.get_context("fork" if hasattr(os, "fork") else "spawn")
    for trial in range(20):
        directory = tmp_path / str(trial)
        barrier, results = context.Barrier(3), context.Queue()
        openers = [
            context.Process(target=_open_store_at_the_barrier, args=(directory, barrier, results))
            for _ in range(3)
        ]
        for opener in openers:
            opener.start()
        outcomes = [results.get(timeout=120) for _ in openers]
        for opener in openers:
            opener.join(timeout=120)
        assert outcomes == ["ok"] * 3, (trial, outcomes)


def test_a_writer_killed_mid_run_loses_no_stored_cell(tmp_path):
    """SIGKILL of a process writing cells as fast as it can: every cell it reported stored
    (after its commit returned) is there, the database opens cleanly and takes new cells."""
    directory = tmp_path / "store"
    writer = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(directory), "100000", "report"],
        stdout=subprocess.PIPE,
        text=True,
        env=ENV,
    )
    reported = []
    for line in writer.stdout:
        reported.append(int(line))
        if len(reported) == 200:
            break
    writer.send_signal(signal.SIGKILL)
    writer.communicate(timeout=60)
    assert writer.returncode == -signal.SIGKILL
    store = Store(directory)
    stored = {record["seed"] for record in store.cells.records.values()}
    assert set(reported) <= stored and len(stored) < 100000
    assert stored == set(range(len(stored)))  # nothing half-written in between
    assert _rows(store.path, "PRAGMA integrity_check") == [("ok",)]
    assert _add(store, 100000 + 1)


def test_a_rolled_back_run_row_is_written_again_with_the_next_record(tmp_path, monkeypatch):
    """The first record of a run writes the run's provenance row in the same transaction; if
    that transaction rolls back (here: the record's row fails to build), the next record must
    write the run row again, or its cells would name a run the store does not hold."""
    store = Store(tmp_path / "store")
    schema = store.cells.schema

    class FailingRow:  # the table's schema, but building the record's row fails
        def __getattr__(self, name):
            return getattr(schema, name)

        def row(self, record):
            raise RuntimeError("the record's row fails after the run row was inserted")

    monkeypatch.setattr(store.cells, "schema", FailingRow())
    with pytest.raises(RuntimeError, match="fails after the run row"):
        _add(store, 0)
    assert _rows(store.path, "SELECT run FROM runs") == []  # rolled back with the record
    monkeypatch.setattr(store.cells, "schema", schema)
    assert _add(store, 1)
    (run,) = _rows(store.path, "SELECT DISTINCT run FROM cells")
    assert _rows(store.path, "SELECT run FROM runs") == [run]
    ((git_rev,),) = _rows(store.path, "SELECT git_rev FROM runs")
    assert set(Store(tmp_path / "store").cells_frame("t")["git_rev"]) == {git_rev}


def test_the_content_version_changes_with_every_added_record_only(tmp_path):
    store = Store(tmp_path / "store")
    empty = store.content_version()
    assert _add(store, 0)
    one = store.content_version()
    assert one != empty and not _add(store, 0) and store.content_version() == one
    assert store.content_version(("tunings",)) == Store(tmp_path / "store").content_version(
        ("tunings",)
    )
    assert Store(tmp_path / "other").content_version() != empty  # another store's identity
    with pytest.raises(ValueError, match="`tables`: no table 'cell'"):
        store.content_version(("cell",))


@pytest.mark.parametrize("format", ["csv", "parquet"])
def test_the_export_writes_one_file_per_table(tmp_path, format):
    if format == "parquet":
        pytest.importorskip("pyarrow")
    store = Store(tmp_path / "store")
    for seed in range(3):
        assert _add(store, seed, value=0.1 + 0.2)
    assert store.add_tuning(**FIELDS, params={"w": 1e-300}, loss=-0.0, evaluations=3, seconds=1)
    written = store.export(tmp_path / "export", format=format)
    names = ["meta", "runs", "cells", "tunings", "studies", "failures"]
    assert written == [tmp_path / "export" / f"{name}.{format}" for name in names]
    read = pd.read_csv if format == "csv" else pd.read_parquet
    cells, tunings = read(written[2]), read(written[3])
    assert list(cells["seed"]) == [0, 1, 2] and len(read(written[1])) == 1
    assert [json.loads(s)[0][3] for s in cells["scores"]] == [0.1 + 0.2 + s for s in range(3)]
    assert json.loads(tunings["params"].iloc[0]) == {"w": 1e-300}
    assert tunings["key"].iloc[0] == tuning_key(**FIELDS)
    if format == "parquet":  # typed: the sign of zero is kept
        assert math.copysign(1.0, tunings["loss"].iloc[0]) == -1.0
    with pytest.raises(ValueError, match="`format` must be 'csv' or 'parquet'"):
        store.export(tmp_path / "export", format="xlsx")


# --- the JSON Lines store of earlier versions ------------------------------------------------
RUN_LINE = (
    '{"command":"diffbench run t","git_rev":"abc123","record":"run","run":"0123456789abcdef",'
    '"started_utc":"2026-11-20T09:59:00+00:00","versions":"numpy=2.0"}'
)
CELL_LINE = (  # a cell exactly as diffbench's JSON Lines store wrote it
    '{"elapsed_s":0.25,"finished_utc":"2026-11-20T10:00:00+00:00","key":"[\\"t\\",\\"m\\",'
    '{\\"w\\":0.5},0,{\\"by\\":\\"paper\\",\\"criterion\\":\\"\\",\\"cutoff_hz\\":null,'
    '\\"origin\\":\\"preset\\",\\"preset\\":\\"paper-signal\\",\\"tuned_order\\":null,'
    '\\"tuning_seed\\":null,\\"variant\\":\\"\\"}]","method":"m","package":"diffbench 1.0",'
    '"params":{"w":0.5},"record":"cell","role":{"by":"paper","criterion":"",'
    '"cutoff_hz":null,"origin":"preset","preset":"paper-signal","tuned_order":null,'
    '"tuning_seed":null,"variant":""},"run":"0123456789abcdef",'
    '"scores":[[1,"interior","rmse",0.30000000000000004]],"seed":0,"task":"t"}'
)


def _header(kind: str, version: int = 1) -> str:
    return canonical(
        {"record": "header", "format": "diffbench-store", "kind": kind, "version": version}
    )


def _old_store(directory: Path) -> None:
    """A store as diffbench wrote it before SQLite: four JSON Lines files, with a torn last
    line (a killed writer), a line of garbage and a tuning with an invalid seed count."""
    directory.mkdir(parents=True)
    tuning = {
        "record": "tuning",
        "key": tuning_key(**FIELDS),
        **FIELDS,
        "params": {"w": 2.5},
        "loss": 0.5,
        "evaluations": 3,
        "seconds": 0.1,
        "finished_utc": "2026-11-20T10:01:00+00:00",
        "run": "0123456789abcdef",
    }
    bad = {
        **tuning,
        "tuning_seed": 1,
        "tuning_seeds": 0,
        "key": tuning_key(**{**FIELDS, "tuning_seed": 1}, tuning_seeds=0),
    }
    study = {
        "record": "study",
        "key": canonical(["s", "i", ["a"]]),
        "study": "s",
        "item": "i",
        "setting": ["a"],
        "rows": [[["value", 1e-300]]],
        "finished_utc": "2026-11-20T10:02:00+00:00",
        "run": "0123456789abcdef",
    }
    lines = {
        "cells.jsonl": [_header("cell"), RUN_LINE, CELL_LINE, "oops"],
        "tunings.jsonl": [_header("tuning"), RUN_LINE, canonical(tuning), canonical(bad)],
        "studies.jsonl": [_header("study"), RUN_LINE, canonical(study)],
    }
    for name, content in lines.items():
        (directory / name).write_text("\n".join(content) + "\n")
    with (directory / "cells.jsonl").open("a") as handle:
        handle.write(CELL_LINE[:40])  # torn


def test_an_old_json_lines_store_is_imported_once_with_its_runs(tmp_path):
    directory = tmp_path / "store"
    _old_store(directory)
    before = {path.name: path.read_bytes() for path in directory.iterdir()}
    store = Store(directory)
    assert sorted(str(item) for item in store.set_aside) == [
        "cells.jsonl line 4: not a JSON record (Expecting value at column 1)",
        "cells.jsonl line 5: torn last line (a write cut short)",
        "tunings.jsonl line 4: invalid tuning record: `tuning_seeds` must be an integer >= 1,"
        " got 0",
    ]
    assert {name: (directory / name).read_bytes() for name in before} == before  # untouched
    (cell,) = store.cells.records.values()
    assert cell == json.loads(CELL_LINE)  # the record and its key as they were
    frame = store.cells_frame("t")
    assert frame["value"].iloc[0] == 0.1 + 0.2 and set(frame["git_rev"]) == {"abc123"}
    assert store.revisions() == {"abc123"}
    assert store.find_tuning(**FIELDS)["params"] == {"w": 2.5}
    assert store.find_study_rows("s", "i", ["a"]) == [{"value": 1e-300}]
    assert store.runs["0123456789abcdef"]["command"] == "diffbench run t"
    # opened again: the files are not read again, every record is still there once
    store.close()
    again = Store(directory)
    assert again.set_aside == [] and len(again.cells.records) == 1 and len(again.runs) == 1
    assert _rows(again.path, "SELECT count(*) FROM cells") == [(1,)]


V1 = Path(__file__).parent / "data" / "store_v1"
"""A store written by diffbench's JSON Lines store (bench/core/store.py at cbfef4f): two runs,
seven cells (1e-300, 0.1 + 0.2, -0.0, NaN, inf, 5e-324 as scores; one with ``same_as``), a
tuning, a study's rows, a failure, and a torn last line in cells.jsonl."""


def test_a_store_written_by_the_json_lines_code_is_migrated_exactly(tmp_path):
    directory = tmp_path / "store"
    directory.mkdir()
    lines = {}
    for path in V1.iterdir():
        (directory / path.name).write_bytes(path.read_bytes())
        lines[path.stem] = [json.loads(line) for line in path.read_text().splitlines()[:-1]]
        if path.stem != "cells":  # the torn last line of cells.jsonl is not a record
            lines[path.stem].append(json.loads(path.read_text().splitlines()[-1]))
    store = Store(directory)
    assert [str(item) for item in store.set_aside] == [
        "cells.jsonl line 11: torn last line (a write cut short)"
    ]
    for table in ("cells", "tunings", "studies", "failures"):
        records = [r for r in lines[table] if r["record"] not in ("header", "run")]
        assert list(store.tables[table].records.values()) == records  # keys and all, exactly
        for path in V1.iterdir():
            assert (directory / path.name).read_bytes() == path.read_bytes()  # untouched
    runs = [r for r in lines["cells"] if r["record"] == "run"]
    assert store.runs == {run["run"]: run for run in runs}
    assert store.runs["00000000000000a1"]["command"] == "diffbench run t --methods m,m"
    frame = store.cells_frame("t").query("order == 1 and origin == 'preset'")
    expected = [1e-300, 0.1 + 0.2, -0.0, math.nan, math.inf, 5e-324]
    assert all(_same(a, b) for a, b in zip(frame["value"], expected, strict=True))
    assert set(frame["git_rev"]) == {runs[0]["git_rev"]}
    (tuned,) = [r for r in store.cells.records.values() if "same_as" in r]
    assert tuned["same_as"] == next(iter(store.cells.records))
    assert _same(store.tunings_frame()["loss"].iloc[0], -0.0)
    assert store.find_study_rows("s", "item", ["a", "b"]) == [{"ratio": 1e-300, "name": "x"}]
    assert list(store.failed_cells("t")["reason"]) == ["timeout after 1 s"]
    versions = store.content_version(("cells", "tunings", "studies", "failures"))
    store.close()
    again = Store(directory)  # imported once: nothing is read or added again
    assert again.set_aside == [] and len(again.cells.records) == 7 and len(again.runs) == 2
    assert again.content_version(("cells", "tunings", "studies", "failures")) == versions


def test_an_old_store_of_another_version_or_a_foreign_file_is_refused_untouched(tmp_path):
    directory = tmp_path / "store"
    directory.mkdir()
    (directory / "cells.jsonl").write_text(_header("cell", version=7) + "\n")
    with pytest.raises(StoreError, match="another diffbench store version: its header says"):
        Store(directory)
    assert not (directory / STORE_FILE).exists()
    (directory / "cells.jsonl").write_text("a,b\n1,2\n")
    with pytest.raises(StoreError, match="is not a diffbench store"):
        Store(directory)
    assert (directory / "cells.jsonl").read_text() == "a,b\n1,2\n"


def one_dict() -> dict:
    return Role.tuned("oracle", 1, 10_000).as_dict()


def test_a_one_seed_tuning_keeps_the_keys_stored_before_the_seed_count_existed(tmp_path):
    fields = dict(FIELDS)
    # the key as every earlier version wrote it: the seven fields, sorted, compact JSON
    assert tuning_key(**fields) == json.dumps(fields, sort_keys=True, separators=(",", ":"))
    assert tuning_key(**fields, tuning_seeds=1) == tuning_key(**fields)
    assert tuning_key(**fields, tuning_seeds=5) != tuning_key(**fields)
    assert tuning_key(**fields, region="interior") == tuning_key(**fields)
    assert tuning_key(**fields, region="whole") != tuning_key(**fields)
    whole = Role.tuned("oracle", 2, 10_000, region="whole")
    assert whole.as_dict()["tuned_region"] == "whole" and "tuned_region" not in one_dict()
    assert Role.tuned("oracle", 1, 10_000, seeds=5, region="whole").label == (
        "oracle-tuned for ẋ (whole record, 5 seeds)"
    )
    with pytest.raises(ValueError, match="`tuned_region` must be one of interior, whole"):
        Role.tuned("oracle", 1, 10_000, region="ends")
    one, five = Role.tuned("oracle", 1, 10_000), Role.tuned("oracle", 1, 10_000, seeds=5)
    assert "tuning_seeds" not in one.as_dict() and five.as_dict()["tuning_seeds"] == 5
    assert one.label == "oracle-tuned for ẋ" and five.label == "oracle-tuned for ẋ (5 seeds)"
    assert cell_key("t", "m", {}, 0, one.as_dict()) != cell_key("t", "m", {}, 0, five.as_dict())
    store = Store(tmp_path / "store")
    for role in (one, five):
        assert store.add_cell(
            task="t", method="m", params={}, seed=0, role=role.as_dict(), scores=[], elapsed_s=0.0
        )
    for count in (1, 5):
        assert store.add_tuning(
            **fields, tuning_seeds=count, params={"w": count}, loss=0.5, evaluations=3, seconds=0.1
        )
    assert store.add_tuning(
        **fields, region="whole", params={"w": 0}, loss=0.5, evaluations=3, seconds=0.1
    )
    again = Store(tmp_path / "store")
    assert again.set_aside == []
    assert again.find_tuning(**fields)["params"] == {"w": 1}
    assert again.find_tuning(**fields, tuning_seeds=5)["params"] == {"w": 5}
    assert again.find_tuning(**fields, region="whole")["params"] == {"w": 0}
    frame = again.tunings_frame()
    assert sorted(zip(frame["tuning_seeds"], frame["region"], strict=True)) == [
        (1, "interior"),
        (1, "whole"),
        (5, "interior"),
    ]
    with pytest.raises(ValueError, match="`tuning_seeds` must be an integer >= 1"):
        Role.tuned("oracle", 1, 10_000, seeds=0)
    with pytest.raises(ValueError, match="only a tuned role"):
        Role(origin="preset", tuning_seeds=2)


def test_a_store_written_before_the_screen_column_gets_it_and_reads_as_written(tmp_path):
    """A tuning's ``screen`` (the choice combinations screened down to) is an optional key
    field: an unscreened tuning keeps the key it had before; a store whose tunings table
    lacks the column (an earlier version's) gets it on opening, its records unchanged, and
    takes screened tunings beside them."""
    fields = dict(FIELDS)
    assert tuning_key(**fields, screen=None) == tuning_key(**fields)
    assert tuning_key(**fields, screen=2) != tuning_key(**fields)
    store = Store(tmp_path / "store")
    assert store.add_tuning(**fields, params={"w": 1}, loss=0.5, evaluations=3, seconds=0.1)
    store.close()
    with sqlite3.connect(tmp_path / "store" / STORE_FILE) as connection:
        connection.execute('ALTER TABLE tunings DROP COLUMN "screen"')  # as an earlier version
    again = Store(tmp_path / "store")
    with sqlite3.connect(tmp_path / "store" / STORE_FILE) as connection:
        columns = [row[1] for row in connection.execute("PRAGMA table_info(tunings)")]
    assert "screen" in columns
    old = again.find_tuning(**fields)
    assert old["params"] == {"w": 1} and "screen" not in old
    assert again.add_tuning(
        **fields, screen=2, params={"w": 2}, loss=0.4, evaluations=3, seconds=0.1
    )
    assert again.find_tuning(**fields, screen=2)["params"] == {"w": 2}
    assert again.find_tuning(**fields)["params"] == {"w": 1}
    frame = Store(tmp_path / "store").tunings_frame()
    assert sorted(frame["screen"].fillna(0).astype(int)) == [0, 2]
    with pytest.raises(ValueError, match="`screen` must be an integer >= 1"):
        again.add_tuning(**fields, screen=0, params={}, loss=0.5, evaluations=1, seconds=0.1)
