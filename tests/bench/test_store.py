"""The results store keeps every good record through damage, duplicates and concurrent writers."""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from diffbench.bench.core.roles import Role
from diffbench.bench.core.store import Store

ROOT = Path(__file__).resolve().parents[2]
ROLE = Role.of_preset("paper-signal", "paper").as_dict()


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
    return store.cells.path


def _values(directory) -> dict[int, float]:
    frame = Store(directory).cells_frame("t")
    return dict(zip(frame["seed"], frame["value"], strict=True))


def _quarantined(path: Path) -> list[dict]:
    quarantine = path.with_name("cells.quarantine.jsonl")
    return [json.loads(line) for line in quarantine.read_text().splitlines()]


def test_records_round_trip_exactly_with_provenance_once_per_run(tmp_path):
    store = Store(tmp_path / "store")
    assert _add(store, 0, value=0.1 + 0.2)
    assert _add(store, 1, value=float("nan"))
    frame = Store(tmp_path / "store").cells_frame("t")
    assert frame["value"].iloc[0] == 0.1 + 0.2  # bit-exact
    assert frame["value"].isna().iloc[1]
    assert set(frame["origin"]) == {"preset"} and set(frame["by"]) == {"paper"}
    lines = store.cells.path.read_text().splitlines()
    kinds = [json.loads(line)["record"] for line in lines]
    assert kinds == ["header", "run", "cell", "cell"]  # provenance once, not per row
    assert "git_rev" in json.loads(lines[1]) and "git_rev" not in json.loads(lines[2])


def test_a_stored_key_is_refused(tmp_path):
    store = Store(tmp_path / "store")
    assert _add(store, 0)
    assert not _add(store, 0, value=99.0)
    assert _values(tmp_path / "store") == {0: 1.0}


@pytest.mark.parametrize(
    ("damage", "line", "reason"),
    [
        ("garbage", 4, "not a JSON record"),
        ("binary", 4, "not UTF-8 text"),
        ("torn", 8, "torn last line"),
        ("header", 1, "not this store's header line"),
        ("edited", 4, "`key` does not match"),
    ],
)
def test_a_damaged_file_keeps_every_good_record_and_sets_the_bad_line_aside(
    tmp_path, damage, line, reason, capsys
):
    path = _filled(tmp_path)
    lines = path.read_bytes().split(b"\n")  # header, run, 5 cells, ""
    if damage == "garbage":
        lines.insert(3, b"oops")
    elif damage == "binary":
        lines.insert(3, bytes(range(128, 256)))
    elif damage == "torn":
        lines[-1] = lines[4][:40]  # a sixth cell cut mid-write: no final newline
    elif damage == "header":
        lines[0] = b"cell_key,method,params,preset,scenario,seed"
    elif damage == "edited":  # a hand edit of a value: the key no longer matches the content
        lines.insert(3, lines[3].replace(b'"seed":1', b'"seed":7'))
    path.write_bytes(b"\n".join(lines))
    store = Store(tmp_path / "store")
    assert [(item.line, reason in item.reason) for item in store.set_aside] == [(line, True)]
    assert _values(tmp_path / "store") == {seed: 1.0 + seed for seed in range(5)}
    assert [entry["line"] for entry in _quarantined(path)] == [line]
    # the file is repaired: a second open sets nothing aside, and new records append cleanly
    again = Store(tmp_path / "store")
    assert again.set_aside == []
    assert _add(again, 9)
    assert len(_values(tmp_path / "store")) == 6


def test_an_empty_file_is_a_new_store(tmp_path):
    path = tmp_path / "store" / "cells.jsonl"
    path.parent.mkdir()
    path.write_bytes(b"")
    store = Store(tmp_path / "store")
    assert store.set_aside == [] and _add(store, 0)
    assert _values(tmp_path / "store") == {0: 1.0}


def test_a_torn_tail_then_an_append_keeps_both_cells(tmp_path):
    """A killed writer leaves half a line; the next writer (already open) starts a new line."""
    path = _filled(tmp_path, cells=2)
    store = Store(tmp_path / "store")
    with open(path, "ab") as handle:
        handle.write(b'{"record":"cell","key":"[\\"t\\"')
    assert _add(store, 5)
    reopened = Store(tmp_path / "store")
    assert [item.line for item in reopened.set_aside] == [5]  # header, run, 2 cells, the tear
    assert _values(tmp_path / "store") == {0: 1.0, 1: 2.0, 5: 6.0}


def test_a_foreign_file_is_refused_not_overwritten(tmp_path):
    path = tmp_path / "store" / "cells.jsonl"
    path.parent.mkdir()
    path.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="is not a diffbench store"):
        Store(tmp_path / "store")
    assert path.read_text() == "a,b\n1,2\n"


def test_another_store_version_is_refused(tmp_path):
    path = _filled(tmp_path, cells=1)
    text = path.read_text().replace('"version":1', '"version":2', 1)
    path.write_text(text)
    with pytest.raises(ValueError, match="another diffbench store version"):
        Store(tmp_path / "store")
    assert path.read_text() == text


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
        written += store.add_cell(task="t", method="m", params={}, seed=seed, role=role,
                                  scores=[{"order": 1, "region": "r", "metric": "x",
                                           "value": float(seed)}], elapsed_s=0.0)
    print(written)
    """
)


def test_two_concurrent_writers_store_every_cell_exactly_once(tmp_path):
    directory = tmp_path / "store"
    Store(directory)
    cells = 300
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    writers = [
        subprocess.Popen(
            [sys.executable, "-c", WRITER, str(directory), str(cells)],
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )
        for _ in range(2)
    ]
    counts = [int(w.communicate(timeout=120)[0]) for w in writers]
    assert all(w.returncode == 0 for w in writers)
    assert sum(counts) == cells  # every cell written by exactly one of them
    lines = [json.loads(x) for x in (directory / "cells.jsonl").read_text().splitlines()]
    keys = [line["key"] for line in lines if line["record"] == "cell"]
    assert len(keys) == len(set(keys)) == cells
    assert Store(directory).set_aside == []


def one_dict() -> dict:
    return Role.tuned("oracle", 1, 10_000).as_dict()


def test_a_one_seed_tuning_keeps_the_keys_stored_before_the_seed_count_existed(tmp_path):
    from diffbench.bench.core.store import cell_key, tuning_key

    fields = {
        "task": "t",
        "method": "m",
        "criterion": "oracle",
        "order": 1,
        "tuning_seed": 10_000,
        "cutoff_hz": None,
        "budget": None,
    }
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


def test_a_record_with_a_bad_seed_count_is_set_aside(tmp_path):
    from diffbench.bench.core.store import tuning_key

    store = Store(tmp_path / "store")
    fields = {
        "task": "t",
        "method": "m",
        "criterion": "oracle",
        "order": 1,
        "tuning_seed": 10_000,
        "cutoff_hz": None,
        "budget": None,
    }
    assert store.add_tuning(**fields, params={}, loss=0.5, evaluations=1, seconds=0.1)
    bad = {
        "record": "tuning",
        "key": tuning_key(**fields, tuning_seeds=0),
        **fields,
        "tuning_seeds": 0,
        "params": {},
        "loss": 0.5,
        "evaluations": 1,
        "seconds": 0.1,
        "finished_utc": "2026-11-24T00:00:00Z",
    }
    with store.tunings.path.open("a") as handle:
        handle.write(json.dumps(bad) + "\n")
    again = Store(tmp_path / "store")
    assert len(again.tunings.records) == 1
    assert [str(item) for item in again.set_aside] and "tuning_seeds" in str(again.set_aside[0])
