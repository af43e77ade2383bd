"""Reports written once per inputs: a rerun with the same store, options and code skips them."""

import json

import pytest

from diffbench.bench.cli import main
from diffbench.bench.core import uptodate


def _writer(directory, calls):
    def write():
        calls.append(1)
        directory.mkdir(parents=True, exist_ok=True)
        path = directory / "table.md"
        path.write_text(f"written {len(calls)} times\n")
        return [path]

    return write


def test_a_report_is_written_again_only_when_its_key_or_a_file_changes(tmp_path):
    directory, calls = tmp_path / "report", []
    write = _writer(directory, calls)
    first = uptodate.report_once(directory, "key-a", write)
    assert first == [directory / "table.md"] and len(calls) == 1
    assert uptodate.report_once(directory, "key-a", write) == first and len(calls) == 1
    assert (directory / "table.md").read_text() == "written 1 times\n"
    uptodate.report_once(directory, "key-b", write)  # other inputs
    assert len(calls) == 2
    (directory / "table.md").unlink()  # a file of the report is gone
    assert uptodate.report_once(directory, "key-b", write) == first and len(calls) == 3
    (directory / uptodate.KEY_FILE).write_text("{not json")  # a damaged record
    uptodate.report_once(directory, "key-b", write)
    assert len(calls) == 4
    assert json.loads((directory / uptodate.KEY_FILE).read_text())["files"] == ["table.md"]


def test_a_report_that_fails_leaves_no_record_of_success(tmp_path):
    directory, calls = tmp_path / "report", []
    uptodate.report_once(directory, "key-a", _writer(directory, calls))

    def broken():
        raise RuntimeError("drawing failed")

    with pytest.raises(RuntimeError):
        uptodate.report_once(directory, "key-b", broken)
    assert not (directory / uptodate.KEY_FILE).exists()
    uptodate.report_once(directory, "key-a", _writer(directory, calls))  # written again
    assert len(calls) == 2


def test_the_key_follows_options_and_the_content_version_of_the_store(tmp_path):
    from diffbench.bench.core.roles import Role
    from diffbench.bench.core.store import Store

    store = Store(tmp_path / "store")
    key = uptodate.inputs_key({"report": "x"}, store.content_version())
    assert uptodate.inputs_key({"report": "x"}, store.content_version()) == key
    assert uptodate.inputs_key({"report": "y"}, store.content_version()) != key
    role = Role.of_preset("paper-signal", "paper").as_dict()
    cell = dict(task="t", method="m", params={}, seed=0, role=role, scores=[], elapsed_s=0.0)
    assert store.add_cell(**cell)
    added = uptodate.inputs_key({"report": "x"}, store.content_version())
    assert added != key
    assert not store.add_cell(**cell)  # refused: the content is the same
    assert uptodate.inputs_key({"report": "x"}, Store(store.directory).content_version()) == added
    assert uptodate.code_fingerprint().split(";")[0] == uptodate._source_digest()


def test_a_rerun_of_run_skips_the_report_until_a_cell_is_added(tmp_path, capsys, monkeypatch):
    from diffbench.bench import tasks

    args = [
        "run",
        "paper-signal",
        "--seeds",
        "1",
        "--out",
        str(tmp_path),
        "--no-progress",
        "--methods",
        "finite_difference",
    ]
    assert main(args) == 0
    listed = capsys.readouterr().out.splitlines()[1:]
    reports = []
    original = tasks.SignalTask.report

    def counted(self, *a, **k):
        reports.append(self.name)
        return original(self, *a, **k)

    monkeypatch.setattr(tasks.SignalTask, "report", counted)
    assert main(args) == 0
    assert reports == []  # everything stored, the same store: nothing drawn again
    assert capsys.readouterr().out.splitlines()[1:] == listed  # the same files listed
    assert main([*args[:3], "2", *args[4:]]) == 0  # a new cell: the store changed
    assert reports == ["paper-signal"]
