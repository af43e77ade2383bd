"""The SQLite store through the CLI: a method named twice is computed and stored once, a
damaged database is refused in one line and left as it is, and a report reads a store
migrated from the JSON Lines files."""

import contextlib
import json
import sqlite3

from diffbench.bench.cli import main
from diffbench.bench.core.store import STORE_FILE, Store

RUN = ["run", "paper-signal", "--seeds", "2", "--no-progress"]


def _keys(directory) -> list[str]:
    with contextlib.closing(sqlite3.connect(directory / STORE_FILE)) as connection:
        return [key for (key,) in connection.execute("SELECT key FROM cells")]


def test_a_method_named_twice_is_stored_once(tmp_path, capsys):
    argv = [*RUN, "--methods", "finite_difference,finite_difference", "--out", str(tmp_path)]
    assert main(argv) == 0
    assert "2 cells computed, 0 already stored" in capsys.readouterr().out
    keys = _keys(tmp_path / "store")
    assert len(keys) == len(set(keys)) == 2
    assert main(argv) == 0
    assert "0 cells computed, 2 already stored" in capsys.readouterr().out


def test_a_damaged_database_is_one_line_and_left_as_it_is(tmp_path, capsys):
    argv = [*RUN, "--methods", "finite_difference", "--out", str(tmp_path)]
    assert main(argv) == 0
    Store(tmp_path / "store").close()
    path = tmp_path / "store" / STORE_FILE
    with contextlib.closing(sqlite3.connect(path)) as connection:
        connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")  # everything in the file
    damaged = path.read_bytes()[:100] + b"\x00" * 4000 + path.read_bytes()[4100:]
    path.write_bytes(damaged)
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"diffbench: error: {path} is damaged"), err
    assert "move it away" in err and "another --out directory" in err
    assert path.read_bytes() == damaged


def test_a_report_reads_a_store_migrated_from_json_lines(tmp_path, capsys):
    argv = [*RUN, "--methods", "finite_difference", "--out", str(tmp_path / "new")]
    assert main(argv) == 0
    table = (tmp_path / "new" / "paper-signal" / "rmse.csv").read_text()
    # the same cells as the JSON Lines store of an earlier version held them
    store = Store(tmp_path / "new" / "store")
    old = tmp_path / "old" / "store"
    old.mkdir(parents=True)
    with (old / "cells.jsonl").open("w") as stream:
        header = {"record": "header", "format": "diffbench-store", "kind": "cell", "version": 1}
        stream.write(json.dumps(header) + "\n")
        for run in store.runs.values():
            stream.write(json.dumps(run) + "\n")
        for record in store.cells.records.values():
            stream.write(json.dumps(record) + "\n")
    assert main(["report", "paper-signal", "--out", str(tmp_path / "old")]) == 0
    assert (tmp_path / "old" / "paper-signal" / "rmse.csv").read_text() == table
    assert _keys(old) == list(store.cells.records)
